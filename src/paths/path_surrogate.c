/* A frame of a surrogate-driven field motion, planned by the value the
 * breath takes rather than by its samples. The motion at time t is a
 * function of the surrogate's value s(t) alone, so the blur over a frame is
 * the mean of the voxel's positions over the values the breath visits,
 * weighed by how long it stays near each: the order of the visits does not
 * matter. Walking the visits in time costs a segment per belt sample (a
 * 25 Hz belt gives a gate of a five-minute scan some 1500 for every voxel);
 * walking the values costs a segment per value bin, however long the frame
 * and however often the breath returns.
 *
 * The values are cut into bins, each inside one interval between two
 * fields' values (where the path is straight) and short enough that no
 * voxel moves more than a set distance across it. The time the frame spends
 * in a bin is exact (the signal is linear between its samples); within the
 * bin that time is spread unevenly, most near the breath's turning points,
 * so the bin's segment is the uniform stretch of values with the same mean
 * and spread as the time spent there: its blur then errs only in the third
 * moment of a distribution one bin wide. */
#include "path.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"

/* The largest move of any field voxel between fields k and k + 1, in image
 * voxels of the smallest size. */
static double field_step(const pb_field_motion *f, size_t k, double vmin)
{
    size_t n = pb_field_voxels(f);
    const float *a = f->displacements + k * n * 3, *b = a + n * 3;
    double worst = 0.0;
    for (size_t i = 0; i < n; i++) {
        double s = 0.0;
        for (int c = 0; c < 3; c++) {
            double d = (double)b[3 * i + (size_t)c] - (double)a[3 * i + (size_t)c];
            s += d * d;
        }
        worst = fmax(worst, s);
    }
    return sqrt(worst) / vmin;
}

typedef struct moments {
    double m0, m1, m2; /* time, and time times the value above the bin's lower edge and its square (relative: a
                        * belt in raw units far from 0 keeps its spread) */
} moments;

typedef struct bins {
    const double *v;  /* the fields' values */
    size_t fields;
    size_t *first;    /* bins of field interval k: first[k] .. first[k + 1] - 1 */
    moments *acc;
} bins;

/* The bin of value s: in the field interval that holds it (the upper one at
 * a field's value, the last at the top). */
static size_t bin_of(const bins *b, double s)
{
    size_t lo = pb_sample_before(b->v, b->fields, s); /* v[lo] <= s < v[lo + 1] */
    if (lo > b->fields - 2)
        lo = b->fields - 2;
    size_t n = b->first[lo + 1] - b->first[lo];
    /* Compared before the cast: a value within the signal's tolerance past the
     * top field, over a top interval far narrower than that, is 1e80 bins up. */
    double u = (s - b->v[lo]) / (b->v[lo + 1] - b->v[lo]) * (double)n;
    size_t i = !(u > 0.0) ? 0 : u < (double)n ? (size_t)u : n - 1;
    return b->first[lo] + (i < n ? i : n - 1);
}

/* The field interval bin i lies in, and its ends. */
static size_t bin_range(const bins *b, size_t i, double *lo, double *hi)
{
    size_t k = 0;
    while (b->first[k + 1] <= i)
        k++;
    double n = (double)(b->first[k + 1] - b->first[k]), w = (b->v[k + 1] - b->v[k]) / n;
    *lo = b->v[k] + w * (double)(i - b->first[k]);
    *hi = i + 1 == b->first[k + 1] ? b->v[k + 1] : *lo + w;
    return k;
}

/* Adds dt spent uniformly between values sa and sb (a point where equal). */
static void add_piece(bins *b, double sa, double sb, double dt)
{
    double lo = fmin(sa, sb), hi = fmax(sa, sb);
    if (!(dt > 0.0))
        return;
    double edge, top;
    if (hi == lo) {
        size_t i = bin_of(b, lo);
        bin_range(b, i, &edge, &top);
        moments *m = &b->acc[i];
        m->m0 += dt;
        m->m1 += dt * (lo - edge);
        m->m2 += dt * (lo - edge) * (lo - edge);
        return;
    }
    for (size_t i = bin_of(b, lo), last = bin_of(b, hi); i <= last; i++) {
        bin_range(b, i, &edge, &top);
        double p = fmax(edge, lo) - edge, q = fmin(top, hi) - edge;
        if (!(q > p))
            continue;
        double w = dt * (q - p) / (hi - lo);
        b->acc[i].m0 += w;
        b->acc[i].m1 += w * 0.5 * (p + q);
        b->acc[i].m2 += w * (p * p + p * q + q * q) / 3.0;
    }
}

/* The knot at value s in field interval k, as path_field.c's locate() makes
 * them: a field of no weight is dropped. */
static pb_path_knot knot_at(const bins *b, size_t k, double s)
{
    pb_path_knot kn = {k, k + 1, (s - b->v[k]) / (b->v[k + 1] - b->v[k])};
    kn.alpha = fmin(1.0, fmax(0.0, kn.alpha));
    if (kn.alpha == 0.0)
        kn.f1 = kn.f0;
    else if (kn.alpha == 1.0)
        kn.f0 = kn.f1;
    return kn;
}

pb_status pb_path_surrogate_knots(struct pb_context *ctx, const pb_field_motion *f, const double *iv,
                                  size_t intervals, double total, double max_move, pb_path *plan)
{
    const double *v = f->times, *vs = plan->geometry.voxel_size;
    double vmin = fmin(vs[0], fmin(vs[1], vs[2]));
    /* The signal's extremes in an interval are at its ends or at samples
     * inside: each must lie within the fields' values (the error says when). */
    for (size_t i = 0; i < intervals; i++) {
        size_t f0, f1;
        double a;
        pb_status st = pb_field_locate(ctx, f, iv[2 * i], &f0, &f1, &a);
        for (size_t j = pb_sample_before(f->signal_times, f->signal_count, iv[2 * i]);
             j < f->signal_count && f->signal_times[j] < iv[2 * i + 1] && st == PB_OK; j++)
            if (f->signal_times[j] > iv[2 * i])
                st = pb_field_locate(ctx, f, f->signal_times[j], &f0, &f1, &a);
        if (st == PB_OK)
            st = pb_field_locate(ctx, f, iv[2 * i + 1], &f0, &f1, &a);
        if (st != PB_OK)
            return st;
    }
    bins b = {v, f->count, calloc(f->count, sizeof(size_t)), NULL};
    if (!b.first)
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory planning a surrogate's frame");
    /* The values the frame visits, and bins over the field intervals they touch (an interval starting on a
     * sample takes its value there from the piece after it, not from the empty end of the one before). */
    double smin = HUGE_VAL, smax = -HUGE_VAL;
    const double *st = f->signal_times, *sv = f->signal;
    for (size_t i = 0; i < intervals; i++)
        for (size_t j = pb_sample_before(st, f->signal_count, iv[2 * i]);
             j + 1 < f->signal_count && st[j] <= iv[2 * i + 1]; j++) {
            double ta = fmax(st[j], iv[2 * i]), tb = fmin(st[j + 1], iv[2 * i + 1]);
            if (!(tb >= ta))
                continue;
            double r = sv[j + 1] - sv[j], dtj = st[j + 1] - st[j];
            double sa = sv[j] + r * (ta - st[j]) / dtj, sb = sv[j] + r * (tb - st[j]) / dtj;
            smin = fmin(smin, fmin(sa, sb));
            smax = fmax(smax, fmax(sa, sb));
        }
    size_t nb = 0;
    double moved = 0.0; /* over the intervals visited, uncapped: what the refusal below reports */
    for (size_t k = 0; k + 1 < f->count; k++) {
        b.first[k] = nb;
        if (v[k + 1] < smin || v[k] > smax) {
            nb += 1;
        } else {
            const double step = field_step(f, k, vmin);
            moved += step;
            nb += (size_t)fmin(1e5, fmax(1.0, ceil(step / max_move)));
        }
    }
    b.first[f->count - 1] = nb;
    b.fields = f->count;
    if (nb > PB_MAX_SEGMENTS / 2) {
        free(b.first);
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "the fields move a voxel up to %.3g voxels over their values: "
                        "%zu value bins at this path bound, more than one blur walks; check the units of the fields and of "
                        "the voxel sizes (micrometres read as mm?), or give a larger max_path_error",
                        moved, nb);
    }
    b.acc = calloc(nb, sizeof *b.acc);
    if (!b.acc) {
        free(b.first);
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory planning a surrogate's frame");
    }
    /* The time spent in each bin, from every piece of the signal inside the frame's intervals. */
    for (size_t i = 0; i < intervals; i++)
        for (size_t j = pb_sample_before(st, f->signal_count, iv[2 * i]);
             j + 1 < f->signal_count && st[j] <= iv[2 * i + 1]; j++) {
            double ta = fmax(st[j], iv[2 * i]), tb = fmin(st[j + 1], iv[2 * i + 1]);
            if (!(tb > ta))
                continue;
            double r = sv[j + 1] - sv[j], dtj = st[j + 1] - st[j];
            add_piece(&b, sv[j] + r * (ta - st[j]) / dtj, sv[j] + r * (tb - st[j]) / dtj, tb - ta);
        }
    size_t used = 0;
    for (size_t i = 0; i < nb; i++)
        used += b.acc[i].m0 > 0.0;
    pb_path_field *pf = calloc(1, sizeof *pf);
    plan->field = pf;
    plan->count = 2 * (used ? used : 1);
    plan->poses = calloc(plan->count, sizeof *plan->poses);
    if (pf)
        pf->knots = calloc(plan->count, sizeof *pf->knots);
    if (!pf || !plan->poses || !pf->knots) {
        free(b.first);
        free(b.acc);
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory planning a frame of %zu value bins", used);
    }
    /* A bin's segment: the uniform stretch with its time's mean and spread,
     * kept inside the bin's field interval; the step to the next bin skipped. */
    size_t j = 0;
    for (size_t i = 0; i < nb; i++) {
        const moments *m = &b.acc[i];
        if (!(m->m0 > 0.0))
            continue;
        double lo, hi, mean = m->m1 / m->m0;
        size_t k = bin_range(&b, i, &lo, &hi);
        double h = sqrt(3.0 * fmax(0.0, m->m2 / m->m0 - mean * mean)), c = fmin(hi, fmax(lo, lo + mean));
        /* Cut at a field's value, the stretch keeps its mean and gives up spread. */
        double p = c - h, q = c + h;
        if (p < v[k]) {
            p = v[k];
            q = fmin(v[k + 1], 2.0 * c - v[k]);
        }
        if (q > v[k + 1]) {
            q = v[k + 1];
            p = fmax(v[k], 2.0 * c - v[k + 1]);
        }
        pf->knots[j] = knot_at(&b, k, p);
        pf->knots[j + 1] = knot_at(&b, k, q);
        plan->poses[j].time = p; /* values, not times: only REF, never planned so, reads times */
        plan->poses[j + 1].time = q;
        plan->poses[j].weight = m->m0 / total;
        plan->poses[j + 1].skip = 1;
        j += 2;
    }
    if (!used) { /* no time at all: cannot happen for a frame with time; one still knot of no weight */
        pf->knots[0] = pf->knots[1] = knot_at(&b, 0, v[0]);
        plan->poses[0].skip = plan->poses[1].skip = 1;
    }
    free(b.first);
    free(b.acc);
    return PB_OK;
}
