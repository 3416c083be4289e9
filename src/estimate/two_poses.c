/* A frame as two poses held in turn: f ~ a V(A) + b V(B) + o, a, b >= 0,
 * both poses fitted. Pass 3's paths run between poses the neighbours give
 * (their registered poses, or a pose taken as far again), and where the
 * neighbours move themselves (a jerk inside a slow nod, a jerk in the
 * series' last frame) no such path reaches the poses the head held: the
 * frame shows motion that no path follows. A time average cannot tell the
 * order of what it holds, only where and for how long, so two poses and
 * their shares are what the frame itself determines.
 *
 * Levenberg-Marquardt on the twelve pose numbers (pb_pose_perturb's for
 * each), a, b and o solved at every trial (pbe_dwell_at: a dwell at the two
 * poses, non-negative least squares) and eliminated from the step (their Schur complement, as
 * register.c's information), each voxel weighed by level->host[PBE_SUPPORT]
 * as the caller set it, held through the fit. The Jacobian of each pose is
 * its view's own (view_jacobian.c). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "estimate.h"
#include "motion.h"

enum { NPOSE = 12, NLIN = 3 };
/* the pose block's upper triangle, its cross terms with the linear
 * unknowns, and the pose gradient */
enum { POSE_SUMS = NPOSE * (NPOSE + 1) / 2 + NPOSE * NLIN + NPOSE };
_Static_assert((int)POSE_SUMS <= (int)PB_MOST_SUMS, "the two poses' normal equations have more sums than a pass takes");

typedef struct two_job {
    const float *va, *vb, *f, *w;
    const pbe_view_jacobian *ja, *jb;
    double lin[NLIN];
} two_job;

static void pose_sums(void *arg, size_t begin, size_t end, double *s)
{
    const two_job *j = arg;
    for (size_t i = begin; i < end; i++) {
        const double w = (double)j->w[i];
        if (!(w > 0.0))
            continue;
        double J[NPOSE];
        const double L[NLIN] = {(double)j->va[i], (double)j->vb[i], 1.0};
        pbe_view_jacobian_at(j->ja, i, J);
        pbe_view_jacobian_at(j->jb, i, J + 6);
        for (int p = 0; p < 6; p++) {
            J[p] *= j->lin[0];
            J[p + 6] *= j->lin[1];
        }
        const double r = j->lin[0] * L[0] + j->lin[1] * L[1] + j->lin[2] - (double)j->f[i];
        double *up = s;
        for (int p = 0; p < NPOSE; p++) {
            const double wp = w * J[p];
            for (int q = p; q < NPOSE; q++)
                *up++ += wp * J[q];
            for (int q = 0; q < NLIN; q++)
                *up++ += wp * L[q];
            *up++ += wp * r;
        }
    }
}

/* The linear unknowns at A and B (pbe_dwell_at: a dwell at two poses, with
 * the offset), the weighted residual and the normal matrix; the views stay
 * in pbe_level_views(level, 2). usable: both shares above zero. */
typedef struct two_state {
    pb_pose a, b;
    double lin[NLIN], sse, gram[NLIN * NLIN];
} two_state;

static pb_status evaluate(pb_context *ctx, pbe_level *level, const float *frame, const double c[3], two_state *s,
                          int *usable)
{
    const pb_pose poses[2] = {s->a, s->b};
    pb_status st = pbe_dwell_at(ctx, level, frame, c, poses, 2, s->lin, &s->sse, s->gram);
    *usable = st == PB_OK && s->lin[0] > 0.0 && s->lin[1] > 0.0;
    return st;
}

/* The pose block's normal equations at state s with the linear unknowns
 * eliminated: A = Jp'WJp - Jp'WL (L'WL)^-1 L'WJp, g = Jp'W r. */
static int reduced_normal(pb_pool *pool, const pb_geometry *g, const float *frame, const float *w, const float *va,
                          const float *vb, const double c[3], const two_state *s, double *A, double *grad)
{
    pbe_view_jacobian ja, jb;
    pbe_view_jacobian_init(&ja, g, va, &s->a, c);
    pbe_view_jacobian_init(&jb, g, vb, &s->b, c);
    two_job job = {va, vb, frame, w, &ja, &jb, {s->lin[0], s->lin[1], s->lin[2]}};
    double sums[POSE_SUMS], cross[NPOSE * NLIN];
    const size_t n = g->dims[0] * g->dims[1] * g->dims[2];
    pb_pool_sums(pool, n, POSE_SUMS, pose_sums, &job, sums);
    const double *up = sums;
    for (int p = 0; p < NPOSE; p++) {
        for (int q = p; q < NPOSE; q++)
            A[p * NPOSE + q] = A[q * NPOSE + p] = *up++;
        for (int q = 0; q < NLIN; q++)
            cross[p * NLIN + q] = *up++;
        grad[p] = *up++;
    }
    return pbe_pair_eliminate(A, cross, s->gram, NLIN);
}

int pbe_pair_eliminate(double *A, const double *cross, const double *gram, size_t nl)
{
    double inv[PBE_PAIR_LINEAR_MOST * PBE_PAIR_LINEAR_MOST];
    if (nl > PBE_PAIR_LINEAR_MOST)
        return 0;
    for (size_t q = 0; q < nl; q++) {
        double G[PBE_PAIR_LINEAR_MOST * PBE_PAIR_LINEAR_MOST], e[PBE_PAIR_LINEAR_MOST] = {0.0};
        memcpy(G, gram, nl * nl * sizeof *G);
        e[q] = 1.0;
        if (!pbe_solve(G, e, (int)nl, &inv[q * nl]))
            return 0;
    }
    for (int p = 0; p < NPOSE; p++)
        for (int q = 0; q < NPOSE; q++) {
            double t = 0.0;
            for (size_t u = 0; u < nl; u++)
                for (size_t v = 0; v < nl; v++)
                    t += cross[p * nl + u] * inv[u * nl + v] * cross[q * nl + v];
            A[p * NPOSE + q] -= t;
        }
    return 1;
}

pb_status pbe_pair_descend(pbe_pair_steps *f, unsigned iterations)
{
    double lambda = 1e-3;
    pb_status st = PB_OK;
    for (unsigned it = 0; it < iterations && st == PB_OK; it++) {
        double A[NPOSE * NPOSE], grad[NPOSE], step[NPOSE];
        if (!f->normal(f->user, A, grad))
            break;
        int improved = 0;
        while (!improved && lambda <= 1e6) {
            double M[NPOSE * NPOSE], rhs[NPOSE], gain = 0.0, sse = 0.0;
            memcpy(M, A, sizeof M);
            for (int p = 0; p < NPOSE; p++) {
                M[p * NPOSE + p] *= 1.0 + lambda;
                rhs[p] = -grad[p];
            }
            if (!pbe_solve(M, rhs, NPOSE, step) || !pb_all_finite(step, NPOSE)) {
                lambda *= 8.0;
                continue;
            }
            pb_pose a, b;
            pb_pose_perturb(&f->a, step, &a);
            pb_pose_perturb(&f->b, step + 6, &b);
            if (pbe_within_grid(f->g, f->c, &f->a0, &a) && pbe_within_grid(f->g, f->c, &f->b0, &b) &&
                (st = f->trial(f->user, &a, &b, &gain, &sse)) != PB_OK)
                break;
            if (gain > 0.0) {
                f->a = a;
                f->b = b;
                lambda = fmax(lambda / 3.0, 1e-7);
                improved = 1;
                if (gain < 1e-7 * sse)
                    it = iterations;
            } else
                lambda *= 8.0;
        }
        if (!improved)
            break;
    }
    return st;
}

/* pbe_two_poses' fit so far (best, its views in va and vb) and its trials */
typedef struct two_fit {
    pb_context *ctx;
    pbe_level *level;
    const float *frame, *views;
    const double *c;
    float *va, *vb;
    two_state best, trial;
} two_fit;

static int two_normal(void *user, double *A, double *grad)
{
    two_fit *f = user;
    return reduced_normal(f->level->pool, &f->level->g, f->frame, f->level->host[PBE_SUPPORT], f->va, f->vb, f->c,
                          &f->best, A, grad);
}

static pb_status two_trial(void *user, const pb_pose *a, const pb_pose *b, double *gain, double *sse)
{
    two_fit *f = user;
    int ok = 0;
    f->trial.a = *a;
    f->trial.b = *b;
    pb_status st = evaluate(f->ctx, f->level, f->frame, f->c, &f->trial, &ok);
    if (st == PB_OK && ok && f->trial.sse < f->best.sse) {
        *gain = f->best.sse - f->trial.sse;
        f->best = f->trial;
        *sse = f->best.sse;
        memcpy(f->va, f->views, sizeof(float) * f->level->n * 2);
    }
    return st;
}

pb_status pbe_two_poses(pb_context *ctx, pbe_level *level, const float *frame, const double c[3], pb_pose *a,
                        pb_pose *b, unsigned iterations, double *share_a, double *sse)
{
    float *views = pbe_level_views(level, 2);
    if (!views)
        return PB_ERR_OUT_OF_MEMORY;
    /* the best state's views, A's then B's, kept beside the trial's (views) */
    float *va = malloc(sizeof(float) * level->n * 2);
    if (!va)
        return PB_ERR_OUT_OF_MEMORY;
    two_fit f = {ctx, level, frame, views, c, va, va + level->n, {*a, *b, {0.0}, (double)INFINITY, {0.0}},
                 {*a, *b, {0.0}, (double)INFINITY, {0.0}}};
    int usable = 0;
    *share_a = -1.0;
    *sse = (double)INFINITY;
    pb_status st = evaluate(ctx, level, frame, c, &f.best, &usable);
    if (st == PB_OK)
        memcpy(va, views, sizeof(float) * level->n * 2);
    if (st == PB_OK && usable)
        st = pbe_pair_descend(&(pbe_pair_steps){two_normal, two_trial, &f, &level->g, c, *a, *b, *a, *b}, iterations);
    if (st == PB_OK && usable) {
        *a = f.best.a;
        *b = f.best.b;
        *share_a = f.best.lin[0] / (f.best.lin[0] + f.best.lin[1]);
        *sse = f.best.sse;
    }
    free(va);
    return st;
}

pb_status pbe_two_poses_held(pb_context *ctx, pbe_level *level, const float *frame, const double c[3],
                             const pb_pose *a, const pb_pose *b, double within, double *held)
{
    enum { POINTS = 9 }; /* a at the third, b at the seventh: a quarter of their distance apart */
    _Static_assert((int)POINTS <= (int)PBE_DWELL_MOST, "a dwell of more poses than it has sums for");
    pb_pose s, t;
    double u[POINTS + 1], sse, total = 0.0, near = 0.0;
    pb_pose_interpolate(a, b, -0.5, &s);
    pb_pose_interpolate(a, b, 1.5, &t);
    pb_pose_normalized(&s, &s);
    pb_pose_normalized(&t, &t);
    *held = 0.0;
    pb_status st = pbe_dwell(ctx, level, frame, c, &s, &t, POINTS, u, &sse);
    for (int i = 0; i < POINTS && st == PB_OK; i++) {
        const double at = -0.5 + 0.25 * i, w = fmax(u[i], 0.0);
        total += w;
        if (fmin(fabs(at), fabs(at - 1.0)) <= fmin(within, 0.25) + 1e-9)
            near += w;
    }
    if (st == PB_OK && total > 0)
        *held = near / total;
    return st;
}
