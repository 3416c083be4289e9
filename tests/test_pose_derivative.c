/* pb_blur_pose_derivative against central finite differences of pb_blur on a
 * fresh smooth volume and a fresh three-pose motion, on each backend; and
 * pb_motion_estimate's refusals of what a series cannot be. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "motion.h"
#include "testlib.h"

enum { NX = 36, NY = 32, NZ = 28 };

/* Smooth blobs inside the grid (the object is zero outside it, as the blur
 * takes it): finite differences then see the derivative, not the sampling. */
static void smooth_volume(const pb_geometry *g, float *v)
{
    size_t n = g->dims[0] * g->dims[1] * g->dims[2];
    memset(v, 0, n * sizeof *v);
    for (int b = 0; b < 12; b++) {
        double c[3], w = pb_rand_range(3.5, 5.0), a = pb_rand_range(0.5, 1.0);
        for (int i = 0; i < 3; i++)
            c[i] = pb_rand_range(0.38, 0.62) * (double)g->dims[i];
        for (size_t k = 0; k < g->dims[2]; k++)
            for (size_t j = 0; j < g->dims[1]; j++)
                for (size_t i = 0; i < g->dims[0]; i++) {
                    double d = ((double)i - c[0]) * ((double)i - c[0]) + ((double)j - c[1]) * ((double)j - c[1]) +
                               ((double)k - c[2]) * ((double)k - c[2]);
                    v[i + g->dims[0] * (j + g->dims[1] * k)] += (float)(a * exp(-0.5 * d / (w * w)));
                }
    }
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

static void test_derivative(pb_context *ctx)
{
    pb_geometry g = {{NX, NY, NZ}, {2.0, 2.5, 2.2}};
    size_t n = NX * NY * NZ;
    float *x = malloc(n * sizeof *x), *plus = malloc(n * sizeof *plus), *minus = malloc(n * sizeof *minus);
    float *d = malloc(n * sizeof *d);
    smooth_volume(&g, x);
    double times[3] = {0, 0.4, 1}, axis[3] = {pb_rand_range(-1, 1), pb_rand_range(-1, 1), 1};
    pb_pose poses[3] = {pb_test_pose(0, 0, 0, axis, 0),
                        pb_test_pose(pb_rand_range(-3, 3), pb_rand_range(-3, 3), 1, axis, pb_rand_range(2, 6)),
                        pb_test_pose(pb_rand_range(-3, 3), 2, pb_rand_range(-3, 3), axis, pb_rand_range(-6, 6))};
    pb_motion m = {times, poses, 3, 0, 1, 1, {pb_rand_range(20, 36), pb_rand_range(20, 40), pb_rand_range(15, 30)}};
    pb_blur_options opt = {.filter = PB_FILTER_EXACT};
    pb_volume *obj = NULL, *der[6] = {0};
    pb_status st = pb_volume_create(ctx, &g, &obj);
    for (int j = 0; j < 6 && st == PB_OK; j++)
        st = pb_volume_create(ctx, &g, &der[j]);
    if (st == PB_OK)
        st = pb_volume_upload(obj, x);
    if (st == PB_OK)
        st = pb_blur_pose_derivative(ctx, obj, &m, &opt, der);
    pb_check(st == PB_OK, "pb_blur_pose_derivative: %s", pb_last_error(ctx));
    for (int j = 0; j < 6 && st == PB_OK; j++) {
        /* Translations by one voxel: the blur of central differences is the
         * difference of the blur over one voxel along an axis. Rotations by 1
         * degree, which moves the object's points less than a voxel: there
         * the trilinear fetches' slope, constant across each voxel, and the
         * smooth gradient differ by the sampling (docs/motion.md). */
        double eps = j < 3 ? g.voxel_size[j] : 3.14159265358979323846 / 180.0;
        pb_pose p[3];
        pb_motion mp = m;
        mp.poses = p;
        perturbed(&m, p, j, eps);
        pb_test_blur(ctx, &g, x, &mp, &opt, plus);
        perturbed(&m, p, j, -eps);
        pb_test_blur(ctx, &g, x, &mp, &opt, minus);
        pb_volume_download(der[j], d);
        double err = 0, ref = 0, worst = 0, top = 0;
        for (size_t i = 0; i < n; i++) {
            double fd = ((double)plus[i] - (double)minus[i]) / (2 * eps);
            err += (fd - (double)d[i]) * (fd - (double)d[i]);
            ref += fd * fd;
            worst = fmax(worst, fabs(fd - (double)d[i]));
            top = fmax(top, fabs(fd));
        }
        double rms = 100 * sqrt(err / ref), max = 100 * worst / top;
        printf("d(Bx)/d%s%c: relative RMS %.2f %%, max %.2f %% of the largest\n", j < 3 ? "v" : "w",
               "xyz"[j % 3], rms, max);
        /* measured over fresh draws: translations 0.05-1.2 % RMS, rotations
         * 2-7 % on blobs 3.5-5 voxels wide. A sign or a centre wrong is
         * 100 % and more. */
        double tol = j < 3 ? 2.5 : 10.0;
        pb_check(rms < tol && max < 2 * tol, "d(Bx)/d(pose %d): %.2f %% RMS, %.2f %% max from finite differences", j,
                 rms, max);
    }
    for (int j = 0; j < 6; j++)
        pb_volume_destroy(der[j]);
    pb_volume_destroy(obj);
    free(x), free(plus), free(minus), free(d);
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
    test_estimate_refusals(ctx);
    pb_context_destroy(ctx);
    return pb_test_finish();
}
