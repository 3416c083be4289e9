/* No OpenCL platform at all: the ICD loader is pointed at an empty vendor
 * folder before its first call, and the library must say so, not crash. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "testlib.h"

int main(void)
{
    char dir[] = "/tmp/pb_no_vendors_XXXXXX";
    if (!mkdtemp(dir)) {
        perror("mkdtemp");
        return 1;
    }
    setenv("OCL_ICD_VENDORS", dir, 1);
    unsetenv("OCL_ICD_FILENAMES");

    int n = -1;
    pb_status st = pb_device_count(PB_BACKEND_OPENCL, &n);
    pb_check(st == PB_OK && n == 0, "no platform: %d devices (%s)", n, pb_status_string(st));

    pb_context *ctx = NULL;
    pb_context_options o = {PB_BACKEND_OPENCL, 0, NULL};
    st = pb_context_create(&o, &ctx);
    pb_check(st == PB_ERR_NO_DEVICE && ctx == NULL, "opencl context without a platform: %s: %s",
             pb_status_string(st), pb_last_error(NULL));
    pb_check(strstr(pb_last_error(NULL), "pocl-opencl-icd") != NULL, "the message says what to install: %s",
             pb_last_error(NULL));
    if (!pb_backend_compiled(PB_BACKEND_CUDA)) {
        o.backend = PB_BACKEND_AUTO;
        st = pb_context_create(&o, &ctx);
        pb_check(st == PB_ERR_NO_DEVICE, "auto without any device: %s", pb_status_string(st));
    }
    rmdir(dir);
    return pb_test_finish();
}
