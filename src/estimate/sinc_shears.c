/* Rigid moves that keep a volume's energy, its noise's included. A pose is
 * applied as a shift and nine shears (three turns about the axes, each
 * three shears), every shear a shift of lines by trigonometric (periodic
 * sinc) interpolation on a grid padded to odd sizes: each line shift is an
 * orthogonal matrix, so the moved volume has exactly the energy it had.
 * Trilinear resampling smooths noise by an amount that depends on where the
 * pose puts the samples between voxels; a comparison of many noisy frames
 * moved by different poses then follows the smoothing, not the frames'
 * agreement (contrast_poses.c).
 *
 * The lines are a few dozen samples, so each shift is a direct sum with the
 * kernel in closed form (the Dirichlet kernel, O(n) sines a line) rather
 * than an FFT: no library for the package and the device machine to carry. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "estimate.h"
#include "motion.h"

#define PB_PI 3.14159265358979323846

static size_t odd_padded(size_t n)
{
    size_t margin = n / 4 > 4 ? n / 4 : 4;
    size_t p = n + 2 * margin;
    return p % 2 ? p : p + 1;
}

void pbe_unitary_dims(const pb_geometry *g, size_t pad[3])
{
    for (int a = 0; a < 3; a++)
        pad[a] = odd_padded(g->dims[a]);
}

/* h's line of n samples (odd n), stride apart, read as a periodic
 * trigonometric polynomial and sampled at i + s: out[i] = sum_j h[j] D(i + s
 * - j), D(x) = sin(pi x) / (n sin(pi x / n)). Only the line's support (its
 * samples from the first to the last that is not 0) enters the sum. buf
 * holds 4 n floats. */
static void shift_line(float *h, size_t n, size_t stride, double s, float *buf)
{
    float *line = buf, *restrict rk = buf + n, *restrict acc = buf + 3 * n;
    size_t j0 = n, j1 = 0;
    for (size_t j = 0; j < n; j++) {
        line[j] = h[j * stride];
        if (line[j] != 0.0f) {
            j0 = j < j0 ? j : j0;
            j1 = j;
        }
    }
    /* the padding's lines, most of them, stay empty */
    if (j0 == n)
        return;
    double r = floor(s + 0.5), f = s - r;
    long rs = (long)r % (long)n;
    if (rs < 0)
        rs += (long)n;
    if (fabs(f) < 1e-9) {
        for (size_t i = 0; i < n; i++)
            h[i * stride] = line[(i + (size_t)rs) % n];
        return;
    }
    /* D(f - d) for d = j - i - rs mod n, held backwards and twice over:
     * rk[2 n - 1 - d] = rk[n - 1 - d] = D(f - d), so that the sum below runs
     * forwards through it without a modulo. sin(pi (f - d)) = (-1)^d
     * sin(pi f). */
    const double sf = sin(PB_PI * f), dn = (double)n;
    /* sin(pi (f - d) / n) by turning one step of pi / n at a time: two sines a
     * line instead of n, the sum's rounding far below the kernel's float */
    const double sb = sin(PB_PI / dn), cb = cos(PB_PI / dn);
    double s_d = sin(PB_PI * f / dn), c_d = cos(PB_PI * f / dn);
    for (size_t d = 0; d < n; d++) {
        rk[2 * n - 1 - d] = rk[n - 1 - d] = (float)((d % 2 ? -sf : sf) / (dn * s_d));
        double s_next = s_d * cb - c_d * sb;
        c_d = c_d * cb + s_d * sb;
        s_d = s_next;
    }
    /* out[i] = sum over j of src[j] D(f - d), d = (j0 + j - i - rs) mod n:
     * summed a sample j at a time into every out[i] (the same order of
     * adds for each i as one out[i] at a time, so the same floats), where
     * the i run forwards through rk and vectorise without reordering a sum
     * (the shears' lines are most of the motion estimate's time). d at j = 0
     * is b0 - i up to i = b0 and b0 + n - i beyond. */
    const float *src = line + j0;
    const size_t len = j1 - j0 + 1, b0 = (j0 + 2 * n - (size_t)rs) % n;
    memset(acc, 0, sizeof(float) * n);
    for (size_t j = 0; j < len; j++) {
        const float v = src[j];
        const float *near = rk + (2 * n - 1 - b0 - j), *far = rk + (n - j);
        for (size_t i = 0; i <= b0; i++)
            acc[i] += v * near[i];
        for (size_t i = b0 + 1; i < n; i++)
            acc[i] += v * far[i - b0 - 1];
    }
    for (size_t i = 0; i < n; i++)
        h[i * stride] = acc[i];
}

/* Every line along axis u shifted by a + b (index along v less cv). */
static void shift_lines(float *h, const size_t n[3], int u, int v, double a, double b, double cv, float *buf)
{
    const size_t stride[3] = {1, n[0], n[0] * n[1]};
    const int w = 3 - u - v; /* the third axis when v is not u */
    const int other[2] = {v == u ? (u + 1) % 3 : v, v == u ? (u + 2) % 3 : w};
    for (size_t i = 0; i < n[other[0]]; i++)
        for (size_t j = 0; j < n[other[1]]; j++) {
            float *line = h + i * stride[other[0]] + j * stride[other[1]];
            double at = other[0] == v ? (double)i : (double)j;
            shift_line(line, n[u], stride[u], a + b * (at - cv), buf);
        }
}

/* h(y) -> h(R y) for R turning the (u, v) plane by theta, y in mm about the
 * centre: R = S_u(p) S_v(q) S_u(p), p = -tan(theta / 2), q = sin(theta),
 * each shear h(y + p y_v e_u) a shift of the lines along u, in voxels of u,
 * by p y_v. */
static void turn_plane(float *h, const size_t n[3], const double vs[3], const double cidx[3], int u, int v,
                       double theta, float *buf)
{
    if (fabs(theta) < 1e-12)
        return;
    const double p = -tan(0.5 * theta), q = sin(theta);
    shift_lines(h, n, u, v, 0.0, p * vs[v] / vs[u], cidx[v], buf);
    shift_lines(h, n, v, u, 0.0, q * vs[u] / vs[v], cidx[u], buf);
    shift_lines(h, n, u, v, 0.0, p * vs[v] / vs[u], cidx[v], buf);
}

pb_status pbe_move_unitary(const pb_geometry *g, const float *f, const size_t pad[3], const pb_pose *pose,
                           const double c[3], float *out)
{
    size_t lo[3], longest = 0;
    double cidx[3], m[16];
    for (int a = 0; a < 3; a++) {
        lo[a] = (pad[a] - g->dims[a]) / 2;
        /* the centre c (mm from the grid's corner) in padded voxel indices */
        cidx[a] = c[a] / g->voxel_size[a] - 0.5 + (double)lo[a];
        longest = pad[a] > longest ? pad[a] : longest;
    }
    float *buf = malloc(sizeof(float) * 4 * longest);
    if (!buf)
        return PB_ERR_OUT_OF_MEMORY;
    memset(out, 0, sizeof(float) * pad[0] * pad[1] * pad[2]);
    for (size_t z = 0; z < g->dims[2]; z++)
        for (size_t y = 0; y < g->dims[1]; y++)
            memcpy(out + ((z + lo[2]) * pad[1] + y + lo[1]) * pad[0] + lo[0],
                   f + (z * g->dims[1] + y) * g->dims[0], sizeof(float) * g->dims[0]);
    /* out(y) = f(c + t + R y), y in mm about c: first the shift by t, then
     * the turn R = Rx(a) Ry(b) Rz(g), applied as h(Rx Ry Rz y) one axis at
     * a time. */
    pb_status st = pb_pose_to_matrix(pose, m);
    for (int a = 0; a < 3 && st == PB_OK; a++)
        if (!isfinite(pose->translation[a]))
            st = PB_ERR_INVALID_ARGUMENT;
    if (st != PB_OK) {
        free(buf);
        return st;
    }
    for (int a = 0; a < 3; a++)
        shift_lines(out, pad, a, a, pose->translation[a] / g->voxel_size[a], 0.0, 0.0, buf);
    double r02 = fmax(-1.0, fmin(1.0, m[2]));
    double ax = atan2(-m[6], m[10]), by = asin(r02), gz = atan2(-m[1], m[0]);
    turn_plane(out, pad, g->voxel_size, cidx, 1, 2, ax, buf);
    turn_plane(out, pad, g->voxel_size, cidx, 2, 0, by, buf);
    turn_plane(out, pad, g->voxel_size, cidx, 0, 1, gz, buf);
    free(buf);
    return PB_OK;
}
