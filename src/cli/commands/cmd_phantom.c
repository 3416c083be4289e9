/* petblur phantom: the paper's phantoms as files. */
#include <stdio.h>
#include <stdlib.h>

#include "petblur.h"
#include "cli.h"
#include "commands.h"
#include "image_io.h"
#include "options.h"
#include "phantom.h"
#include "picture.h"

static const pbc_option options[] = {
    {"--kind", NULL, "KIND", "homogeneity (8 cubes), derenzo (hot rods) or brain (analytic head)"},
    {"--dims", NULL, "NX,NY,NZ", "grid (default 256,256,256; brain 128,128,64)"},
    {"--voxel-size", NULL, "DX,DY,DZ", "voxel size in mm (default 1,1,1; brain 2.2,2.2,2.8)"},
    {"--output", "-o", "OUT", "volume: .nii, .nii.gz, .hv or .raw"},
    {"--png", NULL, "PICTURE.png", "picture of its central slices"},
    {"--quiet", "-q", NULL, "print nothing but errors"},
};

static const pbc_command command = {
    "phantom", "--kind homogeneity|derenzo|brain -o OUT [options]",
    "Makes one of the paper's three phantoms (section 4), analytic in mm: the same object on every grid (the\n"
    "brain an ~18 cm head, Derenzo's cylinder 217.6 mm), each voxel the mean activity over its volume. It is\n"
    "centred on the scanner's origin as a head-first supine patient (NIfTI sform and qform, Interfile's STIR\n"
    "keys). brain stands in for the Zubal head phantom (128x128x64), whose terms forbid redistribution; a Zubal\n"
    "file of your own goes straight into petblur blur -i.",
    options, (int)(sizeof options / sizeof options[0]), 0, 0,
    "examples:\n"
    "  petblur phantom --kind derenzo -o derenzo.nii.gz --png derenzo.png\n"
    "  petblur phantom --kind brain -o brain.hv\n"
    "  petblur phantom --kind homogeneity --dims 128,128,96 --voxel-size 2,2,2 -o cubes.raw"};

/* Placed as a head-first supine patient in STIR's gantry frame, centred on the
 * scanner's origin: the array runs right to left, front to back and top to
 * bottom (affine diag(-dx, -dy, -dz) into RAS+), which NIfTI viewers show
 * upright and STIR reads back from the Interfile keys. The phantom is made
 * with its axes along RAS+, so its voxels are reversed along all three axes,
 * which is the reverse of the whole array. */
static void place(pbc_image *img)
{
    size_t n = pbc_image_frame_voxels(img);
    for (size_t i = 0, j = n - 1; i < j; i++, j--) {
        float t = img->data[i];
        img->data[i] = img->data[j];
        img->data[j] = t;
    }
    double a[16] = {0};
    for (int r = 0; r < 3; r++) {
        a[5 * r] = -img->voxel_size[r];
        a[4 * r + 3] = 0.5 * (double)(img->dims[r] - 1) * img->voxel_size[r];
    }
    a[15] = 1.0;
    pbc_orientation_set_affine(&img->orientation, a);
}

static int geometry(const pbc_args *args, pbc_phantom_kind kind, size_t dims[3], double vs[3])
{
    const char *d = pbc_arg(&command, args, "--dims"), *v = pbc_arg(&command, args, "--voxel-size");
    pbc_phantom_default_geometry(kind, dims, vs);
    int rc = 0;
    if ((d && (rc = pbc_parse_dims("--dims", d, dims))) || (v && (rc = pbc_parse_vec3("--voxel-size", v, 1, vs))))
        return rc;
    /* the sizes every other command reads: a phantom the blur refuses, or a
     * header of infinities, is no phantom */
    for (int i = 0; i < 3; i++)
        if (!(vs[i] >= PB_MIN_VOXEL_MM && vs[i] <= PB_MAX_VOXEL_MM))
            return pbc_fail(PBC_EXIT_USAGE, "--voxel-size %s: voxel size %c is %s mm; give sizes from %s to %s mm", v,
                            "xyz"[i], PBC_NUM(vs[i]), PBC_NUM(PB_MIN_VOXEL_MM), PBC_NUM(PB_MAX_VOXEL_MM));
    return 0;
}

/* The volume and its picture need files of their own (pbc_files_check). */
static int check_files(const char *out, const char *png)
{
    pbc_files f = {0};
    pbc_files_write(&f, "-o", out);
    pbc_files_write(&f, "--png", png);
    return pbc_files_check(&f);
}

int pbc_cmd_phantom(int argc, char **argv)
{
    pbc_args args;
    pbc_phantom_kind kind;
    int rc = pbc_parse_args(&command, argc, argv, &args);
    if (rc)
        return rc < 0 ? 0 : rc;
    const char *name = pbc_arg(&command, &args, "--kind"), *out = pbc_arg(&command, &args, "--output"),
               *png = pbc_arg(&command, &args, "--png");
    if (!name || !out)
        return pbc_fail(PBC_EXIT_USAGE, "phantom needs --kind and -o OUT; see petblur phantom --help");
    if (pbc_phantom_parse(name, &kind) != 0)
        return pbc_fail(PBC_EXIT_USAGE, "--kind %s: choose homogeneity, derenzo or brain", name);
    if ((rc = pbc_check_output("-o", out, 0)) || (png && (rc = pbc_check_output("--png", png, 1))) ||
        (rc = check_files(out, png)))
        return rc;
    size_t dims[3];
    double vs[3];
    pbc_image img = {0};
    if ((rc = geometry(&args, kind, dims, vs)) || (rc = pbc_image_check_output(out, dims, 1)) ||
        (rc = pbc_image_alloc(&img, dims, vs)))
        return rc;
    if (!(rc = pbc_phantom_make(kind, dims, vs, img.data))) {
        place(&img);
        rc = pbc_image_write(out, &img);
    }
    if (!rc && png) {
        pbc_picture_row row = {pbc_phantom_name(kind), img.data, 0};
        pbc_picture pic = {{dims[0], dims[1], dims[2]}, {vs[0], vs[1], vs[2]}, &row, 1};
        rc = pbc_picture_write(png, &pic);
    }
    if (!rc && !pbc_arg(&command, &args, "--quiet"))
        printf("%s: %s phantom, %zu x %zu x %zu voxels of %g x %g x %g mm\n", out, pbc_phantom_name(kind), dims[0],
               dims[1], dims[2], vs[0], vs[1], vs[2]);
    pbc_image_free(&img);
    return rc;
}
