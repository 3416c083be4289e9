/* The paper's three phantoms (section 4), made analytically at any grid size. */
#ifndef PBC_PHANTOM_H
#define PBC_PHANTOM_H

#include <stddef.h>

typedef enum pbc_phantom_kind {
    PBC_PHANTOM_HOMOGENEITY, /* 8 cubes of constant, different activities; default 256^3, 1 mm */
    PBC_PHANTOM_DERENZO,     /* rods between two plates, six sectors of one rod diameter each; default 256^3, 1 mm */
    PBC_PHANTOM_BRAIN        /* analytic head (scalp, skull, grey/white matter, ventricles, lesions);
                                default 128x128x64, 2.2 x 2.2 x 2.8 mm (the Zubal head's field of view) */
} pbc_phantom_kind;

/* Parses "homogeneity", "derenzo" or "brain"; returns 0 on success, -1 otherwise. */
int pbc_phantom_parse(const char *name, pbc_phantom_kind *kind);
const char *pbc_phantom_name(pbc_phantom_kind kind);

/* The default grid of a kind. */
void pbc_phantom_default_geometry(pbc_phantom_kind kind, size_t dims[3], double voxel_size[3]);

/* Fills out (dims[0]*dims[1]*dims[2] floats, x fastest) with the phantom's
 * activity (relative units, FDG-like ratios) on the given grid. The object is
 * analytic in mm, of a fixed size (the default grid's field of view) and
 * centred on the grid: a finer grid samples the same object, a smaller one
 * crops it. Array axes run as the object's x (across, +x the lesions' side), y
 * (back to front) and z (up). Returns 0, or an exit status after printing the
 * message. */
int pbc_phantom_make(pbc_phantom_kind kind, const size_t dims[3], const double voxel_size[3], float *out);

#endif
