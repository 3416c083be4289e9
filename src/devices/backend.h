/* The one backend boundary. A device backend (OpenCL, CUDA) offers primitives:
 * buffers, images, a kernel launch by id, and timing; the launch sequence
 * built from them (which kernel, its input made current, zeroing, progress
 * slabs, timing) is written once, in launch.c, for every device backend. The
 * host backend is the reference: it offers the whole operator in double
 * precision, and its buffers are host memory. Both kinds offer the same
 * per-frame operation (frame_prepare, frame_apply, frames_forward), so the
 * plan above never asks which backend it holds. A backend sees primitives
 * only: its device (pb_device), a plan's frames (pb_frame_set) and memory with
 * what it made of it (pb_memory); the objects users hold (contexts, volumes,
 * plans) are the API layer's (src/api/objects.h). Only a backend's own file
 * includes its runtime's headers; everything above this table dispatches
 * through it. */
#ifndef PB_BACKEND_H
#define PB_BACKEND_H

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
    void *poses; /* device buffer, uploaded once; NULL while streamed */
    /* A field frame past the device's budget for resident fields stays on
     * the host, packed, and is uploaded for each launch (launch.c). */
    void *streamed;
    size_t bytes; /* of the packed key points and fields */
    /* The forward for an input laid out once (a volume) and for one laid out
     * every call (the caller's device memory): kernel_choice.h. */
    pb_kernel_id forward, forward_fresh, adjoint;
    pb_kparams forward_prm, adjoint_prm;
} pb_plan_frame;

/* What a backend sees of a plan: the grid, the options its frames were
 * prepared under, the frames, and the images made from the caller's device
 * memory (refreshed every call). */
typedef struct pb_frame_set {
    pb_geometry geometry;
    size_t count; /* voxels */
    pb_blur_options options;
    size_t frames;
    pb_plan_frame *frame;
    pb_images input;
} pb_frame_set;

/* A volume's memory as a backend sees it: the buffer and its images. */
typedef struct pb_memory {
    void *buffer;
    pb_images images;
} pb_memory;

typedef struct pb_device pb_device;

typedef struct pb_backend_ops {
    pb_backend id;
    /* Whether buffers are addresses in one space (host memory, CUDA's unified
     * addressing), so that two ranges can be seen to overlap; OpenCL's are
     * handles. */
    int addresses;
    /* Device listing; errors go to the calling thread's last-error text. */
    pb_status (*device_count)(int *count);
    pb_status (*device_info)(int index, pb_device_info *info);
    /* Opens device index and builds what it needs; fills dev->info,
     * dev->impl, dev->layer_limits and dev->texture_weight_steps. */
    pb_status (*context_init)(pb_device *dev, int index, const char *build_options);
    void (*context_release)(pb_device *dev);
    /* The native handles of pb_context_native. */
    void (*native)(const pb_device *dev, pb_native *out);

    /* Buffers of device memory (host memory on the host backend). write and
     * read return with the copy finished; zero is queued. release may be
     * called with kernels that read the buffer still queued: the memory goes
     * only after them (a streamed frame's upload is released so). */
    pb_status (*buffer_create)(pb_device *dev, size_t bytes, void **buffer);
    void (*buffer_release)(pb_device *dev, void *buffer);
    pb_status (*buffer_write)(pb_device *dev, void *buffer, const void *host, size_t bytes);
    pb_status (*buffer_read)(pb_device *dev, const void *buffer, void *host, size_t bytes);
    pb_status (*buffer_zero)(pb_device *dev, void *buffer, size_t bytes);
    /* Whether memory the caller owns can be a kernel's input (written 0) or
     * output (1) of bytes: of this device and context, large enough and
     * readable or writable where the runtime can tell. */
    pb_status (*buffer_check)(pb_device *dev, const void *buffer, size_t bytes, const char *what,
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
     * Each sets dev->last_kernel_ms and dev->last_input_ms and reports
     * progress within the call, not its end. */
    pb_status (*frame_prepare)(pb_device *dev, const pb_blur_options *opt, pb_plan_frame *frame);
    pb_status (*frame_apply)(pb_device *dev, const pb_frame_set *plan, size_t index, int adjoint,
                             const void *in, pb_images *in_images, void *out, int accumulate, int fresh_input);
    pb_status (*frames_forward)(pb_device *dev, const pb_frame_set *plan,
                                const pb_memory *const *ins, pb_memory *const *outs);
    /* Frames [first, first + count) in one call on memory of this backend
     * (the caller's): forward, one object (ins[0], fresh) into outs[i]; or the
     * adjoint of ins[i] summed into outs[0] (accumulate: added to it). One
     * timer spans the call; the forward's object is made current once. NULL
     * (the host): the caller loops frame_apply. */
    pb_status (*frames_apply)(pb_device *dev, const pb_frame_set *plan, size_t first, size_t count,
                              int adjoint, const void *const *ins, pb_images *in_images, void *const *outs,
                              int accumulate);

    /* Device primitives (host: NULL). Images are float, single channel,
     * filtered by the kernels' samplers: 3-D of extent, or layered (extent[2]
     * layers of extent[0] x extent[1]). image_copy queues a device copy of a
     * dense buffer of that extent, x fastest, into the image. */
    pb_status (*image_create)(pb_device *dev, int layered, const size_t extent[3], void **image);
    void (*image_release)(pb_device *dev, void *image);
    pb_status (*image_copy)(pb_device *dev, void *image, const void *buffer);
    /* Optional: queues the layout of a dense buffer of a volume of dims (x
     * fastest) into a layered image along axis m (pb_layer_across), in one
     * pass. NULL: launch.c lays it out with pb_permute and image_copy. */
    pb_status (*image_layout)(pb_device *dev, void *image, const void *buffer, const size_t dims[3], int m);
    /* Queues one launch, in groups of its kernel's table row (GPUs), or as the
     * runtime splits it (CPUs). */
    pb_status (*launch)(pb_device *dev, const pb_launch *launch);
    /* Times the work queued from timer_begin to timer_end with device events;
     * timer_end waits for it, reports a kernel's failure, and gives the total
     * and the part queued before timer_mark (making the input current). */
    pb_status (*timer_begin)(pb_device *dev);
    pb_status (*timer_mark)(pb_device *dev);
    pb_status (*timer_end)(pb_device *dev, double *total_ms, double *before_mark_ms);
    /* Optional (CUDA): queue on the caller's stream (NULL: the context's own).
     * There timer_end only records, and timer_wait later waits for what it
     * timed: returns 1 with the times when such a timing is pending, else 0. */
    pb_status (*set_stream)(pb_device *dev, void *stream);
    int (*timer_wait)(const pb_device *dev, pb_status *status, double *total_ms, double *before_mark_ms);
} pb_backend_ops;

/* One device opened on one backend: what the backend keeps and reports. The
 * context that holds it (owner) is only named to the error texts. */
struct pb_device {
    const pb_backend_ops *ops;
    struct pb_context *owner;
    pb_device_info info;
    void *impl;
    size_t layer_limits[3];      /* largest layered image: width, height, layers; 0: none */
    float texture_weight_steps;  /* the texture unit's weight steps (256 on NVIDIA), 0: float weights */
    size_t resident_field_bytes; /* field frames' buffers resident on the device (launch.c's budget) */
    void *scratch;               /* a volume laid out for its layers (pb_permute), kept */
    size_t scratch_bytes;
    double last_kernel_ms, last_input_ms;
    pb_progress_fn progress;
    void *progress_user;
    char notes[1600]; /* pb_context_notes */
};

/* The context an error text goes to: none (the thread's only) where a device
 * is listed or checked without one. */
static inline struct pb_context *pb_owner(const pb_device *dev)
{
    return dev ? dev->owner : NULL;
}

extern const pb_backend_ops pb_backend_host_ops;
#ifdef PB_HAVE_OPENCL
extern const pb_backend_ops pb_backend_opencl_ops;
#endif
#ifdef PB_HAVE_CUDA
extern const pb_backend_ops pb_backend_cuda_ops;
#endif

/* Whether a volume of geometry g fits a device that reports info: a pure
 * function of what it reports, so that every refusal can be tested without
 * such a device (device_limits.c). */
pb_status pb_device_check_volume(pb_device *dev, const pb_device_info *info, const pb_geometry *g);

/* launch.c: the per-frame operation of every device backend. A frame's
 * kernels, parameters and key poses on the device; one direction of one frame
 * from a buffer (with its images) into a buffer: the input made current,
 * zeroed or accumulated, launched in progress slabs, timed (a fresh input's
 * copy with the kernel); every frame forward, queued back to back and waited
 * for once, every input made current first. */
pb_status pb_launch_prepare(pb_device *dev, const pb_blur_options *opt, pb_plan_frame *frame);
pb_status pb_launch_frame(pb_device *dev, const pb_frame_set *plan, size_t index, int adjoint,
                          const void *in, pb_images *in_images, void *out, int accumulate, int fresh_input);
pb_status pb_launch_frames(pb_device *dev, const pb_frame_set *plan, const pb_memory *const *ins,
                           pb_memory *const *outs);
pb_status pb_launch_frames_apply(pb_device *dev, const pb_frame_set *plan, size_t first, size_t count,
                                 int adjoint, const void *const *ins, pb_images *in_images, void *const *outs,
                                 int accumulate);
/* One launch of kernel over a small grid of dims from buffer in, its input
 * made for it and released after, the output read back into host. */
pb_status pb_launch_read(pb_device *dev, pb_kernel_id kernel, const pb_kparams *prm, const void *in,
                         const size_t *dims, const void *plan, void *out, float *host);
/* shift_taps.c: under a motion of translations whose taps cost less than
 * the frame's kernel (pb_shift_taps_limit), the frame's kernels become the
 * convolution's (cl/pb_taps.cl), its poses buffer their taps, measured on the
 * device; otherwise the frame is left as it is. At most PB_SHIFT_TAPS_MAX
 * taps are always taken; gpu: whether the device filters in a texture unit.
 * The limit is for a path of translations (pb_path_shift_invariant). */
#define PB_SHIFT_TAPS_MAX 24
long pb_shift_taps_limit(const pb_blur_options *opt, const pb_path *path, int gpu);
pb_status pb_shift_taps_prepare(pb_device *dev, const pb_blur_options *opt, pb_plan_frame *frame);
/* A buffer changed: what was made from it is out of date. */
void pb_images_stale(pb_images *images);
void pb_images_release(pb_device *dev, pb_images *images);

/* Slabs of z-slices for progress reports: how many slices per launch, so that
 * a volume takes about 32 launches. */
size_t pb_progress_slab(size_t nz);

#endif
