/* petblur demo: the main job end to end. A phantom moves through a frame with
 * a translation and a rotation; AB, RM and CL blur it on the default device and
 * are compared with the paper's multi-point reference (REF). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blur_run.h"
#include "cli.h"
#include "commands.h"
#include "phantom.h"
#include "picture.h"

static const pbc_option options[] = {
    PBC_OPTION_DEVICE,
    {"--kind", NULL, "KIND", "phantom: brain (default), homogeneity or derenzo"},
    {"--size", NULL, "N", "in-plane voxels (default 96; brain: N x N x N/2)"},
    {"--points", NULL, "K", "REF's random points per voxel (default 200, the paper's)"},
    {"--out-dir", NULL, "DIR", "where the volumes and demo.png go (default petblur-demo)"},
    {"--quiet", "-q", NULL, "no progress lines"},
};

static const pbc_command command = {
    "demo", "[--device DEV] [--kind KIND] [--size N] [--out-dir DIR]",
    "The main job, end to end: makes a phantom, moves it through a frame (translation 9,6,-4.5 mm and a\n"
    "10 degree turn about z, through the grid's centre), blurs it with AB, RM and CL on the device, compares\n"
    "each with the multi-point reference REF (relative RMS and max error, %) and writes the volumes (.nii.gz) and demo.png.",
    options, (int)(sizeof options / sizeof options[0]), 0, 0, NULL};

typedef struct demo_run {
    const char *name, *file;
    pb_method method;
    pb_filter filter;
} demo_run;

static const demo_run runs[] = {{"REF", "ref", PB_METHOD_REF, PB_FILTER_EXACT},
                                {"AB", "ab", PB_METHOD_AB, PB_FILTER_HARDWARE},
                                {"RM", "rm", PB_METHOD_RM, PB_FILTER_HARDWARE},
                                {"CL", "cl", PB_METHOD_CL, PB_FILTER_HARDWARE}};
enum { RUNS = sizeof runs / sizeof runs[0] };

static int make_phantom(const pbc_args *args, pbc_image *img, pbc_phantom_kind *kind)
{
    const char *k = pbc_arg(&command, args, "--kind"), *s = pbc_arg(&command, args, "--size");
    unsigned long n = 96;
    int rc = 0;
    *kind = PBC_PHANTOM_BRAIN;
    if (k && pbc_phantom_parse(k, kind) != 0)
        return pbc_fail(PBC_EXIT_USAGE, "--kind %s: choose brain, homogeneity or derenzo", k);
    if (s && (rc = pbc_parse_count("--size", s, 8, 1024, &n)))
        return rc;
    /* The phantom's default field of view on an n-voxel grid: the same object
     * as at full size, sampled coarser. */
    size_t dims[3];
    double vs[3];
    pbc_phantom_default_geometry(*kind, dims, vs);
    for (int i = 0; i < 3; i++) {
        size_t m = i < 2 ? n : (*kind == PBC_PHANTOM_BRAIN ? n / 2 : n);
        vs[i] *= (double)dims[i] / (double)m;
        dims[i] = m;
    }
    if ((rc = pbc_image_alloc(img, dims, vs)))
        return rc;
    return pbc_phantom_make(*kind, dims, vs, img->data);
}

static int out_path(char *buf, size_t size, const char *dir, const char *name, const char *ext)
{
    if (snprintf(buf, size, "%s/%s%s", dir, name, ext) >= (int)size)
        return pbc_fail(PBC_EXIT_USAGE, "--out-dir %s: the path is too long", dir);
    return 0;
}

static int write_picture(const char *dir, const pbc_image *phantom, const float *ab, const float *ref)
{
    size_t n = phantom->dims[0] * phantom->dims[1] * phantom->dims[2];
    float *diff = malloc(n * sizeof *diff);
    char path[4096];
    int rc = out_path(path, sizeof path, dir, "demo", ".png");
    if (!diff)
        rc = pbc_fail(PBC_EXIT_RUNTIME, "out of memory for the picture");
    if (!rc) {
        for (size_t i = 0; i < n; i++)
            diff[i] = ab[i] - ref[i];
        pbc_picture_row rows[3] = {{"phantom", phantom->data, 0}, {"AB blur", ab, 0}, {"AB - REF", diff, 1}};
        pbc_picture pic = {{phantom->dims[0], phantom->dims[1], phantom->dims[2]},
                           {phantom->voxel_size[0], phantom->voxel_size[1], phantom->voxel_size[2]}, rows, 3};
        rc = pbc_picture_write(path, &pic);
    }
    free(diff);
    return rc;
}

/* Runs every method into vols[r], writing each volume as it comes, and prints
 * the table. */
static int run_all(pb_context *ctx, unsigned long points, const pbc_image *phantom, const pb_motion *motion,
                   const char *dir, float *const vols[RUNS])
{
    size_t n = phantom->dims[0] * phantom->dims[1] * phantom->dims[2];
    int rc = 0;
    printf("\n%-4s %-9s %10s %10s %12s\n", "", "filter", "rms %", "max %", "kernel ms");
    for (int r = 0; r < RUNS && !rc; r++) {
        pb_blur_options opt = {runs[r].method, runs[r].filter, 0, (unsigned)points, 0, 1, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
        pbc_image out = *phantom;
        double ms = 0.0;
        char path[4096];
        out.data = vols[r];
        if ((rc = pbc_blur_image(ctx, phantom, motion, &opt, 0, runs[r].name, vols[r], &ms)) ||
            (rc = out_path(path, sizeof path, dir, runs[r].file, ".nii.gz")) || (rc = pbc_image_write(path, &out)))
            break;
        if (r == 0)
            printf("%-4s %-9s %21s %12.2f   (%lu points per voxel)\n", runs[r].name, "box", "reference", ms, points);
        else {
            pb_comparison c;
            if (pb_compare(vols[0], vols[r], n, &c) != PB_OK)
                return pbc_fail(PBC_EXIT_RUNTIME, "%s against REF: %s", runs[r].name, pb_last_error(NULL));
            printf("%-4s %-9s %10.4f %10.4f %12.2f\n", runs[r].name, "hardware", c.rms_percent, c.max_percent, ms);
        }
        fflush(stdout);
    }
    return rc;
}

static int demo(pb_context *ctx, const pbc_args *args, const pbc_image *phantom, const pb_motion *motion,
                const char *dir)
{
    const char *p = pbc_arg(&command, args, "--points");
    unsigned long points = 200;
    size_t n = phantom->dims[0] * phantom->dims[1] * phantom->dims[2];
    float *vols[RUNS] = {NULL};
    char path[4096];
    int rc = p ? pbc_parse_count("--points", p, 1, 100000, &points) : 0;
    for (int r = 0; r < RUNS && !rc; r++)
        if (!(vols[r] = malloc(n * sizeof(float))))
            rc = pbc_fail(PBC_EXIT_RUNTIME, "out of memory for the demo's volumes; use a smaller --size");
    if (!rc && !(rc = pbc_make_dir("--out-dir", dir)) && !(rc = out_path(path, sizeof path, dir, "phantom", ".nii.gz")) &&
        !(rc = pbc_image_write(path, phantom)) && !(rc = run_all(ctx, points, phantom, motion, dir, vols)))
        rc = write_picture(dir, phantom, vols[1], vols[0]);
    if (!rc)
        printf("\nwrote %s/{phantom,ref,ab,rm,cl}.nii.gz and %s/demo.png\n", dir, dir);
    for (int r = 0; r < RUNS; r++)
        free(vols[r]);
    return rc;
}

/* The demo's outputs (phantom, one volume per method, the picture) need files
 * of their own (pbc_files_check) that petblur may replace, as every other
 * command's outputs (no link written through or replaced); it reads nothing.
 * The folder may not exist yet: pbc_make_dir makes it. */
static int check_files(const char *dir)
{
    pbc_files f = {0};
    char path[4096];
    for (int r = -1; r <= RUNS && !f.status; r++) {
        const char *name = r < 0 ? "phantom" : r < RUNS ? runs[r].file : "demo";
        if (!(f.status = out_path(path, sizeof path, dir, name, r < RUNS ? ".nii.gz" : ".png")) &&
            !(f.status = pbc_check_replaceable("--out-dir", path)))
            pbc_files_write(&f, "--out-dir", path);
    }
    return pbc_files_check(&f);
}

int pbc_cmd_demo(int argc, char **argv)
{
    pbc_args args;
    pbc_image phantom = {0};
    pbc_phantom_kind kind;
    pb_context *ctx = NULL;
    int rc = pbc_parse_args(&command, argc, argv, &args);
    if (rc)
        return rc < 0 ? 0 : rc;
    if (pbc_arg(&command, &args, "--quiet"))
        pbc_show_progress = 0;
    const char *dir = pbc_arg(&command, &args, "--out-dir");
    dir = dir ? dir : "petblur-demo";
    if ((rc = check_files(dir)) || (rc = make_phantom(&args, &phantom, &kind)) ||
        (rc = pbc_open_device(pbc_arg(&command, &args, "--device"), &ctx)))
        goto done;
    /* A frame that starts at rest and ends moved and turned about the scanner
     * axis through the grid's centre. */
    double times[2] = {0.0, 1.0}, z[3] = {0, 0, 1};
    pb_pose poses[2] = {{{0, 0, 0}, {1, 0, 0, 0}}, {{9.0, 6.0, -4.5}, {1, 0, 0, 0}}};
    pb_quaternion_from_axis_angle(z, 10.0, poses[1].rotation);
    pb_motion motion = {times, poses, 2, 0.0, 1.0, 0, {0, 0, 0}};
    char dev[600];
    pbc_describe_device(ctx, dev, sizeof dev);
    printf("device: %s\n", dev);
    printf("phantom: %s, %zu x %zu x %zu voxels of %.3g x %.3g x %.3g mm\n", pbc_phantom_name(kind), phantom.dims[0],
           phantom.dims[1], phantom.dims[2], phantom.voxel_size[0], phantom.voxel_size[1], phantom.voxel_size[2]);
    printf("motion: translation (9, 6, -4.5) mm and 10 deg about z over the frame\n");
    rc = demo(ctx, &args, &phantom, &motion, dir);
done:
    pb_context_destroy(ctx);
    pbc_image_free(&phantom);
    return rc;
}
