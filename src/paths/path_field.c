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
#include "numbers.h"

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

/* Where time t lies between the fields, as global field indices (the frame's
 * own are made when its fields are gathered). On a sample the other field
 * has no weight: it is dropped, so that a frame keeps only what it reads. */
static pb_status locate(struct pb_context *ctx, const pb_field_motion *f, double t, pb_path_knot *k)
{
    pb_status st = pb_field_locate(ctx, f, t, &k->f0, &k->f1, &k->alpha);
    if (k->alpha == 0.0)
        k->f1 = k->f0;
    else if (k->alpha == 1.0)
        k->f0 = k->f1;
    return st;
}

/* REF's reach: its random points lie up to half an image voxel past the
 * centres, so the field voxels they read. */
#define PB_REF_REACH 0.5

/* The largest move of any field voxel REF reads (box [lo, hi]) between two
 * knots, each axis in its own image voxels (data in texel units), as a
 * track's REF counts it. */
static double largest_move(const pb_path *plan, const size_t lo[3], const size_t hi[3], const pb_path_knot *a,
                           const pb_path_knot *b)
{
    const pb_path_field *pf = plan->field;
    double worst = 0.0;
    size_t n = pf->dims[0] * pf->dims[1] * pf->dims[2];
    const float *a0 = pf->data + a->f0 * n * 3, *a1 = pf->data + a->f1 * n * 3;
    const float *b0 = pf->data + b->f0 * n * 3, *b1 = pf->data + b->f1 * n * 3;
    for (size_t l = lo[2]; l <= hi[2]; l++)
        for (size_t j = lo[1]; j <= hi[1]; j++)
            for (size_t i = lo[0]; i <= hi[0]; i++) {
                const size_t v = 3 * (i + pf->dims[0] * (j + pf->dims[1] * l));
                double s = 0.0;
                for (size_t c = 0; c < 3; c++) {
                    double da = (1.0 - a->alpha) * (double)a0[v + c] + a->alpha * (double)a1[v + c];
                    double db = (1.0 - b->alpha) * (double)b0[v + c] + b->alpha * (double)b1[v + c];
                    s += (db - da) * (db - da);
                }
                worst = fmax(worst, sqrt(s));
            }
    return worst;
}

/* REF's time steps: every walked segment cut so that no voxel moves more
 * than half a voxel a step (at least 16), as for a track; in global field
 * indices, as the key points before their fields are gathered. Needs the
 * fields at hand: planned after the gather, its knots remapped by `local`. */
static pb_status plan_ref_knots(struct pb_context *ctx, const pb_field_motion *f, const size_t *local,
                                const pb_blur_options *opt, pb_path *plan)
{
    size_t nseg = plan->count - 1, total = 0, lo[3], hi[3];
    unsigned *per = calloc(nseg, sizeof *per);
    if (!per)
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory planning the reference");
    pb_field_reach_box(&plan->geometry, f, PB_REF_REACH, lo, hi);
    for (size_t j = 0; j < nseg; j++) {
        unsigned n = plan->poses[j].skip ? 0 : opt->ref_time_steps;
        if (n == 0 && !plan->poses[j].skip) {
            double d = largest_move(plan, lo, hi, &plan->field->knots[j], &plan->field->knots[j + 1]);
            n = (unsigned)fmin(100000.0, fmax(16.0, 2.0 * ceil(d)));
        }
        per[j] = n;
        total += n;
    }
    plan->ref_steps = calloc(total ? total : 1, sizeof *plan->ref_steps);
    plan->field->ref_knots = calloc(total ? total : 1, sizeof *plan->field->ref_knots);
    if (!plan->ref_steps || !plan->field->ref_knots) {
        free(per);
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for %zu reference time steps", total);
    }
    size_t k = 0;
    pb_status st = PB_OK;
    for (size_t j = 0; j < nseg && st == PB_OK; j++)
        for (unsigned i = 0; i < per[j] && st == PB_OK; i++, k++) {
            double t = plan->poses[j].time + (plan->poses[j + 1].time - plan->poses[j].time) * (i + 0.5) / per[j];
            pb_path_knot g;
            if ((st = locate(ctx, f, t, &g)) != PB_OK)
                break;
            if (local[g.f0] == (size_t)-1 || local[g.f1] == (size_t)-1) {
                st = pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "REF's step at %s s reads a field that its segment's key "
                              "points do not; a planning error, please report it with the fields' times",
                              PB_NUM(t));
                break;
            }
            g.f0 = local[g.f0]; /* gathered with the segment's (pb_path_create_field) */
            g.f1 = local[g.f1];
            plan->field->ref_knots[k] = g;
            plan->ref_steps[k].weight = plan->poses[j].weight / per[j];
        }
    plan->ref_count = total ? total : 1; /* none walked: one step of weight 0 keeps the buffer non-empty */
    free(per);
    return st;
}

/* Where a key point lies among the fields, in (global) field indices. */
static double knot_place(const pb_path_knot *k)
{
    return (1.0 - k->alpha) * (double)k->f0 + k->alpha * (double)k->f1;
}

/* How far each walked segment carries the object along each image axis, in
 * its voxels, checked by pb_path_walk_check. The displacement is linear in
 * the field index between fields, so between two key points it changes by at
 * most each field interval's largest difference (over the field voxels under
 * the image, pb_field_reach_box) times the share of that interval the segment
 * spans: exact where a segment lies inside one interval, as time's do. Before
 * the key points are made local; the fields' differences read once each. */
static pb_status check_field_walk(struct pb_context *ctx, const pb_geometry *g, const pb_field_motion *f,
                                  const pb_blur_options *opt, const pb_path *plan, int by_value)
{
    if (!pb_path_walk_counts(opt)) {
        double samples = 0.0;
        return pb_path_check_samples(ctx, opt, plan, &samples);
    }
    const pb_path_knot *kn = plan->field->knots;
    double first = HUGE_VAL, last = -HUGE_VAL;
    for (size_t j = 0; j + 1 < plan->count; j++)
        if (!plan->poses[j].skip) {
            first = fmin(first, fmin(knot_place(&kn[j]), knot_place(&kn[j + 1])));
            last = fmax(last, fmax(knot_place(&kn[j]), knot_place(&kn[j + 1])));
        }
    if (!(last > first))
        return PB_OK;
    const size_t k0 = (size_t)floor(first), k1 = (size_t)ceil(last), n = pb_field_voxels(f);
    double *most = calloc(3 * (k1 - k0), sizeof *most);
    if (!most)
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory checking a frame's fields");
    size_t lo[3], hi[3];
    pb_field_reach_box(g, f, opt->method == PB_METHOD_REF ? PB_REF_REACH : 0.0, lo, hi);
    for (size_t k = k0; k < k1; k++) {
        const float *a = f->displacements + k * n * 3, *b = a + n * 3;
        double *m = most + 3 * (k - k0);
        for (size_t l = lo[2]; l <= hi[2]; l++)
            for (size_t j = lo[1]; j <= hi[1]; j++)
                for (size_t i = lo[0]; i <= hi[0]; i++) {
                    const size_t v = 3 * (i + f->dims[0] * (j + f->dims[1] * l));
                    for (int c = 0; c < 3; c++)
                        m[c] = fmax(m[c], fabs((double)b[v + c] - (double)a[v + c]) / g->voxel_size[c]);
                }
    }
    double total[3] = {0.0, 0.0, 0.0};
    pb_status st = PB_OK;
    for (size_t j = 0; j + 1 < plan->count && st == PB_OK; j++) {
        if (plan->poses[j].skip)
            continue;
        const double sa = fmin(knot_place(&kn[j]), knot_place(&kn[j + 1]));
        const double sb = fmax(knot_place(&kn[j]), knot_place(&kn[j + 1]));
        double walk[3] = {0.0, 0.0, 0.0};
        for (size_t k = (size_t)floor(sa); k < k1 && (double)k < sb; k++)
            for (int c = 0; c < 3; c++)
                walk[c] += (fmin(sb, (double)k + 1.0) - fmax(sa, (double)k)) * most[3 * (k - k0) + (size_t)c];
        for (int c = 0; c < 3 && st == PB_OK; c++)
            st = pb_path_walk_check(ctx, g, "fields", c, walk[c], &total[c], plan->poses[j].time, by_value);
    }
    free(most);
    return st;
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

/* Appends t to times[] at *n (when times is not NULL) and counts it. */
static void emit(double *times, size_t *n, double t, double *last)
{
    if (times)
        times[*n] = t;
    (*n)++;
    *last = t;
}

/* The key times of one interval [t0, t1], increasing: its ends and, strictly
 * inside, the field times; or with a surrogate its sample times and the
 * times between them where the signal crosses a field's value, where the
 * motion, linear in the value, bends. Written to times[] from *n when times
 * is not NULL, else only counted (the same times both ways). */
static void interval_times(const pb_field_motion *f, double t0, double t1, double *times, size_t *n)
{
    double last = t0;
    emit(times, n, t0, &last);
    if (!f->signal_count) {
        for (size_t i = 0; i < f->count; i++)
            if (f->times[i] > t0 && f->times[i] < t1)
                emit(times, n, f->times[i], &last);
    } else {
        const double *st = f->signal_times, *sv = f->signal;
        for (size_t i = pb_sample_before(st, f->signal_count, t0); i + 1 < f->signal_count && st[i] < t1; i++) {
            double ta = st[i], tb = st[i + 1], sa = sv[i], sb = sv[i + 1];
            if (tb <= t0)
                continue;
            if (ta > t0 && ta > last)
                emit(times, n, ta, &last);
            if (sa == sb)
                continue;
            for (size_t j = 0; j < f->count; j++) { /* the values passed, in the order the signal passes them */
                double v = f->times[sb > sa ? j : f->count - 1 - j];
                if (!(v > fmin(sa, sb) && v < fmax(sa, sb)))
                    continue;
                double tc = ta + (v - sa) / (sb - sa) * (tb - ta);
                if (tc > last && tc > t0 && tc < t1 && tc < tb)
                    emit(times, n, tc, &last);
            }
        }
    }
    emit(times, n, t1, &last);
}

/* Key points in time: each interval's ends and what interval_times puts
 * between them, each segment weighed by its share of the frame's time, the
 * gaps between intervals skipped; in global field indices. */
static pb_status time_knots(struct pb_context *ctx, const pb_field_motion *f, const double *iv, size_t intervals,
                            double total, pb_path *plan)
{
    size_t count = 0;
    for (size_t i = 0; i < intervals; i++)
        interval_times(f, iv[2 * i], iv[2 * i + 1], NULL, &count);
    if (count - 1 > PB_MAX_SEGMENTS)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "the frame holds %zu key points, more than the %d segments one "
                        "blur walks; use shorter frames or fewer samples", count, PB_MAX_SEGMENTS);
    pb_path_field *pf = calloc(1, sizeof *pf);
    double *times = malloc(count * sizeof *times);
    plan->field = pf;
    plan->count = count;
    plan->poses = calloc(count, sizeof *plan->poses);
    if (pf)
        pf->knots = calloc(count, sizeof *pf->knots);
    if (!pf || !times || !plan->poses || !pf->knots) {
        free(times);
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory planning a frame of %zu key points", count);
    }
    size_t k = 0;
    for (size_t i = 0; i < intervals; i++) {
        size_t from = k;
        interval_times(f, iv[2 * i], iv[2 * i + 1], times, &k);
        for (size_t j = from; j < k; j++) {
            plan->poses[j].time = times[j];
            /* The segment to the next key point: inside the interval, its
             * share of the frame's time; from the interval's end to the next
             * one's start, a gap that is skipped. */
            plan->poses[j].skip = j + 1 == k;
            plan->poses[j].weight = j + 1 < k ? (times[j + 1] - times[j]) / total : 0.0;
        }
    }
    pb_status st = PB_OK;
    for (size_t j = 0; j < count && st == PB_OK; j++)
        st = locate(ctx, f, times[j], &pf->knots[j]);
    free(times);
    return st;
}

pb_status pb_path_create_field(struct pb_context *ctx, const pb_geometry *g, const pb_field_motion *f,
                               const double *iv, size_t intervals, const pb_blur_options *opt, pb_path *plan)
{
    memset(plan, 0, sizeof *plan);
    pb_status st = PB_OK;
    double total = 0.0;
    for (size_t i = 0; i < intervals && st == PB_OK; i++) {
        st = pb_field_frame_check(ctx, f, iv[2 * i], iv[2 * i + 1]);
        if (st == PB_OK && i > 0 && iv[2 * i] < iv[2 * i - 1])
            st = pb_error(ctx, PB_ERR_BAD_FRAME, "interval %zu starts at %s s, before interval %zu ends at %s s; a "
                          "gate's intervals increase and do not overlap", i, PB_NUM(iv[2 * i]), i - 1,
                          PB_NUM(iv[2 * i - 1]));
        total += iv[2 * i + 1] - iv[2 * i];
    }
    if (st != PB_OK)
        return st;
    if (intervals == 0 || !(total > 0.0) || !isfinite(total))
        return pb_error(ctx, PB_ERR_BAD_FRAME, "the frame has no time (%zu intervals); give at least one interval "
                        "with end > start", intervals);
    plan->geometry = *g;
    size_t *local = malloc(f->count * sizeof *local);
    if (!local)
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory planning a frame");
    /* A surrogate's frame by the values it visits (path_surrogate.c), unless
     * its samples are asked for (the paper's polyline) or REF's reference
     * walks them densely in time. */
    const int by_value = f->signal_count && opt->method != PB_METHOD_REF && opt->path != PB_PATH_TRACKED;
    if (by_value)
        st = pb_path_surrogate_knots(ctx, f, iv, intervals, total,
                                     PB_VALUE_BIN_MOVES * (opt->path == PB_PATH_BOUNDED ? opt->max_path_error
                                                                                        : PB_DEFAULT_MAX_PATH_ERROR),
                                     plan);
    else
        st = time_knots(ctx, f, iv, intervals, total, plan);
    if (st != PB_OK) {
        free(local);
        pb_path_destroy(plan);
        return st;
    }
    if ((st = check_field_walk(ctx, g, f, opt, plan, by_value)) != PB_OK) {
        free(local);
        pb_path_destroy(plan);
        return st;
    }
    size_t count = plan->count;
    pb_path_field *pf = plan->field;
    /* The fields the key points read, gathered in texel units, once each. */
    size_t n = pb_field_voxels(f), fields = 0;
    for (size_t i = 0; i < f->count; i++)
        local[i] = (size_t)-1;
    /* A walked segment's own fields, and for REF's steps between its key
     * points every field whose value a surrogate passes on the way: those
     * between the two key points' (their indices span them). */
    for (size_t j = 0; j < count && st == PB_OK; j++) {
        size_t lo = pf->knots[j].f0, hi = pf->knots[j].f1;
        if (j + 1 < count && !plan->poses[j].skip && opt->method == PB_METHOD_REF) {
            lo = lo < pf->knots[j + 1].f0 ? lo : pf->knots[j + 1].f0;
            hi = hi > pf->knots[j + 1].f1 ? hi : pf->knots[j + 1].f1;
        }
        for (size_t i = lo; i <= hi; i++)
            if (local[i] == (size_t)-1)
                local[i] = fields++;
    }
    if (st == PB_OK && !(pf->data = malloc(fields * n * 3 * sizeof *pf->data)))
        st = pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for a frame's %zu fields (%.1f MiB)", fields,
                      fields * n * 12.0 / 1048576.0);
    if (st == PB_OK) {
        pf->fields = fields;
        for (int i = 0; i < 3; i++)
            pf->dims[i] = f->dims[i];
        pf->same = !f->has_map;
        texel_to_field(f, pf->map);
        for (size_t gi = 0; gi < f->count; gi++) {
            if (local[gi] == (size_t)-1)
                continue;
            const float *src = f->displacements + gi * n * 3;
            float *dst = pf->data + local[gi] * n * 3;
            for (size_t i = 0; i < n; i++)
                for (int c = 0; c < 3; c++)
                    dst[3 * i + (size_t)c] = (float)((double)src[3 * i + (size_t)c] / g->voxel_size[c]);
        }
        for (size_t j = 0; j < count; j++) {
            pf->knots[j].f0 = local[pf->knots[j].f0];
            pf->knots[j].f1 = local[pf->knots[j].f1];
        }
    }
    if (st == PB_OK && opt->method == PB_METHOD_REF)
        st = plan_ref_knots(ctx, f, local, opt, plan);
    free(local);
    if (st != PB_OK)
        pb_path_destroy(plan);
    return st;
}
