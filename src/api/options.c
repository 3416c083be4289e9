/* Blur options: every range stated once (pb_options_check), the defaults
 * filled in, and how many segments a path of these options needs. */
#include "objects.h"
#include "numbers.h"

static pb_status check_options(pb_context *ctx, const pb_blur_options *o)
{
    if ((unsigned)o->method > PB_METHOD_REF)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "unknown method %d; use AB, RM, CL or REF", (int)o->method);
    if ((unsigned)o->filter > PB_FILTER_EXACT)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "unknown filter %d; use HARDWARE or EXACT", (int)o->filter);
    /* Bounds keep per-voxel loops and step lists within what a kernel can run. */
    if (o->steps > 100000)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "steps %u is above 100000; use fewer", o->steps);
    if (o->ref_points > 100000)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "ref_points %u is above 100000; use fewer", o->ref_points);
    if (o->ref_time_steps > 100000)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "ref_time_steps %u is above 100000; use fewer",
                        o->ref_time_steps);
    if ((unsigned)o->path > PB_PATH_TRACKED)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "unknown path model %d; use PB_PATH_DEFAULT, PB_PATH_BOUNDED "
                        "or PB_PATH_TRACKED", (int)o->path);
    if (o->path == PB_PATH_BOUNDED &&
        !(o->max_path_error >= PB_MIN_MAX_PATH_ERROR && o->max_path_error <= 1000.0))
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "max_path_error %s: give a bound in voxels from %s to 1000 "
                        "(default %s; below %s voxels the walk's own rounding decides the path), or the paper's "
                        "polyline (one segment per tracked interval)", PB_NUM(o->max_path_error),
                        PB_NUM(PB_MIN_MAX_PATH_ERROR), PB_NUM(PB_DEFAULT_MAX_PATH_ERROR),
                        PB_NUM(PB_MIN_MAX_PATH_ERROR));
    if (o->path != PB_PATH_BOUNDED && o->max_path_error != 0.0)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "max_path_error %s is set, but the path model is %s; set the "
                        "model to PB_PATH_BOUNDED for a bound", PB_NUM(o->max_path_error),
                        o->path == PB_PATH_TRACKED ? "the paper's polyline" : "the default bound");
    if (o->jacobian != 0 && o->jacobian != 1)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "jacobian is %d; give 0 (concentrations) or 1 (mass-preserving, "
                        "for images of counts)", o->jacobian);
    if ((unsigned)o->ab_sampling > PB_AB_SAMPLING_CHORD)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "unknown AB sampling %d; use PB_AB_SAMPLING_DEFAULT, SLICE, "
                        "SWEEP or CHORD", (int)o->ab_sampling);
    if (o->ab_sampling != PB_AB_SAMPLING_DEFAULT && o->method != PB_METHOD_AB)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "ab_sampling is set, but the method is %s; it is AB's alone: "
                        "leave it at the default for RM, CL and REF",
                        o->method == PB_METHOD_RM ? "RM" : o->method == PB_METHOD_CL ? "CL" : "REF");
    return PB_OK;
}

/* What AB's plan of a frame holds: its segments, and the tracker noise it
 * measured and does not follow (none where the options' method follows the
 * track itself: CL and REF). */
static pb_status plan_facts(const pb_geometry *geometry, const pb_motion *motion, const pb_blur_options *options,
                            size_t *segments, double *noise_mm)
{
    size_t count;
    pb_blur_options opt = {PB_METHOD_AB, PB_FILTER_HARDWARE, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
    if (options)
        opt = *options;
    pb_status st = pb_geometry_check(NULL, geometry, &count);
    if (st == PB_OK)
        st = check_options(NULL, &opt);
    if (st != PB_OK)
        return st;
    /* AB's plan: CL and REF follow the path itself, but the question is what
     * a polyline of these options would need. */
    int follows = opt.method == PB_METHOD_CL || opt.method == PB_METHOD_REF;
    opt.method = PB_METHOD_AB;
    pb_path plan;
    if ((st = pb_path_create(NULL, geometry, motion, &opt, &plan)) != PB_OK)
        return st;
    *segments = plan.count - 1;
    *noise_mm = follows ? 0.0 : plan.noise_mm;
    pb_path_destroy(&plan);
    return PB_OK;
}

pb_status pb_path_segments(const pb_geometry *geometry, const pb_motion *motion, const pb_blur_options *options,
                           size_t *segments)
{
    double noise;
    if (!geometry || !motion || !segments)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "geometry, motion and segments must not be NULL");
    return plan_facts(geometry, motion, options, segments, &noise);
}

pb_status pb_path_noise(const pb_geometry *geometry, const pb_motion *motion, const pb_blur_options *options,
                        double *noise_mm, size_t *segments)
{
    size_t count;
    if (!geometry || !motion || !noise_mm)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "geometry, motion and noise_mm must not be NULL");
    return plan_facts(geometry, motion, options, segments ? segments : &count, noise_mm);
}

pb_status pb_options_check(const pb_blur_options *options)
{
    pb_blur_options opt;
    return pb_options_prepare(NULL, options, &opt);
}

pb_status pb_options_prepare(pb_context *ctx, const pb_blur_options *options, pb_blur_options *opt)
{
    *opt = (pb_blur_options){PB_METHOD_AB, PB_FILTER_HARDWARE, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
    if (options)
        *opt = *options;
    pb_status st = check_options(ctx, opt);
    if (st == PB_OK && opt->ref_points == 0)
        opt->ref_points = 200;
    return st;
}
