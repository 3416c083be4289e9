/* Fresh PET heads for the estimator's tests (heads.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "estimate.h"
#include "heads.h"
#include "motion.h"
#include "testlib.h"

pb_geometry pbt_head_grid(size_t nx, size_t ny, size_t nz)
{
    const double v = pb_rand_range(2.0, 3.0);
    pb_geometry g = {{nx, ny, nz}, {v, v * pb_rand_range(0.9, 1.1), v * pb_rand_range(0.9, 1.2)}};
    return g;
}

void pbt_late_contrast(double c[PBT_TISSUES])
{
    c[0] = 1.0;
    c[1] = pb_rand_range(0.25, 0.4);
    c[2] = pb_rand_range(1.5, 2.5);
    c[3] = pb_rand_range(0.1, 0.3);
}

double pbt_gauss(void)
{
    double u = fmax(pb_rand_uniform(), 1e-300), v = pb_rand_uniform();
    return sqrt(-2.0 * log(u)) * cos(2.0 * 3.14159265358979323846 * v);
}

/* Each tissue's image: an ellipsoid of cortex, white matter inside it, a
 * few lesions and a vessel along z, smoothed to a PET resolution. */
void pbt_head_tissues(const pb_geometry *g, float *const t[PBT_TISSUES], float *tmp)
{
    const size_t n = g->dims[0] * g->dims[1] * g->dims[2];
    double axes[3], centre[3], lesion[3][3], vessel[2];
    for (int a = 0; a < 3; a++) {
        axes[a] = pb_rand_range(0.30, 0.38) * (double)g->dims[a];
        centre[a] = pb_rand_range(0.45, 0.55) * (double)g->dims[a];
    }
    for (int q = 0; q < 3; q++)
        for (int a = 0; a < 3; a++)
            lesion[q][a] = centre[a] + pb_rand_range(-0.6, 0.6) * axes[a];
    vessel[0] = centre[0] + pb_rand_range(-0.3, 0.3) * axes[0];
    vessel[1] = centre[1] + pb_rand_range(-0.3, 0.3) * axes[1];
    for (int k = 0; k < PBT_TISSUES; k++)
        memset(t[k], 0, sizeof(float) * n);
    for (size_t z = 0; z < g->dims[2]; z++)
        for (size_t y = 0; y < g->dims[1]; y++)
            for (size_t x = 0; x < g->dims[0]; x++) {
                const double p[3] = {(double)x, (double)y, (double)z};
                const size_t i = x + g->dims[0] * (y + g->dims[1] * z);
                double e = 0.0;
                for (int a = 0; a < 3; a++)
                    e += (p[a] - centre[a]) * (p[a] - centre[a]) / (axes[a] * axes[a]);
                int label = e < 0.35 ? 1 : e < 1.0 ? 0 : -1;
                for (int q = 0; q < 3; q++) {
                    double d = 0.0;
                    for (int a = 0; a < 3; a++)
                        d += (p[a] - lesion[q][a]) * (p[a] - lesion[q][a]);
                    if (d < 2.5 * 2.5 && e < 1.0)
                        label = 2;
                }
                if ((p[0] - vessel[0]) * (p[0] - vessel[0]) + (p[1] - vessel[1]) * (p[1] - vessel[1]) < 1.6 * 1.6)
                    label = 3;
                if (label >= 0)
                    t[label][i] = 1.0f;
            }
    for (int k = 0; k < PBT_TISSUES; k++)
        pbe_smooth(NULL, g, t[k], 2.0 * g->voxel_size[0], tmp);
}

void pbt_mix(const float *const t[PBT_TISSUES], const double *c, size_t n, float *out)
{
    for (size_t i = 0; i < n; i++) {
        double s = 0.0;
        for (int k = 0; k < PBT_TISSUES; k++)
            s += c[k] * (double)t[k][i];
        out[i] = (float)s;
    }
}

/* How far pose a lies from b where the head is: the RMS displacement of
 * points spread over a ball of PBT_RADIUS_MM about the centre. */
double pbt_pose_distance(const pb_pose *a, const pb_pose *b)
{
    pb_pose inv, d;
    pb_pose_invert(a, &inv);
    pb_pose_compose(&inv, b, &d);
    pb_pose_normalized(&d, &d);
    double s = sqrt(d.rotation[1] * d.rotation[1] + d.rotation[2] * d.rotation[2] + d.rotation[3] * d.rotation[3]);
    double angle = 2.0 * atan2(s, fabs(d.rotation[0]));
    double t2 = d.translation[0] * d.translation[0] + d.translation[1] * d.translation[1] +
                d.translation[2] * d.translation[2];
    return sqrt(t2 + 0.4 * PBT_RADIUS_MM * PBT_RADIUS_MM * angle * angle);
}


pb_status pbt_late_head(const pb_geometry *g, float *out)
{
    const size_t n = g->dims[0] * g->dims[1] * g->dims[2];
    const size_t longest = g->dims[0] > g->dims[1] ? (g->dims[0] > g->dims[2] ? g->dims[0] : g->dims[2])
                                                   : (g->dims[1] > g->dims[2] ? g->dims[1] : g->dims[2]);
    float *t[PBT_TISSUES] = {NULL}, *tmp = malloc(sizeof(float) * longest);
    int room = tmp != NULL;
    for (int k = 0; k < PBT_TISSUES; k++)
        room &= (t[k] = malloc(sizeof(float) * n)) != NULL;
    if (room) {
        double c[PBT_TISSUES];
        pbt_head_tissues(g, t, tmp);
        pbt_late_contrast(c);
        pbt_mix((const float *const *)t, c, n, out);
    }
    for (int k = 0; k < PBT_TISSUES; k++)
        free(t[k]);
    free(tmp);
    return room ? PB_OK : PB_ERR_OUT_OF_MEMORY;
}

pb_pose pbt_jittered(const pb_pose *p, double mm)
{
    double xi[6], length = 0.0;
    for (int i = 0; i < 6; i++) {
        xi[i] = pbt_gauss();
        length += xi[i] * xi[i];
    }
    for (int i = 0; i < 6; i++)
        xi[i] *= mm / sqrt(length) / (i < 3 ? 1.0 : PBT_RADIUS_MM);
    pb_pose out;
    pb_pose_perturb(p, xi, &out);
    pb_pose_normalized(&out, &out);
    return out;
}

void pbt_jerk(double lo, double hi, pb_pose *a, pb_pose *b)
{
    double axis[3] = {pbt_gauss(), pbt_gauss(), pbt_gauss()}, jaxis[3] = {pbt_gauss(), pbt_gauss(), pbt_gauss()};
    *a = pb_test_pose(pb_rand_range(-2.0, 2.0), pb_rand_range(-2.0, 2.0), pb_rand_range(-2.0, 2.0), axis,
                      pb_rand_range(0.0, 3.0));
    double shift[3] = {pbt_gauss(), pbt_gauss(), pbt_gauss()}, len = 0.0;
    for (int i = 0; i < 3; i++)
        len += shift[i] * shift[i];
    const double jump = pb_rand_range(lo, hi);
    for (int i = 0; i < 3; i++)
        shift[i] *= jump / sqrt(len);
    const pb_pose step = pb_test_pose(shift[0], shift[1], shift[2], jaxis, pb_rand_range(lo, hi));
    pb_pose_compose(&step, a, b);
    pb_pose_normalized(b, b);
}
