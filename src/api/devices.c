/* Backends and their devices: which backends this build holds, device names
 * ("opencl:1"), listing, and the automatic choice. */
#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "objects.h"

static const pb_backend_ops *backend_ops(pb_backend backend)
{
    switch (backend) {
    case PB_BACKEND_HOST: return &pb_backend_host_ops;
#ifdef PB_HAVE_OPENCL
    case PB_BACKEND_OPENCL: return &pb_backend_opencl_ops;
#endif
#ifdef PB_HAVE_CUDA
    case PB_BACKEND_CUDA: return &pb_backend_cuda_ops;
#endif
    default: return NULL;
    }
}

const char *pb_backend_name(pb_backend backend)
{
    switch (backend) {
    case PB_BACKEND_AUTO: return "auto";
    case PB_BACKEND_HOST: return "host";
    case PB_BACKEND_OPENCL: return "opencl";
    case PB_BACKEND_CUDA: return "cuda";
    }
    return "unknown";
}

int pb_backend_compiled(pb_backend backend)
{
    return backend_ops(backend) != NULL;
}

pb_status pb_device_parse(const char *spec, pb_backend *backend, int *index)
{
    if (!spec || !backend || !index)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "spec, backend and index must not be NULL");
    for (int b = PB_BACKEND_AUTO; b <= PB_BACKEND_CUDA; b++) {
        const char *name = pb_backend_name((pb_backend)b);
        size_t n = strlen(name);
        if (strncmp(spec, name, n) != 0)
            continue;
        *backend = (pb_backend)b;
        *index = 0;
        if (spec[n] == '\0')
            return PB_OK;
        /* Only device backends have several devices to number. */
        if (spec[n] == ':' && (b == PB_BACKEND_OPENCL || b == PB_BACKEND_CUDA) && isdigit((unsigned char)spec[n + 1])) {
            char *end;
            long v = strtol(spec + n + 1, &end, 10);
            if (*end == '\0' && v < 1000) {
                *index = (int)v;
                return PB_OK;
            }
        }
    }
    return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "device '%s' is not auto, host, opencl[:N] or cuda[:N]", spec);
}

static pb_status require_ops(pb_backend backend, const pb_backend_ops **ops)
{
    *ops = backend_ops(backend);
    if (*ops)
        return PB_OK;
    if (backend == PB_BACKEND_OPENCL || backend == PB_BACKEND_CUDA)
        return pb_error(NULL, PB_ERR_BACKEND_UNAVAILABLE,
                        "the %s backend is not compiled into this build of petblur; rebuild with -D%s=enabled "
                        "(and its SDK installed) or choose another backend",
                        pb_backend_name(backend), pb_backend_name(backend));
    return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "unknown backend %d; use host, opencl, cuda or auto",
                    (int)backend);
}

pb_status pb_device_count(pb_backend backend, int *count)
{
    const pb_backend_ops *ops;
    if (!count)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "count must not be NULL");
    *count = 0;
    pb_status st = require_ops(backend, &ops);
    return st == PB_OK ? ops->device_count(count) : st;
}

pb_status pb_device_get_info(pb_backend backend, int index, pb_device_info *info)
{
    const pb_backend_ops *ops;
    if (!info)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "info must not be NULL");
    pb_status st = require_ops(backend, &ops);
    if (st != PB_OK)
        return st;
    int n = 0;
    st = ops->device_count(&n);
    if (st != PB_OK)
        return st;
    if (index < 0 || index >= n)
        return pb_error(NULL, PB_ERR_NO_DEVICE, "%s device %d does not exist (%d found); pick 0 to %d",
                        pb_backend_name(backend), index, n, n - 1);
    return ops->device_info(index, info);
}

/* CUDA if a GPU is there, else an OpenCL GPU, else the first OpenCL device. */
static pb_status choose_auto(pb_backend *backend, int *index)
{
    int n = 0;
    if (backend_ops(PB_BACKEND_CUDA) && pb_device_count(PB_BACKEND_CUDA, &n) == PB_OK && n > 0) {
        *backend = PB_BACKEND_CUDA;
        *index = 0;
        return PB_OK;
    }
    pb_status opencl = backend_ops(PB_BACKEND_OPENCL) ? pb_device_count(PB_BACKEND_OPENCL, &n) : PB_OK;
    char why[768] = "";
    if (opencl != PB_OK) /* the reason, before the next message replaces it */
        snprintf(why, sizeof why, " (OpenCL: %s)", pb_last_error(NULL));
    if (backend_ops(PB_BACKEND_OPENCL) && opencl == PB_OK && n > 0) {
        *backend = PB_BACKEND_OPENCL;
        *index = 0;
        for (int i = 0; i < n; i++) {
            pb_device_info info;
            if (pb_device_get_info(PB_BACKEND_OPENCL, i, &info) == PB_OK && info.is_gpu) {
                *index = i;
                break;
            }
        }
        return PB_OK;
    }
    return pb_error(NULL, PB_ERR_NO_DEVICE,
                    "no CUDA or OpenCL device found%s; install an OpenCL driver (on Debian: apt-get install "
                    "pocl-opencl-icd) or choose the host backend",
                    why);
}

pb_status pb_device_auto_estimate(pb_backend *backend, int *index)
{
    if (!backend || !index)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "backend and index must not be NULL");
    pb_device_info info;
    if (choose_auto(backend, index) == PB_OK &&
        (*backend == PB_BACKEND_CUDA ||
         (pb_device_get_info(*backend, *index, &info) == PB_OK && info.is_gpu)))
        return PB_OK;
    *backend = PB_BACKEND_HOST;
    *index = 0;
    return PB_OK;
}

pb_status pb_backend_select(pb_context_options *opt, const pb_backend_ops **ops)
{
    pb_status st = PB_OK;
    if (opt->backend == PB_BACKEND_AUTO)
        st = choose_auto(&opt->backend, &opt->device_index);
    if (st == PB_OK)
        st = require_ops(opt->backend, ops);
    if (st == PB_OK && opt->device_index < 0)
        st = pb_error(NULL, PB_ERR_NO_DEVICE, "device index %d is negative; count devices from 0",
                      opt->device_index);
    return st;
}
