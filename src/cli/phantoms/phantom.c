/* The paper's three phantoms, made analytically in mm and centred on the grid.
 * Each voxel holds the mean activity over its volume, as a scanner of that
 * resolution would see the object: exact overlaps along axes where the shape
 * is a box or a prism, sub-samples elsewhere, taken once per (x, y) column for
 * the rods and, for the head, only in voxels that a surface may cross; so the
 * default grids take well under a second on one core. */
#include <math.h>
#include <string.h>

#include "cli.h"
#include "phantom.h"
#include "phantom_shapes.h"

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
     * 128x128x64 version has twice those sizes, a 281.6 x 281.6 x 179.2 mm
     * field of view, so that motions given in voxels mean the same mm here. */
    int brain = kind == PBC_PHANTOM_BRAIN;
    dims[0] = dims[1] = brain ? 128 : 256;
    dims[2] = brain ? 64 : 256;
    voxel_size[0] = voxel_size[1] = brain ? 2.2 : 1.0;
    voxel_size[2] = brain ? 2.8 : 1.0;
}

/* Fraction of [lo, hi] (lo < hi) inside [a, b]: the exact mean of a step
 * profile over a voxel along one axis. */
double pbc_overlap(double lo, double hi, double a, double b)
{
    double from = fmax(lo, a), to = fmin(hi, b);
    return to > from ? (to - from) / (hi - lo) : 0.0;
}

/* The low edge, in mm from the grid's centre, of voxel i of an axis of n. */
double pbc_voxel_edge(size_t i, size_t n, double voxel_size)
{
    return ((double)i - 0.5 * (double)n) * voxel_size;
}


/* ---- homogeneity: one cube per octant ---------------------------------- */

/* Indexed by octant, bit 0 for +x, bit 1 for +y, bit 2 for +z: the earlier
 * demo's values, so that its results stay comparable. */
static const double cube_activity[8] = {1.0, 0.5, 2.0, 0.25, 1.5, 0.75, 3.0, 0.1};

/* The parts of voxel i of an axis inside the low (cover[0]) and the high
 * (cover[1]) cube. Each cube is inset by a twelfth of the default half field of
 * view (128 mm) from the centre planes and from its outer faces, so no two
 * cubes touch; the cubes are the same in mm on every grid. */
static void cube_cover(size_t i, size_t n, double voxel_size, double cover[2])
{
    double half = 128.0, inset = half / 12.0;
    double lo = pbc_voxel_edge(i, n, voxel_size), hi = lo + voxel_size;
    cover[0] = pbc_overlap(lo, hi, -half + inset, -inset);
    cover[1] = pbc_overlap(lo, hi, inset, half - inset);
}

/* The cubes are boxes, so a voxel's mean is a sum of products of 1-D overlaps. */
void pbc_phantom_homogeneity(const size_t n[3], const double d[3], float *out)
{
    for (size_t k = 0; k < n[2]; k++) {
        double fz[2];
        cube_cover(k, n[2], d[2], fz);
        for (size_t j = 0; j < n[1]; j++) {
            double fy[2], row[2] = {0.0, 0.0}; /* what the -x and +x cubes give on this row */
            cube_cover(j, n[1], d[1], fy);
            for (int yz = 0; yz < 4; yz++)
                for (int ox = 0; ox < 2; ox++)
                    row[ox] += cube_activity[ox + 2 * yz] * fy[yz & 1] * fz[yz >> 1];
            float *line = out + (k * n[1] + j) * n[0];
            for (size_t i = 0; i < n[0]; i++) {
                double fx[2];
                cube_cover(i, n[0], d[0], fx);
                line[i] = (float)(row[0] * fx[0] + row[1] * fx[1]);
            }
        }
    }
}

int pbc_phantom_make(pbc_phantom_kind kind, const size_t dims[3], const double voxel_size[3], float *out)
{
    switch (kind) {
    case PBC_PHANTOM_HOMOGENEITY: pbc_phantom_homogeneity(dims, voxel_size, out); return 0;
    case PBC_PHANTOM_DERENZO: pbc_phantom_derenzo(dims, voxel_size, out); return 0;
    case PBC_PHANTOM_BRAIN: pbc_phantom_brain(dims, voxel_size, out); return 0;
    }
    return pbc_fail(PBC_EXIT_USAGE, "unknown phantom kind %d", (int)kind);
}
