/* What the phantom files share: the exact overlaps along an axis, voxel edges
 * in mm from the grid's centre, and one fill function per phantom. */
#ifndef PBC_PHANTOM_SHAPES_H
#define PBC_PHANTOM_SHAPES_H

#include <stddef.h>

#define PB_PI 3.14159265358979323846

/* Fraction of [lo, hi] (lo < hi) inside [a, b]: the exact mean of a step
 * profile over a voxel along one axis. */
double pbc_overlap(double lo, double hi, double a, double b);

/* The low edge, in mm from the grid's centre, of voxel i of an axis of n. */
double pbc_voxel_edge(size_t i, size_t n, double voxel_size);

void pbc_phantom_homogeneity(const size_t n[3], const double d[3], float *out);
void pbc_phantom_derenzo(const size_t n[3], const double d[3], float *out);
void pbc_phantom_brain(const size_t n[3], const double d[3], float *out);

#endif
