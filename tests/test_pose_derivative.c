/* pb_blur_pose_derivative against central finite differences of pb_blur on a
 * fresh smooth volume and a fresh three-pose motion, on each backend; and
 * pb_motion_estimate's refusals of what a series cannot be. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "estimate.h"
#include "motion.h"
#include "testlib.h"

enum { NX = 36, NY = 32, NZ = 28 };

typedef struct {
    double centre[3], width, height; /* in voxels */
} blob;
enum { BLOBS = 12 };

/* The blobs' sum at voxel (i, j, k), times a window that falls to zero with
 * zero slope one voxel outside the grid, where the blur takes the object to
 * be zero; and the sum's gradient in voxels. */
static double object_at(const pb_geometry *g, const blob *b, const double at[3], double grad[3])
{
    double sum = 0, sum_grad[3] = {0, 0, 0}, win[3], win_slope[3];
    for (int q = 0; q < BLOBS; q++) {
        double d = 0, w2 = b[q].width * b[q].width;
        for (int a = 0; a < 3; a++)
            d += (at[a] - b[q].centre[a]) * (at[a] - b[q].centre[a]);
        double f = b[q].height * exp(-0.5 * d / w2);
        sum += f;
        for (int a = 0; a < 3; a++)
            sum_grad[a] -= f * (at[a] - b[q].centre[a]) / w2;
    }
    for (int a = 0; a < 3; a++) {
        double k = 3.14159265358979323846 / ((double)g->dims[a] + 1), s = sin(k * (at[a] + 1));
        win[a] = s * s, win_slope[a] = 2 * s * cos(k * (at[a] + 1)) * k;
    }
    double window = win[0] * win[1] * win[2];
    for (int a = 0; a < 3; a++)
        grad[a] = sum_grad[a] * window + sum * win_slope[a] * window / win[a];
    return sum * window;
}

/* Smooth blobs inside the grid: finite differences then see the derivative,
 * not the sampling. */
static void smooth_volume(const pb_geometry *g, blob *b, float *v)
{
    size_t n = g->dims[0] * g->dims[1] * g->dims[2];
    memset(v, 0, n * sizeof *v);
    for (int q = 0; q < BLOBS; q++) {
        b[q].width = pb_rand_range(3.5, 5.0), b[q].height = pb_rand_range(0.5, 1.0);
        for (int i = 0; i < 3; i++)
            b[q].centre[i] = pb_rand_range(0.38, 0.62) * (double)g->dims[i];
    }
    for (size_t k = 0; k < g->dims[2]; k++)
        for (size_t j = 0; j < g->dims[1]; j++)
            for (size_t i = 0; i < g->dims[0]; i++) {
                double at[3] = {(double)i, (double)j, (double)k}, grad[3];
                v[i + g->dims[0] * (j + g->dims[1] * k)] = (float)object_at(g, b, at, grad);
            }
}

/* d x(G_xi p)/d xi at every voxel centre p from the object's closed-form
 * gradient, for G a translation along an axis or a turn about one through
 * the motion's centre c: grad x, and (p - c) x grad x. */
static void exact_derivatives(const pb_geometry *g, const blob *b, const double c[3], float *const out[6])
{
    for (size_t k = 0; k < g->dims[2]; k++)
        for (size_t j = 0; j < g->dims[1]; j++)
            for (size_t i = 0; i < g->dims[0]; i++) {
                double at[3] = {(double)i, (double)j, (double)k}, grad[3], r[3];
                object_at(g, b, at, grad);
                for (int a = 0; a < 3; a++) {
                    grad[a] /= g->voxel_size[a];
                    r[a] = (at[a] + 0.5) * g->voxel_size[a] - c[a];
                }
                size_t v = i + g->dims[0] * (j + g->dims[1] * k);
                out[0][v] = (float)grad[0], out[1][v] = (float)grad[1], out[2][v] = (float)grad[2];
                out[3][v] = (float)(r[1] * grad[2] - r[2] * grad[1]);
                out[4][v] = (float)(r[2] * grad[0] - r[0] * grad[2]);
                out[5][v] = (float)(r[0] * grad[1] - r[1] * grad[0]);
            }
}

/* Relative RMS and max (of the reference's largest) in percent. */
static void relative_error(const float *ref, const float *x, size_t n, double *rms, double *max)
{
    double err = 0, sum = 0, worst = 0, top = 0;
    for (size_t i = 0; i < n; i++) {
        double d = (double)x[i] - (double)ref[i];
        err += d * d, sum += (double)ref[i] * (double)ref[i];
        worst = fmax(worst, fabs(d)), top = fmax(top, fabs((double)ref[i]));
    }
    *rms = 100 * sqrt(err / sum), *max = 100 * worst / top;
}

/* Every pose of m turned by G(eps e_j)^-1 on the object's side. */
static void perturbed(const pb_motion *m, pb_pose *poses, int j, double eps)
{
    double step[6] = {0};
    step[j] = eps;
    pb_pose g = {{step[0], step[1], step[2]}, {1, 0, 0, 0}}, gi;
    if (j >= 3) {
        g.rotation[0] = cos(0.5 * eps);
        g.rotation[j - 2] = sin(0.5 * eps);
    }
    pb_pose_invert(&g, &gi);
    for (size_t i = 0; i < m->count; i++)
        pb_pose_compose(&m->poses[i], &gi, &poses[i]);
}

/* The object x on the device and pb_blur_pose_derivative's six images of it
 * under m (EXACT filter) into der. */
static pb_status derivative_images(pb_context *ctx, const pb_geometry *g, const float *x, const pb_motion *m,
                                   pb_volume **obj, pb_volume *der[6])
{
    pb_blur_options opt = {.filter = PB_FILTER_EXACT};
    pb_status st = pb_volume_create(ctx, g, obj);
    for (int j = 0; j < 6 && st == PB_OK; j++)
        st = pb_volume_create(ctx, g, &der[j]);
    if (st == PB_OK)
        st = pb_volume_upload(*obj, x);
    return st == PB_OK ? pb_blur_pose_derivative(ctx, *obj, m, &opt, der) : st;
}

static void test_derivative(pb_context *ctx)
{
    pb_geometry g = {{NX, NY, NZ}, {2.0, 2.5, 2.2}};
    size_t n = NX * NY * NZ;
    float *x = malloc(n * sizeof *x), *plus = malloc(n * sizeof *plus), *minus = malloc(n * sizeof *minus);
    float *d = malloc(n * sizeof *d), *exact = malloc(6 * n * sizeof *exact), *exact_blur = malloc(n * sizeof *d);
    blob blobs[BLOBS];
    smooth_volume(&g, blobs, x);
    double times[3] = {0, 0.4, 1}, axis[3] = {pb_rand_range(-1, 1), pb_rand_range(-1, 1), 1};
    pb_pose poses[3] = {pb_test_pose(0, 0, 0, axis, 0),
                        pb_test_pose(pb_rand_range(-3, 3), pb_rand_range(-3, 3), 1, axis, pb_rand_range(2, 6)),
                        pb_test_pose(pb_rand_range(-3, 3), 2, pb_rand_range(-3, 3), axis, pb_rand_range(-6, 6))};
    pb_motion m = {times, poses, 3, 0, 1, 1, {pb_rand_range(20, 36), pb_rand_range(20, 40), pb_rand_range(15, 30)}};
    float *exact_images[6];
    for (int j = 0; j < 6; j++)
        exact_images[j] = exact + (size_t)j * n;
    exact_derivatives(&g, blobs, m.center, exact_images);
    pb_blur_options opt = {.filter = PB_FILTER_EXACT};
    pb_volume *obj = NULL, *der[6] = {0};
    pb_status st = derivative_images(ctx, &g, x, &m, &obj, der);
    pb_check(st == PB_OK, "pb_blur_pose_derivative: %s", pb_last_error(ctx));
    for (int j = 0; j < 6 && st == PB_OK; j++) {
        char name[3] = {j < 3 ? 'v' : 'w', "xyz"[j % 3], 0};
        pb_volume_download(der[j], d);
        /* The model's derivative: B of the object's exact derivative image.
         * What is left is the library's central differences of the sampled
         * object: 1-3 % RMS on blobs 3.5-5 voxels wide. Measured over 360
         * draws: at most 2.6 % RMS and 3.1 % max for translations, 5.0 % and
         * 4.0 % for rotations. A sign or an axis wrong is 100 % and more, the
         * centre 3 mm off about 10 %. */
        double rms, max;
        pb_test_blur(ctx, &g, exact_images[j], &m, &opt, exact_blur);
        relative_error(exact_blur, d, n, &rms, &max);
        printf("d(Bx)/d%s against B of the exact derivative: relative RMS %.2f %%, max %.2f %%\n", name, rms, max);
        pb_check(rms < 7.5 && max < 7.5, "d(Bx)/d%s: %.2f %% RMS, %.2f %% max from B of the exact derivative", name,
                 rms, max);
        /* Central finite differences of B through perturbed poses: the
         * perturbation means what the API says (object side, about the
         * motion's centre). Translations by one voxel, where the blur of
         * central differences is the difference of the blur over one voxel.
         * Rotations by 6 degrees, which move the object's points a voxel or
         * two: smaller steps see the trilinear fetches' slope, constant
         * across each voxel, in place of the smooth gradient (at 1 degree
         * up to 14 % RMS; at 6, the second-order error is under 1 %). */
        double eps = j < 3 ? g.voxel_size[j] : 6.0 * 3.14159265358979323846 / 180.0;
        pb_pose p[3];
        pb_motion mp = m;
        mp.poses = p;
        perturbed(&m, p, j, eps);
        pb_test_blur(ctx, &g, x, &mp, &opt, plus);
        perturbed(&m, p, j, -eps);
        pb_test_blur(ctx, &g, x, &mp, &opt, minus);
        for (size_t i = 0; i < n; i++)
            plus[i] = (float)(((double)plus[i] - (double)minus[i]) / (2 * eps));
        relative_error(plus, d, n, &rms, &max);
        printf("d(Bx)/d%s against finite differences: relative RMS %.2f %%, max %.2f %%\n", name, rms, max);
        /* Measured over 360 draws: translations at most 0.9 % RMS and
         * 1.3 % max, rotations 7.7 % and 10.9 %. This checks the perturbation's
         * convention; the values are checked against the exact derivative. */
        double tol = j < 3 ? 2.5 : 15.0;
        pb_check(rms < tol && max < 2 * tol, "d(Bx)/d%s: %.2f %% RMS, %.2f %% max from finite differences", name, rms,
                 max);
    }
    for (int j = 0; j < 6; j++)
        pb_volume_destroy(der[j]);
    pb_volume_destroy(obj);
    free(x), free(plus), free(minus), free(d), free(exact), free(exact_blur);
}

/* The estimate's derivative of a still pose's view from the view's own
 * central differences (src/estimate/view_jacobian.c), on the view of a fresh
 * pose of up to 12 degrees, against the blobs' exact derivative at each
 * voxel's point in the object and beside pb_blur_pose_derivative (the blurs
 * of the library's derivative images, which it replaces in the
 * registrations). */
static void test_view_jacobian(pb_context *ctx)
{
    pb_geometry g = {{NX, NY, NZ}, {pb_rand_range(2.0, 3.0), pb_rand_range(2.0, 3.0), pb_rand_range(2.0, 3.3)}};
    size_t n = NX * NY * NZ;
    float *x = malloc(n * sizeof *x), *view = malloc(n * sizeof *view), *d = malloc(n * sizeof *d);
    float *exact = malloc(n * sizeof *exact), *ours = malloc(n * sizeof *ours);
    blob blobs[BLOBS];
    smooth_volume(&g, blobs, x);
    double times[2], axis[3] = {pb_rand_range(-1, 1), pb_rand_range(-1, 1), pb_rand_range(-1, 1)};
    pb_pose poses[2], pose = pb_test_pose(pb_rand_range(-4, 4), pb_rand_range(-4, 4), pb_rand_range(-4, 4), axis,
                                          pb_rand_range(-12, 12));
    const double c[3] = {pb_rand_range(0.3, 0.7) * NX * g.voxel_size[0], pb_rand_range(0.3, 0.7) * NY * g.voxel_size[1],
                         pb_rand_range(0.3, 0.7) * NZ * g.voxel_size[2]};
    pb_motion m;
    pbe_static_motion(&pose, c, times, poses, &m);
    pb_blur_options opt = {.filter = PB_FILTER_EXACT};
    pb_volume *obj = NULL, *der[6] = {0};
    pb_status st = derivative_images(ctx, &g, x, &m, &obj, der);
    if (st == PB_OK)
        st = pb_test_blur(ctx, &g, x, &m, &opt, view);
    pb_check(st == PB_OK, "the view and pb_blur_pose_derivative: %s", pb_last_error(ctx));
    pbe_view_jacobian J;
    pbe_view_jacobian_init(&J, &g, view, &pose, c);
    for (int j = 0; j < 6 && st == PB_OK; j++) {
        char name[3] = {j < 3 ? 'v' : 'w', "xyz"[j % 3], 0};
        for (size_t i = 0; i < n; i++) {
            double out[6];
            pbe_view_jacobian_at(&J, i, out);
            ours[i] = (float)out[j];
        }
        pb_volume_download(der[j], d);
        /* the blobs' exact derivative where each voxel's view reads the object */
        for (size_t k = 0; k < NZ; k++)
            for (size_t jj = 0; jj < NY; jj++)
                for (size_t i = 0; i < NX; i++) {
                    const double y[3] = {(i + 0.5) * g.voxel_size[0], (jj + 0.5) * g.voxel_size[1],
                                         (k + 0.5) * g.voxel_size[2]};
                    double p[3], at[3], grad[3], r[3], e[6];
                    pb_pose_apply_inverse(&pose, c, y, p);
                    for (int a = 0; a < 3; a++)
                        at[a] = p[a] / g.voxel_size[a] - 0.5, r[a] = p[a] - c[a];
                    object_at(&g, blobs, at, grad);
                    for (int a = 0; a < 3; a++)
                        grad[a] /= g.voxel_size[a];
                    e[0] = grad[0], e[1] = grad[1], e[2] = grad[2];
                    e[3] = r[1] * grad[2] - r[2] * grad[1];
                    e[4] = r[2] * grad[0] - r[0] * grad[2];
                    e[5] = r[0] * grad[1] - r[1] * grad[0];
                    exact[i + NX * (jj + NY * k)] = (float)e[j];
                }
        double rms, max, rms_blur, max_blur, rms_apart, max_apart;
        relative_error(exact, ours, n, &rms, &max);
        relative_error(exact, d, n, &rms_blur, &max_blur);
        relative_error(d, ours, n, &rms_apart, &max_apart);
        printf("the view's d/d%s against the exact derivative at each view point: relative RMS %.2f %%, max %.2f %% "
               "(the derivative images' blur: %.2f %%, %.2f %%; the two apart: %.2f %%, %.2f %%)\n", name, rms, max,
               rms_blur, max_blur, rms_apart, max_apart);
        /* Both are central differences, of the view on its own axes or of the object on its axes then read
         * trilinearly, so each stands a few percent off the exact derivative. Measured over 1200 draws: the
         * view's at most 9.3 % RMS and 7.8 % max (3.7 % and 5.0 % median), the derivative images' blur 8.2 % and
         * 6.7 %, the two at most 4.9 % RMS apart (0.9 % median). A sign or an axis wrong is 100 % and more. */
        pb_check(rms < 15.0 && max < 15.0 && rms_apart < 7.5,
                 "the view's d/d%s: %.2f %% RMS, %.2f %% max from the exact derivative, %.2f %% RMS from the derivative "
                 "images' blur", name, rms, max, rms_apart);
    }
    for (int j = 0; j < 6; j++)
        pb_volume_destroy(der[j]);
    pb_volume_destroy(obj);
    free(x), free(view), free(d), free(exact), free(ours);
}

static void expect(pb_status st, pb_status want, const char *what, const char *words)
{
    const char *text = pb_last_error(NULL);
    pb_check(st == want && strstr(text, words), "%s: status %d (want %d), '%s' lacks '%s'", what, st, want, text,
             words);
}

static void test_estimate_refusals(pb_context *ctx)
{
    pb_geometry g = {{16, 16, 16}, {3, 3, 3}};
    size_t n = 16 * 16 * 16;
    float *f = malloc(3 * n * sizeof *f);
    for (size_t i = 0; i < 3 * n; i++)
        f[i] = (float)pb_rand_range(0.1, 1.0);
    double b[4] = {0, 10, 20, 30};
    pb_track *t = (pb_track *)1;
    pb_estimate_options o = {0};
    expect(pb_motion_estimate(ctx, &g, NULL, f, 1, b, NULL, &t, NULL), PB_ERR_INVALID_ARGUMENT, "one frame",
           "at least two frames");
    pb_check(t == NULL, "a refusal leaves no track");
    o.reference = 3;
    expect(pb_motion_estimate(ctx, &g, NULL, f, 3, b, &o, &t, NULL), PB_ERR_INVALID_ARGUMENT, "reference 3",
           "reference frame 3");
    o.reference = 0;
    f[n + 7] = NAN;
    expect(pb_motion_estimate(ctx, &g, NULL, f, 3, b, &o, &t, NULL), PB_ERR_NOT_FINITE, "NaN", "frame 1 holds NaN");
    f[n + 7] = 0.5f;
    memset(f + 2 * n, 0, n * sizeof *f);
    expect(pb_motion_estimate(ctx, &g, NULL, f, 3, b, &o, &t, NULL), PB_ERR_INVALID_ARGUMENT, "empty frame",
           "frame 2 (20 to 30 s) holds no counts");
    double back[4] = {0, 10, 5, 30};
    expect(pb_motion_estimate(ctx, &g, NULL, f, 3, back, &o, &t, NULL), PB_ERR_BAD_FRAME, "bounds", "");
    pb_geometry small = {{16, 6, 16}, {3, 3, 3}};
    expect(pb_motion_estimate(ctx, &small, NULL, f, 3, b, &o, &t, NULL), PB_ERR_ZERO_DIMS, "small grid",
           "at least 8 a side");
    free(f);
}

int main(int argc, char **argv)
{
    pb_test_seed();
    pb_context *ctx = pb_test_context(argc, argv);
    test_derivative(ctx);
    test_view_jacobian(ctx);
    test_estimate_refusals(ctx);
    pb_context_destroy(ctx);
    return pb_test_finish();
}
