/* petblur motion estimate: the patient's motion from a 4-D series of frames,
 * written as a track that petblur blur --motion reads. The estimate itself is
 * the library's (pb_motion_estimate); this file reads, checks and writes. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "atomic_file.h"
#include "blur_run.h"
#include "cli.h"
#include "commands.h"
#include "motion_args.h"

static const pbc_option options[] = {
    {"--output", "-o", "TRACK.csv", "the track (required)"},
    {"--frames", NULL, "T0,T1,...", "the frames' boundaries, seconds: one more than the series' frames"},
    {"--frames-from", NULL, "SIDECAR.json", "the frames from a BIDS-PET sidecar (FrameTimesStart, FrameDuration)"},
    {"--format", NULL, "FORMAT", "matrix-csv (default: rigid maps about the world's origin) or csv (poses about the "
                                 "centre of FRAMES' grid, which blur then needs as its grid or --center)"},
    {"--reference", NULL, "K|auto", "the frame whose object the track moves, from 0; auto (the default): the "
                                    "frame held still whose pose the series determines best, printed"},
    {"--frame-poses-only", NULL, NULL, "one pose per frame: no motion inside frames"},
    {"--levels", NULL, "N", "resolution levels, each halving the grid (default: up to 3)"},
    {"--iterations", NULL, "N", "Gauss-Newton steps at most per level and frame (default 12)"},
    {"--fwhm", NULL, "MM", "smoothing before registration, mm (default two voxels of each level)"},
    {"--voxel-size", NULL, "DX,DY,DZ", "voxel size in mm, for a header that gives none (pixdim 0)"},
    PBC_OPTION_DEVICE,
    {"--quiet", "-q", NULL, "print nothing but errors"},
};

static const pbc_command command = {
    "motion estimate", "FRAMES.nii[.gz] (--frames-from SIDECAR.json | --frames T0,T1,...) -o TRACK.csv [options]",
    "Estimates the head's rigid motion from the frames of a dynamic PET series, inside frames too. Each frame\n"
    "is registered to its neighbour towards the reference frame, then twice to its own reference (the principal\n"
    "images of its nearest frames moved back onto the reference frame, so that changing uptake is followed);\n"
    "the frames before a late frame are linked to it by mutual information, which lets each tissue keep its own\n"
    "intensity (an early frame's blood and tissue stand in another ratio than a late frame's); the poses are\n"
    "then smoothed in time, each weighed by how sure its fit is (a few counts' early frame little, a sharp late\n"
    "one much), jumps between frames kept; a frame whose blur along a path from or between its neighbours'\n"
    "poses fits it better than one pose (a jerk inside it, the first and last frames too, or a nod out and\n"
    "back) gets that path, timed, or two poses of its own held in turn where they fit clearly better (a jerk\n"
    "inside a frame whose neighbours move themselves); and in a series of 12 frames or more every pose gets one\n"
    "correction along the contrast, against the bias changing uptake leaves (docs/motion.md, \"Motion from the\n"
    "frames\"). TRACK says where a point of the reference frame's object is at each time, in the world\n"
    "coordinates of FRAMES' affine: give it to petblur blur --motion and petblur.Motion.from_file as it is. The\n"
    "reference frame is, unless --reference names one, the still frame whose pose the frames determine best (a\n"
    "long late frame rather than the first seconds' few counts, whose error would move every pose). It prints\n"
    "which, and, a line a frame, the share of the frame's variance its fit explains (a frame of few counts, or\n"
    "of a contrast unlike the others', has less: trust its pose less), when the track moves inside it, and\n"
    "where the frame shows motion inside it that the track does not follow (its pose is a mean over that\n"
    "motion: trust it less).",
    options, (int)(sizeof options / sizeof options[0]), 1, 1,
    "examples:\n"
    "  petblur motion estimate sub-01_pet.nii.gz --frames-from sub-01_pet.json -o motion.csv\n"
    "  petblur blur -i sub-01_pet.nii.gz -o blurred.nii.gz --motion motion.csv --frames-from sub-01_pet.json"};

static int check_files(const pbc_args *args, const char *out)
{
    pbc_files f = {0};
    pbc_files_read_image(&f, "FRAMES", args->positional[0]);
    pbc_files_read(&f, "--frames-from", pbc_arg(&command, args, "--frames-from"));
    pbc_files_write(&f, "-o", out);
    return pbc_files_check(&f);
}

static int write_track(const char *path, const pb_track *track, int csv, const double center[3])
{
    pbc_temp t;
    FILE *f;
    int rc = pbc_temp_open(&t, path, &f);
    if (rc)
        return rc;
    const double *times = pb_track_times(track);
    const pb_pose *poses = pb_track_poses(track);
    fputs(csv ? "t,tx,ty,tz,qw,qx,qy,qz\n" : "t,r00,r01,r02,tx,r10,r11,r12,ty,r20,r21,r22,tz\n", f);
    for (size_t i = 0; i < pb_track_count(track); i++) {
        double m[16];
        pb_pose_to_matrix(&poses[i], m);
        fprintf(f, "%.17g", times[i]);
        if (csv) {
            /* about the centre: t_c = t + R c - c */
            double tc[3];
            for (int r = 0; r < 3; r++)
                tc[r] = m[4 * r + 3] + m[4 * r] * center[0] + m[4 * r + 1] * center[1] + m[4 * r + 2] * center[2] -
                        center[r];
            fprintf(f, ",%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", tc[0], tc[1], tc[2], poses[i].rotation[0],
                    poses[i].rotation[1], poses[i].rotation[2], poses[i].rotation[3]);
        } else {
            for (int r = 0; r < 3; r++)
                fprintf(f, ",%.17g,%.17g,%.17g,%.17g", m[4 * r], m[4 * r + 1], m[4 * r + 2], m[4 * r + 3]);
            fputc('\n', f);
        }
    }
    return pbc_temp_commit(&t, f);
}

/* --device auto (the default) as the library resolves it for the estimate:
 * a GPU, else the host backend rather than an OpenCL CPU device. */
static int open_device(const char *spec, pb_context **ctx)
{
    pb_backend backend;
    int index;
    char resolved[32];
    if ((spec && strcmp(spec, "auto") != 0) || pb_device_auto_estimate(&backend, &index) != PB_OK)
        return pbc_open_device(spec, ctx);
    if (backend == PB_BACKEND_HOST)
        snprintf(resolved, sizeof resolved, "host");
    else
        snprintf(resolved, sizeof resolved, "%s:%d", pb_backend_name(backend), index);
    return pbc_open_device(resolved, ctx);
}

static int options_from_args(const pbc_args *args, pb_estimate_options *o, int *csv)
{
    const char *v;
    unsigned long n;
    double d;
    int rc = 0;
    memset(o, 0, sizeof *o);
    static const char *const formats[] = {"matrix-csv", "csv"};
    *csv = 0;
    if ((v = pbc_arg(&command, args, "--format")) && (rc = pbc_parse_choice("--format", v, formats, 2, csv)))
        return rc;
    o->reference = PB_ESTIMATE_REFERENCE_AUTO;
    if ((v = pbc_arg(&command, args, "--reference")) && strcmp(v, "auto") != 0) {
        if (strspn(v, "0123456789") != strlen(v) || !v[0])
            return pbc_fail(PBC_EXIT_USAGE, "--reference %s: give a frame's number, from 0, or auto (the still frame "
                            "whose pose the frames determine best)", v);
        if ((rc = pbc_parse_count("--reference", v, 0, 1000000, &n)))
            return rc;
        o->reference = n;
    }
    if ((v = pbc_arg(&command, args, "--levels"))) {
        if ((rc = pbc_parse_count("--levels", v, 1, 6, &n)))
            return rc;
        o->levels = (unsigned)n;
    }
    if ((v = pbc_arg(&command, args, "--iterations"))) {
        if ((rc = pbc_parse_count("--iterations", v, 1, 1000, &n)))
            return rc;
        o->iterations = (unsigned)n;
    }
    if ((v = pbc_arg(&command, args, "--fwhm"))) {
        if ((rc = pbc_parse_number("--fwhm", v, &d)))
            return rc;
        if (!(d > 0 && d <= 1000))
            return pbc_fail(PBC_EXIT_USAGE, "--fwhm %s: give a width in mm, above 0 and at most 1000", v);
        o->fwhm_mm = d;
    }
    o->frame_poses_only = pbc_arg(&command, args, "--frame-poses-only") != NULL;
    return 0;
}

/* The summary, then a line a frame: how much of it the fit explains (a
 * frame of few counts, or of a contrast unlike the others', less: its pose
 * deserves less trust), and where the track moves inside it, or where motion
 * shows inside it that the track does not follow (its pose is a mean over
 * that motion). */
static void print_summary(pb_context *ctx, const char *out_path, const pb_track *track, size_t frames, int csv,
                          const double *bounds, const pb_estimate_frame *per_frame, const pb_estimate_report *report,
                          int chosen)
{
    char dev[600];
    pbc_describe_device(ctx, dev, sizeof dev);
    char jumps[64] = "";
    size_t n = 0;
    for (size_t f = 0; per_frame && f < frames; f++)
        n += per_frame[f].jumped_at_start != 0;
    if (per_frame) /* without the table the frames' report is not at hand */
        snprintf(jumps, sizeof jumps, ", %zu %s at a boundary", n, n == 1 ? "jump" : "jumps");
    printf("%s: %zu poses from %zu frames (%zu with motion inside%s), %s, on %s in %.1f s\n", out_path,
           pb_track_count(track), frames, report->moving_frames, jumps, csv ? "csv" : "matrix-csv", dev,
           report->seconds);
    printf("  relative to frame %zu%s\n", report->reference,
           chosen ? " (chosen: the still frame whose pose the frames determine best)" : "");
    if (!per_frame)
        return;
    size_t unfollowed = 0;
    for (size_t f = 0; f < frames; f++)
        unfollowed += per_frame[f].unfollowed > 0;
    if (unfollowed)
        printf("  %zu %s motion inside that the track does not follow: %s a mean over it (below)\n", unfollowed,
               unfollowed == 1 ? "frame shows" : "frames show", unfollowed == 1 ? "its pose is" : "their poses are");
    printf("  frame       start s      end s  fit explains  motion inside the frame\n");
    for (size_t f = 0; f < frames; f++) {
        const pb_estimate_frame *r = &per_frame[f];
        printf("  %5zu  %12.3f %10.3f  %11.1f %%  ", f, bounds[f], bounds[f + 1], 100.0 * r->explained);
        if (!r->structure)
            printf("no structure above the noise: a neighbour's pose");
        else if (r->moving)
            printf("from %.3f to %.3f s", r->motion_from, r->motion_to);
        else if (r->unfollowed > 0)
            printf("not followed: a path explains %.0f %% of one pose's residual (trust its pose less)",
                   100.0 * r->unfollowed);
        else
            printf("-");
        printf("%s%s\n", r->jumped_at_start ? " (the head jumped at its start)" : "",
               f == report->reference ? " (the reference)" : "");
    }
}

static int run(const pbc_args *args, const char *in_path, const char *out_path)
{
    pb_estimate_options o;
    int csv, quiet = pbc_arg(&command, args, "--quiet") != NULL;
    const char *fv = pbc_arg(&command, args, "--frames"), *json = pbc_arg(&command, args, "--frames-from");
    int rc = options_from_args(args, &o, &csv);
    if (rc)
        return rc;
    if (!fv == !json)
        return pbc_fail(PBC_EXIT_USAGE, "the frames' times: give --frames-from SIDECAR.json or --frames T0,T1,...");
    double *bounds = NULL;
    size_t nb = 0;
    pbc_image img = {0};
    pb_context *ctx = NULL;
    pb_track *track = NULL;
    pbc_read_hints hints = {0};
    size_t dims[3];
    double voxel_size[3];
    if ((rc = pbc_hints_from_args(&command, args, dims, voxel_size, &hints)))
        return rc;
    hints.allow_frames = 1;
    if ((rc = fv ? pbc_parse_bounds("--frames", fv, &bounds, &nb) : pbc_bids_frames(json, &bounds, &nb)))
        return rc;
    size_t frames = nb - 1;
    rc = pbc_image_read(in_path, &hints, &img);
    size_t have = rc ? 0 : pbc_image_frame_count(&img);
    if (!rc && have < 2)
        rc = pbc_fail(PBC_EXIT_USAGE, "%s holds one volume: motion from the frames needs a 4-D series [x, y, z, t] "
                      "of at least two frames", in_path);
    else if (!rc && have != frames)
        rc = pbc_fail(PBC_EXIT_USAGE, "%s has %zu frames but %s gives %zu; give the frames of this series", in_path,
                      have, fv ? "--frames" : json, frames);
    else if (!rc && o.reference != PB_ESTIMATE_REFERENCE_AUTO && o.reference >= frames)
        rc = pbc_fail(PBC_EXIT_USAGE, "--reference %zu: the series has frames 0 to %zu", o.reference, frames - 1);
    double affine[16], center[3];
    if (!rc) {
        if (!pbc_image_affine(&img, affine)) {
            pb_geometry g = {{img.dims[0], img.dims[1], img.dims[2]},
                             {img.voxel_size[0], img.voxel_size[1], img.voxel_size[2]}};
            pb_geometry_grid_affine(&g, affine);
        }
        pbc_grid_center(affine, img.dims, center); /* a csv track's poses turn about it */
        rc = open_device(pbc_arg(&command, args, "--device"), &ctx);
    }
    if (!rc) {
        pb_geometry g = {{img.dims[0], img.dims[1], img.dims[2]},
                         {img.voxel_size[0], img.voxel_size[1], img.voxel_size[2]}};
        pb_estimate_report report = {0};
        o.frames = calloc(frames, sizeof *o.frames); /* without it, no table: the track stands */
        pb_context_set_progress(ctx, pbc_show_progress && !quiet ? pbc_progress_line : NULL,
                                (void *)"estimating motion");
        pb_status st = pb_motion_estimate(ctx, &g, affine, img.data, frames, bounds, &o, &track, &report);
        if (st != PB_OK) {
            if (pbc_show_progress && !quiet)
                pbc_progress_line(1.0, NULL);
            const char *whence = st != PB_ERR_BAD_VOXEL_SIZE ? ""
                                 : pbc_arg(&command, args, "--voxel-size") ? " (from --voxel-size: fix it)"
                                 : " (this file's header gives it: correct its pixdim, or set it to 0 and give "
                                   "--voxel-size DX,DY,DZ)";
            rc = pbc_fail(pbc_exit_for(st), "%s: %s%s", in_path, pb_last_error(ctx), whence);
        } else {
            pbc_print_warnings(&report.warnings);
            if (!(rc = write_track(out_path, track, csv, center)) && !quiet)
                print_summary(ctx, out_path, track, frames, csv, bounds, o.frames, &report,
                              o.reference == PB_ESTIMATE_REFERENCE_AUTO);
        }
        free(o.frames);
    }
    pb_track_free(track);
    pb_context_destroy(ctx);
    pbc_image_free(&img);
    free(bounds);
    return rc;
}

int pbc_cmd_motion_estimate(int argc, char **argv)
{
    pbc_args args;
    int rc = pbc_parse_args(&command, argc, argv, &args);
    if (rc)
        return rc < 0 ? 0 : rc;
    const char *out = pbc_arg(&command, &args, "--output");
    if (!out)
        return pbc_fail(PBC_EXIT_USAGE, "give the track's file: -o TRACK.csv");
    if ((rc = pbc_check_output("-o", out, 2)) || (rc = check_files(&args, out)))
        return rc;
    return run(&args, args.positional[0], out);
}
