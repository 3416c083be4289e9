/* Volumes: a grid's checks (its size, what the device can hold) and its
 * memory on the device, uploaded, downloaded and handed out. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "objects.h"
#include "numbers.h"

pb_status pb_geometry_check(pb_context *ctx, const pb_geometry *g, size_t *count)
{
    for (int i = 0; i < 3; i++) {
        if (g->dims[i] == 0)
            return pb_error(ctx, PB_ERR_ZERO_DIMS, "volume dimension %c is 0 (dims %zu x %zu x %zu); every dimension needs at least one voxel",
                            "xyz"[i], g->dims[0], g->dims[1], g->dims[2]);
        /* From a tenth of a micrometre to ten metres: outside, sizes are a unit's
         * mistake (metres read as mm, a header's garbage), and the sums over
         * voxels in mm (centres, motions, filter widths) leave double's
         * useful range or take without bound. */
        if (!(g->voxel_size[i] >= PB_MIN_VOXEL_MM && g->voxel_size[i] <= PB_MAX_VOXEL_MM))
            return pb_error(ctx, PB_ERR_BAD_VOXEL_SIZE, "voxel size %c is %s mm; give a size from %s to %s mm",
                            "xyz"[i], PB_NUM(g->voxel_size[i]), PB_NUM(PB_MIN_VOXEL_MM), PB_NUM(PB_MAX_VOXEL_MM));
    }
    /* Kernels index voxels with 32-bit ints and bytes with size_t. */
    if (g->dims[0] > INT32_MAX / g->dims[1] || g->dims[0] * g->dims[1] > INT32_MAX / g->dims[2])
        return pb_error(ctx, PB_ERR_VOLUME_TOO_LARGE,
                        "volume %zu x %zu x %zu has more than 2^31 - 1 voxels; split it into slabs",
                        g->dims[0], g->dims[1], g->dims[2]);
    *count = g->dims[0] * g->dims[1] * g->dims[2];
    return PB_OK;
}

static pb_status volume_create_entered(pb_context *ctx, const pb_geometry *g, pb_volume **out)
{
    *out = NULL;
    size_t count = 0;
    pb_status st = pb_geometry_check(ctx, g, &count);
    if (st == PB_OK)
        st = pb_device_check_volume(&ctx->dev, &ctx->dev.info, g);
    if (st != PB_OK)
        return st;
    pb_volume *vol = calloc(1, sizeof *vol);
    if (!vol)
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for a volume");
    vol->ctx = ctx;
    vol->geometry = *g;
    vol->count = count;
    st = ctx->dev.ops->buffer_create(&ctx->dev, count * sizeof(float), &vol->mem.buffer);
    if (st != PB_OK) {
        free(vol);
        return st;
    }
    pb_images_stale(&vol->mem.images);
    vol->next = ctx->volumes;
    if (ctx->volumes)
        ctx->volumes->prev = vol;
    ctx->volumes = vol;
    pb_context_hold(ctx);
    *out = vol;
    return PB_OK;
}

pb_status pb_volume_create(pb_context *ctx, const pb_geometry *g, pb_volume **out)
{
    if (!ctx || !g || !out)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "ctx, geometry and volume must not be NULL");
    pb_status st = pb_context_enter(ctx);
    if (st != PB_OK)
        return st;
    st = volume_create_entered(ctx, g, out);
    pb_context_leave(ctx);
    return st;
}

void pb_volume_destroy(pb_volume *vol)
{
    if (!vol)
        return;
    pb_context *ctx = vol->ctx;
    if (vol->prev)
        vol->prev->next = vol->next;
    else
        ctx->volumes = vol->next;
    if (vol->next)
        vol->next->prev = vol->prev;
    pb_images_release(&ctx->dev, &vol->mem.images);
    ctx->dev.ops->buffer_release(&ctx->dev, vol->mem.buffer);
    free(vol);
    pb_context_release_hold(ctx);
}

pb_status pb_volume_get_geometry(const pb_volume *vol, pb_geometry *g)
{
    if (!vol || !g)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "volume and geometry must not be NULL");
    *g = vol->geometry;
    return PB_OK;
}

static pb_status volume_upload_entered(pb_volume *vol, const float *host)
{
    /* One NaN would spread through every blur that reads it; refuse it here,
     * where the voxel can still be named. */
    const size_t *n = vol->geometry.dims;
    for (size_t i = 0; i < vol->count; i++)
        if (!isfinite(host[i]))
            return pb_error(vol->ctx, PB_ERR_NOT_FINITE,
                            "activity at voxel (%zu, %zu, %zu) is %g; replace NaN and infinite values (for "
                            "example by 0) before uploading",
                            i % n[0], i / n[0] % n[1], i / (n[0] * n[1]), (double)host[i]);
    pb_status st = vol->ctx->dev.ops->buffer_write(&vol->ctx->dev, vol->mem.buffer, host, vol->count * sizeof(float));
    pb_images_stale(&vol->mem.images);
    return st;
}

pb_status pb_volume_upload(pb_volume *vol, const float *host)
{
    if (!vol || !host)
        return pb_error(vol ? vol->ctx : NULL, PB_ERR_INVALID_ARGUMENT, "volume and host data must not be NULL");
    pb_status st = pb_context_enter(vol->ctx);
    if (st != PB_OK)
        return st;
    st = volume_upload_entered(vol, host);
    pb_context_leave(vol->ctx);
    return st;
}

static pb_status volume_download_entered(const pb_volume *vol, float *host)
{
    return vol->ctx->dev.ops->buffer_read(&vol->ctx->dev, vol->mem.buffer, host, vol->count * sizeof(float));
}

pb_status pb_volume_download(const pb_volume *vol, float *host)
{
    if (!vol || !host)
        return pb_error(vol ? vol->ctx : NULL, PB_ERR_INVALID_ARGUMENT, "volume and host data must not be NULL");
    pb_status st = pb_context_enter(vol->ctx);
    if (st != PB_OK)
        return st;
    st = volume_download_entered(vol, host);
    pb_context_leave(vol->ctx);
    return st;
}

void pb_volume_memory_written(pb_context *ctx, const void *memory)
{
    for (pb_volume *v = ctx->volumes; v; v = v->next)
        if (v->mem.buffer == memory)
            pb_images_stale(&v->mem.images);
}

pb_status pb_volume_memory(const pb_volume *vol, void **memory)
{
    if (!vol || !memory)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "volume and memory must not be NULL");
    *memory = vol->mem.buffer;
    return PB_OK;
}
