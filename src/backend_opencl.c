/* The OpenCL backend (through the ICD loader: PoCL, NVIDIA, AMD, Intel). The only
 * file that includes CL/cl.h. */
#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>
#include <CL/cl_ext.h> /* CL_PLATFORM_NOT_FOUND_KHR: the ICD loader found no platform */

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "backend.h"
#include "kernel_args.h"

extern const char pb_kernel_source[];

typedef struct cl_impl {
    cl_device_id device;
    cl_context context;
    cl_command_queue queue;
    cl_program program;
    cl_kernel kernels[PB_KERNEL_COUNT]; /* indexed by pb_kernel_index */
    int is_gpu;
    int nvidia; /* NVIDIA's platform: its texture unit rounds weights to 8 bits */
    size_t layer_limits[3]; /* 2-D image arrays: width, height, layers */
    cl_mem scratch;         /* a volume laid out for its layers (pb_permute), kept: the adjoint's */
    size_t scratch_bytes;   /* gather lays out every tomograph it reads */
} cl_impl;

typedef struct cl_volume {
    cl_mem buffer; /* what the kernels write and the host reads */
    cl_mem image;  /* what the kernels sample; made on first use as an input */
    int image_stale;
    cl_mem layers[3]; /* 2-D image arrays along each axis, for pb_shift_ab_layers, made on first use */
    int layers_stale[3];
} cl_volume;

/* The buffer changed: the image and layers made from it are out of date. */
static void mark_written(cl_volume *v)
{
    v->image_stale = 1;
    for (int m = 0; m < 3; m++)
        v->layers_stale[m] = 1;
}

static const char *const kernel_names[PB_KERNEL_COUNT] = PB_KERNEL_NAMES;

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
static pb_status cl_fail(pb_context *ctx, pb_status kind, const char *call, cl_int e)
{
    if (e == CL_MEM_OBJECT_ALLOCATION_FAILURE || e == CL_OUT_OF_HOST_MEMORY || e == CL_OUT_OF_RESOURCES)
        kind = PB_ERR_OUT_OF_MEMORY;
    return pb_error(ctx, kind, "%s() failed: %s (%d)%s", call, cl_error_name(e), (int)e,
                    kind == PB_ERR_OUT_OF_MEMORY ? "; free device memory or use a smaller volume" : "");
}

/* All devices of all platforms, flattened in platform order. */
static pb_status list_devices(cl_device_id *devices, cl_platform_id *platforms_of, cl_uint max, cl_uint *count)
{
    cl_platform_id platforms[16];
    cl_uint np = 0;
    *count = 0;
    cl_int e = clGetPlatformIDs(16, platforms, &np);
    if (e == CL_PLATFORM_NOT_FOUND_KHR || (e == CL_SUCCESS && np == 0))
        return PB_OK;
    if (e != CL_SUCCESS)
        return cl_fail(NULL, PB_ERR_DEVICE, "clGetPlatformIDs", e);
    for (cl_uint p = 0; p < np && p < 16; p++) {
        cl_uint nd = 0;
        cl_device_id ids[64];
        e = clGetDeviceIDs(platforms[p], CL_DEVICE_TYPE_ALL, 64, ids, &nd);
        if (e == CL_DEVICE_NOT_FOUND)
            continue;
        if (e != CL_SUCCESS)
            return cl_fail(NULL, PB_ERR_DEVICE, "clGetDeviceIDs", e);
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

static pb_status ocl_device_count(int *count)
{
    cl_uint n = 0;
    pb_status st = list_devices(NULL, NULL, 1024, &n);
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
    clGetDeviceInfo(dev, CL_DEVICE_NAME, sizeof info->name - 1, info->name, NULL);
    clGetPlatformInfo(platform, CL_PLATFORM_NAME, sizeof info->platform - 1, info->platform, NULL);
    clGetDeviceInfo(dev, CL_DEVICE_TYPE, sizeof type, &type, NULL);
    clGetDeviceInfo(dev, CL_DEVICE_IMAGE_SUPPORT, sizeof images, &images, NULL);
    clGetDeviceInfo(dev, CL_DEVICE_IMAGE3D_MAX_WIDTH, sizeof(size_t), &info->image3d_max[0], NULL);
    clGetDeviceInfo(dev, CL_DEVICE_IMAGE3D_MAX_HEIGHT, sizeof(size_t), &info->image3d_max[1], NULL);
    clGetDeviceInfo(dev, CL_DEVICE_IMAGE3D_MAX_DEPTH, sizeof(size_t), &info->image3d_max[2], NULL);
    clGetDeviceInfo(dev, CL_DEVICE_MAX_MEM_ALLOC_SIZE, sizeof max_alloc, &max_alloc, NULL);
    clGetDeviceInfo(dev, CL_DEVICE_GLOBAL_MEM_SIZE, sizeof global_mem, &global_mem, NULL);
    clGetDeviceInfo(dev, CL_DEVICE_MAX_COMPUTE_UNITS, sizeof units, &units, NULL);
    info->is_gpu = (type & CL_DEVICE_TYPE_GPU) != 0;
    info->image_support = images == CL_TRUE;
    info->max_alloc_bytes = max_alloc;
    info->global_mem_bytes = global_mem;
    info->compute_units = units;
}

static pb_status ocl_device_info(int index, pb_device_info *info)
{
    cl_device_id devs[1024];
    cl_platform_id plats[1024];
    cl_uint n = 0;
    pb_status st = list_devices(devs, plats, 1024, &n);
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
    if (clGetSupportedImageFormats(context, CL_MEM_READ_ONLY, CL_MEM_OBJECT_IMAGE3D, 512, formats, &n) != CL_SUCCESS)
        return 0;
    for (cl_uint i = 0; i < n && i < 512; i++)
        if (formats[i].image_channel_order == CL_R && formats[i].image_channel_data_type == CL_FLOAT)
            return 1;
    return 0;
}

static pb_status build_program(pb_context *ctx, cl_impl *cl, const char *extra)
{
    cl_int e;
    const char *src = pb_kernel_source;
    cl->program = clCreateProgramWithSource(cl->context, 1, &src, NULL, &e);
    if (e != CL_SUCCESS)
        return cl_fail(ctx, PB_ERR_BUILD, "clCreateProgramWithSource", e);
    /* NVIDIA's compiler takes inline PTX, which gives the adjoint a native
     * float atomic add (cl/pb_shim.h). */
    const char *vendor = cl->nvidia ? "-DPB_OPENCL_NVIDIA " : "";
    char options[1024];
    snprintf(options, sizeof options, "-cl-std=CL1.2 %s%s", vendor, extra ? extra : "");
    e = clBuildProgram(cl->program, 1, &cl->device, options, NULL, NULL);
    if (e != CL_SUCCESS) {
        size_t len = 0;
        clGetProgramBuildInfo(cl->program, cl->device, CL_PROGRAM_BUILD_LOG, 0, NULL, &len);
        char *log = malloc(len + 1);
        if (log) {
            log[0] = '\0';
            clGetProgramBuildInfo(cl->program, cl->device, CL_PROGRAM_BUILD_LOG, len, log, NULL);
            log[len] = '\0';
        }
        pb_error(ctx, PB_ERR_BUILD,
                 "clBuildProgram() failed: %s (%d) with options \"%s\" on '%s'; check the build options or the "
                 "device's OpenCL compiler. Build log:\n",
                 cl_error_name(e), (int)e, options, ctx->device.name);
        pb_error_append(ctx, log ? log : "(no memory for the log)");
        free(log);
        return PB_ERR_BUILD;
    }
    for (int k = 0; k < PB_KERNEL_COUNT; k++) {
        cl->kernels[k] = clCreateKernel(cl->program, kernel_names[k], &e);
        if (e != CL_SUCCESS)
            return cl_fail(ctx, PB_ERR_BUILD, "clCreateKernel", e);
    }
    return PB_OK;
}

static pb_status ocl_context_init(pb_context *ctx, int index, const char *build_options)
{
    cl_device_id devs[1024];
    cl_platform_id plats[1024];
    cl_uint n = 0;
    pb_status st = list_devices(devs, plats, 1024, &n);
    if (st != PB_OK)
        return pb_error(ctx, st, "%s", pb_last_error(NULL));
    if (n == 0)
        return pb_error(ctx, PB_ERR_NO_DEVICE,
                        "no OpenCL device found; install an OpenCL driver (on Debian: apt-get install "
                        "pocl-opencl-icd ocl-icd-libopencl1) or check OCL_ICD_VENDORS");
    if ((cl_uint)index >= n)
        return pb_error(ctx, PB_ERR_NO_DEVICE, "OpenCL device %d does not exist (%u found); pick 0 to %u", index, n,
                        n - 1);
    cl_impl *cl = calloc(1, sizeof *cl);
    if (!cl)
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for an OpenCL context");
    ctx->impl = cl;
    cl->device = devs[index];
    fill_info(cl->device, plats[index], &ctx->device);
    cl->is_gpu = ctx->device.is_gpu;
    cl->nvidia = strstr(ctx->device.platform, "NVIDIA") != NULL;
    if (clGetDeviceInfo(cl->device, CL_DEVICE_IMAGE2D_MAX_WIDTH, sizeof(size_t), &cl->layer_limits[0], NULL) ||
        clGetDeviceInfo(cl->device, CL_DEVICE_IMAGE2D_MAX_HEIGHT, sizeof(size_t), &cl->layer_limits[1], NULL) ||
        clGetDeviceInfo(cl->device, CL_DEVICE_IMAGE_MAX_ARRAY_SIZE, sizeof(size_t), &cl->layer_limits[2], NULL))
        memset(cl->layer_limits, 0, sizeof cl->layer_limits); /* unknown: no layers */

    cl_int e;
    cl_context_properties props[] = {CL_CONTEXT_PLATFORM, (cl_context_properties)plats[index], 0};
    cl->context = clCreateContext(props, 1, &cl->device, NULL, NULL, &e);
    if (e != CL_SUCCESS)
        return cl_fail(ctx, PB_ERR_DEVICE, "clCreateContext", e);
    if (ctx->device.image_support && !has_float_r_images(cl->context))
        ctx->device.image_support = 0;
    if (!ctx->device.image_support)
        return pb_device_check_volume(ctx, &ctx->device, &(pb_geometry){{1, 1, 1}, {1, 1, 1}});
    cl->queue = clCreateCommandQueue(cl->context, cl->device, CL_QUEUE_PROFILING_ENABLE, &e);
    if (e != CL_SUCCESS)
        return cl_fail(ctx, PB_ERR_DEVICE, "clCreateCommandQueue", e);
    return build_program(ctx, cl, build_options);
}

static void ocl_context_release(pb_context *ctx)
{
    cl_impl *cl = ctx->impl;
    if (!cl)
        return;
    for (int k = 0; k < PB_KERNEL_COUNT; k++)
        if (cl->kernels[k])
            clReleaseKernel(cl->kernels[k]);
    if (cl->program)
        clReleaseProgram(cl->program);
    if (cl->scratch)
        clReleaseMemObject(cl->scratch);
    if (cl->queue)
        clReleaseCommandQueue(cl->queue);
    if (cl->context)
        clReleaseContext(cl->context);
    free(cl);
    ctx->impl = NULL;
}

static pb_status ocl_volume_init(pb_volume *vol)
{
    cl_impl *cl = vol->ctx->impl;
    cl_volume *v = calloc(1, sizeof *v);
    if (!v)
        return pb_error(vol->ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for a volume");
    cl_int e;
    v->buffer = clCreateBuffer(cl->context, CL_MEM_READ_WRITE, vol->count * sizeof(float), NULL, &e);
    if (e != CL_SUCCESS) {
        free(v);
        return cl_fail(vol->ctx, PB_ERR_DEVICE, "clCreateBuffer", e);
    }
    mark_written(v);
    vol->impl = v;
    return PB_OK;
}

static void ocl_volume_release(pb_volume *vol)
{
    cl_volume *v = vol->impl;
    if (v->image)
        clReleaseMemObject(v->image);
    for (int m = 0; m < 3; m++)
        if (v->layers[m])
            clReleaseMemObject(v->layers[m]);
    clReleaseMemObject(v->buffer);
    free(v);
}

static pb_status ocl_volume_upload(pb_volume *vol, const float *host)
{
    cl_impl *cl = vol->ctx->impl;
    cl_volume *v = vol->impl;
    cl_int e = clEnqueueWriteBuffer(cl->queue, v->buffer, CL_TRUE, 0, vol->count * sizeof(float), host, 0, NULL, NULL);
    if (e != CL_SUCCESS)
        return cl_fail(vol->ctx, PB_ERR_DEVICE, "clEnqueueWriteBuffer", e);
    mark_written(v);
    return PB_OK;
}

static pb_status ocl_volume_download(const pb_volume *vol, float *host)
{
    cl_impl *cl = vol->ctx->impl;
    const cl_volume *v = vol->impl;
    cl_int e = clEnqueueReadBuffer(cl->queue, v->buffer, CL_TRUE, 0, vol->count * sizeof(float), host, 0, NULL, NULL);
    if (e != CL_SUCCESS)
        return cl_fail(vol->ctx, PB_ERR_DEVICE, "clEnqueueReadBuffer", e);
    return PB_OK;
}

static cl_int wait_timed(pb_context *ctx, cl_int e, cl_event ev);

/* A single-channel float image the kernels read: 3-D of region, or a 2-D
 * array of region[2] layers of region[0] x region[1]. */
static cl_mem new_float_image(const cl_impl *cl, cl_mem_object_type type, const size_t *region, cl_int *e)
{
    cl_image_format fmt = {CL_R, CL_FLOAT};
    cl_image_desc desc;
    memset(&desc, 0, sizeof desc);
    desc.image_type = type;
    desc.image_width = region[0];
    desc.image_height = region[1];
    if (type == CL_MEM_OBJECT_IMAGE3D)
        desc.image_depth = region[2];
    else
        desc.image_array_size = region[2];
    return clCreateImage(cl->context, CL_MEM_READ_ONLY, &fmt, &desc, NULL, e);
}


/* Brings the volume's image up to date with its buffer; with timed, the copy
 * is waited for and counts with the kernel time (the adjoint's gather, whose
 * input is fresh from a projector each time). */
static pb_status refresh_image(pb_context *ctx, const pb_volume *vol, int timed)
{
    cl_impl *cl = ctx->impl;
    cl_volume *v = vol->impl;
    size_t region[3] = {vol->geometry.dims[0], vol->geometry.dims[1], vol->geometry.dims[2]};
    cl_int e;
    if (!v->image) {
        v->image = new_float_image(cl, CL_MEM_OBJECT_IMAGE3D, region, &e);
        if (e != CL_SUCCESS) {
            v->image = NULL;
            return cl_fail(ctx, PB_ERR_DEVICE, "clCreateImage", e);
        }
        v->image_stale = 1;
    }
    if (v->image_stale) {
        size_t origin[3] = {0, 0, 0};
        cl_event ev = NULL;
        e = clEnqueueCopyBufferToImage(cl->queue, v->buffer, v->image, 0, origin, region, 0, NULL,
                                       timed ? &ev : NULL);
        if (timed)
            e = wait_timed(ctx, e, ev);
        if (e != CL_SUCCESS)
            return cl_fail(ctx, PB_ERR_DEVICE, "clEnqueueCopyBufferToImage", e);
        v->image_stale = 0;
    }
    return PB_OK;
}

/* The plan's key poses (or REF steps) as the kernels read them, in float. */
static pb_status upload_plan(pb_context *ctx, const pb_path *plan, const pb_blur_options *opt, cl_mem *out)
{
    cl_impl *cl = ctx->impl;
    size_t bytes;
    void *data = pb_kernel_plan_pack(plan, opt->method, &bytes);
    if (!data)
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for the %s",
                        opt->method == PB_METHOD_REF ? "reference's steps" : "key poses");
    cl_int e;
    *out = clCreateBuffer(cl->context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, bytes, data, &e);
    free(data);
    return e == CL_SUCCESS ? PB_OK : cl_fail(ctx, PB_ERR_DEVICE, "clCreateBuffer", e);
}

/* Adds a finished command's profiled time to the context's kernel time and
 * releases its event. */
static void add_event_time(pb_context *ctx, cl_event ev)
{
    cl_ulong t0 = 0, t1 = 0;
    clGetEventProfilingInfo(ev, CL_PROFILING_COMMAND_START, sizeof t0, &t0, NULL);
    clGetEventProfilingInfo(ev, CL_PROFILING_COMMAND_END, sizeof t1, &t1, NULL);
    ctx->last_kernel_ms += (double)(t1 - t0) * 1e-6;
    clReleaseEvent(ev);
}

/* Waits for a queued command (e: what queueing it returned; ev is read only
 * when that succeeded) and counts its time. */
static cl_int wait_timed(pb_context *ctx, cl_int e, cl_event ev)
{
    if (e != CL_SUCCESS)
        return e;
    e = clWaitForEvents(1, &ev);
    if (e == CL_SUCCESS)
        add_event_time(ctx, ev);
    else
        clReleaseEvent(ev);
    return e;
}

/* A launch's work group: GPUs get pb_kernel_group's, as CUDA's blocks; CPUs
 * let the runtime split the exact grid (local[0] = 0). */
static void group_of(const cl_impl *cl, int kernel, size_t *local)
{
    unsigned gpu[3];
    pb_kernel_group(kernel, gpu);
    for (int d = 0; d < 3; d++)
        local[d] = cl->is_gpu ? gpu[d] : 0;
}

/* Queues kernel `kernel`, its arguments set, over dims voxels from offset
 * (NULL: the origin), in groups from group_of. The kernels see absolute ids
 * and check bounds. */
static cl_int enqueue_grid(cl_impl *cl, int kernel, const size_t *offset, const size_t *dims, cl_event *ev)
{
    size_t local[3], global[3], extent[3];
    group_of(cl, kernel, local);
    pb_kernel_extent(kernel, dims, extent);
    for (int d = 0; d < 3; d++)
        global[d] = local[0] ? (extent[d] + local[d] - 1) / local[d] * local[d] : extent[d];
    return clEnqueueNDRangeKernel(cl->queue, cl->kernels[kernel], 3, offset, global, local[0] ? local : NULL, 0, NULL,
                                  ev);
}

/* Launches kernel `kernel` over the plan's grid, waited for, its time counted.
 * With a progress report, slabs of z-slices through the global offset, each a
 * whole number of work groups deep: a group that reached past its slab would
 * do the next slab's voxels twice, which the adjoint's adds would count twice. */
static cl_int launch_grid(pb_context *ctx, int kernel, const pb_path *plan)
{
    size_t offset[3] = {0, 0, 0}, local[3];
    group_of(ctx->impl, kernel, local);
    size_t nz = plan->geometry.dims[2], slab = ctx->progress ? pb_progress_slab(nz) : nz;
    if (local[2] > 1)
        slab = (slab + local[2] - 1) / local[2] * local[2];
    cl_int e = CL_SUCCESS;
    for (; offset[2] < nz && e == CL_SUCCESS; offset[2] += slab) {
        size_t dims[3] = {plan->geometry.dims[0], plan->geometry.dims[1], nz - offset[2] < slab ? nz - offset[2] : slab};
        cl_event ev = NULL;
        e = enqueue_grid(ctx->impl, kernel, offset, dims, &ev);
        e = wait_timed(ctx, e, ev);
        if (e == CL_SUCCESS && ctx->progress && offset[2] + slab < nz)
            ctx->progress((double)(offset[2] + slab) / (double)nz, ctx->progress_user);
    }
    return e;
}

/* Sets kernel k's four arguments: what it reads, the plan, the parameters and
 * the buffer it writes. */
static cl_int set_args(cl_kernel k, cl_mem in, cl_mem poses, const pb_kparams *prm, cl_mem out)
{
    cl_int e = clSetKernelArg(k, 0, sizeof(cl_mem), &in);
    e |= clSetKernelArg(k, 1, sizeof(cl_mem), &poses);
    e |= clSetKernelArg(k, 2, sizeof *prm, prm);
    e |= clSetKernelArg(k, 3, sizeof(cl_mem), &out);
    return e;
}

/* The context's scratch buffer, grown to at least bytes; it lives as long as
 * the context. */
static cl_int reserve_scratch(cl_impl *cl, size_t bytes)
{
    if (bytes <= cl->scratch_bytes)
        return CL_SUCCESS;
    if (cl->scratch)
        clReleaseMemObject(cl->scratch);
    cl->scratch_bytes = 0;
    cl_int e;
    cl->scratch = clCreateBuffer(cl->context, CL_MEM_READ_WRITE, bytes, NULL, &e);
    if (e != CL_SUCCESS)
        cl->scratch = NULL;
    else
        cl->scratch_bytes = bytes;
    return e;
}

/* Lays vol out in a 2-D image array along axis m (pb_permute into the
 * context's scratch buffer, then a copy; along z the buffer already is in
 * that order), once per axis and change of the buffer; frames that share an
 * object along different axes each keep theirs. With timed, as in
 * refresh_image, the work is waited for and counts with the kernel time: the
 * forward's object is laid out once and blurred many times, the adjoint's
 * gather lays out every tomograph it reads. */
static pb_status refresh_layers(pb_context *ctx, const pb_volume *vol, int m, int timed)
{
    cl_impl *cl = ctx->impl;
    cl_volume *v = vol->impl;
    const size_t *n = vol->geometry.dims;
    size_t region[3] = {n[pb_layer_across(m, 0)], n[pb_layer_across(m, 1)], n[m]};
    cl_int e = CL_SUCCESS;
    if (!v->layers[m]) {
        v->layers[m] = new_float_image(cl, CL_MEM_OBJECT_IMAGE2D_ARRAY, region, &e);
        if (e != CL_SUCCESS) {
            v->layers[m] = NULL;
            return cl_fail(ctx, PB_ERR_DEVICE, "clCreateImage (layers)", e);
        }
        v->layers_stale[m] = 1;
    }
    if (!v->layers_stale[m])
        return PB_OK;
    cl_mem source = v->buffer;
    cl_event ev = NULL;
    if (m != 2) {
        if ((e = reserve_scratch(cl, vol->count * sizeof(float))) != CL_SUCCESS)
            return cl_fail(ctx, PB_ERR_DEVICE, "clCreateBuffer (layers)", e);
        source = cl->scratch;
        pb_kparams prm;
        pb_kparams_permute(n, m, &prm);
        e = set_args(cl->kernels[PB_KERNEL_PERMUTE], v->buffer, v->buffer, &prm, source);
        if (e == CL_SUCCESS)
            e = enqueue_grid(cl, PB_KERNEL_PERMUTE, NULL, n, timed ? &ev : NULL);
        if (timed)
            e = wait_timed(ctx, e, ev);
    }
    size_t origin[3] = {0, 0, 0};
    if (e == CL_SUCCESS)
        e = clEnqueueCopyBufferToImage(cl->queue, source, v->layers[m], 0, origin, region, 0, NULL,
                                       timed ? &ev : NULL);
    if (timed)
        e = wait_timed(ctx, e, ev);
    if (e != CL_SUCCESS)
        return cl_fail(ctx, PB_ERR_DEVICE, "laying the volume out in layers", e);
    v->layers_stale[m] = 0;
    return PB_OK;
}

/* Brings up to date what forward kernel `kernel` reads of vol (the image, or
 * the layers along the plan's axis) and returns it in *mem. */
static pb_status refresh_input(pb_context *ctx, const pb_volume *vol, int kernel, const pb_path *plan, int timed,
                               cl_mem *mem)
{
    const cl_volume *v = vol->impl;
    int m = pb_path_layer_axis(plan);
    int layered = pb_kernel_layered(kernel);
    pb_status st = layered ? refresh_layers(ctx, vol, m, timed) : refresh_image(ctx, vol, timed);
    *mem = layered ? v->layers[m] : v->image;
    return st;
}

static pb_status ocl_blur(pb_context *ctx, const pb_volume *object, const pb_path *plan,
                          const pb_blur_options *opt, pb_volume *tomograph)
{
    cl_impl *cl = ctx->impl;
    int kernel = pb_forward_kernel(plan, opt, cl->layer_limits);
    cl_mem source;
    pb_status st = refresh_input(ctx, object, kernel, plan, 0, &source);
    if (st != PB_OK)
        return st;
    cl_mem poses;
    st = upload_plan(ctx, plan, opt, &poses);
    if (st != PB_OK)
        return st;
    pb_kparams prm;
    pb_kparams_from_plan(plan, opt, &prm);

    cl_kernel k = cl->kernels[kernel];
    cl_volume *out = tomograph->impl;
    cl_int e = set_args(k, source, poses, &prm, out->buffer);
    if (e != CL_SUCCESS) {
        clReleaseMemObject(poses);
        return cl_fail(ctx, PB_ERR_LAUNCH, "clSetKernelArg", e);
    }
    ctx->last_kernel_ms = 0.0;
    e = launch_grid(ctx, kernel, plan);
    clReleaseMemObject(poses);
    if (e != CL_SUCCESS)
        return cl_fail(ctx, PB_ERR_LAUNCH, "clEnqueueNDRangeKernel or the kernel", e);
    mark_written(out);
    return PB_OK;
}

/* The frames queued back to back, then one wait: each launch keeps its own
 * plan buffer and event until the end. Every frame's kernel runs over the
 * whole grid (no slabs: there is no progress report in a batch). */
static pb_status ocl_blur_batch(pb_context *ctx, size_t frames, const pb_volume *const *objects,
                                const pb_path *plans, const pb_blur_options *opt, pb_volume *const *tomographs)
{
    cl_impl *cl = ctx->impl;
    cl_mem *poses = calloc(frames, sizeof *poses);
    cl_event *events = calloc(frames, sizeof *events);
    if (!poses || !events) {
        free(poses);
        free(events);
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for %zu frames", frames);
    }
    size_t queued = 0;
    pb_status st = PB_OK;
    cl_int e = CL_SUCCESS;
    for (size_t i = 0; i < frames && st == PB_OK; i++) {
        int kernel = pb_forward_kernel(&plans[i], opt, cl->layer_limits);
        cl_mem source;
        if ((st = refresh_input(ctx, objects[i], kernel, &plans[i], 0, &source)) != PB_OK ||
            (st = upload_plan(ctx, &plans[i], opt, &poses[i])) != PB_OK)
            break;
        pb_kparams prm;
        pb_kparams_from_plan(&plans[i], opt, &prm);
        cl_kernel k = cl->kernels[kernel];
        cl_volume *out = tomographs[i]->impl;
        /* A kernel's arguments are taken when it is queued, so one kernel
         * object serves every frame that uses it. */
        if ((e = set_args(k, source, poses[i], &prm, out->buffer)) != CL_SUCCESS) {
            st = cl_fail(ctx, PB_ERR_LAUNCH, "clSetKernelArg", e);
            break;
        }
        if ((e = enqueue_grid(cl, kernel, NULL, plans[i].geometry.dims, &events[i])) != CL_SUCCESS) {
            st = cl_fail(ctx, PB_ERR_LAUNCH, "clEnqueueNDRangeKernel", e);
            break;
        }
        queued++;
        mark_written(out);
    }
    /* Wait for whatever was queued, even after a failure: the buffers it
     * reads are released below. */
    if (queued && (e = clWaitForEvents((cl_uint)queued, events)) != CL_SUCCESS && st == PB_OK)
        st = cl_fail(ctx, PB_ERR_LAUNCH, "the kernel", e);
    ctx->last_kernel_ms = 0.0;
    for (size_t i = 0; i < queued; i++)
        add_event_time(ctx, events[i]);
    for (size_t i = 0; i < frames; i++)
        if (poses[i])
            clReleaseMemObject(poses[i]);
    free(poses);
    free(events);
    return st;
}

/* Zeros a buffer (the scatter adds into it); its time counts with the kernel's. */
static cl_int zero_buffer(pb_context *ctx, cl_mem buffer, size_t bytes)
{
    cl_impl *cl = ctx->impl;
    const float zero = 0.0f;
    cl_event ev = NULL;
    cl_int e = clEnqueueFillBuffer(cl->queue, buffer, &zero, sizeof zero, 0, bytes, 0, NULL, &ev);
    return wait_timed(ctx, e, ev);
}

/* Under a motion of translations only the adjoint is the shift-invariant
 * kernel mirrored (cl/pb_shift.cl): a gather that reads the tomograph through
 * an image, or through layers where the forward reads layers, whose making
 * counts with the kernel time, and writes (or adds into) every object voxel
 * once. Otherwise the scatter adds into zeros. */
static pb_status ocl_adjoint(pb_context *ctx, const pb_volume *tomograph, const pb_path *plan,
                             const pb_blur_options *opt, pb_volume *object, int accumulate)
{
    cl_impl *cl = ctx->impl;
    int gather = pb_path_shift_invariant(plan, opt);
    int kernel = gather ? pb_forward_kernel(plan, opt, cl->layer_limits) : pb_adjoint_index((int)opt->method);
    cl_volume *in = tomograph->impl, *out = object->impl;
    cl_mem source = in->buffer;
    ctx->last_kernel_ms = 0.0;
    pb_status st = gather ? refresh_input(ctx, tomograph, kernel, plan, 1, &source) : PB_OK;
    cl_mem poses;
    if (st != PB_OK || (st = upload_plan(ctx, plan, opt, &poses)) != PB_OK)
        return st;
    pb_kparams prm;
    pb_kparams_from_plan(plan, opt, &prm);
    prm.mirror = gather;
    prm.accumulate = accumulate;
    /* The scatter's transpose of what the image sampler computed
     * (cl/pb_adjoint.cl); PoCL's weights are float. */
    if (!gather && opt->filter == PB_FILTER_HARDWARE && cl->nvidia)
        prm.weight_steps = PB_NVIDIA_WEIGHT_STEPS;
    cl_int e = set_args(cl->kernels[kernel], source, poses, &prm, out->buffer);
    if (e != CL_SUCCESS) {
        clReleaseMemObject(poses);
        return cl_fail(ctx, PB_ERR_LAUNCH, "clSetKernelArg", e);
    }
    if (!gather && !accumulate)
        e = zero_buffer(ctx, out->buffer, object->count * sizeof(float));
    if (e != CL_SUCCESS) {
        clReleaseMemObject(poses);
        return cl_fail(ctx, PB_ERR_DEVICE, "clEnqueueFillBuffer", e);
    }
    e = launch_grid(ctx, kernel, plan);
    clReleaseMemObject(poses);
    mark_written(out);
    if (e != CL_SUCCESS)
        return cl_fail(ctx, PB_ERR_LAUNCH, "clEnqueueNDRangeKernel or the kernel", e);
    return PB_OK;
}

const pb_backend_ops pb_backend_opencl_ops = {
    PB_BACKEND_OPENCL,  ocl_device_count,  ocl_device_info,    ocl_context_init,
    ocl_context_release, ocl_volume_init, ocl_volume_release, ocl_volume_upload,
    ocl_volume_download, ocl_blur,         ocl_adjoint,          ocl_blur_batch,
};
