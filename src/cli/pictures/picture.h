/* Pictures of volumes for people: three orthogonal central slices (axial,
 * coronal, sagittal) of each volume side by side, one row per volume, in a
 * colour map with a labelled colour bar; written as PNG through libpng.
 *
 * All slices share one pixel scale (the largest extent of the field of view
 * becomes 256 to 512 pixels), so each keeps its true aspect ratio. Activity
 * rows share one scale from min(0, smallest) to max(0, largest) in "magma";
 * signed rows share one symmetric about zero in a blue-white-red map, with a
 * colour bar of their own. NaN and infinite voxels are drawn green, with a
 * legend line when there are any. The orientation of each view is described
 * beside `views` in picture.c. */
#ifndef PBC_PICTURE_H
#define PBC_PICTURE_H

#include <stddef.h>

typedef struct pbc_picture_row {
    const char *title;      /* "input", "output", "difference": drawn left of the row; NULL for none; shortened
                               past 24 characters */
    const float *data;      /* nx*ny*nz, x fastest */
    int signed_map;         /* 1: a diverging map symmetric about zero (differences) */
} pbc_picture_row;

typedef struct pbc_picture {
    size_t dims[3];
    double voxel_size[3];   /* mm; slices are drawn with their true aspect ratio */
    const pbc_picture_row *rows;
    int row_count;          /* 1 to 4 */
} pbc_picture;

/* Renders and writes the picture to path (.png), atomically. Returns 0 or an
 * exit status after printing the message: PBC_EXIT_USAGE for a picture that
 * cannot be drawn (row count, dimensions, voxel sizes), PBC_EXIT_RUNTIME for
 * memory and file errors. */
int pbc_picture_write(const char *path, const pbc_picture *picture);

#endif
