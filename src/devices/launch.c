/* The per-frame operation of every device backend, written once from the
 * primitives of backend.h: a frame's kernels chosen and its key poses
 * uploaded; the kernel's input made current (the 3-D image or the layers of a
 * buffer), the output zeroed or added into, launches in progress slabs, timed
 * with device events. */
#include <stdio.h>
#include <stdlib.h>

#include "backend.h"
#include "kernel_choice.h"

void pb_images_stale(pb_images *images)
{
    images->image_stale = 1;
    for (int m = 0; m < 3; m++)
        images->layers_stale[m] = 1;
}

void pb_images_release(pb_device *dev, pb_images *images)
{
    if (images->image)
        dev->ops->image_release(dev, images->image);
    for (int m = 0; m < 3; m++)
        if (images->layers[m])
            dev->ops->image_release(dev, images->layers[m]);
    *images = (pb_images){0};
}

size_t pb_progress_slab(size_t nz)
{
    return nz < 32 ? 1 : (nz + 31) / 32;
}

/* The context's scratch buffer, grown to at least bytes; it lives as long as
 * the context, so that laying out the objects of many plans allocates once. */
static pb_status reserve_scratch(pb_device *dev, size_t bytes)
{
    if (bytes <= dev->scratch_bytes)
        return PB_OK;
    if (dev->scratch)
        dev->ops->buffer_release(dev, dev->scratch);
    dev->scratch = NULL;
    dev->scratch_bytes = 0;
    pb_status st = dev->ops->buffer_create(dev, bytes, &dev->scratch);
    if (st == PB_OK)
        dev->scratch_bytes = bytes;
    return st;
}

/* The budget for field frames resident on the device, bytes: half its
 * memory (the rest for volumes, images and other plans), or
 * PETBLUR_FIELD_MEMORY_MIB; 0 where the device does not say. */
static double field_budget(const pb_device *dev)
{
    const char *env = getenv("PETBLUR_FIELD_MEMORY_MIB");
    char *end = NULL;
    double mib = env && *env ? strtod(env, &end) : -1.0;
    if (env && *env && end && *end == '\0' && mib >= 0.0)
        return mib * 1048576.0;
    return 0.5 * (double)dev->info.global_mem_bytes;
}

/* A frame's buffer for one launch: resident, or a streamed frame's uploaded
 * now into a buffer of its own (*temp set: release it after the launch; a
 * backend's release waits for the kernels queued that read it, backend.h). */
static pb_status frame_buffer(pb_device *dev, const pb_plan_frame *f, void **buffer, int *temp)
{
    *buffer = f->poses;
    *temp = 0;
    if (f->poses || !f->streamed)
        return PB_OK;
    pb_status st = dev->ops->buffer_create(dev, f->bytes, buffer);
    if (st == PB_OK && (st = dev->ops->buffer_write(dev, *buffer, f->streamed, f->bytes)) != PB_OK)
        dev->ops->buffer_release(dev, *buffer);
    if (st != PB_OK) {
        char why[160];
        snprintf(why, sizeof why, " (uploading a frame's fields, %.2f GiB, streamed past the device's budget for "
                 "resident fields: use shorter frames, or fields on a coarser grid)", (double)f->bytes / 1073741824.0);
        pb_error_append(pb_owner(dev), why);
        *buffer = NULL;
    }
    *temp = st == PB_OK;
    return st;
}

static void frame_buffer_done(pb_device *dev, void *buffer, int temp)
{
    if (temp)
        dev->ops->buffer_release(dev, buffer);
}

/* Queues kernel over a grid of dims with prm. */
static pb_status launch(pb_device *dev, pb_kernel_id kernel, const void *input, const void *plan,
                        const pb_kparams *prm, void *out, const size_t *dims)
{
    pb_launch l = {kernel, input, plan, *prm, out, {0, 0, 0}};
    pb_kernel_extent(kernel, dims, l.extent);
    return dev->ops->launch(dev, &l);
}

/* Makes sure what kernel reads of a volume of dims exists: its 3-D image or
 * its layers, and the scratch buffer their layout takes. Done before a timer
 * starts, so that the allocations, host work, do not count as device time. */
static pb_status allocate_input(pb_device *dev, pb_kernel_id kernel, const pb_kparams *prm, const size_t *dims,
                                pb_images *images)
{
    pb_status st = PB_OK;
    switch (pb_kernel_table[kernel].reads) {
    case PB_READS_BUFFER: return PB_OK;
    case PB_READS_LAYERS: {
        int m = prm->layer_axis;
        size_t extent[3] = {dims[pb_layer_across(m, 0)], dims[pb_layer_across(m, 1)], dims[m]};
        if (!images->layers[m] && (st = dev->ops->image_create(dev, 1, extent, &images->layers[m])) == PB_OK)
            images->layers_stale[m] = 1;
        if (st == PB_OK && m != 2 && !dev->ops->image_layout)
            st = reserve_scratch(dev, dims[0] * dims[1] * dims[2] * sizeof(float));
        return st;
    }
    default:
        if (!images->image && (st = dev->ops->image_create(dev, 0, dims, &images->image)) == PB_OK)
            images->image_stale = 1;
        return st;
    }
}

/* Makes images->layers[m], allocated (allocate_input), current with buffer:
 * in one pass where the backend lays a buffer out in layers itself; otherwise
 * along z the buffer already is in layer order and is copied as it is, and
 * along x or y pb_permute lays it out in the scratch buffer first. */
static pb_status refresh_layers(pb_device *dev, const void *buffer, const size_t *n, pb_images *images, int m)
{
    pb_status st = PB_OK;
    if (!images->layers_stale[m])
        return PB_OK;
    if (dev->ops->image_layout) {
        if ((st = dev->ops->image_layout(dev, images->layers[m], buffer, n, m)) == PB_OK)
            images->layers_stale[m] = 0;
        return st;
    }
    const void *source = buffer;
    if (m != 2) {
        pb_kparams prm;
        pb_kparams_permute(n, m, &prm);
        if ((st = launch(dev, PB_KERNEL_PERMUTE, buffer, NULL, &prm, dev->scratch, n)) != PB_OK)
            return st;
        source = dev->scratch;
    }
    if ((st = dev->ops->image_copy(dev, images->layers[m], source)) == PB_OK)
        images->layers_stale[m] = 0;
    return st;
}

/* Makes what kernel reads of buffer, allocated (allocate_input), current and
 * returns it in *input: the buffer itself, its 3-D image, or its layers along
 * prm->layer_axis. */
static pb_status refresh_input(pb_device *dev, pb_kernel_id kernel, const pb_kparams *prm, const void *buffer,
                               const size_t *dims, pb_images *images, const void **input)
{
    pb_status st = PB_OK;
    switch (pb_kernel_table[kernel].reads) {
    case PB_READS_BUFFER:
        *input = buffer;
        return PB_OK;
    case PB_READS_LAYERS:
        st = refresh_layers(dev, buffer, dims, images, prm->layer_axis);
        *input = images->layers[prm->layer_axis];
        return st;
    default:
        if (images->image_stale && (st = dev->ops->image_copy(dev, images->image, buffer)) == PB_OK)
            images->image_stale = 0;
        *input = images->image;
        return st;
    }
}

pb_status pb_launch_read(pb_device *dev, pb_kernel_id kernel, const pb_kparams *prm, const void *in,
                         const size_t *dims, const void *plan, void *out, float *host)
{
    pb_images images = {0};
    const void *input = NULL;
    pb_status st = allocate_input(dev, kernel, prm, dims, &images);
    if (st == PB_OK)
        st = refresh_input(dev, kernel, prm, in, dims, &images, &input);
    if (st == PB_OK)
        st = launch(dev, kernel, input, plan, prm, out, dims);
    if (st == PB_OK) /* returns with the queue's work done, before the images go */
        st = dev->ops->buffer_read(dev, out, host, dims[0] * dims[1] * dims[2] * sizeof(float));
    pb_images_release(dev, &images);
    return st;
}

/* Launches over the grid: whole, or with a progress report in slabs of
 * z-slices, each as deep as a whole number of work groups reach (a group that
 * reached past its slab would do the next slab's voxels twice, which the
 * adjoint's adds would count twice), waiting and reporting after each. The timer runs
 * from before the first slab; returns with it stopped and the times set. */
static pb_status launch_slabs(pb_device *dev, pb_kernel_id kernel, const void *input, const void *plan,
                              pb_kparams prm, void *out, const size_t *dims)
{
    size_t nz = dims[2], slab = dev->progress ? pb_progress_slab(nz) : nz;
    unsigned depth = pb_kernel_table[kernel].group[2] * pb_kernel_run_z(kernel);
    slab = (slab + depth - 1) / depth * depth;
    double total = 0.0, input_ms = 0.0;
    pb_status st = PB_OK;
    for (size_t z0 = 0; z0 < nz && st == PB_OK; z0 += slab) {
        size_t part[3] = {dims[0], dims[1], nz - z0 < slab ? nz - z0 : slab};
        prm.z0 = (int)z0;
        if (z0 > 0 && (st = dev->ops->timer_begin(dev)) != PB_OK)
            break;
        pb_status launched = launch(dev, kernel, input, plan, &prm, out, part);
        double ms = 0.0, before = 0.0;
        st = dev->ops->timer_end(dev, &ms, &before); /* waits for what was queued, even after a failure */
        if (launched != PB_OK)
            st = launched;
        total += ms;
        input_ms += before;
        if (st == PB_OK && dev->progress && z0 + slab < nz)
            dev->progress((double)(z0 + slab) / (double)nz, dev->progress_user);
    }
    dev->last_kernel_ms = total;
    dev->last_input_ms = input_ms;
    return st;
}

/* The kernels and parameters of both directions, and the key poses on the
 * device. Under translations only the adjoint is the forward kernel mirrored
 * (a gather), and where the path is short both become the convolution of its
 * taps (shift_taps.c); otherwise the adjoint is the scatter, whose weights
 * are rounded as the forward's texture unit rounds them (cl/pb_adjoint.cl). */
pb_status pb_launch_prepare(pb_device *dev, const pb_blur_options *opt, pb_plan_frame *f)
{
    f->forward = pb_forward_kernel(&f->path, opt, dev->layer_limits, 0);
    f->forward_fresh = pb_forward_kernel(&f->path, opt, dev->layer_limits, 1);
    f->adjoint = pb_adjoint_kernel(&f->path, opt, dev->layer_limits);
    pb_kparams_from_path(&f->path, opt, &f->forward_prm);
    f->adjoint_prm = f->forward_prm;
    int gather = !pb_kernel_scatters(f->adjoint);
    f->adjoint_prm.mirror = gather;
    if (!gather && opt->filter == PB_FILTER_HARDWARE && dev->texture_weight_steps > 0.0f) {
        f->adjoint_prm.weight_steps = dev->texture_weight_steps;
        f->adjoint_prm.weight_step = 1.0f / dev->texture_weight_steps;
    }
    size_t bytes = 0;
    void *data = pb_kernel_path_pack(&f->path, opt->method, &bytes);
    if (!data)
        return pb_error(pb_owner(dev), PB_ERR_OUT_OF_MEMORY, "out of host memory for the %s",
                        opt->method == PB_METHOD_REF ? "reference's steps" : "key poses");
    f->bytes = bytes;
    pb_status st = PB_OK;
    if (f->path.field && (double)(dev->resident_field_bytes + bytes) > field_budget(dev)) {
        if (dev->info.max_alloc_bytes && bytes > dev->info.max_alloc_bytes) {
            free(data);
            return pb_error(pb_owner(dev), PB_ERR_DEVICE, "a frame's key points and fields take %.2f GiB, more than "
                            "the %.2f GiB one buffer of %s may hold; use shorter frames (fewer fields each), or "
                            "fields on a coarser grid", (double)bytes / 1073741824.0,
                            (double)dev->info.max_alloc_bytes / 1073741824.0, dev->info.name);
        }
        f->streamed = data; /* uploaded for each launch */
        data = NULL;
    } else {
        st = dev->ops->buffer_create(dev, bytes, &f->poses);
        if (st == PB_OK && (st = dev->ops->buffer_write(dev, f->poses, data, bytes)) != PB_OK) {
            dev->ops->buffer_release(dev, f->poses); /* not counted: the plan's release must not uncount it */
            f->poses = NULL;
        }
        if (st == PB_OK && f->path.field)
            dev->resident_field_bytes += bytes;
    }
    free(data);
    /* A field frame's fields now live in its buffer; the host's copy is only
     * the host backend's. */
    if (st == PB_OK && f->path.field) {
        free(f->path.field->data);
        f->path.field->data = NULL;
    }
    return st == PB_OK ? pb_shift_taps_prepare(dev, opt, f) : st;
}

pb_status pb_launch_frame(pb_device *dev, const pb_frame_set *plan, size_t index, int adjoint, const void *in,
                          pb_images *in_images, void *out, int accumulate, int fresh_input)
{
    const pb_plan_frame *frame = &plan->frame[index];
    const pb_geometry *g = &plan->geometry;
    const pb_backend_ops *ops = dev->ops;
    pb_kernel_id kernel = adjoint ? frame->adjoint : fresh_input ? frame->forward_fresh : frame->forward;
    pb_kparams prm = adjoint ? frame->adjoint_prm : frame->forward_prm;
    prm.accumulate = accumulate;
    dev->last_kernel_ms = dev->last_input_ms = 0.0;
    pb_status st = allocate_input(dev, kernel, &prm, g->dims, in_images);
    int timing = 0;
    if (st == PB_OK && fresh_input)
        timing = (st = ops->timer_begin(dev)) == PB_OK;
    const void *input = NULL;
    if (st == PB_OK)
        st = refresh_input(dev, kernel, &prm, in, g->dims, in_images, &input);
    /* A fresh input's part of the time: its copy (a scatter reads the buffer
     * itself); an input made current once for many calls is not timed. */
    if (st == PB_OK && fresh_input && pb_kernel_table[kernel].reads != PB_READS_BUFFER)
        st = ops->timer_mark(dev);
    else if (st == PB_OK && !fresh_input)
        timing = (st = ops->timer_begin(dev)) == PB_OK;
    /* The scatter adds into its output: zeros, or what to add to. */
    if (st == PB_OK && pb_kernel_scatters(kernel) && !accumulate)
        st = ops->buffer_zero(dev, out, g->dims[0] * g->dims[1] * g->dims[2] * sizeof(float));
    if (st != PB_OK) {
        double ms, before;
        if (timing)
            ops->timer_end(dev, &ms, &before); /* waits for what was queued; the first error stands */
        return st;
    }
    void *buffer;
    int temp;
    if ((st = frame_buffer(dev, frame, &buffer, &temp)) != PB_OK) {
        double ms, before;
        if (timing)
            ops->timer_end(dev, &ms, &before);
        return st;
    }
    st = launch_slabs(dev, kernel, input, buffer, prm, out, g->dims);
    frame_buffer_done(dev, buffer, temp);
    return st;
}

pb_status pb_launch_frames(pb_device *dev, const pb_frame_set *plan, const pb_memory *const *ins,
                           pb_memory *const *outs)
{
    const pb_backend_ops *ops = dev->ops;
    const void **inputs = calloc(plan->frames, sizeof *inputs);
    if (!inputs)
        return pb_error(pb_owner(dev), PB_ERR_OUT_OF_MEMORY, "out of host memory for %zu frames", plan->frames);
    pb_status st = PB_OK;
    for (size_t i = 0; i < plan->frames && st == PB_OK; i++) {
        const pb_plan_frame *f = &plan->frame[i];
        pb_memory *in = (pb_memory *)ins[i];
        st = allocate_input(dev, f->forward, &f->forward_prm, plan->geometry.dims, &in->images);
        if (st == PB_OK)
            st = refresh_input(dev, f->forward, &f->forward_prm, in->buffer, plan->geometry.dims, &in->images,
                               &inputs[i]);
    }
    if (st == PB_OK)
        st = ops->timer_begin(dev);
    if (st == PB_OK) {
        pb_status launched = PB_OK;
        for (size_t i = 0; i < plan->frames && launched == PB_OK; i++) {
            const pb_plan_frame *f = &plan->frame[i];
            void *buffer;
            int temp;
            if ((launched = frame_buffer(dev, f, &buffer, &temp)) != PB_OK)
                break;
            launched = launch(dev, f->forward, inputs[i], buffer, &f->forward_prm, outs[i]->buffer,
                              plan->geometry.dims);
            frame_buffer_done(dev, buffer, temp);
            pb_images_stale(&outs[i]->images);
        }
        double before = 0.0;
        st = ops->timer_end(dev, &dev->last_kernel_ms, &before); /* waits for whatever was queued */
        if (launched != PB_OK)
            st = launched;
        dev->last_input_ms = 0.0;
    }
    free(inputs);
    return st;
}

/* Frames on the caller's memory in one call (backend.h's frames_apply). The
 * forward reads one object in every frame: each frame's fresh-input kernel
 * (the 3-D image, not layers laid out for one frame), the image copied once,
 * before timer_mark, then the frames queued back to back. The adjoint reads a
 * tomograph per frame, each made current (a gather's image) just before its
 * launch, in one timer with the launches; frames after the first add into
 * the sum. Progress is not reported inside: one wait at the end. */
pb_status pb_launch_frames_apply(pb_device *dev, const pb_frame_set *plan, size_t first, size_t count, int adjoint,
                                 const void *const *ins, pb_images *in_images, void *const *outs, int accumulate)
{
    const pb_backend_ops *ops = dev->ops;
    const size_t *dims = plan->geometry.dims;
    dev->last_kernel_ms = dev->last_input_ms = 0.0;
    pb_status st = PB_OK;
    for (size_t i = first; i < first + count && st == PB_OK; i++) {
        const pb_plan_frame *f = &plan->frame[i];
        st = adjoint ? allocate_input(dev, f->adjoint, &f->adjoint_prm, dims, in_images)
                     : allocate_input(dev, f->forward_fresh, &f->forward_prm, dims, in_images);
    }
    if (st != PB_OK || (st = ops->timer_begin(dev)) != PB_OK)
        return st;
    pb_images_stale(in_images);
    pb_status launched = PB_OK;
    if (!adjoint) {
        const void *input = NULL;
        int copies = 0; /* whether any frame reads an image (the taps read the buffer itself) */
        for (size_t i = first; i < first + count && launched == PB_OK; i++) { /* copies only the first time */
            launched = refresh_input(dev, plan->frame[i].forward_fresh, &plan->frame[i].forward_prm, ins[0], dims,
                                     in_images, &input);
            copies = copies || pb_kernel_table[plan->frame[i].forward_fresh].reads != PB_READS_BUFFER;
        }
        if (launched == PB_OK && copies)
            launched = ops->timer_mark(dev);
        for (size_t i = first; i < first + count && launched == PB_OK; i++) {
            const pb_plan_frame *f = &plan->frame[i];
            refresh_input(dev, f->forward_fresh, &f->forward_prm, ins[0], dims, in_images, &input); /* current */
            void *buffer;
            int temp;
            if ((launched = frame_buffer(dev, f, &buffer, &temp)) != PB_OK)
                break;
            launched = launch(dev, f->forward_fresh, input, buffer, &f->forward_prm, outs[i - first], dims);
            frame_buffer_done(dev, buffer, temp);
        }
    } else {
        size_t bytes = dims[0] * dims[1] * dims[2] * sizeof(float);
        for (size_t i = first; i < first + count && launched == PB_OK; i++) {
            const pb_plan_frame *f = &plan->frame[i];
            pb_kparams prm = f->adjoint_prm;
            prm.accumulate = accumulate || i > first;
            const void *input = NULL;
            if (i > first)
                pb_images_stale(in_images); /* another tomograph */
            launched = refresh_input(dev, f->adjoint, &prm, ins[i - first], dims, in_images, &input);
            if (launched == PB_OK && pb_kernel_scatters(f->adjoint) && !prm.accumulate)
                launched = ops->buffer_zero(dev, outs[0], bytes);
            void *buffer = NULL;
            int temp = 0;
            if (launched == PB_OK)
                launched = frame_buffer(dev, f, &buffer, &temp);
            if (launched == PB_OK)
                launched = launch(dev, f->adjoint, input, buffer, &prm, outs[0], dims);
            frame_buffer_done(dev, buffer, temp);
        }
    }
    double before = 0.0;
    st = ops->timer_end(dev, &dev->last_kernel_ms, &before); /* waits for whatever was queued */
    dev->last_input_ms = adjoint ? 0.0 : before;
    return launched != PB_OK ? launched : st;
}
