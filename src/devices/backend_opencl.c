/* The OpenCL backend's primitives (src/devices/backend.h): buffers, images, launches
 * by kernel id and profiling-event timing, each a translation into OpenCL
 * calls; the device side is opencl_device.c. */
#include <stdlib.h>
#include <string.h>

#include "opencl_impl.h"

static void ocl_native(const pb_device *dev, pb_native *out)
{
    const cl_impl *cl = dev->impl;
    out->context = cl->context;
    out->queue = cl->queue;
    out->device = cl->device;
}

/* ---- buffers ----------------------------------------------------------- */

static pb_status ocl_buffer_create(pb_device *dev, size_t bytes, void **buffer)
{
    cl_impl *cl = dev->impl;
    cl_int e;
    cl_mem mem = pb_cl.clCreateBuffer(cl->context, CL_MEM_READ_WRITE, bytes, NULL, &e);
    if (e != CL_SUCCESS)
        return pb_cl_fail(dev, PB_ERR_DEVICE, "clCreateBuffer", e);
    *buffer = mem;
    return PB_OK;
}

static void ocl_buffer_release(pb_device *dev, void *buffer)
{
    (void)dev;
    pb_cl.clReleaseMemObject((cl_mem)buffer);
}

static pb_status ocl_buffer_write(pb_device *dev, void *buffer, const void *host, size_t bytes)
{
    cl_impl *cl = dev->impl;
    cl_int e = pb_cl.clEnqueueWriteBuffer(cl->queue, (cl_mem)buffer, CL_TRUE, 0, bytes, host, 0, NULL, NULL);
    return e == CL_SUCCESS ? PB_OK : pb_cl_fail(dev, PB_ERR_DEVICE, "clEnqueueWriteBuffer", e);
}

static pb_status ocl_buffer_read(pb_device *dev, const void *buffer, void *host, size_t bytes)
{
    cl_impl *cl = dev->impl;
    cl_int e = pb_cl.clEnqueueReadBuffer(cl->queue, (cl_mem)buffer, CL_TRUE, 0, bytes, host, 0, NULL, NULL);
    return e == CL_SUCCESS ? PB_OK : pb_cl_fail(dev, PB_ERR_DEVICE, "clEnqueueReadBuffer", e);
}

/* The event slot of the next command: one of the timer's, or NULL. */
static cl_event *timed_slot(pb_device *dev)
{
    cl_impl *cl = dev->impl;
    if (!cl->timing)
        return NULL;
    if (cl->timed_count == cl->timed_cap) {
        size_t cap = cl->timed_cap ? 2 * cl->timed_cap : 64;
        cl_timed *t = realloc(cl->timed, cap * sizeof *t);
        if (!t)
            return NULL; /* the command runs untimed */
        cl->timed = t;
        cl->timed_cap = cap;
    }
    cl->timed[cl->timed_count].event = NULL;
    cl->timed[cl->timed_count].before_mark = 0;
    return &cl->timed[cl->timed_count].event;
}

/* A command was queued with the slot from timed_slot: keep its event. */
static void timed_queued(pb_device *dev, cl_event *slot)
{
    cl_impl *cl = dev->impl;
    if (slot && *slot)
        cl->timed_count++;
}

static pb_status ocl_buffer_zero(pb_device *dev, void *buffer, size_t bytes)
{
    cl_impl *cl = dev->impl;
    const float zero = 0.0f;
    cl_event *ev = timed_slot(dev);
    cl_int e = pb_cl.clEnqueueFillBuffer(cl->queue, (cl_mem)buffer, &zero, sizeof zero, 0, bytes, 0, NULL, ev);
    if (e != CL_SUCCESS)
        return pb_cl_fail(dev, PB_ERR_DEVICE, "clEnqueueFillBuffer", e);
    timed_queued(dev, ev);
    return PB_OK;
}

/* A valid cl_mem is all it can check: OpenCL has no way to ask whether a
 * pointer is one, and the ICD loader reads through what it is given. */
static pb_status ocl_buffer_check(pb_device *dev, const void *buffer, size_t bytes, const char *what, int written)
{
    cl_impl *cl = dev->impl;
    cl_mem mem = (cl_mem)buffer;
    cl_mem_object_type type = 0;
    cl_mem_flags flags = 0;
    cl_context owner = NULL;
    size_t size = 0;
    if (pb_cl.clGetMemObjectInfo(mem, CL_MEM_TYPE, sizeof type, &type, NULL) != CL_SUCCESS ||
        type != CL_MEM_OBJECT_BUFFER)
        return pb_error(pb_owner(dev), PB_ERR_INVALID_ARGUMENT, "the %s is not an OpenCL buffer; pass a cl_mem made by "
                        "clCreateBuffer", what);
    if (pb_cl.clGetMemObjectInfo(mem, CL_MEM_CONTEXT, sizeof owner, &owner, NULL) != CL_SUCCESS || owner != cl->context)
        return pb_error(pb_owner(dev), PB_ERR_INVALID_ARGUMENT, "the %s buffer belongs to another OpenCL context; make it in "
                        "the context's own (pb_context_native)", what);
    if (pb_cl.clGetMemObjectInfo(mem, CL_MEM_SIZE, sizeof size, &size, NULL) != CL_SUCCESS || size < bytes)
        return pb_error(pb_owner(dev), PB_ERR_SIZE_MISMATCH, "the %s buffer holds %zu bytes, the plan's volume %zu; pass a "
                        "buffer of the plan's geometry", what, size, bytes);
    if (pb_cl.clGetMemObjectInfo(mem, CL_MEM_FLAGS, sizeof flags, &flags, NULL) == CL_SUCCESS &&
        (flags & (written ? CL_MEM_READ_ONLY : CL_MEM_WRITE_ONLY)))
        return pb_error(pb_owner(dev), PB_ERR_INVALID_ARGUMENT, "the %s buffer is %s; make it CL_MEM_READ_WRITE", what,
                        written ? "CL_MEM_READ_ONLY, and petblur writes it" : "CL_MEM_WRITE_ONLY, and petblur reads it");
    return PB_OK;
}

/* ---- images ------------------------------------------------------------ */

static pb_status ocl_image_create(pb_device *dev, int layered, const size_t extent[3], void **image)
{
    cl_impl *cl = dev->impl;
    cl_image *img = calloc(1, sizeof *img);
    if (!img)
        return pb_error(pb_owner(dev), PB_ERR_OUT_OF_MEMORY, "out of host memory for an image");
    cl_image_format fmt = {CL_R, CL_FLOAT};
    cl_image_desc desc;
    memset(&desc, 0, sizeof desc);
    desc.image_type = layered ? CL_MEM_OBJECT_IMAGE2D_ARRAY : CL_MEM_OBJECT_IMAGE3D;
    desc.image_width = extent[0];
    desc.image_height = extent[1];
    if (layered)
        desc.image_array_size = extent[2];
    else
        desc.image_depth = extent[2];
    cl_int e;
    img->mem = pb_cl.clCreateImage(cl->context, CL_MEM_READ_ONLY, &fmt, &desc, NULL, &e);
    if (e != CL_SUCCESS) {
        free(img);
        return pb_cl_fail(dev, PB_ERR_DEVICE, layered ? "clCreateImage (layers)" : "clCreateImage", e);
    }
    memcpy(img->region, extent, sizeof img->region);
    *image = img;
    return PB_OK;
}

static void ocl_image_release(pb_device *dev, void *image)
{
    (void)dev;
    cl_image *img = image;
    pb_cl.clReleaseMemObject(img->mem);
    free(img);
}

static pb_status ocl_image_copy(pb_device *dev, void *image, const void *buffer)
{
    cl_impl *cl = dev->impl;
    cl_image *img = image;
    size_t origin[3] = {0, 0, 0};
    cl_event *ev = timed_slot(dev);
    cl_int e = pb_cl.clEnqueueCopyBufferToImage(cl->queue, (cl_mem)buffer, img->mem, 0, origin, img->region, 0, NULL, ev);
    if (e != CL_SUCCESS)
        return pb_cl_fail(dev, PB_ERR_DEVICE, "clEnqueueCopyBufferToImage", e);
    timed_queued(dev, ev);
    return PB_OK;
}

/* ---- launches and timing ----------------------------------------------- */

/* GPUs get the table's work groups, as CUDA's blocks; CPUs let the runtime
 * split the exact grid. The kernels check bounds. */
static pb_status ocl_launch(pb_device *dev, const pb_launch *l)
{
    cl_impl *cl = dev->impl;
    const pb_kernel_info *info = &pb_kernel_table[l->kernel];
    cl_kernel k = cl->kernels[l->kernel];
    cl_mem in = info->reads == PB_READS_BUFFER ? (cl_mem)l->input : ((const cl_image *)l->input)->mem;
    cl_mem plan = (cl_mem)l->plan, out = (cl_mem)l->out;
    cl_int e = pb_cl.clSetKernelArg(k, 0, sizeof(cl_mem), &in);
    e |= pb_cl.clSetKernelArg(k, 1, sizeof(cl_mem), &plan);
    e |= pb_cl.clSetKernelArg(k, 2, sizeof l->prm, &l->prm);
    e |= pb_cl.clSetKernelArg(k, 3, sizeof(cl_mem), &out);
    if (e != CL_SUCCESS)
        return pb_cl_fail(dev, PB_ERR_LAUNCH, "clSetKernelArg", e);
    /* On a CPU the implementation picks the group, except for a kernel
     * whose local memory is laid out for the table's (pb_shift_taps_tile). */
    int grouped = cl->is_gpu || l->kernel == PB_KERNEL_SHIFT_TAPS_TILE;
    size_t local[3], global[3];
    for (int d = 0; d < 3; d++) {
        local[d] = info->group[d];
        global[d] = grouped ? (l->extent[d] + local[d] - 1) / local[d] * local[d] : l->extent[d];
    }
    cl_event *ev = timed_slot(dev);
    e = pb_cl.clEnqueueNDRangeKernel(cl->queue, k, 3, NULL, global, grouped ? local : NULL, 0, NULL, ev);
    if (e != CL_SUCCESS)
        return pb_cl_fail(dev, PB_ERR_LAUNCH, "clEnqueueNDRangeKernel", e);
    timed_queued(dev, ev);
    return PB_OK;
}

static pb_status ocl_timer_begin(pb_device *dev)
{
    cl_impl *cl = dev->impl;
    cl->timing = 1;
    cl->timed_count = 0;
    return PB_OK;
}

/* What was timed so far made the input current. */
static pb_status ocl_timer_mark(pb_device *dev)
{
    cl_impl *cl = dev->impl;
    for (size_t i = 0; i < cl->timed_count; i++)
        cl->timed[i].before_mark = 1;
    return PB_OK;
}

/* Waits for the queue, then sums the timed commands' profiled times: the
 * kernels' own, without the gaps between launches. */
static pb_status ocl_timer_end(pb_device *dev, double *total_ms, double *before_mark_ms)
{
    cl_impl *cl = dev->impl;
    cl_int e = pb_cl.clFinish(cl->queue);
    if (e == CL_SUCCESS)
        for (size_t i = 0; i < cl->timed_count && e == CL_SUCCESS; i++)
            e = pb_cl.clWaitForEvents(1, &cl->timed[i].event); /* a failed kernel's status is its event's */
    *total_ms = *before_mark_ms = 0.0;
    for (size_t i = 0; i < cl->timed_count; i++) {
        cl_ulong t0 = 0, t1 = 0;
        pb_cl.clGetEventProfilingInfo(cl->timed[i].event, CL_PROFILING_COMMAND_START, sizeof t0, &t0, NULL);
        pb_cl.clGetEventProfilingInfo(cl->timed[i].event, CL_PROFILING_COMMAND_END, sizeof t1, &t1, NULL);
        double ms = t1 > t0 ? (double)(t1 - t0) * 1e-6 : 0.0;
        *total_ms += ms;
        if (cl->timed[i].before_mark)
            *before_mark_ms += ms;
        pb_cl.clReleaseEvent(cl->timed[i].event);
    }
    cl->timing = 0;
    cl->timed_count = 0;
    return e == CL_SUCCESS ? PB_OK : pb_cl_fail(dev, PB_ERR_LAUNCH, "the kernel (clWaitForEvents)", e);
}

const pb_backend_ops pb_backend_opencl_ops = {
    .id = PB_BACKEND_OPENCL,
    .device_count = pb_ocl_device_count,
    .device_info = pb_ocl_device_info,
    .context_init = pb_ocl_context_init,
    .context_release = pb_ocl_context_release,
    .native = ocl_native,
    .buffer_create = ocl_buffer_create,
    .buffer_release = ocl_buffer_release,
    .buffer_write = ocl_buffer_write,
    .buffer_read = ocl_buffer_read,
    .buffer_zero = ocl_buffer_zero,
    .buffer_check = ocl_buffer_check,
    .image_create = ocl_image_create,
    .image_release = ocl_image_release,
    .image_copy = ocl_image_copy,
    .launch = ocl_launch,
    .frame_prepare = pb_launch_prepare,
    .frame_apply = pb_launch_frame,
    .frames_forward = pb_launch_frames,
    .frames_apply = pb_launch_frames_apply,
    .timer_begin = ocl_timer_begin,
    .timer_mark = ocl_timer_mark,
    .timer_end = ocl_timer_end,
};
