/* One frame registered rigidly to a reference by Mattes mutual information
 * (Mattes et al., IEEE TMI 22(1), 2003; ITK's MattesMutualInformation): the
 * joint histogram of the frame's voxels and the reference's view at the
 * pose, the frame's intensities in box bins and the view's in cubic B-spline
 * Parzen windows, so that the measure has a gradient in the pose. Unlike the
 * least squares of register.c, which asks the frame to be a scale and offset
 * of the view, it lets each tissue keep its own intensity: frames of the
 * first minutes, whose blood and tissue stand in another ratio than a late
 * frame's, are linked to a late frame without the bias that their contrast
 * gives the least-squares pose (docs/estimate-log.md, "A link the contrast
 * does not bias"). The view is register.c's, the reference's blur at the
 * pose on the device; its derivative in the pose comes from its own
 * differences (view_jacobian.c).
 *
 * Written here rather than taken from ITK: the fit runs on the library's
 * own blur of the reference on the device, with its support weights, inside
 * the C library that has no C++ dependency; SimpleITK's Mattes metric is the
 * peer the family compares it with. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "estimate.h"
#include "motion.h"

/* Bins of each axis of the joint histogram, as SimpleITK's Mattes metric in
 * the family's peer; the outer PAD on each side hold the B-spline windows'
 * tails. */
enum { BINS = 50, PAD = 2 };
/* A fit ends where its quasi-Newton step moves the head by less than this
 * share of the level's voxel (5 um on 2.5 mm): well below the 0.1 mm the
 * family's best draws stand at (a line search gives up at a tenth of it).
 * A share, not mm, so that a grid given in other units fits alike (a fixed
 * 5 um ended fits on a grid of twice the voxel size at other steps, and
 * test_voxel_size_is_the_grid_frame's doubled track missed twice the first
 * by up to 1 % one run in ten). */
#define SHORTEST_STEP 2e-3

typedef struct mi_job {
    const float *view, *frame, *w;
    pbe_view_jacobian jac;     /* the view's derivative in the pose (gradient pass) */
    double f_lo, f_per, m_lo, m_per; /* intensity to bin: (v - lo) * per + PAD */
    double *hist;              /* a histogram a chunk (value pass) */
    double *log_ratio;         /* log p(i, k) / p_m(k), from the value pass for the gradient pass */
    size_t n;
} mi_job;

static double bspline3(double x)
{
    x = fabs(x);
    if (x < 1.0)
        return 2.0 / 3.0 - x * x + 0.5 * x * x * x;
    if (x < 2.0) {
        double t = 2.0 - x;
        return t * t * t / 6.0;
    }
    return 0.0;
}

static double bspline3_derivative(double x)
{
    double a = fabs(x), s = x < 0 ? -1.0 : 1.0;
    if (a < 1.0)
        return s * (-2.0 * a + 1.5 * a * a);
    if (a < 2.0) {
        double t = 2.0 - a;
        return -0.5 * s * t * t;
    }
    return 0.0;
}

static int fixed_bin(const mi_job *j, float f)
{
    double t = ((double)f - j->f_lo) * j->f_per + PAD;
    int b = (int)floor(t);
    return b < PAD ? PAD : b > BINS - 1 - PAD ? BINS - 1 - PAD : b;
}

/* The view's continuous bin, and whether it lies inside the range (outside
 * it is held at the edge and does not move with the pose). */
static double moving_bin(const mi_job *j, float v, int *inside)
{
    double t = ((double)v - j->m_lo) * j->m_per + PAD;
    const double lo = PAD, hi = BINS - 1 - PAD - 1e-9;
    *inside = t >= lo && t <= hi;
    return t < lo ? lo : t > hi ? hi : t;
}

/* Voxel i's weight, its view's continuous bin t (and whether inside the
 * range), and the row of its frame's bin; 0 where it has no weight. */
static int voxel_bins(const mi_job *j, size_t i, double *w, double *t, int *inside, int *row)
{
    *w = (double)j->w[i];
    if (!(*w > 0.0))
        return 0;
    *t = moving_bin(j, j->view[i], inside);
    *row = fixed_bin(j, j->frame[i]) * BINS;
    return 1;
}

static void hist_chunk(void *arg, size_t c)
{
    const mi_job *j = arg;
    const size_t begin = c * PB_CHUNK, end = begin + PB_CHUNK < j->n ? begin + PB_CHUNK : j->n;
    double *h = j->hist + c * BINS * BINS;
    memset(h, 0, sizeof(double) * BINS * BINS);
    for (size_t i = begin; i < end; i++) {
        double w, t;
        int inside, row;
        if (!voxel_bins(j, i, &w, &t, &inside, &row))
            continue;
        const int k0 = (int)floor(t) - 1;
        for (int k = k0; k < k0 + 4; k++)
            h[row + k] += w * bspline3(t - (double)k);
    }
}

static void gradient_sums(void *arg, size_t begin, size_t end, double *s)
{
    const mi_job *j = arg;
    for (size_t i = begin; i < end; i++) {
        double w, t;
        int inside, row;
        if (!voxel_bins(j, i, &w, &t, &inside, &row) || !inside)
            continue;
        const int k0 = (int)floor(t) - 1;
        double d = 0.0;
        for (int k = k0; k < k0 + 4; k++)
            d += bspline3_derivative(t - (double)k) * j->log_ratio[row + k];
        d *= w * j->m_per;
        double jac[6];
        pbe_view_jacobian_at(&j->jac, i, jac);
        for (int p = 0; p < 6; p++)
            s[p] += d * jac[p];
    }
}

/* The joint histogram of the view in level->host[0] against the frame
 * (chunks' histograms added in order), its mutual information, and
 * log p / p_m for the gradient. */
static double mutual_information(pb_pool *pool, mi_job *j, double *total, double *weight)
{
    const size_t chunks = pb_chunks(j->n);
    pb_pool_for(pool, chunks, hist_chunk, j);
    memset(total, 0, sizeof(double) * BINS * BINS);
    for (size_t c = 0; c < chunks; c++)
        for (int b = 0; b < BINS * BINS; b++)
            total[b] += j->hist[c * BINS * BINS + b];
    double W = 0.0, pf[BINS] = {0}, pm[BINS] = {0};
    *weight = 0.0;
    for (int a = 0; a < BINS; a++)
        for (int b = 0; b < BINS; b++) {
            W += total[a * BINS + b];
            pf[a] += total[a * BINS + b];
            pm[b] += total[a * BINS + b];
        }
    if (!(W > 0.0))
        return 0.0;
    double mi = 0.0;
    for (int a = 0; a < BINS; a++)
        for (int b = 0; b < BINS; b++) {
            const double h = total[a * BINS + b];
            j->log_ratio[a * BINS + b] = h > 0.0 && pm[b] > 0.0 ? log(h / pm[b]) : 0.0;
            if (h > 0.0)
                mi += h / W * log(h * W / (pf[a] * pm[b]));
        }
    *weight = W;
    return mi;
}

static void range_of(const float *v, const float *w, size_t n, double *lo, double *hi)
{
    double a = (double)INFINITY, b = -(double)INFINITY;
    for (size_t i = 0; i < n; i++)
        if (w[i] > 0.0f && isfinite(v[i])) {
            a = fmin(a, (double)v[i]);
            b = fmax(b, (double)v[i]);
        }
    *lo = a;
    *hi = b;
}

typedef struct mi_state {
    pb_context *ctx;
    pbe_level *level;
    const double *c;
    mi_job job;
    double *total, weight;
} mi_state;

/* The measure at pose: the view blurred, and the joint histogram. */
static pb_status measure(mi_state *s, const pb_pose *pose, double *mi)
{
    double times[2];
    pb_pose poses[2];
    pb_motion m;
    pbe_static_motion(pose, s->c, times, poses, &m);
    pb_status st = pbe_blur_reference(s->ctx, s->level, &m);
    if (st == PB_OK)
        *mi = mutual_information(s->level->pool, &s->job, s->total, &s->weight);
    return st;
}

/* Its gradient in the pose's six perturbations (pb_pose_perturb's) at the
 * pose the last measure() was taken at, whose view and histogram it uses. */
static pb_status gradient(mi_state *s, const pb_pose *pose, double grad[6])
{
    pbe_level *lv = s->level;
    pbe_view_jacobian_init(&s->job.jac, &lv->g, lv->host[0], pose, s->c);
    double sums[6];
    pb_pool_sums(lv->pool, lv->n, 6, gradient_sums, &s->job, sums);
    for (int p = 0; p < 6; p++)
        grad[p] = s->weight > 0.0 ? sums[p] / s->weight : 0.0;
    return PB_OK;
}

static pb_status evaluate(mi_state *s, const pb_pose *pose, double *mi, double grad[6])
{
    pb_status st = measure(s, pose, mi);
    return st == PB_OK && grad ? gradient(s, pose, grad) : st;
}

static double dot6(const double *a, const double *b)
{
    double s = 0.0;
    for (int i = 0; i < 6; i++)
        s += a[i] * b[i];
    return s;
}

/* The state of a fit: the weights (the support's blur) and the bins'
 * ranges (the frame's and the view's over the weighted voxels) at pose
 * `at`, held through the fit as register.c holds its weights. */
static pb_status begin(mi_state *s, pb_context *ctx, pbe_level *level, const float *frame, const double c[3],
                       const pb_pose *at)
{
    const size_t chunks = pb_chunks(level->n);
    *s = (mi_state){ctx, level, c, {0}, malloc(sizeof(double) * BINS * BINS), 0.0};
    s->job.hist = malloc(sizeof(double) * BINS * BINS * chunks);
    s->job.log_ratio = malloc(sizeof(double) * BINS * BINS);
    pb_status st = s->total && s->job.log_ratio && s->job.hist ? PB_OK : PB_ERR_OUT_OF_MEMORY;
    double times[2];
    pb_pose poses[2];
    pb_motion m;
    pbe_static_motion(at, c, times, poses, &m);
    if (st == PB_OK)
        st = pbe_blur_support(ctx, level, &m);
    if (st == PB_OK)
        st = pbe_blur_reference(ctx, level, &m);
    if (st != PB_OK)
        return st;
    double flo, fhi, mlo, mhi;
    range_of(frame, level->host[PBE_SUPPORT], level->n, &flo, &fhi);
    range_of(level->host[0], level->host[PBE_SUPPORT], level->n, &mlo, &mhi);
    s->job = (mi_job){level->host[0], frame, level->host[PBE_SUPPORT], {0}, flo, (BINS - 2 * PAD) / (fhi - flo),
                      mlo, (BINS - 2 * PAD) / (mhi - mlo), s->job.hist, s->job.log_ratio, level->n};
    /* a frame or view without contrast on the weights holds nothing to fit */
    return fhi > flo && mhi > mlo && isfinite(s->job.f_per) && isfinite(s->job.m_per) ? PB_OK
                                                                                      : PB_ERR_INVALID_ARGUMENT;
}

static void end(mi_state *s)
{
    free(s->total);
    free(s->job.log_ratio);
    free(s->job.hist);
}

pb_status pbe_mutual_information(pb_context *ctx, pbe_level *level, const float *frame, const double c[3],
                                 const pb_pose *pose, const pb_pose *ranges_at, double *mi, double grad[6])
{
    mi_state s;
    pb_status st = begin(&s, ctx, level, frame, c, ranges_at);
    if (st == PB_OK)
        st = evaluate(&s, pose, mi, grad);
    end(&s);
    return st;
}

/* The step in the pose's perturbation (mm, radians) from the scaled one:
 * turns times r, so that a step's length is how far it moves the head. */
static void unscale(const double u[6], double r, double xi[6])
{
    for (int i = 0; i < 6; i++)
        xi[i] = i < 3 ? u[i] : u[i] / r;
}

/* The gradient of -MI in the scaled perturbation, from MI's in pb_pose_perturb's. */
static void scaled_descent(const double g[6], double r, double gu[6])
{
    for (int i = 0; i < 6; i++)
        gu[i] = -(i < 3 ? g[i] : g[i] / r);
}

pb_status pbe_register_mi(pb_context *ctx, pbe_level *level, const float *frame, const double c[3], double r,
                          unsigned iterations, pb_pose *pose, double *mi_out)
{
    mi_state s;
    pb_status st = begin(&s, ctx, level, frame, c, pose);
    double mi = 0.0, g[6] = {0}, gu[6], H[36];
    if (st == PB_OK)
        st = evaluate(&s, pose, &mi, g);
    /* BFGS on -MI in the scaled perturbation (shifts, turns times r), each
     * step's gradient taken in the chart of the pose it starts from;
     * backtracking along each direction (Armijo) */
    const double voxel = fmax(level->g.voxel_size[0], fmax(level->g.voxel_size[1], level->g.voxel_size[2]));
    const double longest = voxel, shortest = SHORTEST_STEP * voxel;
    int fresh = 1;
    scaled_descent(g, r, gu);
    for (unsigned it = 0; it < iterations && st == PB_OK; it++) {
        double d[6], norm_g = sqrt(dot6(gu, gu));
        if (!(norm_g > 0.0) || !isfinite(norm_g))
            break;
        if (fresh) {
            memset(H, 0, sizeof H);
            for (int i = 0; i < 6; i++)
                H[i * 6 + i] = 0.25 * voxel / norm_g;
        }
        for (int i = 0; i < 6; i++) {
            d[i] = 0.0;
            for (int k = 0; k < 6; k++)
                d[i] -= H[i * 6 + k] * gu[k];
        }
        double slope = dot6(gu, d), len = sqrt(dot6(d, d));
        if (!(slope < 0.0)) { /* not a descent: start again from the gradient */
            if (fresh)
                break;
            fresh = 1;
            continue;
        }
        if (len > longest) {
            for (int i = 0; i < 6; i++)
                d[i] *= longest / len;
            slope *= longest / len;
            len = longest;
        }
        double alpha = 1.0, trial_mi = 0.0, xi[6], u[6];
        pb_pose trial;
        int taken = 0;
        for (int tries = 0; tries < 12 && st == PB_OK; tries++, alpha *= 0.3) {
            for (int i = 0; i < 6; i++)
                u[i] = alpha * d[i];
            unscale(u, r, xi);
            if (!pb_all_finite(xi, 6))
                break;
            pb_pose_perturb(pose, xi, &trial);
            st = evaluate(&s, &trial, &trial_mi, NULL);
            if (st == PB_OK && -trial_mi <= -mi + 1e-4 * alpha * slope) {
                taken = 1;
                break;
            }
            if (alpha * len < 0.1 * shortest)
                break;
        }
        if (st != PB_OK)
            break;
        if (!taken) {
            if (fresh)
                break;
            fresh = 1;
            continue;
        }
        double g_new[6], gu_new[6];
        /* the gradient at the step's end, whose view and histogram the line search left */
        st = gradient(&s, &trial, g_new);
        if (st != PB_OK)
            break;
        scaled_descent(g_new, r, gu_new);
        double y[6], ys, yy;
        for (int i = 0; i < 6; i++)
            y[i] = gu_new[i] - gu[i];
        ys = dot6(y, u);
        yy = dot6(y, y);
        if (ys > 1e-12 * sqrt(yy * dot6(u, u))) {
            if (fresh) { /* the first curvature sets the scale (Nocedal and Wright, 6.20) */
                memset(H, 0, sizeof H);
                for (int i = 0; i < 6; i++)
                    H[i * 6 + i] = ys / yy;
            }
            double Hy[6], yHy = 0.0;
            for (int i = 0; i < 6; i++) {
                Hy[i] = 0.0;
                for (int k = 0; k < 6; k++)
                    Hy[i] += H[i * 6 + k] * y[k];
                yHy += y[i] * Hy[i];
            }
            const double rho = 1.0 / ys;
            for (int i = 0; i < 6; i++)
                for (int k = 0; k < 6; k++)
                    H[i * 6 + k] += -rho * (Hy[i] * u[k] + u[i] * Hy[k]) + (rho * rho * yHy + rho) * u[i] * u[k];
            fresh = 0;
        }
        *pose = trial;
        mi = trial_mi;
        memcpy(gu, gu_new, sizeof gu);
        /* a short quasi-Newton step (not one the line search cut) starts the
         * steps again from the gradient, a quarter voxel cut back by the line
         * search: trilinear views kink the measure at every voxel crossing,
         * and a curvature met at a kink shortens the steps long before the
         * top. The fit ends where a gradient step finds no rise or at the
         * iteration bound (a gradient step, a quarter voxel, is never this
         * short) */
        if (len < shortest)
            fresh = 1;
    }
    if (mi_out)
        *mi_out = mi;
    end(&s);
    return st;
}
