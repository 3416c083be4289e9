/* The OpenCL ICD loader opened at run time: a build (a wheel above all) then
 * has no link-time dependency on libOpenCL, runs where it is missing with the
 * OpenCL backend unavailable and the reason shown by `petblur devices` and
 * petblur.backends(), and uses whichever loader the machine has (ocl-icd,
 * Khronos', a vendor's). Written here, not taken from a library: the loader
 * that exists for this (clew) is not packaged by Debian, and the table is the
 * 29 calls the backend makes, typed from the Khronos headers themselves. */
#include "opencl_impl.h"
#include "dl_resolve.h"

#include <dlfcn.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

pb_cl_api pb_cl;

static pthread_once_t once = PTHREAD_ONCE_INIT;
static pb_status load_status = PB_OK;
static char load_error[640];

static void load(void)
{
    const char *env = getenv("PETBLUR_OPENCL_LIBRARY");
    const char *name = env && *env ? env : "libOpenCL.so.1";
    /* RTLD_LOCAL: the loader's symbols stay out of the process's namespace,
     * so another copy (a framework's own) does not bind to ours or we to it. */
    void *lib = dlopen(name, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        const char *why = dlerror();
        load_status = PB_ERR_BACKEND_UNAVAILABLE;
        snprintf(load_error, sizeof load_error,
                 "the OpenCL backend needs an OpenCL ICD loader, and %s could not be opened (%s); install one (on "
                 "Debian: apt-get install ocl-icd-libopencl1, with a driver such as pocl-opencl-icd) or set "
                 "PETBLUR_OPENCL_LIBRARY to its path",
                 name, why ? why : "not found");
        return;
    }
#define PB_CL_NAME(f) #f,
#define PB_CL_SLOT(f) (void *)&pb_cl.f,
    static const char *const names[] = {PB_CL_FUNCTIONS(PB_CL_NAME)};
    void *const slots[] = {PB_CL_FUNCTIONS(PB_CL_SLOT)};
#undef PB_CL_NAME
#undef PB_CL_SLOT
    const char *missing = pb_dl_resolve(lib, names, slots, sizeof names / sizeof *names);
    if (missing) {
        load_status = PB_ERR_BACKEND_UNAVAILABLE;
        snprintf(load_error, sizeof load_error,
                 "the OpenCL library %s lacks %s(), which OpenCL 1.2 defines; point PETBLUR_OPENCL_LIBRARY at an "
                 "OpenCL 1.2 (or newer) ICD loader such as ocl-icd's libOpenCL.so.1",
                 name, missing);
        dlclose(lib);
        memset(&pb_cl, 0, sizeof pb_cl);
        return;
    }
    /* Kept open for the process's life: contexts and their drivers live in it. */
}

pb_status pb_cl_load(pb_device *dev)
{
    pthread_once(&once, load);
    if (load_status != PB_OK)
        return pb_error(pb_owner(dev), load_status, "%s", load_error);
    return PB_OK;
}
