/* A frame as a dwell along a line whose ends are fitted:
 * f ~ sum_i u_i V(P_i) + o, P_i = A + (B - A) i / (m - 1), u_i >= 0, A and B
 * fitted. Two poses held in turn (two_poses.c) are the dwell at the ends
 * only; a jerk that ramps over much of its frame dwells between them, and
 * fitted as two poses its transit was taken in as poses off the line the
 * head held (issue 47: a jerk of 6-7 s, the frame 0.62-0.73 -> 1.33-1.45 mm
 * as two poses). A time average tells where and for how long, not in what
 * order, so a line and the dwell along it are what a frame that moved one
 * way determines.
 *
 * Levenberg-Marquardt on the twelve numbers of A and B (pb_pose_perturb's),
 * the dwell and the offset solved at every trial (pbe_dwell_at, non-negative
 * least squares) and the free ones eliminated from the step (their Schur
 * complement, as two_poses.c). A perturbation xi of A moves point i by about
 * (1 - t_i) xi (the points interpolate A and B: exact for the shifts, to
 * first order in the angle between A and B for the turns), so A's Jacobian at
 * a voxel is sum_i u_i (1 - t_i) J_i, each J_i its view's own
 * (view_jacobian.c). Where the dwell leaves an end unheld, the line is
 * trimmed to the points held and fitted again: beyond its last point held a
 * line's end is free, and the step's matrix singular in it. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"
#include "estimate.h"
#include "motion.h"

enum { NPOSE = 12, NLIN_MOST = PBE_LINE_MOST + 1 };
enum { POSE_SUMS_MOST = NPOSE * (NPOSE + 1) / 2 + NPOSE * NLIN_MOST + NPOSE };
_Static_assert((int)POSE_SUMS_MOST <= (int)PB_MOST_SUMS, "the line's normal equations have more sums than a pass takes");
_Static_assert((int)PBE_LINE_MOST <= (int)PBE_DWELL_MOST, "a line of more points than a dwell fits");

typedef struct line_state {
    pb_pose a, b;
    double u[NLIN_MOST], sse, gram[NLIN_MOST * NLIN_MOST];
} line_state;

typedef struct line_job {
    const float *f, *w;
    const float *views;
    const pbe_view_jacobian *j;
    size_t m, nfree;
    size_t free[NLIN_MOST]; /* the views eliminated (held, u > 0); the offset after them */
    double u[NLIN_MOST], t[PBE_LINE_MOST];
    size_t n;
} line_job;

static void line_sums(void *arg, size_t begin, size_t end, double *s)
{
    const line_job *j = arg;
    const size_t nl = j->nfree + 1;
    for (size_t v = begin; v < end; v++) {
        const double w = (double)j->w[v];
        if (!(w > 0.0))
            continue;
        double J[NPOSE] = {0.0}, L[NLIN_MOST], model = j->u[j->m];
        for (size_t i = 0; i < j->m; i++) {
            if (!(j->u[i] > 0.0))
                continue;
            double Ji[6];
            pbe_view_jacobian_at(&j->j[i], v, Ji);
            const double ua = j->u[i] * (1.0 - j->t[i]), ub = j->u[i] * j->t[i];
            for (int p = 0; p < 6; p++) {
                J[p] += ua * Ji[p];
                J[p + 6] += ub * Ji[p];
            }
            model += j->u[i] * (double)j->views[i * j->n + v];
        }
        for (size_t q = 0; q < j->nfree; q++)
            L[q] = (double)j->views[j->free[q] * j->n + v];
        L[j->nfree] = 1.0;
        const double r = model - (double)j->f[v];
        double *up = s;
        for (int p = 0; p < NPOSE; p++) {
            const double wp = w * J[p];
            for (int q = p; q < NPOSE; q++)
                *up++ += wp * J[q];
            for (size_t q = 0; q < nl; q++)
                *up++ += wp * L[q];
            *up++ += wp * r;
        }
    }
}

static void line_poses(const line_state *s, size_t m, pb_pose *p)
{
    memset(p, 0, PBE_LINE_MOST * sizeof *p);
    for (size_t i = 0; i < m; i++) {
        pb_pose_interpolate(&s->a, &s->b, (double)i / (double)(m - 1), &p[i]);
        pb_pose_normalized(&p[i], &p[i]);
    }
}

/* The dwell and offset at the state's line, its residual and the normal
 * matrix; the views stay in pbe_level_views(level, m). usable: some dwell
 * and a finite residual. */
static pb_status evaluate(pb_context *ctx, pbe_level *level, const float *frame, const double c[3], size_t m,
                          line_state *s, int *usable)
{
    pb_pose p[PBE_LINE_MOST];
    line_poses(s, m, p);
    pb_status st = pbe_dwell_at(ctx, level, frame, c, p, m, s->u, &s->sse, s->gram);
    double total = 0.0;
    for (size_t i = 0; i < m; i++)
        total += fmax(s->u[i], 0.0);
    *usable = st == PB_OK && total > 0.0 && isfinite(s->sse);
    return st;
}

/* The twelve numbers' normal equations at state s, the free linear
 * unknowns eliminated: A = Jp'WJp - Jp'WL (L'WL)^-1 L'WJp, g = Jp'W r. */
static int reduced_normal(pb_pool *pool, const pb_geometry *g, const float *frame, const float *w,
                          const float *views, size_t m, const double c[3], const line_state *s, double *A,
                          double *grad)
{
    pb_pose p[PBE_LINE_MOST];
    pbe_view_jacobian J[PBE_LINE_MOST];
    line_poses(s, m, p);
    const size_t n = g->dims[0] * g->dims[1] * g->dims[2];
    line_job job = {.f = frame, .w = w, .views = views, .j = J, .m = m, .n = n};
    for (size_t i = 0; i < m; i++) {
        pbe_view_jacobian_init(&J[i], g, views + i * n, &p[i], c);
        job.t[i] = (double)i / (double)(m - 1);
        job.u[i] = s->u[i];
        if (s->u[i] > 0.0)
            job.free[job.nfree++] = i;
    }
    job.u[m] = s->u[m];
    const size_t nl = job.nfree + 1, k = m + 1, sums_n = NPOSE * (NPOSE + 1) / 2 + NPOSE * nl + NPOSE;
    double sums[POSE_SUMS_MOST], cross[NPOSE * NLIN_MOST];
    pb_pool_sums(pool, n, sums_n, line_sums, &job, sums);
    const double *up = sums;
    for (int a = 0; a < NPOSE; a++) {
        for (int b = a; b < NPOSE; b++)
            A[a * NPOSE + b] = A[b * NPOSE + a] = *up++;
        for (size_t q = 0; q < nl; q++)
            cross[a * nl + q] = *up++;
        grad[a] = *up++;
    }
    /* the free unknowns' block of the dwell's normal matrix (the offset's last) */
    size_t idx[NLIN_MOST];
    memcpy(idx, job.free, job.nfree * sizeof *idx);
    idx[job.nfree] = m;
    double G[NLIN_MOST * NLIN_MOST];
    for (size_t x = 0; x < nl; x++)
        for (size_t y = 0; y < nl; y++)
            G[x * nl + y] = s->gram[idx[x] * k + idx[y]];
    return pbe_pair_eliminate(A, cross, G, nl);
}

/* the line's fit so far (best, its views in keep) and its trials */
typedef struct line_fit {
    pb_context *ctx;
    pbe_level *level;
    const float *frame, *views;
    const double *c;
    size_t m;
    float *keep;
    line_state best, trial;
} line_fit;

static int line_normal(void *user, double *A, double *grad)
{
    line_fit *f = user;
    return reduced_normal(f->level->pool, &f->level->g, f->frame, f->level->host[PBE_SUPPORT], f->keep, f->m, f->c,
                          &f->best, A, grad);
}

static pb_status line_trial(void *user, const pb_pose *a, const pb_pose *b, double *gain, double *sse)
{
    line_fit *f = user;
    int ok = 0;
    f->trial.a = *a;
    f->trial.b = *b;
    pb_status st = evaluate(f->ctx, f->level, f->frame, f->c, f->m, &f->trial, &ok);
    if (st == PB_OK && ok && f->trial.sse < f->best.sse) {
        *gain = f->best.sse - f->trial.sse;
        f->best = f->trial;
        *sse = f->best.sse;
        memcpy(f->keep, f->views, sizeof(float) * f->level->n * f->m);
    }
    return st;
}

/* A point's dwell below this share of the line's is not held: the least
 * squares spread the frame's noise over points beside those held. */
#define HELD_SHARE 0.02

/* The line trimmed to its first and last points held: 1 where it was
 * shortened (s replaced), 0 where both ends hold dwell. Two poses fit as
 * well at points i and j of a longer line as at its ends, so without the
 * trim a line's dwell says little of where its ends lie. */
static int trimmed(line_state *s, size_t m)
{
    double total = 0.0;
    for (size_t i = 0; i < m; i++)
        total += fmax(s->u[i], 0.0);
    size_t lo = 0, hi = m - 1;
    while (lo < hi && !(s->u[lo] > HELD_SHARE * total))
        lo++;
    while (hi > lo && !(s->u[hi] > HELD_SHARE * total))
        hi--;
    if (lo == hi) /* one point held: keep a line about it, a point's width either side */
        lo = lo > 0 ? lo - 1 : lo, hi = hi + 1 < m ? hi + 1 : hi;
    if (lo == 0 && hi == m - 1)
        return 0;
    pb_pose a, b;
    pb_pose_interpolate(&s->a, &s->b, (double)lo / (double)(m - 1), &a);
    pb_pose_interpolate(&s->a, &s->b, (double)hi / (double)(m - 1), &b);
    pb_pose_normalized(&a, &s->a);
    pb_pose_normalized(&b, &s->b);
    return 1;
}

pb_status pbe_line_dwell(pb_context *ctx, pbe_level *level, const float *frame, const double c[3], pb_pose *a,
                         pb_pose *b, size_t m, unsigned iterations, double *u, double *sse)
{
    *sse = (double)INFINITY;
    if (m < 2 || m > PBE_LINE_MOST)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "a line of %zu points (2 to %d)", m, (int)PBE_LINE_MOST);
    float *views = pbe_level_views(level, m), *keep = malloc(sizeof(float) * level->n * m);
    if (!views || !keep) {
        free(keep);
        return PB_ERR_OUT_OF_MEMORY;
    }
    line_fit f = {.ctx = ctx, .level = level, .frame = frame, .views = views, .c = c, .m = m, .keep = keep,
                  .best = {.a = *a, .b = *b, .sse = (double)INFINITY}};
    f.trial = f.best;
    int usable = 0;
    pb_status st = evaluate(ctx, level, frame, c, m, &f.best, &usable);
    /* fits, each from the last trimmed to its points held: a trim moves the
     * points, so each is a new dwell, kept only where it fits no worse */
    for (int round = 0; round < 3 && st == PB_OK && usable; round++) {
        memcpy(keep, views, sizeof(float) * level->n * m);
        st = pbe_pair_descend(&(pbe_pair_steps){line_normal, line_trial, &f, &level->g, c, *a, *b, f.best.a, f.best.b},
                              iterations);
        line_state shorter = f.best;
        if (st != PB_OK || !trimmed(&shorter, m))
            break;
        int ok = 0;
        if ((st = evaluate(ctx, level, frame, c, m, &shorter, &ok)) != PB_OK || !ok || !(shorter.sse <= f.best.sse))
            break;
        f.best = shorter;
    }
    if (st == PB_OK && usable && isfinite(f.best.sse)) {
        *a = f.best.a;
        *b = f.best.b;
        memcpy(u, f.best.u, (m + 1) * sizeof *u);
        *sse = f.best.sse;
    }
    free(keep);
    return st;
}
