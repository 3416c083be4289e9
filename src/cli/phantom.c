/* The paper's three phantoms, made analytically in mm and centred on the grid.
 * Each voxel holds the mean activity over its volume (exact overlaps where the
 * shape is a box, sub-samples elsewhere), as a scanner of that resolution
 * would see the object. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "phantom.h"

static const char *const kind_names[] = {"homogeneity", "derenzo", "brain"};

int pbc_phantom_parse(const char *name, pbc_phantom_kind *kind)
{
    for (int k = 0; k < 3; k++)
        if (!strcmp(name, kind_names[k])) {
            *kind = (pbc_phantom_kind)k;
            return 0;
        }
    return -1;
}

const char *pbc_phantom_name(pbc_phantom_kind kind)
{
    return (unsigned)kind < 3 ? kind_names[kind] : "unknown";
}

void pbc_phantom_default_geometry(pbc_phantom_kind kind, size_t dims[3], double voxel_size[3])
{
    /* The Zubal head is 256x256x128 voxels of 1.1 x 1.1 x 1.4 mm; the paper's
     * 128x128x64 version has twice those sizes. */
    int brain = kind == PBC_PHANTOM_BRAIN;
    dims[0] = dims[1] = brain ? 128 : 256;
    dims[2] = brain ? 64 : 256;
    voxel_size[0] = voxel_size[1] = brain ? 2.2 : 1.0;
    voxel_size[2] = brain ? 2.8 : 1.0;
}

/* Length of [a0, a1] inside [b0, b1], as a fraction of the first. */
static double overlap(double a0, double a1, double b0, double b1)
{
    double lo = fmax(a0, b0), hi = fmin(a1, b1);
    return hi > lo ? (hi - lo) / (a1 - a0) : 0.0;
}

/* Eight cubes, one per octant, inset from each other and from the edge by a
 * twelfth of the octant; the activities are those of the earlier demo. */
static void homogeneity(const size_t n[3], const double d[3], float *out)
{
    static const float activity[8] = {1.0f, 0.5f, 2.0f, 0.25f, 1.5f, 0.75f, 3.0f, 0.1f};
    double half[3], inset[3];
    for (int a = 0; a < 3; a++) {
        half[a] = 0.5 * (double)n[a] * d[a];
        inset[a] = half[a] / 12.0;
    }
    for (size_t k = 0; k < n[2]; k++)
        for (size_t j = 0; j < n[1]; j++)
            for (size_t i = 0; i < n[0]; i++) {
                size_t idx[3] = {i, j, k};
                double v = 0.0;
                for (int o = 0; o < 8; o++) {
                    double f = activity[o];
                    for (int a = 0; a < 3 && f > 0.0; a++) {
                        double lo = ((o >> a) & 1) * half[a] + inset[a], hi = lo + half[a] - 2.0 * inset[a];
                        f *= overlap((double)idx[a] * d[a], (double)(idx[a] + 1) * d[a], lo, hi);
                    }
                    v += f;
                }
                out[i + n[0] * (j + n[1] * k)] = (float)v;
            }
}

#define PB_PI 3.14159265358979323846

enum { SUB = 4 }; /* sub-samples per axis where no closed form is at hand */

/* Adds value * (the fraction of each pixel inside the disc) to a 2-D map. */
static void add_disc(float *map, const size_t n[3], const double d[3], double cx, double cy, double r, float value)
{
    long i0 = (long)floor((cx - r) / d[0]), i1 = (long)floor((cx + r) / d[0]);
    long j0 = (long)floor((cy - r) / d[1]), j1 = (long)floor((cy + r) / d[1]);
    for (long j = j0 < 0 ? 0 : j0; j <= j1 && j < (long)n[1]; j++)
        for (long i = i0 < 0 ? 0 : i0; i <= i1 && i < (long)n[0]; i++) {
            int inside = 0;
            for (int sj = 0; sj < SUB; sj++)
                for (int si = 0; si < SUB; si++) {
                    double x = ((double)i + (si + 0.5) / SUB) * d[0] - cx, y = ((double)j + (sj + 0.5) / SUB) * d[1] - cy;
                    inside += x * x + y * y <= r * r;
                }
            map[i + (size_t)n[0] * (size_t)j] += value * (float)inside / (float)(SUB * SUB);
        }
}

/* The common Derenzo layout: six 60-degree sectors, each a triangular lattice of
 * rods of one diameter with centre spacing twice the diameter, apex towards the
 * centre. At 256 mm in-plane (the default) the insert has its true size: rods
 * of 11.1 to 3.2 mm within a 100 mm radius; other grids scale it to 85 % of
 * the smaller in-plane field of view. */
static void derenzo_rods(float *map, const size_t n[3], const double d[3], double scale)
{
    static const double diameter[6] = {11.1, 9.5, 7.9, 6.4, 4.8, 3.2};
    const double radius = 100.0 * scale, gap = 1.5 * scale;
    double cx = 0.5 * (double)n[0] * d[0], cy = 0.5 * (double)n[1] * d[1];
    for (int s = 0; s < 6; s++) {
        /* Sectors start at -30 degrees, so that the central coronal and
         * sagittal slices cut through rods rather than between sectors. */
        double rod = diameter[s] * scale, pitch = 2.0 * rod, a0 = PB_PI / 3.0 * s - PB_PI / 6.0, a1 = a0 + PB_PI / 3.0;
        double u[2] = {cos(a0), sin(a0)}, v[2] = {cos(a1), sin(a1)}, mid = a0 + PB_PI / 6.0;
        /* The apex rod sits on the bisector, rod/2 + gap from both edges; rows
         * a + b = m are added while the row's end rods stay inside the insert. */
        double o[2] = {2.0 * (0.5 * rod + gap) * cos(mid), 2.0 * (0.5 * rod + gap) * sin(mid)};
        int rows = 0;
        while (hypot(o[0] + pitch * (rows + 1) * u[0], o[1] + pitch * (rows + 1) * u[1]) + 0.5 * rod <= radius)
            rows++;
        for (int a = 0; a <= rows; a++)
            for (int b = 0; a + b <= rows; b++)
                add_disc(map, n, d, cx + o[0] + pitch * (a * u[0] + b * v[0]), cy + o[1] + pitch * (a * u[1] + b * v[1]),
                         0.5 * rod, 1.0f);
    }
}

/* Rods (activity 1) between two plates (0.5), in a cold body: the plates are
 * discs as wide as the insert, 10 mm thick, and the whole phantom spans 80 % of
 * the axial field of view. */
static int derenzo(const size_t n[3], const double d[3], float *out)
{
    double fov = fmin((double)n[0] * d[0], (double)n[1] * d[1]), scale = 0.85 * fov / 216.0;
    size_t plane = n[0] * n[1];
    float *rods = calloc(2 * plane, sizeof *rods), *plate = rods + plane;
    if (!rods)
        return pbc_fail(PBC_EXIT_RUNTIME, "out of memory for the Derenzo phantom's rod map");
    derenzo_rods(rods, n, d, scale);
    add_disc(plate, n, d, 0.5 * (double)n[0] * d[0], 0.5 * (double)n[1] * d[1], 104.0 * scale, 0.5f);
    double zlen = 0.8 * (double)n[2] * d[2], z0 = 0.5 * ((double)n[2] * d[2] - zlen), thick = fmin(10.0 * scale, 0.2 * zlen);
    for (size_t k = 0; k < n[2]; k++) {
        double a = (double)k * d[2], b = a + d[2];
        double fp = overlap(a, b, z0, z0 + thick) + overlap(a, b, z0 + zlen - thick, z0 + zlen);
        double fr = overlap(a, b, z0 + thick, z0 + zlen - thick);
        float *slice = out + k * plane;
        for (size_t p = 0; p < plane; p++)
            slice[p] = (float)(fr * (double)rods[p] + fp * (double)plate[p]);
    }
    free(rods);
    return 0;
}

/* An analytic head in the spirit of the Zubal phantom, built of ellipsoids
 * painted in order (a later one replaces an earlier one where they overlap).
 * Activities are FDG-like ratios: grey matter 4 : white matter 1 (the usual
 * 3-4 : 1 of FDG brain scans), deep grey nuclei as cortex or a little above,
 * cerebellum a little below cortex, scalp and muscle 0.5, skull 0.1, CSF 0.05,
 * and three hot lesions of 6-8 (5 to 10 mm), one cortical, two deep. Sizes
 * in mm, x left-right, y posterior-anterior, z inferior-superior, at the default
 * 281.6 x 281.6 x 179.2 mm field of view; other grids scale the head to fit. */
typedef struct ellipsoid {
    double c[3], r[3];
    float activity;
} ellipsoid;

static const ellipsoid head[] = {
    {{0, 0, 0}, {72, 92, 84}, 0.5f},       /* scalp and soft tissue */
    {{0, 0, 2}, {67, 87, 79}, 0.1f},       /* skull */
    {{0, 0, 3}, {62, 82, 74}, 0.05f},      /* CSF between skull and brain */
    {{0, 2, 6}, {60, 80, 70}, 4.0f},       /* cortex (grey matter) */
    {{0, 4, 10}, {51, 70, 58}, 1.0f},      /* white matter */
    {{0, -48, -36}, {40, 22, 17}, 3.2f},   /* cerebellum */
    {{0, -16, -38}, {10, 12, 26}, 1.5f},   /* brainstem */
    {{-9, 8, 16}, {5, 26, 10}, 0.05f},     /* lateral ventricles */
    {{9, 8, 16}, {5, 26, 10}, 0.05f},
    {{-13, 22, 10}, {5, 10, 7}, 4.0f},     /* caudate nuclei */
    {{13, 22, 10}, {5, 10, 7}, 4.0f},
    {{-25, 5, 2}, {6, 14, 9}, 4.5f},       /* putamen */
    {{25, 5, 2}, {6, 14, 9}, 4.5f},
    {{-9, -10, 4}, {8, 11, 7}, 4.0f},      /* thalami */
    {{9, -10, 4}, {8, 11, 7}, 4.0f},
    {{42, 24, 1}, {5, 5, 5}, 8.0f},        /* lesions */
    {{-22, -32, 22}, {4, 4, 4}, 7.0f},
    {{12, -8, 2}, {3, 3, 3}, 6.0f},
};
enum { HEAD_PARTS = sizeof head / sizeof head[0] };

static float head_activity(const double p[3])
{
    float v = 0.0f;
    for (int e = 0; e < HEAD_PARTS; e++) {
        double q = 0.0;
        for (int a = 0; a < 3 && q <= 1.0; a++) {
            double t = (p[a] - head[e].c[a]) / head[e].r[a];
            q += t * t;
        }
        if (q <= 1.0)
            v = head[e].activity;
        else if (e == 0)
            return 0.0f; /* outside the scalp is air */
    }
    return v;
}

static void brain(const size_t n[3], const double d[3], float *out)
{
    static const double fov[3] = {281.6, 281.6, 179.2};
    double scale = INFINITY, centre[3];
    for (int a = 0; a < 3; a++) {
        scale = fmin(scale, (double)n[a] * d[a] / fov[a]);
        centre[a] = 0.5 * (double)n[a] * d[a];
    }
    for (size_t k = 0; k < n[2]; k++)
        for (size_t j = 0; j < n[1]; j++)
            for (size_t i = 0; i < n[0]; i++) {
                size_t idx[3] = {i, j, k};
                double sum = 0.0, p[3];
                for (int s = 0; s < SUB * SUB * SUB; s++) {
                    int sub[3] = {s % SUB, s / SUB % SUB, s / (SUB * SUB)};
                    for (int a = 0; a < 3; a++)
                        p[a] = (((double)idx[a] + (sub[a] + 0.5) / SUB) * d[a] - centre[a]) / scale;
                    sum += (double)head_activity(p);
                }
                out[i + n[0] * (j + n[1] * k)] = (float)(sum / (SUB * SUB * SUB));
            }
}

int pbc_phantom_make(pbc_phantom_kind kind, const size_t dims[3], const double voxel_size[3], float *out)
{
    switch (kind) {
    case PBC_PHANTOM_HOMOGENEITY: homogeneity(dims, voxel_size, out); return 0;
    case PBC_PHANTOM_DERENZO: return derenzo(dims, voxel_size, out);
    case PBC_PHANTOM_BRAIN: brain(dims, voxel_size, out); return 0;
    }
    return pbc_fail(PBC_EXIT_USAGE, "unknown phantom kind %d", (int)kind);
}
