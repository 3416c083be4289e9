/* Where a grid lies in the world: NIfTI's sform and qform, and the placement
 * STIR gives an Interfile image.
 *
 * STIR (its IO/interfile.cxx and stir/DiscretisedDensity.inl) puts
 * voxel (i, j, k) of an Interfile image, index [1] fastest, at the centre
 * p = first pixel offset + (i dx, j dy, k dz) in its gantry frame (x left to
 * right seen from the bed, y top to bottom of the gantry, z out along the
 * bed), and turns that into patient LPS by one sign per axis from the patient
 * position; unknown and other positions count as head first supine. NIfTI's
 * RAS+ is LPS with x and y negated, so the affine is diag(e) (p), with e below.
 * Without first pixel offsets STIR centres x and y on index n / 2 (integer
 * division) and starts z at 0. */
#include <math.h>
#include <string.h>

#include "cli.h"
#include "image_formats.h"

typedef struct stir_position {
    const char *orientation, *rotation;
    double ras_sign[3]; /* RAS+ = diag(ras_sign) * STIR's gantry coordinates */
} stir_position;

static const stir_position positions[] = {
    {"head_in", "supine", {-1, -1, -1}}, /* HFS: LPS = (x, y, -z) */
    {"head_in", "prone", {1, 1, -1}},    /* HFP: LPS = (-x, -y, -z) */
    {"feet_in", "supine", {1, -1, 1}},   /* FFS: LPS = (-x, y, z) */
    {"feet_in", "prone", {-1, 1, 1}},    /* FFP: LPS = (x, -y, z) */
};

void pbc_affine_point(const double a[16], const double idx[3], double out[3])
{
    for (int r = 0; r < 3; r++)
        out[r] = a[4 * r + 3] + a[4 * r] * idx[0] + a[4 * r + 1] * idx[1] + a[4 * r + 2] * idx[2];
}

void pbc_grid_center(const double a[16], const size_t dims[3], double out[3])
{
    double idx[3];
    for (int k = 0; k < 3; k++)
        idx[k] = 0.5 * ((double)dims[k] - 1.0);
    pbc_affine_point(a, idx, out);
}

int pbc_image_affine(const pbc_image *img, double a[16])
{
    const pbc_orientation *o = &img->orientation;
    const double(*m)[4] = o->sform_code > 0 ? o->sto_xyz : o->qform_code > 0 ? o->qto_xyz : NULL;
    if (!m)
        return 0;
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            a[4 * r + c] = m[r][c];
    return 1;
}

void pbc_orientation_set_affine(pbc_orientation *o, const double a[16])
{
    /* NIFTI_XFORM_SCANNER_ANAT: coordinates of the scanner, as STIR's are. */
    o->qform_code = o->sform_code = 1;
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            o->qto_xyz[r][c] = o->sto_xyz[r][c] = a[4 * r + c];
}

static int same_word(const char *a, const char *b)
{
    for (; *a && *b; a++, b++)
        if ((*a | 0x20) != (*b | 0x20))
            return 0;
    return *a == *b;
}

int pbc_stir_affine(const char *path, const char *orientation, const char *rotation, const double fpo[3],
                    const size_t dims[3], const double vs[3], double a[16])
{
    const stir_position *pos = &positions[0];
    int known_o = same_word(orientation, "head_in") || same_word(orientation, "feet_in");
    int known_r = same_word(rotation, "supine") || same_word(rotation, "prone");
    if (known_o && !known_r && (same_word(rotation, "right") || same_word(rotation, "left")))
        return pbc_fail(PBC_EXIT_USAGE, "%s: 'patient rotation := %s' (decubitus) has no placement in STIR's "
                        "convention, nor in petblur's; give the image as NIfTI with its affine", path, rotation);
    for (size_t i = 0; known_o && known_r && i < sizeof positions / sizeof positions[0]; i++)
        if (same_word(orientation, positions[i].orientation) && same_word(rotation, positions[i].rotation))
            pos = &positions[i];
    double first[3];
    int given = !isnan(fpo[0]) + !isnan(fpo[1]) + !isnan(fpo[2]);
    if (given != 0 && given != 3)
        return pbc_fail(PBC_EXIT_USAGE, "%s: %d of the three 'first pixel offset (mm) [1-3]' keys; give all three or "
                        "none (STIR's default placement)", path, given);
    for (int i = 0; i < 3; i++)
        first[i] = given ? fpo[i] : i < 2 ? -(double)(dims[i] / 2) * vs[i] : 0.0;
    memset(a, 0, 16 * sizeof *a);
    for (int i = 0; i < 3; i++) {
        a[5 * i] = pos->ras_sign[i] * vs[i];
        a[4 * i + 3] = pos->ras_sign[i] * first[i];
    }
    a[15] = 1.0;
    return 0;
}

int pbc_stir_placement(const double a[16], const double vs[3], const char **orientation, const char **rotation,
                       double fpo[3])
{
    double sign[3];
    for (int r = 0; r < 3; r++) {
        for (int c = 0; c < 3; c++)
            if (r != c && fabs(a[4 * r + c]) > 1e-6 * vs[c])
                return 0; /* oblique */
        if (fabs(fabs(a[5 * r]) - vs[r]) > 1e-4 * vs[r])
            return 0;
        sign[r] = a[5 * r] < 0 ? -1.0 : 1.0;
    }
    for (size_t i = 0; i < sizeof positions / sizeof positions[0]; i++)
        if (!memcmp(sign, positions[i].ras_sign, sizeof sign)) {
            *orientation = positions[i].orientation;
            *rotation = positions[i].rotation;
            for (int r = 0; r < 3; r++)
                fpo[r] = sign[r] * a[4 * r + 3];
            return 1;
        }
    return 0;
}
