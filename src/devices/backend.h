/* The one backend boundary. A device backend (OpenCL, CUDA) offers primitives:
 * buffers, images, a kernel launch by id, and timing; the launch sequence
 * built from them (which kernel, its input made current, zeroing, progress
 * slabs, timing) is written once, in launch.c, for every device backend. The
 * host backend is the reference: it offers the whole operator in double
 * precision, and its buffers are host memory. Both kinds offer the same
 * per-frame operation (frame_prepare, frame_apply, frames_forward), so the
 * plan above never asks which backend it holds. Only a backend's own file
 * includes its runtime's headers; everything above this table dispatches
 * through it. */
#ifndef PB_BACKEND_H
#define PB_BACKEND_H

#include <stdatomic.h>

#include "error.h"
#include "pb_kernel_table.h"
#include "path.h"
#include "petblur.h"
#include "pb_kernel_types.h"

/* NVIDIA's texture unit keeps each linear-filter weight in 9-bit fixed point
 * with 8 fractional bits (CUDA C Programming Guide, "Linear Filtering"); the
 * device test test_hardware_weights checks the rounding to the nearest step. */
#define PB_NVIDIA_WEIGHT_STEPS 256.0f

/* One kernel launch (launch.c fills it from cl/pb_kernel_table.h). */
typedef struct pb_launch {
    pb_kernel_id kernel;
    const void *input; /* an image made by image_create, or a buffer: the kernel's `reads` */
    const void *plan;  /* a buffer of key poses or REF steps; NULL for pb_permute */
    pb_kparams prm;
    void *out;         /* a buffer */
    size_t extent[3];  /* work items per axis, before rounding to whole groups */
} pb_launch;

/* What a kernel reads of a buffer, made from it on first use: its 3-D image
 * and its layers along each axis, each marked stale when the buffer changes. */
typedef struct pb_images {
    void *image;
    int image_stale;
    void *layers[3];
    int layers_stale[3];
} pb_images;

/* One frame of a plan: its key poses on the host (the host backend walks
 * them) and on the device, and the kernels and parameters of both
 * directions. */
typedef struct pb_plan_frame {
    pb_path path;
    void *poses; /* device buffer, uploaded once */
    /* The forward for an input laid out once (a volume) and for one laid out
     * every call (the caller's device memory): kernel_args.h. */
    pb_kernel_id forward, forward_fresh, adjoint;
    pb_kparams forward_prm, adjoint_prm;
} pb_plan_frame;

typedef struct pb_backend_ops {
    pb_backend id;
    /* Whether buffers are addresses in one space (host memory, CUDA's unified
     * addressing), so that two ranges can be seen to overlap; OpenCL's are
     * handles. */
    int addresses;
    /* Device listing; errors go to the calling thread's last-error text. */
    pb_status (*device_count)(int *count);
    pb_status (*device_info)(int index, pb_device_info *info);
    /* Opens device index and builds what it needs; fills ctx->device,
     * ctx->impl, ctx->layer_limits and ctx->texture_weight_steps. */
    pb_status (*context_init)(struct pb_context *ctx, int index, const char *build_options);
    void (*context_release)(struct pb_context *ctx);
    /* The native handles of pb_context_native. */
    void (*native)(const struct pb_context *ctx, pb_native *out);

    /* Buffers of device memory (host memory on the host backend). write and
     * read return with the copy finished; zero is queued. */
    pb_status (*buffer_create)(struct pb_context *ctx, size_t bytes, void **buffer);
    void (*buffer_release)(struct pb_context *ctx, void *buffer);
    pb_status (*buffer_write)(struct pb_context *ctx, void *buffer, const void *host, size_t bytes);
    pb_status (*buffer_read)(struct pb_context *ctx, const void *buffer, void *host, size_t bytes);
    pb_status (*buffer_zero)(struct pb_context *ctx, void *buffer, size_t bytes);
    /* Whether memory the caller owns can be a kernel's input (written 0) or
     * output (1) of bytes: of this device and context, large enough and
     * readable or writable where the runtime can tell. */
    pb_status (*buffer_check)(struct pb_context *ctx, const void *buffer, size_t bytes, const char *what,
                              int written);

    /* The per-frame operation, one shape on every backend. frame_prepare
     * readies a planned frame (frame->path set) for runs under opt: on a
     * device its kernels, their parameters and its key poses in device
     * memory; the host walks the path itself. frame_apply runs one direction
     * of frame `index` of plan from in into out, memory of this backend: the
     * forward overwrites out; the adjoint overwrites it, or with accumulate
     * adds into it. in_images are what a device made of in before, and
     * fresh_input says that in is new this call (the caller's memory, the
     * adjoint's tomograph). frames_forward runs every frame of plan forward,
     * frame i from ins[i] into outs[i], queued back to back where it can.
     * Each sets ctx->last_kernel_ms and ctx->last_input_ms and reports
     * progress within the call, not its end. */
    pb_status (*frame_prepare)(struct pb_context *ctx, const pb_blur_options *opt, pb_plan_frame *frame);
    pb_status (*frame_apply)(struct pb_context *ctx, const struct pb_plan *plan, size_t index, int adjoint,
                             const void *in, pb_images *in_images, void *out, int accumulate, int fresh_input);
    pb_status (*frames_forward)(struct pb_context *ctx, const struct pb_plan *plan,
                                const struct pb_volume *const *ins, struct pb_volume *const *outs);
    /* Frames [first, first + count) in one call on memory of this backend
     * (the caller's): forward, one object (ins[0], fresh) into outs[i]; or the
     * adjoint of ins[i] summed into outs[0] (accumulate: added to it). One
     * timer spans the call; the forward's object is made current once. NULL
     * (the host): the caller loops frame_apply. */
    pb_status (*frames_apply)(struct pb_context *ctx, const struct pb_plan *plan, size_t first, size_t count,
                              int adjoint, const void *const *ins, pb_images *in_images, void *const *outs,
                              int accumulate);

    /* Device primitives (host: NULL). Images are float, single channel,
     * filtered by the kernels' samplers: 3-D of extent, or layered (extent[2]
     * layers of extent[0] x extent[1]). image_copy queues a device copy of a
     * dense buffer of that extent, x fastest, into the image. */
    pb_status (*image_create)(struct pb_context *ctx, int layered, const size_t extent[3], void **image);
    void (*image_release)(struct pb_context *ctx, void *image);
    pb_status (*image_copy)(struct pb_context *ctx, void *image, const void *buffer);
    /* Optional: queues the layout of a dense buffer of a volume of dims (x
     * fastest) into a layered image along axis m (pb_layer_across), in one
     * pass. NULL: launch.c lays it out with pb_permute and image_copy. */
    pb_status (*image_layout)(struct pb_context *ctx, void *image, const void *buffer, const size_t dims[3], int m);
    /* Queues one launch, in groups of its kernel's table row (GPUs), or as the
     * runtime splits it (CPUs). */
    pb_status (*launch)(struct pb_context *ctx, const pb_launch *launch);
    /* Times the work queued from timer_begin to timer_end with device events;
     * timer_end waits for it, reports a kernel's failure, and gives the total
     * and the part queued before timer_mark (making the input current). */
    pb_status (*timer_begin)(struct pb_context *ctx);
    pb_status (*timer_mark)(struct pb_context *ctx);
    pb_status (*timer_end)(struct pb_context *ctx, double *total_ms, double *before_mark_ms);
    /* Optional (CUDA): queue on the caller's stream (NULL: the context's own).
     * There timer_end only records, and timer_wait later waits for what it
     * timed: returns 1 with the times when such a timing is pending, else 0. */
    pb_status (*set_stream)(struct pb_context *ctx, void *stream);
    int (*timer_wait)(const struct pb_context *ctx, pb_status *status, double *total_ms, double *before_mark_ms);
} pb_backend_ops;

struct pb_context {
    const pb_backend_ops *ops;
    pb_device_info device;
    void *impl;
    size_t layer_limits[3];      /* largest layered image: width, height, layers; 0: none */
    float texture_weight_steps;  /* the texture unit's weight steps (256 on NVIDIA), 0: float weights */
    void *scratch;               /* a volume laid out for its layers (pb_permute), kept */
    size_t scratch_bytes;
    double last_kernel_ms, last_input_ms;
    pb_progress_fn progress;
    void *progress_user;
    char last_error[PB_ERROR_TEXT_MAX];
    char notes[1600]; /* pb_context_notes */
    /* Volumes and plans keep their context alive: pb_context_destroy before
     * them only marks it, and the last of them releases it, so bindings whose
     * garbage collector frees in any order stay safe. */
    size_t holders;
    int destroyed;
    struct pb_volume *volumes;
    /* Set while a thread works in the context (pb_context_enter), so that a
     * second thread's call is refused, not raced. */
    atomic_int busy;
};

struct pb_volume {
    struct pb_context *ctx;
    pb_geometry geometry;
    size_t count; /* voxels */
    void *buffer;
    pb_images images;
    /* The context's volumes, so that a device-memory call that writes a
     * volume's memory (pb_volume_memory) can mark its images stale. */
    struct pb_volume *prev, *next;
};

struct pb_plan {
    struct pb_context *ctx;
    pb_geometry geometry;
    size_t count; /* voxels */
    pb_blur_options options;
    size_t frames;
    pb_plan_frame *frame;
    pb_images input; /* made from the caller's device memory, refreshed every call */
};

extern const pb_backend_ops pb_backend_host_ops;
#ifdef PB_HAVE_OPENCL
extern const pb_backend_ops pb_backend_opencl_ops;
#endif
#ifdef PB_HAVE_CUDA
extern const pb_backend_ops pb_backend_cuda_ops;
#endif

/* devices.c: the backend of options, the automatic choice made (which fills
 * in the backend and device index), compiled in, and the device index not
 * negative. */
pb_status pb_backend_select(pb_context_options *opt, const pb_backend_ops **ops);

/* options.c, volume.c, context.c: the checks every blur makes of its options, with the defaults
 * filled in; whether a volume of geometry g fits the device (a pure function
 * of the device's reported capabilities, so that every refusal can be tested
 * without such a device); a context's holders. */
pb_status pb_options_prepare(struct pb_context *ctx, const pb_blur_options *options, pb_blur_options *opt);
pb_status pb_geometry_check(struct pb_context *ctx, const pb_geometry *g, size_t *count);
pb_status pb_device_check_volume(struct pb_context *ctx, const pb_device_info *info, const pb_geometry *g);
void pb_context_hold(struct pb_context *ctx);
/* A call's work in ctx: refused when another thread is inside it; nested
 * calls of one thread (a one-shot blur's plan, a progress report that blurs
 * again) enter again. Every PB_OK of enter is matched by one leave. */
pb_status pb_context_enter(struct pb_context *ctx);
void pb_context_leave(struct pb_context *ctx);
void pb_context_release_hold(struct pb_context *ctx);

/* launch.c: the per-frame operation of every device backend. A frame's
 * kernels, parameters and key poses on the device; one direction of one frame
 * from a buffer (with its images) into a buffer: the input made current,
 * zeroed or accumulated, launched in progress slabs, timed (a fresh input's
 * copy with the kernel); every frame forward, queued back to back and waited
 * for once, every input made current first. */
pb_status pb_launch_prepare(struct pb_context *ctx, const pb_blur_options *opt, pb_plan_frame *frame);
pb_status pb_launch_frame(struct pb_context *ctx, const struct pb_plan *plan, size_t index, int adjoint,
                          const void *in, pb_images *in_images, void *out, int accumulate, int fresh_input);
pb_status pb_launch_frames(struct pb_context *ctx, const struct pb_plan *plan, const struct pb_volume *const *ins,
                           struct pb_volume *const *outs);
pb_status pb_launch_frames_apply(struct pb_context *ctx, const struct pb_plan *plan, size_t first, size_t count,
                                 int adjoint, const void *const *ins, pb_images *in_images, void *const *outs,
                                 int accumulate);
/* One launch of kernel over a small grid of dims from buffer in, its input
 * made for it and released after, the output read back into host. */
pb_status pb_launch_read(struct pb_context *ctx, pb_kernel_id kernel, const pb_kparams *prm, const void *in,
                         const size_t *dims, const void *plan, void *out, float *host);
/* shift_taps.c: under a motion of translations whose path is short, the
 * frame's kernels become the convolution's (cl/pb_taps.cl), its poses buffer
 * their taps, measured on the device; otherwise the frame is left as it is.
 * Short: at most PB_SHIFT_TAPS_MAX taps. The taps grow about four times as
 * fast as the walk's slices, whose fetches the texture unit filters eight
 * voxels at a time; at this limit the taps cost 0.6 of the walk's kernel, and
 * the one case measured past it, 50 taps, still 0.94, so the limit keeps a
 * margin (docs/performance.md, "Short translations"). PETBLUR_SHIFT_TAPS sets
 * another limit, 0 none, for comparisons. */
#define PB_SHIFT_TAPS_MAX 24
pb_status pb_shift_taps_prepare(struct pb_context *ctx, const pb_blur_options *opt, pb_plan_frame *frame);
/* A buffer changed: what was made from it is out of date. */
void pb_images_stale(pb_images *images);
/* context.c: device memory at `memory` was written behind the volumes' back:
 * the images of the volume it belongs to, if any, are out of date. */
void pb_volume_memory_written(struct pb_context *ctx, const void *memory);
void pb_images_release(struct pb_context *ctx, pb_images *images);

/* Slabs of z-slices for progress reports: how many slices per launch, so that
 * a volume takes about 32 launches. */
size_t pb_progress_slab(size_t nz);

#endif
