/* The objects users hold: a context (one device opened, and what the API
 * keeps beside it), a volume (memory of the context's device) and a plan (a
 * motion's frames prepared for the device). Backends see only what these hold
 * for them: the device, the frame set and the memory (src/devices/backend.h). */
#ifndef PB_OBJECTS_H
#define PB_OBJECTS_H

#include <stdatomic.h>

#include "backend.h"

struct pb_context {
    pb_device dev;
    char last_error[PB_ERROR_TEXT_MAX];
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
    pb_memory mem;
    /* The context's volumes, so that a device-memory call that writes a
     * volume's memory (pb_volume_memory) can mark its images stale. */
    struct pb_volume *prev, *next;
};

struct pb_plan {
    struct pb_context *ctx;
    pb_frame_set set;
};

/* devices.c: the backend of options, the automatic choice made (which fills
 * in the backend and device index), compiled in, and the device index not
 * negative. */
pb_status pb_backend_select(pb_context_options *opt, const pb_backend_ops **ops);

/* options.c, volume.c, context.c: the checks every blur makes of its options,
 * with the defaults filled in; a grid's checks and its voxel count; a
 * context's holders. */
pb_status pb_options_prepare(struct pb_context *ctx, const pb_blur_options *options, pb_blur_options *opt);
pb_status pb_geometry_check(struct pb_context *ctx, const pb_geometry *g, size_t *count);
void pb_context_hold(struct pb_context *ctx);
/* A call's work in ctx: refused when another thread is inside it; nested
 * calls of one thread (a one-shot blur's plan, a progress report that blurs
 * again) enter again. Every PB_OK of enter is matched by one leave. */
pb_status pb_context_enter(struct pb_context *ctx);
void pb_context_leave(struct pb_context *ctx);
void pb_context_release_hold(struct pb_context *ctx);
/* Device memory at `memory` was written behind the volumes' back: the images
 * of the volume it belongs to, if any, are out of date. */
void pb_volume_memory_written(struct pb_context *ctx, const void *memory);

#endif
