/* Private to the image readers and writers: what image_io.c offers the
 * per-format files (image_nifti.c, image_interfile.c, image_raw.c), and what
 * they offer it. */
#ifndef PBC_IMAGE_FORMATS_H
#define PBC_IMAGE_FORMATS_H

#include <stddef.h>
#include <stdio.h>

#include "atomic_file.h"
#include "image_io.h"

/* The sample types found in files; every one is read into float. */
typedef enum pbc_sample_type {
    PBC_SAMPLE_U8, PBC_SAMPLE_I8, PBC_SAMPLE_U16, PBC_SAMPLE_I16,
    PBC_SAMPLE_U32, PBC_SAMPLE_I32, PBC_SAMPLE_F32, PBC_SAMPLE_F64
} pbc_sample_type;

typedef struct pbc_sample_format {
    pbc_sample_type type;
    int swap;               /* the file's byte order differs from this machine's */
    double slope, inter;    /* value = slope * stored + inter */
} pbc_sample_format;

/* Reads up to `bytes` bytes into buf from source; returns how many it read
 * (fewer only at the end of the data or on an error). */
typedef size_t (*pbc_read_fn)(void *source, void *buf, size_t bytes);

size_t pbc_sample_size(pbc_sample_type type);
int pbc_host_is_big_endian(void);

/* Refuses a grid with no voxels or more than 2^31 - 1; path (may be NULL) names
 * the file in the message. Returns 0 or an exit status. */
int pbc_image_check_grid(const char *path, const size_t dims[3]);

/* Called by each reader once the header is parsed and img->dims and
 * img->voxel_size are set (a voxel size of 0 where the header gives none):
 * settles the geometry against the hints, checks the grid's size and
 * allocates img->data. Returns 0 or an exit status after printing the message. */
int pbc_image_prepare(const char *path, const pbc_read_hints *hints, pbc_image *img);

/* Reads img's voxel count of samples from source into img->data. data_path
 * names the file the samples come from, for the message when they run out. */
int pbc_samples_read(const char *data_path, pbc_read_fn read, void *source, const pbc_sample_format *format,
                     pbc_image *img);

/* fread as a pbc_read_fn, for a FILE *. */
size_t pbc_read_stdio(void *file, void *buf, size_t bytes);

/* Writes n floats as little-endian float32; returns 0 or -1 (errno set). */
int pbc_write_f32le(FILE *f, const float *data, size_t n);

/* The voxel count of img (its dims are already checked). */
size_t pbc_image_voxels(const pbc_image *img);

/* The per-format halves of pbc_image_read and pbc_image_write, with the same
 * contracts; path's extension is already known to be theirs. */
/* What a NIfTI header says, checked before nifti_clib parses it
 * (image_nifti_header.c): a single-file NIfTI-1 or NIfTI-2, dim[0] in 1..7,
 * every used dimension >= 1, a supported data type, a sane vox_offset and no
 * more data promised than the file holds. */
typedef struct pbc_nifti_facts {
    int version, swap;
    long long vox_offset;
    double pixdim[3]; /* as written: nifti_clib turns 0 into 1 */
    /* The orientation as written: nifti_clib turns NaN and infinity into 0. */
    int qform_code, sform_code;
    double qfac, quatern[3], qoffset[3], srow[12];
    /* The scaling as written: nifti_clib turns NaN and infinity into 0. */
    double scl_slope, scl_inter;
    double intent_p1; /* as written: nifti_clib turns NaN and infinity into 0 */
} pbc_nifti_facts;
int pbc_nifti_check_header(const char *path, pbc_nifti_facts *facts);
/* The grid's place in the world as nibabel chooses it (image_nifti_orientation.c):
 * the sform when its code is set, else the qform when its code is set, else
 * none; in mm (unit_mm per file unit). A form that would be used but is not
 * finite, not a rotation (qform) or singular is refused: 0 or an exit status
 * after the message. */
int pbc_nifti_orientation(const char *path, const pbc_nifti_facts *facts, double unit_mm, pbc_orientation *o);

/* What the volume reader (image_nifti.c) shares with the vector reader
 * (image_nifti_vectors.c), on a nifti_image * (void *: nifti2_io.h stays in
 * those two files): nibabel's rule for scl_slope and scl_inter, the sample
 * format of the data type (0 or an exit status after the message), mm per
 * file unit of xyz_units, and znzread as a pbc_read_fn. */
int pbc_nifti_check_scaling(const char *path, const pbc_nifti_facts *facts);
int pbc_nifti_sample_format(const char *path, const void *nim, pbc_sample_format *format);
double pbc_nifti_unit_mm(int xyz_units);
size_t pbc_read_znz(void *source, void *buf, size_t bytes);

int pbc_nifti_read(const char *path, const pbc_read_hints *hints, pbc_image *img);
int pbc_nifti_write(const char *path, const pbc_image *img);
/* Whether NIfTI-1 holds the grid and frames: 0 or an exit status. */
int pbc_nifti_check_output(const char *path, const size_t dims[3], size_t frames);
int pbc_interfile_read(const char *path, const pbc_read_hints *hints, pbc_image *img);
int pbc_interfile_write(const char *path, const pbc_image *img);
/* The data file that writing the header path (OUT.hv) also writes (OUT.v). */
int pbc_interfile_data_name(const char *path, char *out, size_t size);
/* STIR's placement of an Interfile image (image_placement.c): the RAS+
 * voxel-to-world affine of its patient position and first pixel offsets
 * (NaN where absent), or an exit status after the message; and back, 1 with the
 * keys when the affine is one that Interfile can hold, 0 when it is not. */
int pbc_stir_affine(const char *path, const char *orientation, const char *rotation, const double fpo[3],
                    const size_t dims[3], const double vs[3], double a[16]);
int pbc_stir_placement(const double a[16], const double vs[3], const char **orientation, const char **rotation,
                       double fpo[3]);
int pbc_raw_read(const char *path, const pbc_read_hints *hints, pbc_image *img);
int pbc_raw_write(const char *path, const pbc_image *img);
/* The voxels as bare float32 in a fresh temporary for path, left open for the
 * caller to commit (an Interfile header's data file is one). On failure the
 * temporary is gone and the message printed. */
int pbc_raw_write_temp(const char *path, const pbc_image *img, pbc_temp *t, FILE **f);

#endif
