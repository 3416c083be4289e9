/* The one backend boundary. Everything above this table (context.c, path_plan.c)
 * dispatches through it and never asks which backend it is talking to; only a
 * backend's own file includes its runtime's headers. */
#ifndef PB_BACKEND_H
#define PB_BACKEND_H

#include "error.h"
#include "motion.h"
#include "petblur.h"

typedef struct pb_backend_ops {
    pb_backend id;
    /* Device listing; errors go to the calling thread's last-error text. */
    pb_status (*device_count)(int *count);
    pb_status (*device_info)(int index, pb_device_info *info);
    /* Opens device index and builds what it needs; fills ctx->device and ctx->impl. */
    pb_status (*context_init)(struct pb_context *ctx, int index, const char *build_options);
    void (*context_release)(struct pb_context *ctx);
    /* Volumes: geometry is set and checked against the device before volume_init. */
    pb_status (*volume_init)(struct pb_volume *vol);
    void (*volume_release)(struct pb_volume *vol);
    pb_status (*volume_upload)(struct pb_volume *vol, const float *host);
    pb_status (*volume_download)(const struct pb_volume *vol, float *host);
    /* Blurs with a validated plan; sets ctx->last_kernel_ms. */
    pb_status (*blur)(struct pb_context *ctx, const struct pb_volume *object, const pb_path *plan,
                      const pb_blur_options *options, struct pb_volume *tomograph);
    /* The transpose of blur with the same plan: reads tomograph, overwrites
     * object, or with accumulate adds into it (frames that share an object:
     * the transpose of one volume blurred into many is the sum of their
     * back projections); sets ctx->last_kernel_ms. */
    pb_status (*adjoint)(struct pb_context *ctx, const struct pb_volume *tomograph, const pb_path *plan,
                         const pb_blur_options *options, struct pb_volume *object, int accumulate);
    /* pb_blur_frames without progress: frame i blurs objects[i] into
     * tomographs[i] with plans[i], exactly as blur would; the launches are
     * queued back to back and waited for once, so the device never idles
     * between frames. Sets ctx->last_kernel_ms to the frames' total. NULL:
     * the caller calls blur per frame. */
    pb_status (*blur_batch)(struct pb_context *ctx, size_t frames, const struct pb_volume *const *objects,
                            const pb_path *plans, const pb_blur_options *options,
                            struct pb_volume *const *tomographs);
} pb_backend_ops;

struct pb_context {
    const pb_backend_ops *ops;
    pb_device_info device;
    void *impl;
    double last_kernel_ms;
    pb_progress_fn progress;
    void *progress_user;
    char last_error[PB_ERROR_TEXT_MAX];
    /* Volumes keep their context alive: pb_context_destroy before them only
     * marks it, and the last pb_volume_destroy releases it, so bindings whose
     * garbage collector frees in any order stay safe. */
    size_t volumes;
    int destroyed;
};

struct pb_volume {
    struct pb_context *ctx;
    pb_geometry geometry;
    size_t count; /* voxels */
    void *impl;
};

extern const pb_backend_ops pb_backend_host_ops;
#ifdef PB_HAVE_OPENCL
extern const pb_backend_ops pb_backend_opencl_ops;
#endif
#ifdef PB_HAVE_CUDA
extern const pb_backend_ops pb_backend_cuda_ops;
#endif

/* Whether a volume of geometry g fits the device: image support, 3-D image
 * limits and largest allocation. A pure function of the device's reported
 * capabilities, so that every refusal can be tested without such a device. */
/* Slabs of z-slices for progress reports: how many slices per launch, so that
 * a volume takes about 32 launches. */
size_t pb_progress_slab(size_t nz);

/* The checks every blur makes (context, volumes, options) before any work;
 * opt receives the options with their defaults filled in. */
pb_status pb_blur_prepare(struct pb_context *ctx, const struct pb_volume *object, const pb_blur_options *options,
                          const struct pb_volume *tomograph, pb_blur_options *opt);

pb_status pb_device_check_volume(struct pb_context *ctx, const pb_device_info *info, const pb_geometry *g);

#endif
