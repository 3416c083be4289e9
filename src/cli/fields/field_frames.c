/* Frames of a field motion: their blur through one plan (the library's
 * pb_plan_create_field_frames), and what petblur motion says of them. */
#include <math.h>
#include <stdlib.h>

#include "blur_run.h"
#include "cli.h"
#include "fields.h"

int pbc_blur_fields_image(pb_context *ctx, const pbc_image *in, const pbc_fields *f, const double *bounds,
                          size_t frames, const pb_blur_options *options, int adjoint, int sum, const char *label,
                          float *out, double *ms)
{
    double one[2] = {f->motion.frame_start, f->motion.frame_end};
    int gated = !bounds && f->gates;
    if (gated)
        frames = f->gates;
    else if (!bounds) {
        bounds = one;
        frames = 1;
    }
    pb_geometry g = {{in->dims[0], in->dims[1], in->dims[2]}, {in->voxel_size[0], in->voxel_size[1], in->voxel_size[2]}};
    pb_plan *plan = NULL;
    pb_status st;
    pb_context_set_progress(ctx, pbc_show_progress ? pbc_progress_line : NULL, (void *)label);
    if (gated)
        st = pb_plan_create_field_gates(ctx, &g, &f->motion, f->intervals, f->counts, frames, options, &plan);
    else
        st = pb_plan_create_field_frames(ctx, &g, &f->motion, bounds, frames, options, &plan);
    return pbc_blur_plan_image(ctx, st, plan, in, frames, adjoint, sum, label, out, ms);
}

/* Where t falls among the loaded fields: between f0 and f0 + 1, alpha of the way. */
static void locate(const pb_field_motion *m, double t, size_t *f0, double *alpha)
{
    size_t j = 0;
    while (j + 2 < m->count && m->times[j + 1] <= t)
        j++;
    double s = (t - m->times[j]) / (m->times[j + 1] - m->times[j]);
    *f0 = j;
    *alpha = fmin(1.0, fmax(0.0, s));
}

/* Component c of voxel v's displacement at (f0, alpha). */
static double at(const pb_field_motion *m, size_t voxels, size_t f0, double alpha, size_t v, int c)
{
    const float *d = m->displacements + f0 * voxels * 3 + 3 * v + (size_t)c;
    return (1.0 - alpha) * (double)d[0] + (alpha > 0.0 ? alpha * (double)d[voxels * 3] : 0.0);
}

void pbc_fields_frame_summary(const pbc_fields *f, double t0, double t1, size_t *samples, double *max_mm)
{
    const pb_field_motion *m = &f->motion;
    size_t voxels = m->dims[0] * m->dims[1] * m->dims[2], s0, inside = 0;
    double a0, worst = 0.0;
    locate(m, t0, &s0, &a0);
    /* A voxel's path is straight between the samples, so its farthest point
     * from the start is one of them, or the frame's end. */
    for (size_t k = 0; k <= m->count; k++) {
        double t = k < m->count ? m->times[k] : t1;
        if (k < m->count && !(t > t0 && t < t1))
            continue;
        inside += k < m->count;
        size_t s;
        double a;
        locate(m, t, &s, &a);
        for (size_t v = 0; v < voxels; v++) {
            double d2 = 0.0;
            for (int c = 0; c < 3; c++) {
                double d = at(m, voxels, s, a, v, c) - at(m, voxels, s0, a0, v, c);
                d2 += d * d;
            }
            worst = fmax(worst, d2);
        }
    }
    *samples = inside + 2;
    *max_mm = sqrt(worst);
}
