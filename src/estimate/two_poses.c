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
    double inv[NLIN * NLIN];
    for (int q = 0; q < NLIN; q++) {
        double G[NLIN * NLIN], e[NLIN] = {0.0, 0.0, 0.0};
        memcpy(G, s->gram, sizeof G);
        e[q] = 1.0;
        if (!pbe_solve(G, e, NLIN, &inv[q * NLIN]))
            return 0;
    }
    for (int p = 0; p < NPOSE; p++)
        for (int q = 0; q < NPOSE; q++) {
            double t = 0.0;
            for (int u = 0; u < NLIN; u++)
                for (int v = 0; v < NLIN; v++)
                    t += cross[p * NLIN + u] * inv[u * NLIN + v] * cross[q * NLIN + v];
            A[p * NPOSE + q] -= t;
        }
    return 1;
}

pb_status pbe_two_poses(pb_context *ctx, pbe_level *level, const float *frame, const double c[3], pb_pose *a,
                        pb_pose *b, unsigned iterations, double *share_a, double *sse)
{
    const pb_pose a0 = *a, b0 = *b;
    float *views = pbe_level_views(level, 2);
    if (!views)
        return PB_ERR_OUT_OF_MEMORY;
    /* the best state's views, A's then B's, kept beside the trial's (views) */
    float *va = malloc(sizeof(float) * level->n * 2);
    if (!va)
        return PB_ERR_OUT_OF_MEMORY;
    float *vb = va + level->n;
    two_state best = {*a, *b, {0.0}, (double)INFINITY, {0.0}}, trial = best;
    int usable = 0;
    double lambda = 1e-3;
    *share_a = -1.0;
    *sse = (double)INFINITY;
    pb_status st = evaluate(ctx, level, frame, c, &best, &usable);
    if (st == PB_OK)
        memcpy(va, views, sizeof(float) * level->n * 2);
    for (unsigned it = 0; it < iterations && st == PB_OK && usable; it++) {
        double A[NPOSE * NPOSE], grad[NPOSE], step[NPOSE];
        if (!reduced_normal(level->pool, &level->g, frame, level->host[PBE_SUPPORT], va, vb, c, &best, A, grad))
            break;
        int improved = 0;
        while (!improved && lambda <= 1e6) {
            double M[NPOSE * NPOSE], rhs[NPOSE];
            memcpy(M, A, sizeof M);
            for (int p = 0; p < NPOSE; p++) {
                M[p * NPOSE + p] *= 1.0 + lambda;
                rhs[p] = -grad[p];
            }
            if (!pbe_solve(M, rhs, NPOSE, step) || !pb_all_finite(step, NPOSE)) {
                lambda *= 8.0;
                continue;
            }
            pb_pose_perturb(&best.a, step, &trial.a);
            pb_pose_perturb(&best.b, step + 6, &trial.b);
            int ok = 0;
            if (!pbe_within_grid(&level->g, c, &a0, &trial.a) || !pbe_within_grid(&level->g, c, &b0, &trial.b)) {
                lambda *= 8.0;
                continue;
            }
            if ((st = evaluate(ctx, level, frame, c, &trial, &ok)) != PB_OK)
                break;
            if (ok && trial.sse < best.sse) {
                const double gain = best.sse - trial.sse;
                best = trial;
                memcpy(va, views, sizeof(float) * level->n * 2);
                lambda = fmax(lambda / 3.0, 1e-7);
                improved = 1;
                if (gain < 1e-7 * best.sse)
                    it = iterations;
            } else
                lambda *= 8.0;
        }
        if (!improved)
            break;
    }
    if (st == PB_OK && usable) {
        *a = best.a;
        *b = best.b;
        *share_a = best.lin[0] / (best.lin[0] + best.lin[1]);
        *sse = best.sse;
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
