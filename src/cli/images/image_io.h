/* Volumes in files: NIfTI-1 (.nii, .nii.gz, through nifti_clib), Interfile as
 * STIR writes it (.hv with its data file), and bare float32 (.raw). The format
 * is chosen by the extension. */
#ifndef PBC_IMAGE_IO_H
#define PBC_IMAGE_IO_H

#include <stddef.h>

/* Where the grid sits in scanner space, kept from a NIfTI input so that the
 * output lands on the same place; converted to mm whatever the input's units.
 * A matrix means something only when its code is > 0; codes 0 and zero
 * matrices when the source had none. */
typedef struct pbc_orientation {
    int qform_code, sform_code;
    double qto_xyz[4][4];  /* voxel index -> mm, from the quaternion fields */
    double sto_xyz[4][4];  /* voxel index -> mm, the general affine */
    char descrip[80];
} pbc_orientation;

typedef struct pbc_image {
    size_t dims[3];        /* nx, ny, nz */
    double voxel_size[3];  /* mm */
    float *data;           /* nx*ny*nz floats per frame, x fastest, frame after frame, scaling already applied */
    size_t frames;         /* volumes along the 4th (time) dimension; 0 or 1: one 3-D volume. Only NIfTI
                            * carries more than one */
    double frame_seconds;  /* NIfTI's pixdim[4] when every frame lasts as long; 0 otherwise */
    pbc_orientation orientation;
    char source[4096];     /* the file the voxels were read from: an Interfile header's data file, else the
                            * file itself; "" for an image made here */
} pbc_image;

/* What the command line adds: --dims (needed for .raw, checked against the
 * header otherwise) and --voxel-size (.raw, default 1 mm; checked against the
 * header otherwise, and filling in a header that gives none). NULL members are
 * "not given". */
typedef struct pbc_read_hints {
    const size_t *dims;
    const double *voxel_size;
    int allow_frames; /* a 4-D NIfTI is read whole (dynamic frames); otherwise it is refused */
} pbc_read_hints;

/* The image's voxel-to-world affine (row-major 4x4, voxel index to RAS+ mm):
 * the sform when its code is > 0, else the qform when its code is > 0.
 * Returns 1 when there is one, 0 for an image with no placement. */
int pbc_image_affine(const pbc_image *img, double affine[16]);
/* out = the world mm of voxel index idx (fractional) under affine a. */
void pbc_affine_point(const double a[16], const double idx[3], double out[3]);
/* The world mm of the centre of a grid of dims under affine a. */
void pbc_grid_center(const double a[16], const size_t dims[3], double out[3]);
/* Places an image by an affine (both codes 1, scanner-based). */
void pbc_orientation_set_affine(pbc_orientation *o, const double affine[16]);

/* 1 when path's extension is one that pbc_image_read/pbc_image_write handle. */
int pbc_image_format_known(const char *path);

/* Reads a volume; hints may be NULL. On success img->data is malloc'ed (free
 * with pbc_image_free). Volumes with NaN or infinite voxels are refused. Returns
 * 0, or an exit status after printing "petblur: <path>: what is wrong; how to
 * fix it" (img->data is then NULL). */
int pbc_image_read(const char *path, const pbc_read_hints *hints, pbc_image *img);

/* Whether path's format can hold a grid of dims with frames frames (1: a 3-D
 * volume), so that a command refuses before any work what pbc_image_write
 * would refuse after it. Returns 0 or an exit status after the message. */
int pbc_image_check_output(const char *path, const size_t dims[3], size_t frames);

/* Writes img as float32 in the format of path's extension, atomically (OUT.hv
 * also writes its data file OUT.v, before the header). Returns 0 or an exit
 * status after printing the message. */
int pbc_image_write(const char *path, const pbc_image *img);

/* A fresh image of geometry dims/voxel_size with zeroed data and no
 * orientation (the NIfTI writer then writes pixdim only, codes 0). Returns 0,
 * or after printing the message PBC_EXIT_USAGE for a grid with no voxels or
 * more than 2^31 - 1, PBC_EXIT_RUNTIME when memory runs out. */
int pbc_image_alloc(pbc_image *img, const size_t dims[3], const double voxel_size[3]);
/* The same with `frames` volumes (a 4-D image when frames > 1). */
int pbc_image_alloc_frames(pbc_image *img, const size_t dims[3], const double voxel_size[3], size_t frames);

/* Voxels of one frame, and frames (at least 1). */
size_t pbc_image_frame_voxels(const pbc_image *img);
size_t pbc_image_frame_count(const pbc_image *img);

void pbc_image_free(pbc_image *img);

/* A NIfTI vector image, a registration's displacement field: (nx, ny, nz, 1,
 * 3), as NiftyReg, ITK and nibabel write it, or (nx, ny, nz, 3). What its
 * header says, read through nifti_clib after the checks a volume's header
 * gets (image_nifti_vectors.c); what the vectors mean is the reader's to say
 * (src/cli/fields/). */
typedef struct pbc_vector_header {
    size_t dims[3];
    double voxel_size[3];  /* mm */
    int placed;            /* 0: sform and qform codes 0 */
    double affine[16];     /* voxel index to RAS+ mm, as pbc_image_affine chooses it */
    double unit_mm;        /* mm per file unit (xyz_units): the vectors are in that unit */
    int intent_code;
    char intent_name[17];
    double intent_p1;
} pbc_vector_header;

/* The header of path, checked: a single-file NIfTI with three components
 * along its 5th (or 4th) dimension and a usable sform or qform. Returns 0 or
 * an exit status after the message, which names the file and the fix. */
int pbc_vector_header_read(const char *path, pbc_vector_header *h);
/* The vectors of path (whose header is h), in mm, the three components of a
 * voxel together, voxels x fastest: out holds 3 * nx * ny * nz floats. NaN
 * and infinities are kept for the caller to name. Returns 0 or an exit
 * status after the message. */
int pbc_vector_read(const char *path, const pbc_vector_header *h, float *out);


#endif
