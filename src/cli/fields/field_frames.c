/* Frames of a field motion: their blur through one plan (the library's
 * pb_plan_create_field_frames), and what petblur motion says of them. */
#include <math.h>
#include <stdlib.h>

#include "blur_run.h"
#include "cli.h"
#include "fields.h"

static int blur_failed(pb_context *ctx, pb_status st, const char *label)
{
    if (pbc_show_progress)
        pbc_progress_line(1.0, NULL);
    return pbc_fail(pbc_exit_for(st), "%s: %s: %s", label, pb_status_string(st), pb_last_error(ctx));
}

static void destroy_all(pb_volume **v, size_t n)
{
    for (size_t i = 0; v && i < n; i++)
        pb_volume_destroy(v[i]);
    free(v);
}

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
    size_t n = pbc_image_frame_voxels(in), sources = pbc_image_frame_count(in), outputs = adjoint && sum ? 1 : frames;
    pb_volume **src = calloc(sources, sizeof *src), **dst = calloc(outputs, sizeof *dst);
    pb_plan *plan = NULL;
    if (!src || !dst) {
        free(src);
        free(dst);
        return pbc_fail(PBC_EXIT_RUNTIME, "%s: out of host memory for %zu volumes' handles", label, sources + outputs);
    }
    pb_status st = PB_OK;
    pb_context_set_progress(ctx, pbc_show_progress ? pbc_progress_line : NULL, (void *)label);
    if (st == PB_OK && gated)
        st = pb_plan_create_field_gates(ctx, &g, &f->motion, f->intervals, f->counts, frames, options, &plan);
    else if (st == PB_OK)
        st = pb_plan_create_field_frames(ctx, &g, &f->motion, bounds, frames, options, &plan);
    /* Each input frame goes up once; a 3-D input serves every frame. */
    for (size_t i = 0; i < sources && st == PB_OK; i++)
        if ((st = pb_volume_create(ctx, &g, &src[i])) == PB_OK)
            st = pb_volume_upload(src[i], in->data + i * n);
    for (size_t i = 0; i < outputs && st == PB_OK; i++)
        st = pb_volume_create(ctx, &g, &dst[i]);
    *ms = 0.0;
    for (size_t i = 0; i < frames && st == PB_OK; i++) {
        const pb_volume *x = src[sources == 1 ? 0 : i];
        /* With sum, every frame's back projection lands in the one output:
         * the first overwrites it, the others add. */
        st = adjoint ? pb_plan_adjoint(plan, i, x, dst[outputs == 1 ? 0 : i], sum && i > 0)
                     : pb_plan_forward(plan, i, x, dst[i]);
        double t = 0.0;
        if (st == PB_OK && pb_context_last_kernel_ms(ctx, &t) == PB_OK)
            *ms += t;
    }
    for (size_t i = 0; i < outputs && st == PB_OK; i++)
        st = pb_volume_download(dst[i], out + i * n);
    pb_plan_destroy(plan);
    destroy_all(src, sources);
    destroy_all(dst, outputs);
    return st == PB_OK ? 0 : blur_failed(ctx, st, label);
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
