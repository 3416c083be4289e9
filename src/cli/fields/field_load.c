/* The fields a command's frames cover, from their files into the library's
 * pb_field_motion: each file's convention told (or refused), its vectors
 * made displacements in RAS mm, then turned into the image grid's frame by
 * the image's direction matrix transposed (petblur.h: d_grid = Dir^T
 * d_world); the map from image to field voxels made from the two affines. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "fields.h"

/* NIfTI's intent codes for vectors (nifti1.h). */
#define INTENT_DISPVECT 1006
#define INTENT_VECTOR 1007
/* NiftyReg's marker of its transformations, and intent_p1's values
 * (NiftyReg's NREG_TRANS_TYPE, reg-lib/cpu/Maths.hpp). */
#define NIFTYREG_NAME "NREG_TRANS"
static const char *const niftyreg_kinds[] = {"deformation field", "displacement field", "cubic B-spline grid",
                                             "deformation velocity field", "displacement velocity field",
                                             "B-spline velocity grid", "linear spline grid"};
/* mm: no body moves a kilometre; the library refuses it too. */
#define MAX_DISPLACEMENT_MM 1e6
/* What the loaded fields may take in memory, the library's copies aside. */
#define MAX_FIELD_BYTES (16.0 * 1073741824.0)

/* How a file's vectors become RAS displacements. */
typedef struct field_kind {
    int lps;      /* ITK: x and y negated */
    int absolute; /* NiftyReg's deformation: positions, each voxel's own subtracted */
} field_kind;

static int vector_without_marker(const char *path)
{
    return pbc_fail(PBC_EXIT_USAGE, "%s: a vector image (intent 1007, NIFTI_INTENT_VECTOR) with no mark of whose it "
                    "is: ITK, ANTs and SimpleITK write LPS displacements so, NiftyReg and SIRF their own kind "
                    "(intent_p1); say which with --field-convention itk or niftyreg (nifti: RAS displacements)", path);
}

static int file_kind(const pbc_fields *f, const char *path, const pbc_vector_header *h, int *warned, field_kind *k)
{
    int marked = h->intent_code == INTENT_VECTOR && !strcmp(h->intent_name, NIFTYREG_NAME);
    int conv = f->convention;
    if (conv == PBC_FIELDS_AUTO && h->intent_code == INTENT_DISPVECT)
        conv = PBC_FIELDS_NIFTI;
    else if (conv == PBC_FIELDS_AUTO && marked)
        conv = PBC_FIELDS_NIFTYREG;
    else if (conv == PBC_FIELDS_AUTO && h->intent_code == INTENT_VECTOR)
        return vector_without_marker(path);
    else if (conv == PBC_FIELDS_AUTO)
        return pbc_fail(PBC_EXIT_USAGE, "%s: intent code %d, not a displacement field's (1006, "
                        "NIFTI_INTENT_DISPVECT); set it to 1006 if the file holds RAS displacements in mm, or say "
                        "what it holds with --field-convention nifti|niftyreg|itk", path, h->intent_code);
    if (marked && conv != PBC_FIELDS_NIFTYREG && !*warned) {
        *warned = 1;
        fprintf(stderr, "petblur: warning: %s carries NiftyReg's mark (intent_name %s) and is read as "
                "--field-convention %s says\n", path, NIFTYREG_NAME, conv == PBC_FIELDS_ITK ? "itk" : "nifti");
    }
    k->lps = conv == PBC_FIELDS_ITK;
    k->absolute = 0;
    if (conv != PBC_FIELDS_NIFTYREG)
        return 0;
    double p1 = h->intent_p1;
    if (p1 == 0.0 || p1 == 1.0) {
        k->absolute = p1 == 0.0;
        return 0;
    }
    if (p1 == floor(p1) && p1 >= 2 && p1 <= 6)
        return pbc_fail(PBC_EXIT_USAGE, "%s: a NiftyReg %s (intent_p1 %d), not a field of displacements; turn it "
                        "into one first: reg_transform -ref IMAGE -disp %s disp.nii.gz", path,
                        niftyreg_kinds[(int)p1], (int)p1, path);
    return pbc_fail(PBC_EXIT_USAGE, "%s: intent_p1 %s is none of NiftyReg's kinds (0: deformation, 1: displacement); "
                    "write the field with reg_transform -disp, or give --field-convention nifti or itk", path,
                    PBC_NUM(p1));
}

static int same_grid(const pbc_vector_header *a, const pbc_vector_header *b)
{
    if (memcmp(a->dims, b->dims, sizeof a->dims))
        return 0;
    for (int i = 0; i < 12; i++) /* headers keep float32: 1e-4 mm, or float32's own step */
        if (fabs(a->affine[i] - b->affine[i]) > 1e-4 + 1e-6 * fabs(a->affine[i]))
            return 0;
    return 1;
}

/* The rows frames [lo, hi] read: the last at or before lo to the first at or after hi. */
static int frame_rows(pbc_fields *f, double lo, double hi, size_t *count)
{
    size_t last = f->rows - 1;
    if (lo < f->times[0] || hi > f->times[last])
        return pbc_fail(PBC_EXIT_USAGE, "--fields %s: the fields cover %s to %s s and the frames reach from %s to %s "
                        "s; give fields at or beyond the frames' ends, or frames inside the fields' times", f->table,
                        PBC_NUM(f->times[0]), PBC_NUM(f->times[last]), PBC_NUM(lo), PBC_NUM(hi));
    size_t first = 0;
    while (first + 1 < f->rows && f->times[first + 1] <= lo)
        first++;
    while (last > 0 && f->times[last - 1] >= hi)
        last--;
    if (last <= first)
        last = first + 1 < f->rows ? first + 1 : first;
    if (last == first)
        first--;
    f->first = first;
    *count = last - first + 1;
    return 0;
}

/* Every file's header: one grid, placed, of a known convention. */
static int check_headers(pbc_fields *f, size_t count, field_kind *kinds)
{
    int warned = 0, rc = 0;
    for (size_t k = 0; k < count && !rc; k++) {
        const char *path = f->paths[f->first + k];
        pbc_vector_header h;
        if ((rc = pbc_vector_header_read(path, &h)))
            break;
        if (!h.placed)
            return pbc_fail(PBC_EXIT_USAGE, "%s: no placement in the world (sform and qform codes 0), and a "
                            "field's vectors are world mm on its grid; write it with its image's affine", path);
        if (k == 0)
            f->grid = h;
        else if (!same_grid(&f->grid, &h) && h.unit_mm != f->grid.unit_mm)
            return pbc_fail(PBC_EXIT_USAGE, "%s and %s differ in their units (xyz_units: %g and %g mm a unit), so "
                            "their grids differ; the fields of one table share one grid in one unit: write them "
                            "alike, in mm", f->paths[f->first], path, f->grid.unit_mm, h.unit_mm);
        else if (!same_grid(&f->grid, &h))
            return pbc_fail(PBC_EXIT_USAGE, "%s and %s lie on different grids (%zux%zux%zu and %zux%zux%zu, or other "
                            "affines); the fields of one table share one grid: resample them onto one, or register "
                            "every frame against one reference image", f->paths[f->first], path, f->grid.dims[0],
                            f->grid.dims[1], f->grid.dims[2], h.dims[0], h.dims[1], h.dims[2]);
        rc = file_kind(f, path, &h, &warned, &kinds[k]);
    }
    return rc;
}

/* The image's side: its affine and grid (the fields' own without an image),
 * and its direction matrix, which must be a rotation for D^T to invert it. */
static int image_side(pbc_fields *f, const pbc_image *img, const char *in_path, double a[16], double dir[9])
{
    if (img && !pbc_image_affine(img, a))
        return pbc_fail(PBC_EXIT_USAGE, "%s: no placement in the world (a .raw file, or a NIfTI with sform and qform "
                        "codes 0), and --fields' vectors are world mm; give the image with its affine (NIfTI or "
                        "Interfile)", in_path);
    if (!img)
        memcpy(a, f->grid.affine, 16 * sizeof *a);
    for (int i = 0; i < 3; i++) {
        f->geometry.dims[i] = img ? img->dims[i] : f->grid.dims[i];
        f->geometry.voxel_size[i] = img ? img->voxel_size[i] : f->grid.voxel_size[i];
    }
    double norm[3];
    for (int c = 0; c < 3; c++)
        norm[c] = sqrt(a[c] * a[c] + a[4 + c] * a[4 + c] + a[8 + c] * a[8 + c]);
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            dir[3 * r + c] = a[4 * r + c] / norm[c];
    for (int c = 0; c < 3; c++)
        for (int e = c + 1; e < 3; e++)
            if (fabs(dir[c] * dir[e] + dir[3 + c] * dir[3 + e] + dir[6 + c] * dir[6 + e]) > 1e-4)
                return pbc_fail(PBC_EXIT_USAGE, "%s: its affine shears the grid's axes, so world vectors have no "
                                "frame along them; resample the image onto a grid with perpendicular axes", img ?
                                in_path : f->paths[f->first]);
    return 0;
}

/* field_from_grid = inv(A_field) A_image, rows 0..2. */
static void field_map(const double af[16], const double a[16], double map[12])
{
    const double *m = af;
    double det = m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) +
                 m[2] * (m[4] * m[9] - m[5] * m[8]);
    double inv[9] = {(m[5] * m[10] - m[6] * m[9]) / det, (m[2] * m[9] - m[1] * m[10]) / det,
                     (m[1] * m[6] - m[2] * m[5]) / det, (m[6] * m[8] - m[4] * m[10]) / det,
                     (m[0] * m[10] - m[2] * m[8]) / det, (m[2] * m[4] - m[0] * m[6]) / det,
                     (m[4] * m[9] - m[5] * m[8]) / det, (m[1] * m[8] - m[0] * m[9]) / det,
                     (m[0] * m[5] - m[1] * m[4]) / det};
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 4; c++) {
            double s = 0.0;
            for (int k = 0; k < 3; k++)
                s += inv[3 * r + k] * (a[4 * k + c] - (c == 3 ? af[4 * k + 3] : 0.0));
            map[4 * r + c] = s;
        }
}

static int is_identity(const double map[12])
{
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 4; c++)
            if (fabs(map[4 * r + c] - (r == c)) > 1e-6)
                return 0;
    return 1;
}

/* One file's vectors, read into v, made RAS displacements and checked, then
 * turned into the grid's frame. */
static int convert(const pbc_fields *f, const char *path, const field_kind *kind, const double dir[9], float *v)
{
    int rc = pbc_vector_read(path, &f->grid, v);
    const size_t *n = f->grid.dims;
    const double *af = f->grid.affine;
    for (size_t i = 0; !rc && i < n[0] * n[1] * n[2]; i++) {
        size_t x = i % n[0], y = i / n[0] % n[1], z = i / n[0] / n[1];
        double d[3];
        for (int c = 0; c < 3; c++) {
            d[c] = (double)v[3 * i + (size_t)c];
            if (kind->absolute) /* NiftyReg's deformation: where the voxel goes, less where it is */
                d[c] -= af[4 * c] * (double)x + af[4 * c + 1] * (double)y + af[4 * c + 2] * (double)z + af[4 * c + 3];
            if (kind->lps && c < 2)
                d[c] = -d[c];
            if (!isfinite(d[c]))
                return pbc_fail(PBC_EXIT_USAGE, "%s: component %c of voxel (%zu, %zu, %zu) is %s; a displacement "
                                "field must be finite everywhere: fill what the registration left undefined (outside "
                                "its mask) with 0", path, "xyz"[c], x, y, z, isnan(d[c]) ? "NaN" : "infinite");
            if (fabs(d[c]) > MAX_DISPLACEMENT_MM)
                return pbc_fail(PBC_EXIT_USAGE, "%s: voxel (%zu, %zu, %zu) moves %s mm along %c, beyond a kilometre; "
                                "the vectors must be mm (check the file's xyz_units, and whether it holds positions: "
                                "--field-convention)", path, x, y, z, PBC_NUM(d[c]), "xyz"[c]);
        }
        for (int r = 0; r < 3; r++)
            v[3 * i + (size_t)r] = (float)(dir[r] * d[0] + dir[3 + r] * d[1] + dir[6 + r] * d[2]);
    }
    return rc;
}

static void warn_folds(const pbc_fields *f)
{
    pb_field_folds folds;
    if (pb_field_check_folds(&f->geometry, &f->motion, &folds) != PB_OK || !folds.voxels)
        return;
    const size_t *n = f->grid.dims;
    size_t v = (size_t)folds.voxel;
    fprintf(stderr, "petblur: warning: --fields: the fields fold at %zu voxel%s of their grid, first %s at voxel "
            "(%zu, %zu, %zu) (Jacobian determinant down to %.3g): the blur there reads one place for two; check the "
            "registration (a smoother or diffeomorphic one does not fold)\n", folds.voxels,
            folds.voxels == 1 ? "" : "s", f->paths[f->first + (size_t)folds.field], v % n[0], v / n[0] % n[1],
            v / n[0] / n[1], folds.worst_determinant);
}

int pbc_fields_load(pbc_fields *f, const pbc_image *img, const char *in_path, const double *bounds, size_t frames)
{
    size_t count = 0;
    double a[16], dir[9];
    int rc = 0;
    if (f->by_value) { /* fields at the signal's values: the library checks the signal against them */
        f->first = 0;
        count = f->rows;
    } else
        rc = frame_rows(f, bounds ? bounds[0] : f->frame[0], bounds ? bounds[frames] : f->frame[1], &count);
    field_kind *kinds = rc ? NULL : calloc(count, sizeof *kinds);
    if (!rc && !kinds)
        rc = pbc_fail(PBC_EXIT_RUNTIME, "--fields %s: out of memory", f->table);
    if (!rc)
        rc = check_headers(f, count, kinds);
    if (!rc)
        rc = image_side(f, img, in_path, a, dir);
    size_t voxels = f->grid.dims[0] * f->grid.dims[1] * f->grid.dims[2];
    double bytes = (double)count * (double)voxels * 12.0;
    if (!rc && bytes > MAX_FIELD_BYTES)
        rc = pbc_fail(PBC_EXIT_USAGE, "--fields %s: %zu fields of %zux%zux%zu voxels take %.1f GiB, more than "
                      "petblur reads at once (%.0f GiB); use coarser fields, fewer of them or shorter frames", f->table,
                      count, f->grid.dims[0], f->grid.dims[1], f->grid.dims[2], bytes / 1073741824.0,
                      MAX_FIELD_BYTES / 1073741824.0);
    if (!rc && !(f->vectors = malloc(count * voxels * 3 * sizeof *f->vectors)))
        rc = pbc_fail(PBC_EXIT_RUNTIME, "--fields %s: not enough memory for %zu fields (%.1f GiB); free some memory "
                      "or use coarser fields", f->table, count, bytes / 1073741824.0);
    for (size_t k = 0; k < count && !rc; k++) {
        /* A breathing cycle's table names its few gates again and again: each file is read once. */
        size_t same = 0;
        while (same < k && strcmp(f->paths[f->first + same], f->paths[f->first + k]))
            same++;
        float *slot = f->vectors + k * voxels * 3;
        if (same < k && !memcmp(&kinds[same], &kinds[k], sizeof *kinds))
            memcpy(slot, f->vectors + same * voxels * 3, voxels * 3 * sizeof *slot);
        else
            rc = convert(f, f->paths[f->first + k], &kinds[k], dir, slot);
    }
    free(kinds);
    if (rc)
        return rc;
    pb_field_motion *m = &f->motion;
    m->times = f->times + f->first;
    m->displacements = f->vectors;
    m->count = count;
    memcpy(m->dims, f->grid.dims, sizeof m->dims);
    field_map(f->grid.affine, a, m->field_from_grid);
    m->has_map = !(is_identity(m->field_from_grid) && !memcmp(m->dims, f->geometry.dims, sizeof m->dims));
    m->frame_start = f->frame[0];
    m->frame_end = f->frame[1];
    if (f->by_value) {
        m->signal_times = f->signal_times;
        m->signal = f->signal;
        m->signal_count = f->signal_count;
    }
    warn_folds(f);
    return 0;
}
