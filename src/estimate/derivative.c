/* pb_blur_pose_derivative: d(B x)/d(pose) as B applied to the object's
 * derivative images. For a perturbation G shared by every pose of the path,
 * (B' x)(y) = mean over t of x(G(T(t)^-1 y)) = B (x o G) (y), so the
 * derivative is B of d(x o G)/dxi, an image in object space. */
#include <stdlib.h>

#include "objects.h"
#include "error.h"
#include "estimate.h"

pb_status pb_blur_pose_derivative(pb_context *ctx, const pb_volume *object, const pb_motion *motion,
                                  const pb_blur_options *options, pb_volume *const derivatives[6])
{
    if (!ctx || !object || !motion || !derivatives)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "context, object, motion and derivatives must not be NULL");
    for (int j = 0; j < 6; j++) {
        if (!derivatives[j] || derivatives[j] == object)
            return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "derivatives[%d] is %s; give six volumes apart from the "
                            "object", j, derivatives[j] ? "the object" : "NULL");
        for (int i = 0; i < j; i++)
            if (derivatives[i] == derivatives[j])
                return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "derivatives[%d] and [%d] are one volume; give six "
                                "different volumes", i, j);
    }
    pb_geometry g;
    pb_status st = pb_volume_get_geometry(object, &g);
    if (st != PB_OK)
        return st;
    if ((st = pb_context_enter(ctx)) != PB_OK)
        return st;
    const size_t n = g.dims[0] * g.dims[1] * g.dims[2];
    double c[3];
    for (int a = 0; a < 3; a++)
        c[a] = motion->has_center ? motion->center[a] : 0.5 * (double)g.dims[a] * g.voxel_size[a];
    float *x = malloc(sizeof(float) * n), *images = malloc(sizeof(float) * 6 * n);
    pb_volume *image = NULL;
    if (!x || !images)
        st = pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for the derivative images of a %zu x %zu x %zu "
                      "volume", g.dims[0], g.dims[1], g.dims[2]);
    if (st == PB_OK)
        st = pb_volume_download(object, x);
    if (st == PB_OK)
        st = pb_volume_create(ctx, &g, &image);
    if (st == PB_OK) {
        float *d[6];
        for (int j = 0; j < 6; j++)
            d[j] = images + (size_t)j * n;
        pbe_pose_gradients(NULL, &g, x, c, d);
        for (int j = 0; j < 6 && st == PB_OK; j++) {
            st = pb_volume_upload(image, d[j]);
            if (st == PB_OK)
                st = pb_blur(ctx, image, motion, options, derivatives[j]);
        }
    }
    pb_volume_destroy(image);
    free(x);
    free(images);
    pb_context_leave(ctx);
    return st;
}
