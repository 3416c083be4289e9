/* NIfTI images through nifti_clib: any single-file NIfTI-1 (or NIfTI-2) volume
 * in, float32 NIfTI-1 out, with the input's placement in scanner space kept. */
#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <unistd.h>

#include <nifti2_io.h>
#include <zlib.h>

#include "atomic_file.h"
#include "cli.h"
#include "image_formats.h"

_Static_assert(sizeof(nifti_1_header) == 348, "a NIfTI-1 header is 348 bytes");

/* NIfTI-1 keeps dimensions in shorts. */
#define NIFTI1_MAX_DIM 32767
/* The header, then the 4-byte extender saying "no extensions". */
#define NIFTI1_DATA_OFFSET 352

/* nifti_clib prints its own "** ERROR" lines on stderr unless its debug level
 * is 0; every message of the program starts with "petblur:", so the library
 * is kept quiet and its failures are told here in our words. Its helpers that
 * print whatever the level (nifti_read_header and kin) are not used. */
static void quiet_library(void)
{
    nifti_set_debug_level(0);
}

/* znzread passes on gzread's -1 for a damaged stream. */
size_t pbc_read_znz(void *source, void *buf, size_t bytes)
{
    size_t n = znzread(buf, 1, bytes, source);
    return n > bytes ? 0 : n;
}

static int check_layout(const char *path, const nifti_image *nim, int allow_frames)
{
    for (int d = 4; d <= nim->ndim && d < 8; d++) {
        if (nim->dim[d] <= 1 || (d == 4 && allow_frames))
            continue;
        if (d == 4)
            return pbc_fail(PBC_EXIT_USAGE, "%s: has %lld time frames (a 4-D image); blur them all with --frames "
                            "T0,T1,... (one boundary more than frames) and --motion TRACK.csv, or extract one frame "
                            "first, e.g. fslroi %s frame.nii.gz 0 1", path, (long long)nim->dim[d], path);
        return pbc_fail(PBC_EXIT_USAGE, "%s: is a %lld-D image with %lld entries along dimension %d and petblur "
                        "blurs 3-D volumes and 4-D frame series; extract those first", path, (long long)nim->ndim,
                        (long long)nim->dim[d], d);
    }
    return 0;
}

/* nibabel's rule: a slope of 0 or not finite means no scaling, and a finite
 * slope with an intercept that is not is refused, since no value can be made
 * of it (nifti_clib would read the intercept as 0). */
int pbc_nifti_check_scaling(const char *path, const pbc_nifti_facts *facts)
{
    double slope = facts->scl_slope, inter = facts->scl_inter;
    if (slope == 0.0 || !isfinite(slope) || isfinite(inter))
        return 0;
    return pbc_fail(PBC_EXIT_USAGE, "%s: scl_inter is %s while scl_slope is %s, so no voxel has a value; set "
                    "scl_inter to 0 in the header (e.g. nibabel: img.header['scl_inter'] = 0) or scl_slope to 0 "
                    "for unscaled data", path, isnan(inter) ? "NaN" : inter > 0 ? "infinite" : "-infinite",
                    PBC_NUM(slope));
}

int pbc_nifti_sample_format(const char *path, const void *header, pbc_sample_format *format)
{
    const nifti_image *nim = header;
    static const struct { int datatype; pbc_sample_type type; } types[] = {
        {NIFTI_TYPE_UINT8, PBC_SAMPLE_U8}, {NIFTI_TYPE_INT8, PBC_SAMPLE_I8},
        {NIFTI_TYPE_UINT16, PBC_SAMPLE_U16}, {NIFTI_TYPE_INT16, PBC_SAMPLE_I16},
        {NIFTI_TYPE_UINT32, PBC_SAMPLE_U32}, {NIFTI_TYPE_INT32, PBC_SAMPLE_I32},
        {NIFTI_TYPE_FLOAT32, PBC_SAMPLE_F32}, {NIFTI_TYPE_FLOAT64, PBC_SAMPLE_F64},
    };
    for (size_t i = 0; i < sizeof types / sizeof types[0]; i++) {
        if (types[i].datatype != nim->datatype)
            continue;
        format->type = types[i].type;
        format->swap = nim->byteorder != nifti_short_order();
        /* The standard: a slope of 0 means the stored values are the values
         * (the library has already turned non-finite ones into 0). */
        format->slope = nim->scl_slope != 0 ? nim->scl_slope : 1;
        format->inter = nim->scl_slope != 0 ? nim->scl_inter : 0;
        return 0;
    }
    return pbc_fail(PBC_EXIT_USAGE, "%s: its data type %s is not supported (use float32, float64, int8, int16, "
                    "int32, uint8, uint16 or uint32); convert it, e.g. fslmaths %s out.nii.gz -odt float", path,
                    nifti_datatype_string(nim->datatype), path);
}

double pbc_nifti_unit_mm(int xyz_units)
{
    switch (xyz_units) {
    case NIFTI_UNITS_METER: return 1000;
    case NIFTI_UNITS_MICRON: return 1e-3;
    default: return 1; /* mm, or unknown: millimetres are what everyone means then */
    }
}

/* Sizes (and the affines, image_nifti_orientation.c) are kept in mm, so that
 * the output, written in mm, lands where the input was whatever its units. A
 * pixdim of 0 (or NaN) is left as 0 for --voxel-size to fill in. */
static void take_geometry(const nifti_image *nim, const double pixdim[3], pbc_image *img)
{
    double mm = pbc_nifti_unit_mm(nim->xyz_units);
    for (int i = 0; i < 3; i++) {
        img->dims[i] = i < nim->ndim ? (size_t)nim->dim[i + 1] : 1;
        img->voxel_size[i] = isfinite(pixdim[i]) ? fabs(pixdim[i]) * mm : 0;
    }
    img->frames = nim->ndim >= 4 && nim->dim[4] > 1 ? (size_t)nim->dim[4] : 1;
    pbc_orientation *o = &img->orientation;
    memcpy(o->descrip, nim->descrip, sizeof o->descrip);
    o->descrip[sizeof o->descrip - 1] = '\0';
}

static int read_data(const char *path, const nifti_image *nim, const pbc_sample_format *format, pbc_image *img)
{
    znzFile fp = znzopen(nim->iname, "rb", nifti_is_gzfile(nim->iname));
    if (znz_isnull(fp))
        return pbc_fail(PBC_EXIT_USAGE, "%s: cannot open it to read the data (%s); check its permissions", path,
                        strerror(errno));
    int rc;
    if (znzseek(fp, (znz_off_t)nim->iname_offset, SEEK_SET) < 0)
        rc = pbc_fail(PBC_EXIT_USAGE, "%s: ends before its data starts (at byte %lld); the file is truncated or "
                      "damaged; copy or write it again", path, (long long)nim->iname_offset);
    else
        rc = pbc_samples_read(path, pbc_read_znz, fp, format, img);
    znzclose(fp);
    return rc;
}

int pbc_nifti_read(const char *path, const pbc_read_hints *hints, pbc_image *img)
{
    quiet_library();
    pbc_nifti_facts facts;
    int rc = pbc_nifti_check_header(path, &facts);
    if (rc)
        return rc;
    nifti_image *nim = nifti_image_read(path, 0);
    if (!nim)
        return pbc_fail(PBC_EXIT_USAGE, "%s: not a readable NIfTI file (its header is missing or damaged); check "
                        "that it is a NIfTI-1 image", path);
    pbc_sample_format format;
    double *pixdim = facts.pixdim;
    rc = check_layout(path, nim, hints && hints->allow_frames);
    if (!rc)
        rc = pbc_nifti_check_scaling(path, &facts);
    if (!rc)
        rc = pbc_nifti_sample_format(path, nim, &format);
    if (!rc) {
        take_geometry(nim, pixdim, img);
        /* From the header's own bytes: nifti_clib reads NaN fields as 0. */
        rc = pbc_nifti_orientation(path, &facts, pbc_nifti_unit_mm(nim->xyz_units), &img->orientation);
    }
    if (!rc)
        rc = pbc_image_prepare(path, hints, img);
    if (!rc)
        rc = read_data(path, nim, &format, img);
    nifti_image_free(nim);
    return rc;
}

static void set_orientation(nifti_image *nim, const pbc_orientation *o)
{
    /* Codes 0 are written as they are, with pixdim only: the grid's place in
     * the scanner is unknown then, and a nonzero code with a made-up affine
     * would claim a placement that nobody measured. Readers fall back to the
     * pixdim scaling, which is all that is known. */
    nim->qform_code = o->qform_code;
    nim->sform_code = o->sform_code;
    if (o->qform_code > 0) {
        nifti_dmat44 q;
        memcpy(q.m, o->qto_xyz, sizeof q.m);
        /* The header keeps the qform as a quaternion, an offset and qfac. */
        nifti_dmat44_to_quatern(q, &nim->quatern_b, &nim->quatern_c, &nim->quatern_d, &nim->qoffset_x,
                                &nim->qoffset_y, &nim->qoffset_z, NULL, NULL, NULL, &nim->qfac);
    }
    if (o->sform_code > 0)
        memcpy(nim->sto_xyz.m, o->sto_xyz, sizeof nim->sto_xyz.m);
    memcpy(nim->descrip, o->descrip, sizeof nim->descrip);
    nim->descrip[sizeof nim->descrip - 1] = '\0';
}

/* cal_min/cal_max tell viewers the display range. */
static void set_range(nifti_image *nim, const pbc_image *img)
{
    size_t n = pbc_image_voxels(img);
    float lo = img->data[0], hi = img->data[0];
    for (size_t i = 1; i < n; i++) {
        lo = img->data[i] < lo ? img->data[i] : lo;
        hi = img->data[i] > hi ? img->data[i] : hi;
    }
    nim->cal_min = (double)lo;
    nim->cal_max = (double)hi;
}

static int make_header(const char *path, const pbc_image *img, nifti_1_header *hdr)
{
    int64_t frames = (int64_t)pbc_image_frame_count(img);
    const int64_t dims[8] = {frames > 1 ? 4 : 3, (int64_t)img->dims[0], (int64_t)img->dims[1], (int64_t)img->dims[2],
                             frames, 1, 1, 1};
    nifti_image *nim = nifti_make_new_nim(dims, NIFTI_TYPE_FLOAT32, 0);
    if (!nim)
        return pbc_fail(PBC_EXIT_RUNTIME, "%s: not enough memory to make the NIfTI header", path);
    nim->nifti_type = NIFTI_FTYPE_NIFTI1_1;
    nim->dx = nim->pixdim[1] = img->voxel_size[0];
    nim->dy = nim->pixdim[2] = img->voxel_size[1];
    nim->dz = nim->pixdim[3] = img->voxel_size[2];
    nim->xyz_units = NIFTI_UNITS_MM;
    if (frames > 1) {
        /* The time axis: frames in seconds, their length when they share one. */
        nim->time_units = NIFTI_UNITS_SEC;
        nim->dt = nim->pixdim[4] = img->frame_seconds > 0 ? img->frame_seconds : 0;
    }
    nim->scl_slope = 1;
    nim->scl_inter = 0;
    nim->iname_offset = NIFTI1_DATA_OFFSET;
    set_range(nim, img);
    set_orientation(nim, &img->orientation);
    int bad = nifti_convert_nim2n1hdr(nim, hdr) != 0;
    nifti_image_free(nim);
    if (bad)
        return pbc_fail(PBC_EXIT_USAGE, "%s: this image does not fit a NIfTI-1 header; write .hv or .raw instead",
                        path);
    return 0;
}

/* Returns 0 or the errno of the first failure. The temporary is written
 * through its descriptor (a copy that gzclose closes), never reopened by name;
 * zlib writes .nii plainly ("T": transparent) and .nii.gz compressed.
 * pbc_temp_commit syncs it. */
static int write_file(int fd, int compress, const nifti_1_header *hdr, const pbc_image *img)
{
    static const char extender[4] = {0};
    size_t n = pbc_image_voxels(img);
    errno = 0;
    int copy = dup(fd);
    gzFile fp = copy >= 0 ? gzdopen(copy, compress ? "wb" : "wbT") : NULL;
    if (!fp) {
        int e = errno ? errno : EIO;
        if (copy >= 0)
            close(copy);
        return e;
    }
    int ok = gzfwrite(hdr, sizeof *hdr, 1, fp) == 1 && gzfwrite(extender, 1, sizeof extender, fp) == sizeof extender
             && gzfwrite(img->data, sizeof *img->data, n, fp) == n;
    int e = ok ? 0 : errno ? errno : EIO;
    /* A full disk often shows only when the last block is written at close. */
    if (gzclose(fp) != Z_OK && !e)
        e = errno ? errno : EIO;
    return e;
}

int pbc_nifti_check_output(const char *path, const size_t dims[3], size_t frames)
{
    const size_t *d = dims;
    if (d[0] > NIFTI1_MAX_DIM || d[1] > NIFTI1_MAX_DIM || d[2] > NIFTI1_MAX_DIM)
        return pbc_fail(PBC_EXIT_USAGE, "%s: NIfTI-1 holds at most %d entries along an axis and the grid is "
                        "%zux%zux%zu; write .hv or .raw instead", path, NIFTI1_MAX_DIM, d[0], d[1], d[2]);
    if (frames > NIFTI1_MAX_DIM)
        return pbc_fail(PBC_EXIT_USAGE, "%s: NIfTI-1 holds at most %d frames and there are %zu; blur the frames in "
                        "parts of at most %d (--frames with fewer boundaries), one output each", path,
                        NIFTI1_MAX_DIM, frames, NIFTI1_MAX_DIM);
    return 0;
}

int pbc_nifti_write(const char *path, const pbc_image *img)
{
    int rc = pbc_nifti_check_output(path, img->dims, pbc_image_frame_count(img));
    if (rc)
        return rc;
    quiet_library();
    nifti_1_header hdr;
    if ((rc = make_header(path, img, &hdr)))
        return rc;
    pbc_temp t;
    rc = pbc_temp_create(&t, path);
    if (rc)
        return rc;
    char ext[16];
    pbc_file_extension(path, ext, sizeof ext);
    int e = write_file(t.fd, !strcmp(ext, ".nii.gz"), &hdr, img);
    if (e) {
        pbc_temp_abort(&t, NULL);
        return pbc_fail(PBC_EXIT_RUNTIME, "%s: writing failed (%s); nothing was written; free some space or choose "
                        "another folder", path, strerror(e));
    }
    return pbc_temp_commit(&t, NULL);
}
