/* A NIfTI grid's place in the world, chosen as nibabel chooses it
 * (Nifti1Header.get_best_affine): the sform when sform_code is set, else the
 * qform when qform_code is set, else none. The qform is built as nibabel
 * builds it after its load-time fixes: qfac (pixdim[0]) other than -1 counts
 * as 1, pixdims by their magnitude with 0 as 1, and a quaternion whose
 * b^2 + c^2 + d^2 exceeds 1 by more than 3 epsilon of the header's float type
 * is not a rotation. nifti_clib would read NaN and infinite fields as 0 and
 * scale a quaternion to unit length, silently; here a form that would be used
 * must be finite and invertible, or the file is refused. A qform beside a
 * used sform that fails these checks is dropped, not refused: nothing reads
 * it, and the output should not carry it. */
#include <float.h>
#include <math.h>
#include <string.h>

#include "cli.h"
#include "image_formats.h"

static int all_finite(const double *v, int n)
{
    for (int i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

/* No scanner spans 1000 km: a larger entry is a damaged header, and would not
 * fit the float32 fields of the NIfTI-1 file petblur writes. */
#define MAX_WORLD_MM 1e9

static int within_world(double m[4][4])
{
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 4; c++)
            if (!(fabs(m[r][c]) <= MAX_WORLD_MM))
                return 0;
    return 1;
}

static double det3(double m[4][4])
{
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

/* Singular, or so near it that the grid collapses: |det| against the product
 * of the column lengths (1 for an orthogonal matrix). */
static int invertible(double m[4][4])
{
    double cols = 1.0;
    for (int c = 0; c < 3; c++)
        cols *= sqrt(m[0][c] * m[0][c] + m[1][c] * m[1][c] + m[2][c] * m[2][c]);
    double d = det3(m);
    return isfinite(d) && cols > 0.0 && fabs(d) > 1e-6 * cols;
}

static int sform(const char *path, const pbc_nifti_facts *f, double mm, double out[4][4])
{
    if (!all_finite(f->srow, 12))
        return pbc_fail(PBC_EXIT_USAGE, "%s: its sform (srow_x, srow_y, srow_z), which places the grid in the world, "
                        "holds NaN or infinity; the header is damaged: write the affine again (nibabel: "
                        "img.set_sform(affine, code=1)), or set sform_code to 0 to use the qform", path);
    memset(out, 0, 16 * sizeof **out);
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 4; c++)
            out[r][c] = f->srow[4 * r + c] * mm;
    out[3][3] = 1.0;
    if (!within_world(out))
        return pbc_fail(PBC_EXIT_USAGE, "%s: its sform places voxels beyond 1000 km (an entry over 1e9 mm); the header "
                        "is damaged: write the affine again, or set sform_code to 0 to use the qform", path);
    if (!invertible(out))
        return pbc_fail(PBC_EXIT_USAGE, "%s: its sform is singular (its voxel axes do not span 3-D space), so no "
                        "voxel has one place in the world; write the affine again, or set sform_code to 0", path);
    return 0;
}

/* 0, or a message (no exit status) in why. */
static int qform(const pbc_nifti_facts *f, double mm, double out[4][4], const char **why)
{
    const double *q = f->quatern;
    double px[3];
    if (!all_finite(q, 3) || !all_finite(f->qoffset, 3)) {
        *why = "its qform (quatern_b/c/d, qoffset_x/y/z) holds NaN or infinity";
        return 1;
    }
    if (!all_finite(f->pixdim, 3)) {
        *why = "its voxel sizes (pixdim[1..3]), which scale the qform, hold NaN or infinity";
        return 1;
    }
    double threshold = 3.0 * (f->version == 2 ? DBL_EPSILON : (double)FLT_EPSILON);
    double w2 = 1.0 - (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
    if (w2 < -threshold) {
        *why = "its qform quaternion (quatern_b/c/d) has b^2 + c^2 + d^2 above 1, so it is no rotation";
        return 1;
    }
    double w = fabs(w2) < threshold ? 0.0 : sqrt(w2), x = q[0], y = q[1], z = q[2];
    double n = w * w + x * x + y * y + z * z, s = 2.0 / n;
    double r[3][3] = {{1 - s * (y * y + z * z), s * (x * y - w * z), s * (x * z + w * y)},
                      {s * (x * y + w * z), 1 - s * (x * x + z * z), s * (y * z - w * x)},
                      {s * (x * z - w * y), s * (y * z + w * x), 1 - s * (x * x + y * y)}};
    for (int c = 0; c < 3; c++)
        px[c] = f->pixdim[c] == 0.0 ? 1.0 : fabs(f->pixdim[c]);
    px[2] *= f->qfac == -1.0 ? -1.0 : 1.0;
    memset(out, 0, 16 * sizeof **out);
    for (int i = 0; i < 3; i++) {
        for (int c = 0; c < 3; c++)
            out[i][c] = r[i][c] * px[c] * mm;
        out[i][3] = f->qoffset[i] * mm;
    }
    out[3][3] = 1.0;
    if (!within_world(out)) {
        *why = "its qform places voxels beyond 1000 km (an offset or voxel size over 1e9 mm)";
        return 1;
    }
    return 0;
}

static int known_code(const char *path, const char *name, int code)
{
    if (code >= 0 && code <= 4)
        return 0;
    return pbc_fail(PBC_EXIT_USAGE, "%s: %s is %d, none of NIfTI's codes (0 unknown, 1 scanner, 2 aligned, 3 "
                    "Talairach, 4 MNI); the header is damaged: set the code again (nibabel: img.set_%s(affine, "
                    "code=1))", path, name, code, !strcmp(name, "sform_code") ? "sform" : "qform");
}

int pbc_nifti_orientation(const char *path, const pbc_nifti_facts *f, double unit_mm, pbc_orientation *o)
{
    int rc = known_code(path, "sform_code", f->sform_code);
    if (!rc)
        rc = known_code(path, "qform_code", f->qform_code);
    if (rc)
        return rc;
    o->sform_code = f->sform_code;
    o->qform_code = f->qform_code;
    if (o->sform_code && (rc = sform(path, f, unit_mm, o->sto_xyz)))
        return rc;
    const char *why = NULL;
    if (o->qform_code && qform(f, unit_mm, o->qto_xyz, &why)) {
        if (!o->sform_code)
            return pbc_fail(PBC_EXIT_USAGE, "%s: %s; the qform places the grid in the world (sform_code is 0), so the "
                            "header is damaged: write the affine again (nibabel: img.set_qform(affine, code=1))",
                            path, why);
        o->qform_code = 0;
    }
    return 0;
}
