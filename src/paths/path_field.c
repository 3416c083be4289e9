/* Planning a frame of a field motion: its key points are the frame's ends
 * and the field times inside it. A voxel's path between two of them is
 * straight (the field is linear in time there), so nothing is cut; the
 * fields the frame reads are copied in texel units, the only ones its
 * device buffer holds. */
#include "path.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"

void pb_path_field_point(const pb_path *plan, const pb_path_knot *knot, const double u[3], double out[3])
{
    const pb_path_field *pf = plan->field;
    size_t n = pf->dims[0] * pf->dims[1] * pf->dims[2];
    double q[3], d0[3], d1[3];
    for (int r = 0; r < 3; r++)
        q[r] = pf->map[4 * r] * u[0] + pf->map[4 * r + 1] * u[1] + pf->map[4 * r + 2] * u[2] + pf->map[4 * r + 3];
    pb_field_sample(pf->data + knot->f0 * n * 3, pf->dims, q, d0);
    pb_field_sample(pf->data + knot->f1 * n * 3, pf->dims, q, d1);
    for (int r = 0; r < 3; r++)
        out[r] = u[r] + (1.0 - knot->alpha) * d0[r] + knot->alpha * d1[r];
}

/* Where time t lies between the fields, as indices into the frame's own
 * run of fields, which starts at global field `first`. */
static pb_path_knot locate(const pb_field_motion *f, size_t first, double t)
{
    pb_path_knot k;
    pb_field_locate(f, t, &k.f0, &k.f1, &k.alpha);
    /* On a sample the other field has no weight, and may lie outside the
     * frame's run (its last sample is the one at or after its end). */
    if (k.alpha == 0.0)
        k.f1 = k.f0;
    else if (k.alpha == 1.0)
        k.f0 = k.f1;
    k.f0 -= first;
    k.f1 -= first;
    return k;
}

/* The largest move of any field voxel between two knots, in voxels of the
 * smallest image voxel size (data in texel units). */
static double largest_move(const pb_path *plan, const pb_path_knot *a, const pb_path_knot *b)
{
    const pb_path_field *pf = plan->field;
    const double *v = plan->geometry.voxel_size;
    double vmin = fmin(v[0], fmin(v[1], v[2])), worst = 0.0;
    size_t n = pf->dims[0] * pf->dims[1] * pf->dims[2];
    const float *a0 = pf->data + a->f0 * n * 3, *a1 = pf->data + a->f1 * n * 3;
    const float *b0 = pf->data + b->f0 * n * 3, *b1 = pf->data + b->f1 * n * 3;
    for (size_t i = 0; i < n; i++) {
        double s = 0.0;
        for (int c = 0; c < 3; c++) {
            size_t x = 3 * i + (size_t)c;
            double da = (1.0 - a->alpha) * (double)a0[x] + a->alpha * (double)a1[x];
            double db = (1.0 - b->alpha) * (double)b0[x] + b->alpha * (double)b1[x];
            double mm = (db - da) * v[c];
            s += mm * mm;
        }
        worst = fmax(worst, sqrt(s) / vmin);
    }
    return worst;
}

/* REF's time steps: every segment cut so that no voxel moves more than half
 * a voxel a step (at least 16), as for a track. */
static pb_status plan_ref_knots(struct pb_context *ctx, const pb_field_motion *f, size_t first,
                                const pb_blur_options *opt, pb_path *plan)
{
    size_t nseg = plan->count - 1, total = 0;
    unsigned *per = calloc(nseg, sizeof *per);
    if (!per)
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory planning the reference");
    for (size_t j = 0; j < nseg; j++) {
        unsigned n = opt->ref_time_steps;
        if (n == 0) {
            double d = largest_move(plan, &plan->field->knots[j], &plan->field->knots[j + 1]);
            n = (unsigned)fmin(100000.0, fmax(16.0, 2.0 * ceil(d)));
        }
        per[j] = n;
        total += n;
    }
    plan->ref_steps = calloc(total, sizeof *plan->ref_steps);
    plan->field->ref_knots = calloc(total, sizeof *plan->field->ref_knots);
    if (!plan->ref_steps || !plan->field->ref_knots) {
        free(per);
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for %zu reference time steps", total);
    }
    size_t k = 0;
    for (size_t j = 0; j < nseg; j++)
        for (unsigned i = 0; i < per[j]; i++, k++) {
            double t = plan->poses[j].time + (plan->poses[j + 1].time - plan->poses[j].time) * (i + 0.5) / per[j];
            plan->field->ref_knots[k] = locate(f, first, t);
            plan->ref_steps[k].weight = plan->poses[j].weight / per[j];
        }
    plan->ref_count = total;
    free(per);
    return PB_OK;
}

/* The map from image texel coordinates (centre at i + 0.5) to field voxel
 * coordinates (centre at i). */
static void texel_to_field(const pb_field_motion *f, double map[12])
{
    static const double identity[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
    const double *m = f->has_map ? f->field_from_grid : identity;
    for (int r = 0; r < 3; r++) {
        for (int c = 0; c < 4; c++)
            map[4 * r + c] = m[4 * r + c];
        map[4 * r + 3] -= 0.5 * (m[4 * r] + m[4 * r + 1] + m[4 * r + 2]);
    }
}

pb_status pb_path_create_field(struct pb_context *ctx, const pb_geometry *g, const pb_field_motion *f, double t0,
                               double t1, const pb_blur_options *opt, pb_path *plan)
{
    memset(plan, 0, sizeof *plan);
    pb_status st = pb_field_frame_check(ctx, f, t0, t1);
    if (st != PB_OK)
        return st;
    plan->geometry = *g;
    /* The frame's run of fields: the sample at or before t0 to the one at or
     * after t1. */
    size_t first = 0, last = f->count - 1;
    while (first + 1 < f->count && f->times[first + 1] <= t0)
        first++;
    while (last > 0 && f->times[last - 1] >= t1)
        last--;
    if (last <= first)
        last = first + 1 < f->count ? first + 1 : first;
    if (first == last)
        first--;
    size_t inside = 0;
    for (size_t i = 0; i < f->count; i++)
        inside += f->times[i] > t0 && f->times[i] < t1;
    plan->count = inside + 2;
    if (plan->count - 1 > PB_MAX_SEGMENTS)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "the frame holds %zu field samples, more than the %d segments "
                        "one blur walks; use shorter frames or fewer fields", inside, PB_MAX_SEGMENTS);
    pb_path_field *pf = calloc(1, sizeof *pf);
    plan->field = pf;
    plan->poses = calloc(plan->count, sizeof *plan->poses);
    size_t n = pb_field_voxels(f), fields = last - first + 1;
    if (pf) {
        pf->knots = calloc(plan->count, sizeof *pf->knots);
        pf->data = malloc(fields * n * 3 * sizeof *pf->data);
    }
    if (!pf || !plan->poses || !pf->knots || !pf->data) {
        pb_path_destroy(plan);
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for a frame's %zu fields (%.1f MiB)", fields,
                        fields * n * 12.0 / 1048576.0);
    }
    pf->fields = fields;
    for (int i = 0; i < 3; i++)
        pf->dims[i] = f->dims[i];
    pf->same = !f->has_map;
    texel_to_field(f, pf->map);
    const float *src = f->displacements + first * n * 3;
    for (size_t i = 0; i < fields * n; i++)
        for (int c = 0; c < 3; c++)
            pf->data[3 * i + (size_t)c] = (float)((double)src[3 * i + (size_t)c] / g->voxel_size[c]);

    size_t k = 0;
    plan->poses[k].time = t0;
    pf->knots[k++] = locate(f, first, t0);
    for (size_t i = 0; i < f->count; i++)
        if (f->times[i] > t0 && f->times[i] < t1) {
            plan->poses[k].time = f->times[i];
            pf->knots[k++] = (pb_path_knot){i - first, i - first, 0.0};
        }
    plan->poses[k].time = t1;
    pf->knots[k] = locate(f, first, t1);
    for (size_t j = 0; j + 1 < plan->count; j++)
        plan->poses[j].weight = (plan->poses[j + 1].time - plan->poses[j].time) / (t1 - t0);
    if (opt->method == PB_METHOD_REF && (st = plan_ref_knots(ctx, f, first, opt, plan)) != PB_OK) {
        pb_path_destroy(plan);
        return st;
    }
    return PB_OK;
}
