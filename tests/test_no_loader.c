/* A machine without an OpenCL ICD loader (PETBLUR_OPENCL_LIBRARY names a file
 * that is not there, then a library that is not a loader): the library loads
 * and runs without it, and the OpenCL backend is unavailable with the reason
 * and the fix, in every call that reaches it. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "testlib.h"

static void expect_unavailable(const char *what, const char *words)
{
    int n = -1;
    pb_status st = pb_device_count(PB_BACKEND_OPENCL, &n);
    pb_check(st == PB_ERR_BACKEND_UNAVAILABLE && n == 0, "%s: device count %s, %d devices (%s)", what,
             pb_status_string(st), n, pb_last_error(NULL));
    pb_check(strstr(pb_last_error(NULL), words) != NULL, "%s: the message names '%s': %s", what, words,
             pb_last_error(NULL));
    pb_device_info info;
    st = pb_device_get_info(PB_BACKEND_OPENCL, 0, &info);
    pb_check(st != PB_OK, "%s: device info answered without a loader", what);
    pb_context *ctx = NULL;
    pb_context_options o = {PB_BACKEND_OPENCL, 0, NULL};
    st = pb_context_create(&o, &ctx);
    pb_check(st == PB_ERR_BACKEND_UNAVAILABLE && ctx == NULL, "%s: context %s (%s)", what, pb_status_string(st),
             pb_last_error(NULL));
    pb_check(strstr(pb_last_error(NULL), "PETBLUR_OPENCL_LIBRARY") != NULL, "%s: the fix is named: %s", what,
             pb_last_error(NULL));
}

int main(int argc, char **argv)
{
    if (!pb_backend_compiled(PB_BACKEND_OPENCL)) {
        printf("SKIP: the OpenCL backend is not compiled in\n");
        return PB_TEST_SKIP;
    }
    /* Which library is tried is decided once per process: one case a run. */
    const char *kind = argc > 1 ? argv[1] : "missing";
    if (strcmp(kind, "missing") == 0) {
        setenv("PETBLUR_OPENCL_LIBRARY", "/nonexistent/libOpenCL.so.1", 1);
        expect_unavailable("a missing loader", "ocl-icd-libopencl1");
    } else {
        setenv("PETBLUR_OPENCL_LIBRARY", "libm.so.6", 1); /* a library, but no OpenCL in it */
        expect_unavailable("a library that is not a loader", "clBuildProgram");
    }
    /* The host backend runs on. */
    pb_context *ctx = NULL;
    pb_context_options o = {PB_BACKEND_HOST, 0, NULL};
    pb_check(pb_context_create(&o, &ctx) == PB_OK, "host: %s", pb_last_error(NULL));
    pb_context_destroy(ctx);
    return pb_test_finish();
}
