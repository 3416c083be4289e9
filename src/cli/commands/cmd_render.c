/* petblur render: a picture of a volume's central slices. */
#include <stdio.h>
#include <string.h>

#include "cli.h"
#include "commands.h"
#include "image_io.h"
#include "options.h"
#include "picture.h"

static const pbc_option options[] = {
    {"--output", "-o", "PICTURE.png", "the picture"},
    {"--dims", NULL, "NX,NY,NZ", "grid of a .raw input"},
    {"--voxel-size", NULL, "DX,DY,DZ", "voxel size in mm of a .raw input (default 1,1,1)"},
    {"--title", NULL, "TEXT", "the row's title (default the file's name)"},
    {"--rows", NULL, "N", "of a 4-D image, how many frames to show, evenly spread, first and last among them "
                          "(default 4, at most 12)"},
};

static const pbc_command command = {
    "render", "IN -o PICTURE.png [options]",
    "Draws the axial, coronal and sagittal central slices of a volume side by side, with a colour bar; of a\n"
    "4-D NIfTI (petblur blur --frames writes one), up to --rows frames, first and last among them, a row each,\n"
    "each labelled with its frame's number before the title.",
    options, (int)(sizeof options / sizeof options[0]), 1, 1,
    "example:\n  petblur render blurred.nii.gz -o blurred.png"};

/* The picture must not name the volume it shows (pbc_files_check). */
static int check_files(const char *in, const char *out)
{
    pbc_files f = {0};
    pbc_files_read_image(&f, "the input", in);
    pbc_files_write(&f, "-o", out);
    return pbc_files_check(&f);
}

int pbc_cmd_render(int argc, char **argv)
{
    pbc_args args;
    int rc = pbc_parse_args(&command, argc, argv, &args);
    if (rc)
        return rc < 0 ? 0 : rc;
    const char *in = args.positional[0], *out = pbc_arg(&command, &args, "--output"),
               *title = pbc_arg(&command, &args, "--title");
    if (!out)
        return pbc_fail(PBC_EXIT_USAGE, "render needs -o PICTURE.png; see petblur render --help");
    if ((rc = pbc_check_output("-o", out, 1)) || (rc = check_files(in, out)))
        return rc;
    size_t dims[3];
    double vs[3];
    pbc_read_hints hints;
    pbc_image img = {0};
    if ((rc = pbc_hints_from_args(&command, &args, dims, vs, &hints)))
        return rc;
    hints.allow_frames = 1;
    if ((rc = pbc_image_read(in, &hints, &img)))
        return rc;
    if (!title) {
        const char *slash = strrchr(in, '/');
        title = slash ? slash + 1 : in;
    }
    /* A 4-D image: up to --rows frames, the first and last among them, one
     * row each; the frame's number leads its label, so that a long title is
     * what gets shortened. */
    size_t frames = pbc_image_frame_count(&img);
    unsigned long rows_wanted = 4;
    const char *v = pbc_arg(&command, &args, "--rows");
    if (v && (rc = pbc_parse_count("--rows", v, 1, 12, &rows_wanted))) {
        pbc_image_free(&img);
        return rc;
    }
    size_t shown = frames < rows_wanted ? frames : rows_wanted;
    pbc_picture_row rows[12];
    char labels[12][96];
    for (size_t r = 0; r < shown; r++) {
        size_t f = shown > 1 ? r * (frames - 1) / (shown - 1) : 0;
        snprintf(labels[r], sizeof labels[r], "frame %zu/%zu %s", f, frames, title);
        rows[r] = (pbc_picture_row){frames > 1 ? labels[r] : title, img.data + f * pbc_image_frame_voxels(&img), 0};
    }
    pbc_picture pic = {{img.dims[0], img.dims[1], img.dims[2]},
                       {img.voxel_size[0], img.voxel_size[1], img.voxel_size[2]}, rows, (int)shown};
    rc = pbc_picture_write(out, &pic);
    pbc_image_free(&img);
    return rc;
}
