/* The estimator's energy-keeping rigid move (src/estimate/sinc_shears.c), on
 * fresh random poses and grids each run: a Gaussian blob moved lands where
 * the pose's inverse takes its centre (against the blob written there in
 * closed form), noise keeps its energy, and whole-voxel shifts are exact. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "estimate.h"
#include "motion.h"
#include "testlib.h"

static pb_pose random_pose(double mm, double deg)
{
    double axis[3] = {pb_rand_range(-1, 1), pb_rand_range(-1, 1), pb_rand_range(-1, 1)};
    return pb_test_pose(pb_rand_range(-mm, mm), pb_rand_range(-mm, mm), pb_rand_range(-mm, mm), axis,
                        pb_rand_range(-deg, deg));
}

/* A blob of width sigma mm centred at b (mm from the grid's corner), sampled
 * at voxel centres of g, or of the padded grid pad (g in its middle). */
static void blob(const pb_geometry *g, const size_t *pad, const double b[3], double sigma, float *out)
{
    size_t n[3], lo[3] = {0, 0, 0};
    for (int a = 0; a < 3; a++) {
        n[a] = pad ? pad[a] : g->dims[a];
        if (pad)
            lo[a] = (pad[a] - g->dims[a]) / 2;
    }
    for (size_t z = 0; z < n[2]; z++)
        for (size_t y = 0; y < n[1]; y++)
            for (size_t x = 0; x < n[0]; x++) {
                size_t i[3] = {x, y, z};
                double r2 = 0.0;
                for (int a = 0; a < 3; a++) {
                    double p = ((double)i[a] - (double)lo[a] + 0.5) * g->voxel_size[a];
                    r2 += (p - b[a]) * (p - b[a]);
                }
                out[(z * n[1] + y) * n[0] + x] = (float)exp(-0.5 * r2 / (sigma * sigma));
            }
}

static void test_blob(void)
{
    for (int run = 0; run < 6; run++) {
        pb_geometry g = {{(size_t)pb_rand_range(22, 28), (size_t)pb_rand_range(22, 28), (size_t)pb_rand_range(22, 28)},
                         {pb_rand_range(2.0, 3.5), pb_rand_range(2.0, 3.5), pb_rand_range(2.0, 3.5)}};
        double c[3], b[3], moved_to[3];
        size_t pad[3];
        pbe_unitary_dims(&g, pad);
        for (int a = 0; a < 3; a++) {
            c[a] = 0.5 * (double)g.dims[a] * g.voxel_size[a];
            b[a] = c[a] + pb_rand_range(-4, 4);
        }
        pb_pose pose = random_pose(4.0, 12.0);
        /* kept inside the grid: what its edges cut of the tails stays under the bound below */
        /* out(x) = f(T x) is the blob centred where T^-1 takes b */
        pb_pose_apply_inverse(&pose, c, b, moved_to);
        const double sigma = 1.5 * fmax(g.voxel_size[0], fmax(g.voxel_size[1], g.voxel_size[2]));
        size_t n = g.dims[0] * g.dims[1] * g.dims[2], np = pad[0] * pad[1] * pad[2];
        float *f = malloc(sizeof(float) * n), *out = malloc(sizeof(float) * np), *want = malloc(sizeof(float) * np);
        blob(&g, NULL, b, sigma, f);
        blob(&g, pad, moved_to, sigma, want);
        pb_check(pbe_move_unitary(&g, f, pad, &pose, c, out) == PB_OK, "the move runs");
        double err = pb_max_abs_diff(out, want, np);
        pb_check(err < 2e-3, "a blob of %.1f mm on %zu x %zu x %zu voxels of %.2f x %.2f x %.2f mm lands where the "
                 "pose takes it: max error %.2e of 1", sigma, g.dims[0], g.dims[1], g.dims[2], g.voxel_size[0],
                 g.voxel_size[1], g.voxel_size[2], err);
        free(f);
        free(out);
        free(want);
    }
}

static void test_energy(void)
{
    for (int run = 0; run < 4; run++) {
        pb_geometry g = {{(size_t)pb_rand_range(10, 20), (size_t)pb_rand_range(10, 20), (size_t)pb_rand_range(10, 20)},
                         {pb_rand_range(1.0, 4.0), pb_rand_range(1.0, 4.0), pb_rand_range(1.0, 4.0)}};
        double c[3];
        size_t pad[3];
        pbe_unitary_dims(&g, pad);
        for (int a = 0; a < 3; a++)
            c[a] = 0.5 * (double)g.dims[a] * g.voxel_size[a] + pb_rand_range(-3, 3);
        size_t n = g.dims[0] * g.dims[1] * g.dims[2], np = pad[0] * pad[1] * pad[2];
        float *f = pb_random_volume(n), *out = malloc(sizeof(float) * np);
        for (size_t i = 0; i < n; i++)
            f[i] -= 0.5f; /* noise about 0, the energy all in its grain */
        pb_pose pose = random_pose(5.0, 15.0);
        pb_check(pbe_move_unitary(&g, f, pad, &pose, c, out) == PB_OK, "the move runs");
        double before = pb_dot(f, f, n), after = pb_dot(out, out, np);
        pb_check(fabs(after / before - 1.0) < 1e-5, "noise keeps its energy under a move: ratio %.8f", after / before);
        free(f);
        free(out);
    }
}

static void test_whole_voxels(void)
{
    pb_geometry g = {{12, 10, 14}, {2.0, 3.0, 2.5}};
    double c[3] = {12.0, 15.0, 17.5};
    size_t pad[3];
    pbe_unitary_dims(&g, pad);
    size_t n = 12 * 10 * 14, np = pad[0] * pad[1] * pad[2];
    float *f = pb_random_volume(n), *out = malloc(sizeof(float) * np);
    /* -3 to 3, never 0: each axis really shifts */
    int d[3];
    for (int a = 0; a < 3; a++) {
        d[a] = 1 + (int)(pb_rand_uniform() * 3.0);
        d[a] = pb_rand_uniform() < 0.5 ? -d[a] : d[a];
    }
    pb_pose pose = {{d[0] * 2.0, d[1] * 3.0, d[2] * 2.5}, {1, 0, 0, 0}};
    pb_check(pbe_move_unitary(&g, f, pad, &pose, c, out) == PB_OK, "the move runs");
    double worst = 0.0;
    size_t lo[3] = {(pad[0] - 12) / 2, (pad[1] - 10) / 2, (pad[2] - 14) / 2};
    for (size_t z = 0; z < 14; z++)
        for (size_t y = 0; y < 10; y++)
            for (size_t x = 0; x < 12; x++) {
                /* out(p) = f(p + d): voxel x of f lands at x - d */
                size_t q[3] = {x + lo[0] - (size_t)d[0], y + lo[1] - (size_t)d[1], z + lo[2] - (size_t)d[2]};
                float v = out[(q[2] * pad[1] + q[1]) * pad[0] + q[0]];
                worst = fmax(worst, fabs((double)v - (double)f[(z * 10 + y) * 12 + x]));
            }
    pb_check(worst == 0.0, "a shift by whole voxels (%d, %d, %d) moves every voxel exactly: worst %.2e", d[0], d[1],
             d[2], worst);
    free(f);
    free(out);
}

int main(void)
{
    pb_test_seed();
    test_blob();
    test_energy();
    test_whole_voxels();
    return pb_test_finish();
}
