/* NIfTI vector images: the displacement fields that registration tools
 * write, read through nifti_clib after the byte-by-byte header checks a
 * volume gets (image_nifti_header.c), with the same placement rules
 * (image_nifti_orientation.c). Only the layout is checked here; what the
 * vectors mean (intent, conventions) is src/cli/fields/'s to decide. */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <nifti2_io.h>

#include "cli.h"
#include "image_formats.h"

/* dim[1..7] as written, 1 beyond ndim. */
static void full_dims(const nifti_image *nim, long long d[8])
{
    for (int i = 1; i < 8; i++)
        d[i] = i <= nim->ndim ? (long long)nim->dim[i] : 1;
}

/* (nx, ny, nz, 1, 3), the standard's place for vectors, or (nx, ny, nz, 3). */
static int check_shape(const char *path, const nifti_image *nim)
{
    long long d[8];
    full_dims(nim, d);
    int five = nim->ndim >= 5 && d[4] == 1 && d[5] == 3 && d[6] == 1 && d[7] == 1;
    int four = nim->ndim == 4 && d[4] == 3;
    if (five || four)
        return 0;
    if ((nim->ndim >= 5 && d[5] == 2) || (nim->ndim == 4 && d[4] == 2))
        return pbc_fail(PBC_EXIT_USAGE, "%s: holds two components per voxel, a 2-D field; petblur moves 3-D "
                        "volumes: write the field of the 3-D registration (three components)", path);
    char shape[160];
    int n = snprintf(shape, sizeof shape, "%lld", d[1]);
    for (int i = 2; i <= nim->ndim && i < 8 && n > 0 && (size_t)n < sizeof shape; i++)
        n += snprintf(shape + n, sizeof shape - (size_t)n, ", %lld", d[i]);
    return pbc_fail(PBC_EXIT_USAGE, "%s: has the shape (%s), not a displacement field's (nx, ny, nz, 1, 3) or (nx, "
                    "ny, nz, 3); write the three components of each voxel along the 5th dimension (nibabel: an "
                    "array of shape (nx, ny, nz, 1, 3))", path, shape);
}

static void take_header(const nifti_image *nim, const pbc_nifti_facts *facts, const pbc_orientation *o,
                        pbc_vector_header *h)
{
    h->unit_mm = pbc_nifti_unit_mm(nim->xyz_units);
    for (int i = 0; i < 3; i++) {
        h->dims[i] = (size_t)nim->dim[i + 1];
        double v = fabs(facts->pixdim[i]) * h->unit_mm;
        h->voxel_size[i] = v > 0 && isfinite(v) ? v : h->unit_mm; /* nifti_clib's and nibabel's 0 -> 1 */
    }
    pbc_image placed = {.orientation = *o};
    h->placed = pbc_image_affine(&placed, h->affine);
    h->intent_code = nim->intent_code;
    memcpy(h->intent_name, nim->intent_name, 16);
    h->intent_name[16] = '\0';
    h->intent_p1 = facts->intent_p1; /* as written: a NaN is none of NiftyReg's kinds, not its 0 */
}

/* The header checked and parsed; *nim (nifti_image_free) on success. */
static int open_header(const char *path, pbc_vector_header *h, nifti_image **out)
{
    nifti_set_debug_level(0); /* its messages would not start with "petblur:" (image_nifti.c) */
    pbc_nifti_facts facts;
    int rc = pbc_nifti_check_header(path, &facts);
    if (rc)
        return rc;
    nifti_image *nim = nifti_image_read(path, 0);
    if (!nim)
        return pbc_fail(PBC_EXIT_USAGE, "%s: not a readable NIfTI file (its header is missing or damaged); check "
                        "that it is a NIfTI-1 image", path);
    pbc_orientation o;
    memset(&o, 0, sizeof o);
    if (!(rc = check_shape(path, nim))) {
        size_t dims[3] = {(size_t)nim->dim[1], (size_t)nim->dim[2], (size_t)nim->dim[3]};
        rc = pbc_image_check_grid(path, dims);
    }
    if (!rc)
        rc = pbc_nifti_check_scaling(path, &facts);
    if (!rc)
        rc = pbc_nifti_orientation(path, &facts, pbc_nifti_unit_mm(nim->xyz_units), &o);
    if (rc) {
        nifti_image_free(nim);
        return rc;
    }
    take_header(nim, &facts, &o, h);
    *out = nim;
    return 0;
}

int pbc_vector_header_read(const char *path, pbc_vector_header *h)
{
    nifti_image *nim = NULL;
    int rc = open_header(path, h, &nim);
    nifti_image_free(nim);
    return rc;
}

int pbc_vector_read(const char *path, const pbc_vector_header *want, float *out)
{
    pbc_vector_header h;
    nifti_image *nim = NULL;
    pbc_sample_format format;
    int rc = open_header(path, &h, &nim);
    if (!rc && memcmp(h.dims, want->dims, sizeof h.dims))
        rc = pbc_fail(PBC_EXIT_USAGE, "%s: changed while petblur read it; run again", path);
    if (!rc)
        rc = pbc_nifti_sample_format(path, nim, &format);
    /* The file keeps each component whole (x fastest, then y, z, then the
     * component): read as a 3-frame image, then interleaved. */
    pbc_image img = {.dims = {h.dims[0], h.dims[1], h.dims[2]}, .voxel_size = {1, 1, 1}, .frames = 3};
    size_t n = h.dims[0] * h.dims[1] * h.dims[2];
    if (!rc && !(img.data = malloc(3 * n * sizeof *img.data)))
        rc = pbc_fail(PBC_EXIT_RUNTIME, "%s: not enough memory for its %zu vectors; free some memory or use a "
                      "coarser field", path, n);
    znzFile fp = NULL;
    if (!rc) {
        fp = znzopen(nim->iname, "rb", nifti_is_gzfile(nim->iname));
        if (znz_isnull(fp))
            rc = pbc_fail(PBC_EXIT_USAGE, "%s: cannot open it to read the data (%s); check its permissions", path,
                          strerror(errno));
        else if (znzseek(fp, (znz_off_t)nim->iname_offset, SEEK_SET) < 0)
            rc = pbc_fail(PBC_EXIT_USAGE, "%s: ends before its data starts (at byte %lld); the file is truncated or "
                          "damaged; copy or write it again", path, (long long)nim->iname_offset);
        else
            rc = pbc_samples_read(path, pbc_read_znz, fp, &format, &img);
    }
    if (!znz_isnull(fp))
        znzclose(fp);
    for (size_t v = 0; !rc && v < n; v++)
        for (int c = 0; c < 3; c++)
            out[3 * v + (size_t)c] = (float)((double)img.data[(size_t)c * n + v] * h.unit_mm);
    free(img.data);
    nifti_image_free(nim);
    return rc;
}
