/* What the OpenCL backend's two files share: the context's runtime objects
 * (opencl_device.c opens and builds them, backend_opencl.c runs on them).
 * Only these two files include CL/cl.h. */
#ifndef PB_OPENCL_IMPL_H
#define PB_OPENCL_IMPL_H

#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>

#include "backend.h"

/* The OpenCL calls the backend makes, found at run time in the ICD loader
 * (opencl_loader.c) so that one build runs where libOpenCL is missing, the
 * backend then unavailable with the reason. Called as pb_cl.clName(...). */
#define PB_CL_FUNCTIONS(X)                                                                                            \
    X(clBuildProgram) X(clCreateBuffer) X(clCreateCommandQueue) X(clCreateContext) X(clCreateImage) X(clCreateKernel) \
    X(clCreateProgramWithSource) X(clEnqueueCopyBufferToImage) X(clEnqueueFillBuffer) X(clEnqueueNDRangeKernel)       \
    X(clEnqueueReadBuffer) X(clEnqueueWriteBuffer) X(clFinish) X(clGetDeviceIDs) X(clGetDeviceInfo)                    \
    X(clGetEventProfilingInfo) X(clGetMemObjectInfo) X(clGetPlatformIDs) X(clGetPlatformInfo) X(clGetProgramBuildInfo) \
    X(clGetSupportedImageFormats) X(clReleaseCommandQueue) X(clReleaseContext) X(clReleaseEvent) X(clReleaseKernel)    \
    X(clReleaseMemObject) X(clReleaseProgram) X(clSetKernelArg) X(clWaitForEvents)

typedef struct pb_cl_api {
#define PB_CL_MEMBER(f) __typeof__(f) *f;
    PB_CL_FUNCTIONS(PB_CL_MEMBER)
#undef PB_CL_MEMBER
} pb_cl_api;

extern pb_cl_api pb_cl;

/* Opens the ICD loader once per process (PETBLUR_OPENCL_LIBRARY, else
 * libOpenCL.so.1); every later call gives the first call's answer. On failure
 * the error (set on dev) says what is missing and how to install it. */
pb_status pb_cl_load(pb_device *dev);

/* A timed command's event, and whether it was queued before timer_mark. */
typedef struct cl_timed {
    cl_event event;
    int before_mark;
} cl_timed;

typedef struct cl_impl {
    cl_device_id device;
    cl_context context;
    cl_command_queue queue;
    cl_program program;
    cl_kernel kernels[PB_KERNEL_COUNT]; /* indexed by pb_kernel_id */
    int is_gpu;
    /* Between timer_begin and timer_end every command gets a profiling event. */
    int timing;
    cl_timed *timed;
    size_t timed_count, timed_cap;
} cl_impl;

/* An image and its extent, which a copy into it needs. */
typedef struct cl_image {
    cl_mem mem;
    size_t region[3];
} cl_image;

/* Maps a failed OpenCL call to a status and message; allocation failures are
 * memory errors. */
pb_status pb_cl_fail(pb_device *dev, pb_status kind, const char *call, cl_int e);

/* opencl_device.c: the device ops of pb_backend_opencl_ops. */
pb_status pb_ocl_device_count(int *count);
pb_status pb_ocl_device_info(int index, pb_device_info *info);
pb_status pb_ocl_context_init(pb_device *dev, int index, const char *build_options);
void pb_ocl_context_release(pb_device *dev);

#endif
