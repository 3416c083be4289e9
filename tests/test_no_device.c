/* A machine without devices: every device backend is blinded before its first
 * call (OpenCL: the ICD loader gets an empty vendor folder; CUDA: no visible
 * GPU), and the library must say so, not crash. argv[1] names the backend under
 * test; auto must then find nothing either. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "testlib.h"

int main(int argc, char **argv)
{
    pb_backend b = pb_test_backend(argc, argv);
    char dir[] = "/tmp/pb_no_vendors_XXXXXX";
    if (!mkdtemp(dir)) {
        perror("mkdtemp");
        return 1;
    }
    setenv("OCL_ICD_VENDORS", dir, 1);
    unsetenv("OCL_ICD_FILENAMES");
    setenv("CUDA_VISIBLE_DEVICES", "", 1);

    if (!pb_backend_compiled(b)) {
        printf("SKIP: the %s backend is not compiled in\n", pb_backend_name(b));
        rmdir(dir);
        return PB_TEST_SKIP;
    }
    int n = -1;
    pb_status st = pb_device_count(b, &n);
    pb_check(st == PB_OK && n == 0, "no device: %s reports %d devices (%s: %s)", pb_backend_name(b), n,
             pb_status_string(st), pb_last_error(NULL));

    pb_context *ctx = NULL;
    pb_context_options o = {b, 0, NULL};
    st = pb_context_create(&o, &ctx);
    pb_check(st == PB_ERR_NO_DEVICE && ctx == NULL, "%s context without a device: %s: %s", pb_backend_name(b),
             pb_status_string(st), pb_last_error(NULL));
    /* The message names the way out. */
    const char *fix = b == PB_BACKEND_OPENCL ? "pocl-opencl-icd" : "nvidia-smi";
    pb_check(strstr(pb_last_error(NULL), fix) != NULL, "the message says '%s': %s", fix, pb_last_error(NULL));

    o.backend = PB_BACKEND_AUTO;
    st = pb_context_create(&o, &ctx);
    pb_check(st == PB_ERR_NO_DEVICE && ctx == NULL, "auto without any device: %s", pb_status_string(st));
    pb_check(strstr(pb_last_error(NULL), "host") != NULL, "auto's message offers the host backend: %s",
             pb_last_error(NULL));
    rmdir(dir);
    return pb_test_finish();
}
