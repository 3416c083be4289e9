/* The OpenCL backend's device side, through the ICD loader (PoCL, NVIDIA, AMD,
 * Intel; opened at run time by opencl_loader.c): listing devices, opening one, building the kernels from the
 * embedded source, and naming the runtime's errors. */
#include "opencl_impl.h"

#include <CL/cl_ext.h> /* CL_PLATFORM_NOT_FOUND_KHR: the ICD loader found no platform */

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

extern const char pb_kernel_source[];

static const char *cl_error_name(cl_int e)
{
    switch (e) {
    case CL_DEVICE_NOT_FOUND: return "CL_DEVICE_NOT_FOUND";
    case CL_DEVICE_NOT_AVAILABLE: return "CL_DEVICE_NOT_AVAILABLE";
    case CL_COMPILER_NOT_AVAILABLE: return "CL_COMPILER_NOT_AVAILABLE";
    case CL_MEM_OBJECT_ALLOCATION_FAILURE: return "CL_MEM_OBJECT_ALLOCATION_FAILURE";
    case CL_OUT_OF_RESOURCES: return "CL_OUT_OF_RESOURCES";
    case CL_OUT_OF_HOST_MEMORY: return "CL_OUT_OF_HOST_MEMORY";
    case CL_IMAGE_FORMAT_NOT_SUPPORTED: return "CL_IMAGE_FORMAT_NOT_SUPPORTED";
    case CL_BUILD_PROGRAM_FAILURE: return "CL_BUILD_PROGRAM_FAILURE";
    case CL_INVALID_VALUE: return "CL_INVALID_VALUE";
    case CL_INVALID_PLATFORM: return "CL_INVALID_PLATFORM";
    case CL_INVALID_DEVICE: return "CL_INVALID_DEVICE";
    case CL_INVALID_BUILD_OPTIONS: return "CL_INVALID_BUILD_OPTIONS";
    case CL_INVALID_KERNEL_NAME: return "CL_INVALID_KERNEL_NAME";
    case CL_INVALID_KERNEL_ARGS: return "CL_INVALID_KERNEL_ARGS";
    case CL_INVALID_ARG_SIZE: return "CL_INVALID_ARG_SIZE";
    case CL_INVALID_WORK_GROUP_SIZE: return "CL_INVALID_WORK_GROUP_SIZE";
    case CL_INVALID_IMAGE_SIZE: return "CL_INVALID_IMAGE_SIZE";
    case CL_INVALID_MEM_OBJECT: return "CL_INVALID_MEM_OBJECT";
    case CL_INVALID_OPERATION: return "CL_INVALID_OPERATION";
    case CL_PLATFORM_NOT_FOUND_KHR: return "CL_PLATFORM_NOT_FOUND_KHR (no OpenCL platform installed)";
    default: return "an OpenCL error";
    }
}

/* Maps a failed OpenCL call to a status; allocation failures are memory errors. */
pb_status pb_cl_fail(pb_device *dev, pb_status kind, const char *call, cl_int e)
{
    if (e == CL_MEM_OBJECT_ALLOCATION_FAILURE || e == CL_OUT_OF_HOST_MEMORY || e == CL_OUT_OF_RESOURCES)
        kind = PB_ERR_OUT_OF_MEMORY;
    return pb_error(pb_owner(dev), kind, "%s() failed: %s (%d)%s", call, cl_error_name(e), (int)e,
                    kind == PB_ERR_OUT_OF_MEMORY ? "; free device memory or use a smaller volume" : "");
}

/* All devices of all platforms, flattened in platform order. */
static pb_status list_devices(cl_device_id *devices, cl_platform_id *platforms_of, cl_uint max, cl_uint *count)
{
    cl_platform_id platforms[16];
    cl_uint np = 0;
    *count = 0;
    cl_int e = pb_cl.clGetPlatformIDs(16, platforms, &np);
    if (e == CL_PLATFORM_NOT_FOUND_KHR || (e == CL_SUCCESS && np == 0))
        return PB_OK;
    if (e != CL_SUCCESS)
        return pb_cl_fail(NULL, PB_ERR_DEVICE, "clGetPlatformIDs", e);
    for (cl_uint p = 0; p < np && p < 16; p++) {
        cl_uint nd = 0;
        cl_device_id ids[64];
        e = pb_cl.clGetDeviceIDs(platforms[p], CL_DEVICE_TYPE_ALL, 64, ids, &nd);
        if (e == CL_DEVICE_NOT_FOUND)
            continue;
        if (e != CL_SUCCESS)
            return pb_cl_fail(NULL, PB_ERR_DEVICE, "clGetDeviceIDs", e);
        for (cl_uint d = 0; d < nd && d < 64 && *count < max; d++) {
            if (devices)
                devices[*count] = ids[d];
            if (platforms_of)
                platforms_of[*count] = platforms[p];
            (*count)++;
        }
    }
    return PB_OK;
}

pb_status pb_ocl_device_count(int *count)
{
    cl_uint n = 0;
    *count = 0;
    pb_status st = pb_cl_load(NULL);
    if (st != PB_OK)
        return st;
    st = list_devices(NULL, NULL, 1024, &n);
    *count = (int)n;
    return st;
}

static void fill_info(cl_device_id dev, cl_platform_id platform, pb_device_info *info)
{
    cl_bool images = CL_FALSE;
    cl_device_type type = 0;
    cl_ulong max_alloc = 0, global_mem = 0;
    cl_uint units = 0;
    memset(info, 0, sizeof *info);
    pb_cl.clGetDeviceInfo(dev, CL_DEVICE_NAME, sizeof info->name - 1, info->name, NULL);
    pb_cl.clGetPlatformInfo(platform, CL_PLATFORM_NAME, sizeof info->platform - 1, info->platform, NULL);
    pb_cl.clGetDeviceInfo(dev, CL_DEVICE_TYPE, sizeof type, &type, NULL);
    pb_cl.clGetDeviceInfo(dev, CL_DEVICE_IMAGE_SUPPORT, sizeof images, &images, NULL);
    pb_cl.clGetDeviceInfo(dev, CL_DEVICE_IMAGE3D_MAX_WIDTH, sizeof(size_t), &info->image3d_max[0], NULL);
    pb_cl.clGetDeviceInfo(dev, CL_DEVICE_IMAGE3D_MAX_HEIGHT, sizeof(size_t), &info->image3d_max[1], NULL);
    pb_cl.clGetDeviceInfo(dev, CL_DEVICE_IMAGE3D_MAX_DEPTH, sizeof(size_t), &info->image3d_max[2], NULL);
    pb_cl.clGetDeviceInfo(dev, CL_DEVICE_MAX_MEM_ALLOC_SIZE, sizeof max_alloc, &max_alloc, NULL);
    pb_cl.clGetDeviceInfo(dev, CL_DEVICE_GLOBAL_MEM_SIZE, sizeof global_mem, &global_mem, NULL);
    pb_cl.clGetDeviceInfo(dev, CL_DEVICE_MAX_COMPUTE_UNITS, sizeof units, &units, NULL);
    info->is_gpu = (type & CL_DEVICE_TYPE_GPU) != 0;
    info->image_support = images == CL_TRUE;
    info->max_alloc_bytes = max_alloc;
    info->global_mem_bytes = global_mem;
    info->compute_units = units;
}

pb_status pb_ocl_device_info(int index, pb_device_info *info)
{
    cl_device_id devs[1024];
    cl_platform_id plats[1024];
    cl_uint n = 0;
    pb_status st = pb_cl_load(NULL);
    if (st == PB_OK)
        st = list_devices(devs, plats, 1024, &n);
    if (st != PB_OK)
        return st;
    fill_info(devs[index], plats[index], info);
    return PB_OK;
}

/* Single-channel float 3-D images must exist; linear filtering of float images
 * is then required by OpenCL 1.2 (section 5.3.2.1). */
static int has_float_r_images(cl_context context)
{
    cl_image_format formats[512];
    cl_uint n = 0;
    if (pb_cl.clGetSupportedImageFormats(context, CL_MEM_READ_ONLY, CL_MEM_OBJECT_IMAGE3D, 512, formats, &n) != CL_SUCCESS)
        return 0;
    for (cl_uint i = 0; i < n && i < 512; i++)
        if (formats[i].image_channel_order == CL_R && formats[i].image_channel_data_type == CL_FLOAT)
            return 1;
    return 0;
}

static pb_status build_program(pb_device *dev, cl_impl *cl, const char *extra, int nvidia)
{
    cl_int e;
    const char *src = pb_kernel_source;
    cl->program = pb_cl.clCreateProgramWithSource(cl->context, 1, &src, NULL, &e);
    if (e != CL_SUCCESS)
        return pb_cl_fail(dev, PB_ERR_BUILD, "clCreateProgramWithSource", e);
    /* NVIDIA's compiler takes inline PTX, which gives the adjoint a native
     * float atomic add (cl/pb_shim.h). */
    const char *vendor = nvidia ? "-DPB_OPENCL_NVIDIA " : "";
    char options[1024];
    snprintf(options, sizeof options, "-cl-std=CL1.2 %s%s", vendor, extra ? extra : "");
    e = pb_cl.clBuildProgram(cl->program, 1, &cl->device, options, NULL, NULL);
    if (e != CL_SUCCESS) {
        size_t len = 0;
        pb_cl.clGetProgramBuildInfo(cl->program, cl->device, CL_PROGRAM_BUILD_LOG, 0, NULL, &len);
        char *log = malloc(len + 1);
        if (log) {
            log[0] = '\0';
            pb_cl.clGetProgramBuildInfo(cl->program, cl->device, CL_PROGRAM_BUILD_LOG, len, log, NULL);
            log[len] = '\0';
        }
        pb_error(pb_owner(dev), PB_ERR_BUILD,
                 "clBuildProgram() failed: %s (%d) with options \"%s\" on '%s'; check the build options or the "
                 "device's OpenCL compiler. Build log:\n",
                 cl_error_name(e), (int)e, options, dev->info.name);
        pb_error_append(pb_owner(dev), log ? log : "(no memory for the log)");
        free(log);
        return PB_ERR_BUILD;
    }
    for (int k = 0; k < PB_KERNEL_COUNT; k++) {
        cl->kernels[k] = pb_cl.clCreateKernel(cl->program, pb_kernel_table[k].name, &e);
        if (e != CL_SUCCESS)
            return pb_cl_fail(dev, PB_ERR_BUILD, "clCreateKernel", e);
    }
    return PB_OK;
}

pb_status pb_ocl_context_init(pb_device *dev, int index, const char *build_options)
{
    cl_device_id devs[1024];
    cl_platform_id plats[1024];
    cl_uint n = 0;
    pb_status st = pb_cl_load(dev);
    if (st != PB_OK)
        return st;
    st = list_devices(devs, plats, 1024, &n);
    if (st != PB_OK)
        return pb_error(pb_owner(dev), st, "%s", pb_last_error(NULL));
    if (n == 0)
        return pb_error(pb_owner(dev), PB_ERR_NO_DEVICE,
                        "no OpenCL device found; install an OpenCL driver (on Debian: apt-get install "
                        "pocl-opencl-icd ocl-icd-libopencl1) or check OCL_ICD_VENDORS");
    if ((cl_uint)index >= n)
        return pb_error(pb_owner(dev), PB_ERR_NO_DEVICE, "OpenCL device %d does not exist (%u found); pick 0 to %u", index, n,
                        n - 1);
    cl_impl *cl = calloc(1, sizeof *cl);
    if (!cl)
        return pb_error(pb_owner(dev), PB_ERR_OUT_OF_MEMORY, "out of host memory for an OpenCL context");
    dev->impl = cl;
    cl->device = devs[index];
    fill_info(cl->device, plats[index], &dev->info);
    cl->is_gpu = dev->info.is_gpu;
    int nvidia = strstr(dev->info.platform, "NVIDIA") != NULL;
    /* NVIDIA's texture unit rounds filter weights (cl/pb_adjoint.cl); PoCL's are float. */
    dev->texture_weight_steps = nvidia ? PB_NVIDIA_WEIGHT_STEPS : 0.0f;
    if (pb_cl.clGetDeviceInfo(cl->device, CL_DEVICE_IMAGE2D_MAX_WIDTH, sizeof(size_t), &dev->layer_limits[0], NULL) ||
        pb_cl.clGetDeviceInfo(cl->device, CL_DEVICE_IMAGE2D_MAX_HEIGHT, sizeof(size_t), &dev->layer_limits[1], NULL) ||
        pb_cl.clGetDeviceInfo(cl->device, CL_DEVICE_IMAGE_MAX_ARRAY_SIZE, sizeof(size_t), &dev->layer_limits[2], NULL))
        memset(dev->layer_limits, 0, sizeof dev->layer_limits); /* unknown: no layers */

    cl_int e;
    cl_context_properties props[] = {CL_CONTEXT_PLATFORM, (cl_context_properties)plats[index], 0};
    cl->context = pb_cl.clCreateContext(props, 1, &cl->device, NULL, NULL, &e);
    if (e != CL_SUCCESS)
        return pb_cl_fail(dev, PB_ERR_DEVICE, "clCreateContext", e);
    if (dev->info.image_support && !has_float_r_images(cl->context))
        dev->info.image_support = 0;
    if (!dev->info.image_support)
        return pb_device_check_volume(dev, &dev->info, &(pb_geometry){{1, 1, 1}, {1, 1, 1}});
    cl->queue = pb_cl.clCreateCommandQueue(cl->context, cl->device, CL_QUEUE_PROFILING_ENABLE, &e);
    if (e != CL_SUCCESS)
        return pb_cl_fail(dev, PB_ERR_DEVICE, "clCreateCommandQueue", e);
    return build_program(dev, cl, build_options, nvidia);
}

void pb_ocl_context_release(pb_device *dev)
{
    cl_impl *cl = dev->impl;
    if (!cl)
        return;
    for (int k = 0; k < PB_KERNEL_COUNT; k++)
        if (cl->kernels[k])
            pb_cl.clReleaseKernel(cl->kernels[k]);
    if (cl->program)
        pb_cl.clReleaseProgram(cl->program);
    free(cl->timed);
    if (cl->queue)
        pb_cl.clReleaseCommandQueue(cl->queue);
    if (cl->context)
        pb_cl.clReleaseContext(cl->context);
    free(cl);
    dev->impl = NULL;
}

