/* Key poses fitted to the track by least squares (docs/methods.md, "Where the
 * merged chords' error comes from").
 *
 * AB and RM walk chords between key poses. A chord through two of the track's
 * samples leaves the track between them on one side, so every voxel's time
 * average moves by up to the path bound, and the blur of a sharp edge is
 * first-order sensitive to that shift. A continuous polyline fitted to the
 * samples by least squares over the hat functions of its knots has a residual
 * of zero time mean, and that first-order error cancels
 * (bench/results/2026-11-29_cpu2_ls-knots). Here the frame's key poses (its
 * two ends and the samples inside) are replaced by such a polyline's knots:
 *
 *  - the samples are cut into runs, from each knot the longest run (doubling,
 *    then a binary search, as path_split.c's merge_segments) whose
 *    least-squares line keeps each of the grid's 8 corner voxel centres (their
 *    positions are affine in the voxel, so the corners bound the grid) within
 *    the bound E of every sample (beyond the tracker's noise, below);
 *  - one continuous polyline is fitted to the whole track at once (its
 *    samples and their interpolation, least squares over time), its knots
 *    at the runs' ends (a tridiagonal system), translations linear in
 *    time and the rotation through its rotation vector relative to the
 *    frame's middle sample (continuous to 360 degrees either side of it);
 *    a run whose piece of that polyline fails the same test is cut at its
 *    middle sample and the whole fitted again, for at most PB_FIT_ROUNDS rounds (the last round fits without testing,
 *    so the knots kept are those fitted);
 *  - the knots become the plan's key poses, and pb_path_split cuts each
 *    interval between them to the bound (path_plan.c says why it does not
 *    merge them again).
 *
 * Tracker noise (tracker_noise below). A log's samples scatter about the
 * motion by the tracker's noise, white from sample to sample, and what is
 * noise is not motion: a chord need not follow it. Each corner's noise is
 * measured from the frame's samples (a frame of fewer than 64: from the 512
 * of the log about it, window_noise), where it passes a test of whiteness (a
 * tremor is a motion, however fast); a run's line then holds where
 *  - each corner's residual has a mean square within (0.35 E)^2, as a
 *    noise-free run's (below), plus the noise's: what the run drops of each
 *    voxel's spread of positions beyond the noise bounds the blur's
 *    second-order error. Plus the scatter of that mean square less the
 *    noise's as measured, which a run's noise alone would otherwise exceed
 *    now and then wherever the noise is several times 0.35 E: for white
 *    Gaussian noise its variance is 2 len + (17/8) len^2 / m times the sum
 *    of the squared eigenvalues of the noise's covariance, the second term
 *    the measure's own error over its m lag-1 products, less its covariance
 *    with the run's (whose samples are among those that measured it);
 *    without it a still head's whole frame failed now and then (a measure's
 *    8 % scatter at 323 samples against the mean square's 4.5 %: fresh still
 *    5023 took 9 segments against 1, 1.21 % RMS from the true motion's
 *    blur where one line stands at 0.50;
 *    bench/results/2026-12-02_cpu2_measure-scatter). Of that scatter 3
 *    standard deviations on a run of 64 samples or more, 2 on a shorter one (a still run is tested at many
 *    nested lengths, and 2 at every length cut 3 of 30 still heads, up to
 *    11 segments; 3 at every length let the nods' bends through, 60 fresh
 *    nods at 0.48 % RMS median against 0.40). The runs are then merged
 *    where their union holds (below). Before the scatter, CI drew a noisy
 *    drift at 84 segments against the true motion's 16, and a still head
 *    took 24 against 1 (bench/results/2026-11-29_cpu2_noise-scatter). A
 *    noisy run once kept E^2 where a noise-free one keeps (0.35 E)^2, so a
 *    log with a trace of noise let three times the bias through: on fresh
 *    draws 60 nods stood at 0.476 % RMS (median) from the true motion's
 *    blur, now 0.403, 30 drifts at 0.253, now 0.169, the medians of 30
 *    stills and 30 seizures the same (bench/results/2026-12-02_cpu2_noisy-share);
 *  - the sum of the residual's lag-1 products is within (0.35 E)^2 (len - 1)
 *    plus as many standard deviations of its scatter, the square root of
 *    (len - 1) times the same sum of squared eigenvalues: white noise's
 *    products average zero, so it measures the residual's smooth part (a
 *    nod's arc about its line) without the noise's mean square or its
 *    measure's error. With the measure's error in the mean square alone
 *    the nods' arcs went through (60 nods, 20 better and 40 worse); with
 *    this test as well, 260 fresh noisy nods 165 better and 93 worse (200 of
 *    them 0.405 -> 0.375 % RMS median), 30 drifts 14 and 15, two of 60 still
 *    heads no longer cut (14 and 9 segments -> 1), and issue 46's 20 Hz log
 *    with 0.05 mm of noise 6.2 segments a frame where it took 8.7;
 *  - the mean residual of every k consecutive samples, k = 1, 2, 4, ... up to
 *    the run, is within E + 3 s / sqrt(k), s the corner's noise (the 3D
 *    norm's RMS): the first-order error, where a jerk's few samples leave
 *    the line at the short scales and a slow drift at the long one.
 * A track without noise (or whose noise fails the test) has s = 0: every
 * sample within E of its piece, and their RMS residual within 0.35 E. The
 * blur of a sharp edge is first-order sensitive to that RMS, not second: the
 * interpolated image bends at every voxel centre, and a voxel whose chord
 * passes near one averages |residual| there. A run that keeps within E but
 * wanders about its line all along (one chord for a slow drift of a third of
 * a voxel) stood at up to 0.64 % RMS of the dense reference; at 0.35 E the
 * worst of 200 such drifts at 0.12 % (docs/methods.md, "Where the merged
 * chords' error comes from"). A noisy run's floor is its noise's own mean,
 * which more cuts do not lower (they followed the noise, at 4x the segments):
 * the noise's scatter allowance above keeps its runs long. The bound, the
 * default's or the caller's, is on the motion, and the noise is not motion;
 * the logged polyline itself, noise and all, is PB_PATH_TRACKED's. pb_path_fit's sigma_mm, the tracker's
 * noise per axis where a caller knows it, is a floor under the measured one. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"
#include "path.h"

/* The most rounds of cutting the pieces that fail and fitting again: each
 * round halves them, so a run of 2^32 samples is down to single intervals
 * (which are not tested) within this many. */
enum { PB_FIT_ROUNDS = 32 };
/* A run of at least PB_FIT_SCATTER_RUN noisy samples may have a mean square
 * (and a sum of lag-1 products) up to PB_FIT_SCATTER_Z standard deviations
 * of the noise's scatter above what the bound allows, a shorter one
 * PB_FIT_SCATTER_Z_SHORT (the header says why). */
enum { PB_FIT_SCATTER_RUN = 64 };
/* The fewest samples whose chord offsets measure the tracker's noise, and the
 * samples of the log about a shorter frame that measure it instead: over
 * fewer, white noise's own scatter fails the whiteness test now and then (of
 * 400 short frames of still noisy logs, 6 on 128 samples, 2 on 256, none on
 * 512; bench/results/2026-11-30_cpu2_short-frames). */
enum { PB_NOISE_SAMPLES = 64, PB_NOISE_WINDOW = 512 };
static const double PB_FIT_SCATTER_Z = 3.0, PB_FIT_SCATTER_Z_SHORT = 2.0;
/* A run's mean square less the noise's as measured over m lag-1 products
 * of the chord offsets the run is among: per squared eigenvalue of the
 * noise's covariance, its variance is 2 len + (17/8) len^2 / m for white
 * Gaussian noise (the header's first test). */
static const double PB_NOISE_MEASURE_VAR = 17.0 / 8.0;
/* A noise-free run's residual may have an RMS of at most this share of E
 * (the header says why). */
static const double PB_FIT_RMS_SHARE = 0.35;

typedef struct fit_ctx {
    size_t n;
    const double *t;      /* key pose times, from the first */
    const double *o;      /* 24 per key pose: the 8 corners in object space, mm */
    const double *st, *so; /* prefix sums: t, and per corner o (24 each) */
    double e;             /* bound, mm */
    double noise[8];      /* per corner, the RMS of the noise's 3D norm, mm */
    double fourth[8];     /* per corner, the sum of the squared eigenvalues of the noise's covariance, mm^4 */
    double per_product[8]; /* per corner, 1 / the lag-1 products that measured the noise (0: given) */
    double sigma;         /* per axis, the largest corner's, mm (run_flat) */
} fit_ctx;

/* u_j: how far key pose j's corner c lies from the chord of its two
 * neighbours. */
static void chord_offset(const double *t, const double *o, size_t j, int c, double u[3])
{
    double wa = (t[j + 1] - t[j]) / (t[j + 1] - t[j - 1]), wb = 1.0 - wa;
    for (int k = 0; k < 3; k++) {
        size_t q = 3 * c + k;
        u[k] = o[24 * j + q] - wa * o[24 * (j - 1) + q] - wb * o[24 * (j + 1) + q];
    }
}

/* Each corner's noise, the RMS of its 3D norm, from the samples given, or 0
 * where the track does not look like a motion plus white noise (tested on
 * the corners' mean products, whose scatter is smaller than one corner's).
 * For white noise of sigma per axis (times equally spaced), the mean of
 * u_j . u_{j+l} is
 * 4.5 sigma^2 at lag 0, -3 sigma^2 at lag 1 (they share two samples with
 * opposite signs), 0.75 sigma^2 at lag 2 and 0 beyond; a smooth motion's u is
 * smooth, its products positive at every lag, so a log's bend between samples
 * (a 1 Hz drift) is not taken for noise, and a tremor of frequency f has
 * products in the ratios cos(2 pi f l dt). Those match white noise's within
 * the margins below at lags 0 to 3 for 2 pi f dt in [2.549, 2.574] (8.11 to
 * 8.19 Hz in a 20 Hz log), and at lags 0 to 5 nowhere (docs/methods.md,
 * "Tracker noise"). The test's margins allow
 * the products' own scatter over a few hundred samples (lag 2's, the widest,
 * to 0.25x: a 232-sample still log fell below 0.5x; lags 3 to 5 to 0.75
 * sigma^2, about 3 of their standard deviations there); a shorter log, or
 * one that fails, is followed sample by sample. */
static size_t tracker_noise(size_t n, const double *t, const double *o, double noise[8], double fourth[8])
{
    enum { LAGS = 6 };
    double p[8][LAGS] = {{0}}, all[LAGS] = {0}, cross[8][3][3] = {{{0}}};
    for (int c = 0; c < 8; c++)
        noise[c] = fourth[c] = 0.0;
    if (n < PB_NOISE_SAMPLES)
        return 0;
    for (int c = 0; c < 8; c++) {
        /* lags 0 to 3, the noise's measure, over the n - 5 samples that
         * have lag 3; lags 4 and 5, which only test whiteness, over their
         * own n - 7 */
        for (size_t j = 1; j + 4 < n; j++) {
            double u[LAGS][3];
            int lags = j + LAGS < n ? LAGS : 4;
            for (int l = 0; l < lags; l++)
                chord_offset(t, o, j + (size_t)l, c, u[l]);
            for (int l = 0; l < lags; l++)
                p[c][l] += (u[0][0] * u[l][0] + u[0][1] * u[l][1] + u[0][2] * u[l][2]) /
                           (double)(l < 4 ? n - 5 : n - LAGS - 1);
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 3; b++)
                    cross[c][a][b] += u[0][a] * u[1][b] / (double)(n - 5);
        }
        for (int l = 0; l < LAGS; l++)
            all[l] += p[c][l] / 8.0;
    }
    double s2 = -all[1] / 3.0; /* sigma^2 per axis, from lag 1, over the corners */
    if (!(s2 > 0.0) || all[0] > 2.0 * 4.5 * s2 || all[0] < 0.5 * 4.5 * s2 || all[2] > 2.0 * 0.75 * s2 ||
        all[2] < 0.25 * 0.75 * s2)
        return 0;
    for (int l = 3; l < LAGS; l++)
        if (fabs(all[l]) > 0.25 * 3.0 * s2)
            return 0;
    for (int c = 0; c < 8; c++) {
        noise[c] = p[c][1] < 0.0 ? sqrt(-p[c][1]) : 0.0;
        /* the noise's covariance, -(lag 1's cross products), symmetrized:
         * the sum of its squared entries, that of its eigenvalues */
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++) {
                double cab = 0.5 * (cross[c][a][b] + cross[c][b][a]);
                fourth[c] += cab * cab;
            }
    }
    return n - 5;
}

/* Do the lines a[c] + b[c] t (c: corner, 3 each) keep key poses i..e within
 * the bounds (the header's two tests)? */
static int line_holds(const fit_ctx *f, size_t i, size_t e, const double *a, const double *b)
{
    /* Without noise every sample within E implies every longer window's
     * mean within E: single samples, and the mean square within
     * (PB_FIT_RMS_SHARE E)^2 as well; with noise, every window's mean. */
    int noisy = f->sigma > 0.0;
    size_t len = e - i + 1, top = noisy ? len : 1;
    double share = PB_FIT_RMS_SHARE * f->e;
    for (int c = 0; c < 8; c++) {
        double ms = 0.0, lag1 = 0.0, prev[3] = {0};
        for (size_t m = i; m <= e; m++)
            for (int j = 0; j < 3; j++) {
                size_t q = 3 * c + j;
                double d = f->o[24 * m + q] - (a[q] + b[q] * f->t[m]);
                ms += d * d;
                if (m > i)
                    lag1 += d * prev[j];
                prev[j] = d;
            }
        /* The noise's scatter (the header's first two tests): of the mean
         * square less the noise's as measured, and of the residual's lag-1
         * products, whose mean is the smooth part's mean square alone */
        double s2 = f->noise[c] * f->noise[c], L = (double)len;
        double z = len >= PB_FIT_SCATTER_RUN ? PB_FIT_SCATTER_Z : PB_FIT_SCATTER_Z_SHORT;
        double scatter = z * sqrt(f->fourth[c] * (2.0 * L + PB_NOISE_MEASURE_VAR * L * L * f->per_product[c]));
        if (ms > (share * share + s2) * L + scatter)
            return 0;
        if (noisy && lag1 > share * share * (L - 1.0) + z * sqrt(f->fourth[c] * (L - 1.0)))
            return 0;
    }
    for (size_t k = 1;; k = 2 * k < top ? 2 * k : top) {
        for (size_t m = i; m + k <= e + 1; m++) {
            double mt = (f->st[m + k] - f->st[m]) / (double)k;
            for (int c = 0; c < 8; c++) {
                double bound = f->e + 3.0 * f->noise[c] / sqrt((double)k), d2 = 0.0;
                for (int j = 0; j < 3; j++) {
                    size_t q = 3 * c + j;
                    double d = (f->so[24 * (m + k) + q] - f->so[24 * m + q]) / (double)k - (a[q] + b[q] * mt);
                    d2 += d * d;
                }
                if (d2 > bound * bound)
                    return 0;
            }
        }
        if (k == top)
            return 1;
    }
}

/* The least-squares statistics of key poses i..e: the mean time (*mt),
 * per corner coordinate the mean (mo) and slope (slope); returns
 * sum (t - mean t)^2. Summed over the run itself, about its own first
 * sample: prefix sums of t^2 and t o over a long log grow to 1e12 and more,
 * and their differences lose a short run's spread of times to rounding. */
static double run_stats(const fit_ctx *f, size_t i, size_t e, double *mt, double mo[24], double slope[24])
{
    double N = (double)(e - i + 1), t0 = f->t[i], m = 0.0, stt = 0.0, sto[24] = {0};
    const double *o0 = &f->o[24 * i];
    for (size_t j = i; j <= e; j++)
        m += f->t[j] - t0;
    m /= N;
    for (int q = 0; q < 24; q++)
        mo[q] = 0.0;
    for (size_t j = i; j <= e; j++) {
        double u = f->t[j] - t0 - m;
        stt += u * u;
        for (int q = 0; q < 24; q++) {
            double d = f->o[24 * j + q] - o0[q];
            mo[q] += d;
            sto[q] += u * d;
        }
    }
    for (int q = 0; q < 24; q++) {
        mo[q] = o0[q] + mo[q] / N;
        slope[q] = stt > 0.0 ? sto[q] / stt : 0.0;
    }
    *mt = t0 + m;
    return stt;
}

/* The least-squares lines of key poses i..e (e > i), then line_holds. */
static int run_holds(const fit_ctx *f, size_t i, size_t e)
{
    double a[24], b[24], mo[24], mt;
    run_stats(f, i, e, &mt, mo, b);
    for (int q = 0; q < 24; q++)
        a[q] = mo[q] - b[q] * mt;
    return line_holds(f, i, e, a, b);
}

/* Is the run i..e still within its noise: every corner's least-squares
 * slope within 3 standard errors of none (sigma / sqrt(sum (t - mean t)^2)),
 * and the constant at the mean within the bounds? */
static int run_flat(const fit_ctx *f, size_t i, size_t e)
{
    double a[24], b[24] = {0}, slope[24], mt;
    double stt = run_stats(f, i, e, &mt, a, slope);
    if (!(stt > 0.0))
        return 0;
    for (int q = 0; q < 24; q++)
        if (fabs(slope[q]) > 3.0 * f->sigma / sqrt(stt))
            return 0;
    return line_holds(f, i, e, a, b);
}

static void quat_log(const double q[4], double v[3])
{
    double s = sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    double k = s > 1e-15 ? 2.0 * atan2(s, q[0]) / s : 2.0 / (q[0] != 0.0 ? q[0] : 1.0);
    for (int i = 0; i < 3; i++)
        v[i] = k * q[i + 1];
}

static void quat_exp(const double v[3], double q[4])
{
    double a = 0.5 * sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    double k = a > 1e-15 ? sin(a) / (2.0 * a) : 0.5;
    q[0] = cos(a);
    for (int i = 0; i < 3; i++)
        q[i + 1] = k * v[i];
}

/* The continuous polyline with knots at key poses knot[0..K] (knot[0] = 0,
 * knot[K] = n - 1) fitted to the key poses' 6 parameters x (n x 6) and
 * their linear interpolation between them, the two knots of a flat piece
 * (flat[s]) tied to one value: the knots' parameters into out ((K + 1) x 6).
 * Least squares over time, over the hat functions of the knots (summed over
 * tied knots): a tridiagonal system, symmetric positive definite (every
 * knot's hat covers at least one interval of the track). */
static int fit_polyline(const double *t, const double *x, size_t n, const size_t *knot, const int *flat, size_t K,
                        double *out)
{
    size_t *group = malloc((K + 1) * sizeof *group);
    double *diag = calloc(K + 1, sizeof *diag), *off = calloc(K + 1, sizeof *off);
    double *rhs = calloc((K + 1) * 6, sizeof *rhs), *val = calloc((K + 1) * 6, sizeof *val);
    int ok = group && diag && off && rhs && val;
    if (ok) {
        group[0] = 0;
        for (size_t s = 0; s < K; s++)
            group[s + 1] = group[s] + !flat[s];
        size_t m = group[K] + 1;
        /* The track between samples is their interpolation, so the fit is
         * over time, not over samples: each interval's products of linear
         * functions integrated exactly (Simpson's rule). A sample-weighted
         * fit would count the frame's ends, which close partial intervals,
         * as whole samples and tilt a short log's knots. */
        for (size_t s = 0, j = 0; j + 1 < n; j++) {
            while (s + 1 < K && j >= knot[s + 1])
                s++;
            double span = t[knot[s + 1]] - t[knot[s]], h = (t[j + 1] - t[j]) / 6.0;
            double u[3] = {(t[j] - t[knot[s]]) / span, 0.0, (t[j + 1] - t[knot[s]]) / span}, wq[3] = {h, 4.0 * h, h};
            u[1] = 0.5 * (u[0] + u[2]);
            size_t ga = group[s], gb = group[s + 1];
            for (int r = 0; r < 3; r++) {
                double xr[6];
                for (int p = 0; p < 6; p++)
                    xr[p] = r == 0 ? x[6 * j + p] : r == 2 ? x[6 * (j + 1) + p] : 0.5 * (x[6 * j + p] + x[6 * (j + 1) + p]);
                if (ga == gb) {
                    diag[ga] += wq[r];
                    for (int p = 0; p < 6; p++)
                        rhs[6 * ga + p] += wq[r] * xr[p];
                    continue;
                }
                double a = 1.0 - u[r], b = u[r];
                diag[ga] += wq[r] * a * a;
                off[ga] += wq[r] * a * b;
                diag[gb] += wq[r] * b * b;
                for (int p = 0; p < 6; p++) {
                    rhs[6 * ga + p] += wq[r] * a * xr[p];
                    rhs[6 * gb + p] += wq[r] * b * xr[p];
                }
            }
        }
        for (size_t g = 1; g < m; g++) { /* Thomas */
            double l = off[g - 1] / diag[g - 1];
            diag[g] -= l * off[g - 1];
            for (int p = 0; p < 6; p++)
                rhs[6 * g + p] -= l * rhs[6 * (g - 1) + p];
        }
        for (size_t g = m; g-- > 0;)
            for (int p = 0; p < 6; p++)
                val[6 * g + p] = (rhs[6 * g + p] - (g + 1 < m ? off[g] * val[6 * (g + 1) + p] : 0.0)) / diag[g];
        for (size_t s = 0; s <= K; s++)
            memcpy(&out[6 * s], &val[6 * group[s]], 6 * sizeof *out);
    }
    free(group);
    free(diag);
    free(off);
    free(rhs);
    free(val);
    return ok;
}

static void corners_of(const pb_path *plan, const pb_pose *pose, double *o)
{
    const double *v = plan->geometry.voxel_size;
    for (int c = 0; c < 8; c++) {
        double p[3];
        for (int i = 0; i < 3; i++)
            p[i] = ((c >> i & 1) ? ((double)plan->geometry.dims[i] - 0.5) : 0.5) * v[i];
        pb_pose_apply_inverse(pose, plan->center, p, &o[3 * c]);
    }
}

/* The noise of a frame with too few samples of its own to measure it
 * (tracker_noise's 64), from the PB_NOISE_WINDOW samples of the whole log
 * centred on the frame: a 2 s frame of a 20 Hz log holds 40, and following
 * their noise took 42 segments where the motion took one (docs/methods.md,
 * "Tracker noise"). The window's motion must pass the same whiteness test,
 * so a jerk or a tremor beside the frame leaves it followed as before.
 * Returns 0 where host memory runs out. */
static int window_noise(const pb_path *plan, const pb_motion *track, double noise[8], double fourth[8],
                        size_t *products)
{
    /* part: from the last sample at or before the frame's start to the
     * first at or after its end (a validated track covers the frame), so the
     * samples inside are the ones between; noise stays 0 should it fail */
    pb_motion part;
    if (pb_motion_frame(track, plan->poses[0].time, plan->poses[plan->count - 1].time, &part) != PB_OK)
        return 1;
    size_t n = track->count, first = (size_t)(part.times - track->times) + 1, inside = part.count - 2;
    size_t w = n < PB_NOISE_WINDOW ? n : PB_NOISE_WINDOW, mid = first + inside / 2;
    size_t lo = mid > w / 2 ? mid - w / 2 : 0;
    if (lo + w > n)
        lo = n - w;
    double *t = malloc(w * 25 * sizeof *t);
    if (!t)
        return 0;
    double *o = t + w;
    for (size_t j = 0; j < w; j++) {
        pb_pose p;
        pb_pose_normalized(&track->poses[lo + j], &p);
        t[j] = track->times[lo + j] - track->times[lo];
        corners_of(plan, &p, &o[24 * j]);
    }
    *products = tracker_noise(w, t, o, noise, fourth);
    free(t);
    return 1;
}

pb_status pb_path_fit(struct pb_context *ctx, pb_path *plan, const pb_motion *track, double sigma_mm,
                      double max_error)
{
    size_t n = plan->count;
    const double *v = plan->geometry.voxel_size;
    double vmin = fmin(v[0], fmin(v[1], v[2])), e_mm = max_error * vmin;
    double *buf = calloc(n * (1 + 24 + 6) + (n + 1) * (1 + 24), sizeof *buf);
    size_t *knot = malloc(n * sizeof *knot);
    double *kx = malloc(n * 6 * sizeof *kx);
    pb_path_pose *poses = NULL;
    if (!buf || !knot || !kx) {
        free(buf);
        free(knot);
        free(kx);
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory fitting the path through %zu samples", n);
    }
    double *t = buf, *o = t + n, *x = o + 24 * n, *st = x + 6 * n, *so = st + n + 1;
    double qref[4], qc[4];
    memcpy(qref, plan->poses[n / 2].pose.rotation, sizeof qref);
    pb_quat_conj(qref, qc);
    for (size_t j = 0; j < n; j++) {
        const pb_pose *p = &plan->poses[j].pose;
        t[j] = plan->poses[j].time - plan->poses[0].time;
        corners_of(plan, p, &o[24 * j]);
        /* Not folded to rel[0] >= 0: the plan's poses are each in the
         * hemisphere of the one before (path_plan.c), so rel runs on
         * continuously from the identity at the middle sample, and its
         * rotation vector with it, to turns of 360 degrees either side. */
        double rel[4];
        pb_quat_mul(qc, p->rotation, rel);
        memcpy(&x[6 * j], p->translation, 3 * sizeof *x);
        quat_log(rel, &x[6 * j + 3]);
        st[j + 1] = st[j] + t[j];
        for (int q = 0; q < 24; q++)
            so[24 * (j + 1) + q] = so[24 * j + q] + o[24 * j + q];
    }
    fit_ctx f = {n, t, o, st, so, e_mm, {0}, {0}, {0}, 0.0};
    size_t products = 0;
    if (n < PB_NOISE_SAMPLES && track && track->count >= PB_NOISE_SAMPLES) {
        if (!window_noise(plan, track, f.noise, f.fourth, &products)) {
            free(buf);
            free(knot);
            free(kx);
            return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory measuring the tracker's noise");
        }
    } else {
        products = tracker_noise(n, t, o, f.noise, f.fourth);
    }
    for (int c = 0; c < 8; c++) {
        if (products && f.noise[c] > sqrt(3.0) * sigma_mm) {
            f.per_product[c] = 1.0 / (double)products;
        } else {
            f.noise[c] = fmax(f.noise[c], sqrt(3.0) * sigma_mm);
            f.fourth[c] = f.noise[c] * f.noise[c] * f.noise[c] * f.noise[c] / 3.0;
        }
        f.sigma = fmax(f.sigma, f.noise[c] / sqrt(3.0));
        plan->noise_mm = fmax(plan->noise_mm, f.noise[c]);
    }

    /* Runs: from each knot, the longest run whose line holds (doubling, then
     * a binary search, as merge_segments). */
    size_t K = 0, i = 0;
    knot[0] = 0;
    while (i + 1 < n) {
        size_t limit = n - 1, good = i + 1, bad = limit + 1;
        for (size_t len = 2; good < limit && bad > limit; len *= 2) {
            size_t e = i + len < limit ? i + len : limit;
            if (run_holds(&f, i, e))
                good = e;
            else
                bad = e;
        }
        while (bad <= limit && bad - good > 1) {
            size_t mid = good + (bad - good) / 2;
            if (run_holds(&f, i, mid))
                good = mid;
            else
                bad = mid;
        }
        knot[++K] = good;
        i = good;
    }
    /* Under noise, the runs merged where their union holds: a short run's
     * noise alone fails its mean square now and then (4 % a corner at 8 samples
     * where the noise's RMS is twice E) and ends a run that the motion would not, and
     * the union of two such runs has the scatter allowance where it reaches
     * PB_FIT_SCATTER_RUN samples. Until none merges. */
    for (int merged = f.sigma > 0.0; merged && K > 1;) {
        size_t Kn = 0;
        merged = 0;
        for (size_t s = 0; s < K; s++)
            if (s + 1 < K && run_holds(&f, knot[Kn], knot[s + 2]))
                merged = 1; /* knot s + 1 dropped */
            else
                knot[++Kn] = knot[s + 1];
        K = Kn;
    }
    /* One polyline through every sample, its runs that are still within
     * their noise (a still head, the rest before and after a jerk) held
     * flat: a flat run's value is the mean of its samples, whose noise is
     * sigma / sqrt(n), where a line's ends stray sqrt(3) times as far again
     * and make a still head a spurious drift. A piece that fails is cut at
     * its middle sample and the whole fitted again; a flat piece's halves
     * are lines from then on (two flat runs side by side are tied to one
     * value by the polyline's continuity, which no cut would untie). The last
     * round fits without testing, so the knots kept are those fitted. */
    int ok = 1, *flat = malloc(n * sizeof *flat);
    unsigned char *sloped = calloc(n, 1); /* per piece: never held flat */
    if (!flat || !sloped)
        ok = 0;
    for (int round = 0; ok; round++) {
        for (size_t s = 0; s < K; s++)
            flat[s] = !sloped[s] && knot[s + 1] - knot[s] > 1 && run_flat(&f, knot[s], knot[s + 1]);
        if (!(ok = fit_polyline(t, x, n, knot, flat, K, kx)) || round == PB_FIT_ROUNDS)
            break;
        size_t added = 0;
        double (*ends)[24] = malloc((K + 1) * sizeof *ends);
        size_t *next = malloc(2 * (K + 1) * sizeof *next), Kn = 0;
        unsigned char *next_sloped = malloc(2 * (K + 1));
        if (!(ok = ends && next && next_sloped)) {
            free(ends);
            free(next);
            free(next_sloped);
            break;
        }
        for (size_t s = 0; s <= K; s++) {
            pb_pose p;
            double q[4];
            memcpy(p.translation, &kx[6 * s], 3 * sizeof *kx);
            quat_exp(&kx[6 * s + 3], q);
            pb_quat_mul(qref, q, p.rotation);
            corners_of(plan, &p, ends[s]);
        }
        next[0] = 0;
        for (size_t s = 0; s < K; s++) {
            double a[24], b[24], t0 = t[knot[s]], t1 = t[knot[s + 1]];
            for (int q = 0; q < 24; q++) {
                b[q] = (ends[s + 1][q] - ends[s][q]) / (t1 - t0);
                a[q] = ends[s][q] - b[q] * t0;
            }
            int cut = knot[s + 1] - knot[s] > 1 && !line_holds(&f, knot[s], knot[s + 1], a, b);
            if (cut) {
                next_sloped[Kn] = sloped[s] || flat[s];
                next[++Kn] = knot[s] + (knot[s + 1] - knot[s]) / 2;
                added++;
            }
            next_sloped[Kn] = sloped[s] || (cut && flat[s]);
            next[++Kn] = knot[s + 1];
        }
        free(ends);
        if (added) {
            memcpy(knot, next, (Kn + 1) * sizeof *knot);
            memcpy(sloped, next_sloped, Kn);
            K = Kn;
        }
        free(next);
        free(next_sloped);
        if (!added)
            break;
    }
    if (ok && (poses = calloc(K + 1, sizeof *poses))) {
        for (size_t s = 0; s <= K; s++) {
            double q[4];
            poses[s].time = plan->poses[knot[s]].time;
            memcpy(poses[s].pose.translation, &kx[6 * s], 3 * sizeof *kx);
            quat_exp(&kx[6 * s + 3], q);
            pb_quat_mul(qref, q, poses[s].pose.rotation);
            if (s > 0 && pb_quat_dot(poses[s].pose.rotation, poses[s - 1].pose.rotation) < 0.0)
                for (int k = 0; k < 4; k++)
                    poses[s].pose.rotation[k] = -poses[s].pose.rotation[k];
        }
        free(plan->poses);
        plan->poses = poses;
        plan->count = K + 1;
    }
    free(buf);
    free(knot);
    free(kx);
    free(flat);
    free(sloped);
    return poses ? PB_OK : pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory fitting the path");
}
