/* petblur compare: how far a volume is from a reference, as relative RMS
 * and max in percent, and the paper's eq. (5) named as such. */
#include <math.h>
#include <stdio.h>

#include "cli.h"
#include "commands.h"
#include "image_io.h"
#include "options.h"
#include "petblur.h"

static const pbc_option options[] = {
    {"--dims", NULL, "NX,NY,NZ", "grid of .raw inputs"},
    {"--voxel-size", NULL, "DX,DY,DZ", "voxel size in mm of .raw inputs (default 1,1,1)"},
};

static const pbc_command command = {
    "compare", "REFERENCE TEST [--dims NX,NY,NZ]",
    "Prints how far TEST is from REFERENCE, over every voxel of every frame:\n"
    "  rms% = 100 * sqrt(sum (test - ref)^2 / sum ref^2)  (relative L2)\n"
    "  max% = 100 * max |test - ref| / max |ref|          (relative max)\n"
    "  eq5% = 100 * sum (test - ref)^2 / sum ref^2        (the paper's eq. (5): the square\n"
    "                                                      of rms% / 10; 0.05 there is 2.2 % RMS)\n"
    "the worst voxel, and, last, the line \"rms% = <n> max% = <n> eq5% = <n>\".",
    options, (int)(sizeof options / sizeof options[0]), 2, 2,
    "example:\n  petblur compare ref.nii.gz ab.nii.gz"};

static int read_both(const pbc_args *args, pbc_image *ref, pbc_image *test)
{
    size_t dims[3];
    double vs[3];
    pbc_read_hints hints;
    int rc = pbc_hints_from_args(&command, args, dims, vs, &hints);
    hints.allow_frames = 1;
    if (rc || (rc = pbc_image_read(args->positional[0], &hints, ref)) ||
        (rc = pbc_image_read(args->positional[1], &hints, test)))
        return rc;
    if (pbc_image_frame_count(ref) != pbc_image_frame_count(test))
        return pbc_fail(PBC_EXIT_USAGE, "%s has %zu frames and %s %zu; compare images with as many frames",
                        args->positional[0], pbc_image_frame_count(ref), args->positional[1],
                        pbc_image_frame_count(test));
    for (int i = 0; i < 3; i++)
        if (ref->dims[i] != test->dims[i] || fabs(ref->voxel_size[i] - test->voxel_size[i]) > 1e-6 * ref->voxel_size[i])
            return pbc_fail(PBC_EXIT_USAGE, "%s is %zu x %zu x %zu voxels of %g x %g x %g mm but %s is %zu x %zu x %zu "
                            "of %g x %g x %g mm; compare volumes on the same grid", args->positional[0], ref->dims[0],
                            ref->dims[1], ref->dims[2], ref->voxel_size[0], ref->voxel_size[1], ref->voxel_size[2],
                            args->positional[1], test->dims[0], test->dims[1], test->dims[2], test->voxel_size[0],
                            test->voxel_size[1], test->voxel_size[2]);
    /* The same grid placed elsewhere (an axis flipped, a shift) holds other
     * places in the same voxels: the numbers would compare nothing. Grids
     * with no placement (.raw) are taken as placed alike. */
    double a[16], b[16], apart = 0.0;
    if (pbc_image_affine(ref, a) && pbc_image_affine(test, b)) {
        for (int corner = 0; corner < 8; corner++) {
            double idx[3], pa[3], pb[3], d = 0.0;
            for (int i = 0; i < 3; i++)
                idx[i] = (corner >> i & 1) ? (double)ref->dims[i] - 1.0 : 0.0;
            pbc_affine_point(a, idx, pa);
            pbc_affine_point(b, idx, pb);
            for (int r = 0; r < 3; r++)
                d += (pa[r] - pb[r]) * (pa[r] - pb[r]);
            apart = fmax(apart, sqrt(d));
        }
        double least = fmin(ref->voxel_size[0], fmin(ref->voxel_size[1], ref->voxel_size[2]));
        if (!(apart <= 0.01 * least))
            return pbc_fail(PBC_EXIT_USAGE, "%s and %s are the same grid placed %g mm apart in the world (a corner "
                            "voxel's centre, by their headers' affines: an axis flipped or a shift); compare volumes "
                            "placed alike, resampling one onto the other first", args->positional[0],
                            args->positional[1], apart);
    }
    return 0;
}

int pbc_cmd_compare(int argc, char **argv)
{
    pbc_args args;
    pbc_image ref = {0}, test = {0};
    int rc = pbc_parse_args(&command, argc, argv, &args);
    if (rc)
        return rc < 0 ? 0 : rc;
    /* Nothing is written; the list still checks where an Interfile data
     * file lies before any reading. */
    pbc_files files = {0};
    pbc_files_read_image(&files, "REFERENCE", args.positional[0]);
    pbc_files_read_image(&files, "TEST", args.positional[1]);
    if (!(rc = pbc_files_check(&files)) && !(rc = read_both(&args, &ref, &test))) {
        size_t n = pbc_image_frame_voxels(&ref) * pbc_image_frame_count(&ref); /* every frame */
        pb_comparison c;
        pb_status st = pb_compare(ref.data, test.data, n, &c);
        if (st == PB_ERR_NOT_FINITE) {
            rc = pbc_fail(PBC_EXIT_USAGE, "%s or %s holds a value that is not finite: %s", args.positional[0],
                          args.positional[1], pb_last_error(NULL));
        } else if (st != PB_OK) {
            rc = pbc_fail(PBC_EXIT_USAGE, "%s is zero everywhere, so the relative error is undefined; give a "
                          "non-zero reference", args.positional[0]);
        } else {
            size_t frame = pbc_image_frame_voxels(&ref), v = c.worst % frame;
            size_t ix = v % ref.dims[0], iy = v / ref.dims[0] % ref.dims[1], iz = v / ref.dims[0] / ref.dims[1];
            printf("reference: %s (%zu x %zu x %zu)\ntest: %s\n", args.positional[0], ref.dims[0], ref.dims[1],
                   ref.dims[2], args.positional[1]);
            printf("relative RMS error: %.6g %%\n", c.rms_percent);
            printf("relative max error: %.6g %% (|difference| %.6g at voxel %zu,%zu,%zu of frame %zu; reference "
                   "%.6g there)\n", c.max_percent, c.max_difference, ix, iy, iz, c.worst / frame,
                   (double)ref.data[c.worst]);
            printf("the paper's eq. (5): %.6g %%\n", c.eq5_percent);
            printf("rms%% = %.6g max%% = %.6g eq5%% = %.6g\n", c.rms_percent, c.max_percent, c.eq5_percent);
        }
    }
    pbc_image_free(&ref);
    pbc_image_free(&test);
    return rc;
}
