/* petblur blur: one volume through one frame's motion. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "atomic_file.h"
#include "blur_run.h"
#include "cli.h"
#include "commands.h"
#include "fields.h"
#include "picture.h"

static const pbc_option options[] = {
    {"--input", "-i", "IN", "object-space volume: .nii, .nii.gz, .hv (Interfile) or .raw (float32, x fastest)"},
    {"--output", "-o", "OUT", "blurred volume, same format rules; float32 with the input's geometry"},
    {"--dims", NULL, "NX,NY,NZ", "grid of a .raw input (checked against the header of other formats)"},
    {"--voxel-size", NULL, "DX,DY,DZ", "voxel size in mm of a .raw input (default 1,1,1)"},
    PBC_MOTION_OPTIONS,
    PBC_FIELD_OPTIONS,
    PBC_SIGNAL_OPTIONS,
    {"--frames", NULL, "T0,T1,...", "dynamic PET: the frames' boundaries in the motion, seconds; IN is a 4-D NIfTI "
                                    "with one volume per frame (or 3-D, for all), OUT a 4-D NIfTI"},
    {"--frames-from", NULL, "SIDECAR.json", "the frames from a BIDS-PET sidecar (FrameTimesStart, FrameDuration, "
                                            "s) instead of --frames"},
    {"--method", NULL, "ab|rm|cl|ref", "AB (default), ray marching, classical, or the multi-point reference"},
    {"--filter", NULL, "hardware|exact", "one filtered fetch per sample (default), or float weights; REF: unused"},
    {"--steps", NULL, "N", "RM, CL: samples per segment (default: as many slices as AB visits); AB: sub-segments"},
    {"--max-path-error", NULL, "E", "AB, RM: the most a voxel's path may leave its polyline, voxels (default 0.1; "
                                    "'paper': one segment per tracked interval)"},
    {"--ab-sampling", NULL, "slice|sweep|chord", "AB: read each slice at one point (default, the paper's), at two "
                                                 "where the path sweeps sideways across it, or every segment "
                                                 "exactly, never walked (for segments of 6 voxels and more)"},
    {"--points", NULL, "K", "REF: random points per voxel (default 200)"},
    {"--seed", NULL, "S", "REF: seed of the random points (default 1)"},
    {"--jacobian", NULL, NULL, "with --fields: mass-preserving, each voxel weighed by its field's Jacobian "
                               "determinant, for images of counts (default: concentrations, as PET images hold)"},
    {"--adjoint", NULL, NULL, "apply the transpose instead (back projection's blur): IN is tomograph-space, OUT "
                              "object-space"},
    {"--sum-frames", NULL, NULL, "with --adjoint --frames (or --gates): add every frame's back projection into one "
                                 "3-D OUT (the transpose of a 3-D IN blurred through every frame), in any format"},
    PBC_OPTION_DEVICE,
    {"--png", NULL, "PICTURE.png", "picture of input, output and difference (central slices)"},
    {"--quiet", "-q", NULL, "print nothing but errors"},
};

static const pbc_command command = {
    "blur", "-i IN -o OUT [--translate TX,TY,TZ] [--rotate DEG] [--motion TRACK | --fields TABLE.csv] [options]",
    "Blurs a volume along the motion inside one frame (the tomograph-space activity that the frame's\n"
    "projections see). The pose maps object to tomograph space: p' = R (p - c) + c + t. With --translate and\n"
    "--rotate the frame starts at the identity and ends at that pose. Motions are in the scanner's world\n"
    "coordinates (RAS+ mm, as NIfTI's sform and STIR's Interfile placement give them) wherever the input has\n"
    "a placement, else (.raw, --coords grid) in mm along the array's axes from the grid's corner. With\n"
    "--fields the motion is non-rigid: registrations' displacement fields D(t) (NIfTI, world mm, any grid)\n"
    "put the voxel at r at object point r + D(t)(r), linear in time between the fields.",
    options, (int)(sizeof options / sizeof options[0]), 0, 0,
    "examples:\n"
    "  petblur blur -i brain.nii.gz -o blurred.nii.gz --translate 12,10,-11 --rotate 10 --png blur.png\n"
    "  petblur blur -i derenzo.hv -o moved.hv --motion track.csv --frame 30,60 --method ab --device opencl\n"
    "  petblur blur -i head.nii.gz -o f3.nii.gz --motion head.mt --calibration cal.txt --reference-time 65900 \\\n"
    "      --frame 65930,65960\n"
    "  petblur blur -i zubal.raw --dims 128,128,64 --voxel-size 2.2,2.2,2.8 -o zubal-blurred.nii --rotate 15\n"
    "  petblur blur -i ratio.nii.gz -o backprojected.nii.gz --motion track.csv --frame 30,60 --adjoint\n"
    "  petblur blur -i dynamic.nii.gz -o dynamic-blurred.nii.gz --motion track.csv --frames 0,60,120,300,600\n"
    "  petblur blur -i ratios.nii.gz -o summed.nii.gz --motion track.csv --frames 0,60,120 --adjoint --sum-frames\n"
    "  petblur blur -i act.nii.gz -o gated.nii.gz --fields breathing.csv --frame 0,4 --method rm\n"
    "  petblur blur -i act.nii.gz -o gates.nii.gz --fields amplitudes.csv --signal belt.csv --gates 0,0.3,0.6,1\n"
    "  petblur blur -i act.nii.gz -o gates.nii.gz --motion chest.csv --signal belt.csv --gates 0,0.3,0.6,1"};

static int blur_options(const pbc_args *args, pb_blur_options *opt)
{
    const char *v;
    int rc;
    unsigned long n;
    memset(opt, 0, sizeof *opt);
    opt->seed = 1;
    if ((v = pbc_arg(&command, args, "--method")) && pb_method_parse(v, &opt->method) != PB_OK)
        return pbc_refused_name("--method");
    if ((v = pbc_arg(&command, args, "--filter")) && pb_filter_parse(v, &opt->filter) != PB_OK)
        return pbc_refused_name("--filter");
    /* Counts as far as they fit; their ranges are the library's (pb_options_check). */
    if ((v = pbc_arg(&command, args, "--steps")) && (rc = pbc_parse_count("--steps", v, 1, 0xffffffffUL, &n)) == 0)
        opt->steps = (unsigned)n;
    else if (v)
        return rc;
    const char *bound = pbc_arg(&command, args, "--max-path-error");
    if (bound && !strcmp(bound, "paper"))
        opt->path = PB_PATH_TRACKED;
    else if (bound && (rc = pbc_parse_number("--max-path-error", bound, &opt->max_path_error)))
        return rc;
    else if (bound)
        opt->path = PB_PATH_BOUNDED;
    if ((v = pbc_arg(&command, args, "--ab-sampling")) && pb_ab_sampling_parse(v, &opt->ab_sampling) != PB_OK)
        return pbc_refused_name("--ab-sampling");
    if ((v = pbc_arg(&command, args, "--points")) && (rc = pbc_parse_count("--points", v, 1, 0xffffffffUL, &n)) == 0)
        opt->ref_points = (unsigned)n;
    else if (v)
        return rc;
    opt->jacobian = pbc_arg(&command, args, "--jacobian") != NULL;
    if (opt->jacobian && !pbc_arg(&command, args, "--fields"))
        return pbc_fail(PBC_EXIT_USAGE, "--jacobian weighs a field's blur by its Jacobian determinant; a track's is 1 "
                        "everywhere: give --fields, or leave --jacobian out");
    if ((v = pbc_arg(&command, args, "--seed")) && (rc = pbc_parse_count("--seed", v, 0, 0xffffffffUL, &n)) == 0)
        opt->seed = (uint32_t)n;
    else if (v)
        return rc;
    if (pb_options_check(opt) != PB_OK) { /* the library's words, with the option's name */
        const char *msg = pb_last_error(NULL);
        if (!strncmp(msg, "max_path_error ", 15))
            return pbc_fail(PBC_EXIT_USAGE, "--max-path-error %s", msg + 15);
        if (!strncmp(msg, "ab_sampling ", 12))
            return pbc_fail(PBC_EXIT_USAGE, "--ab-sampling %s", msg + 12);
        return pbc_fail(PBC_EXIT_USAGE, "%s", msg);
    }
    return 0;
}

/* Every file blur reads and writes, for the rule that no output names one it
 * reads (pbc_files_check). */
static int check_files(const pbc_args *args, const pbc_fields *fields, const char *in, const char *out,
                       const char *png)
{
    pbc_files f = {0};
    pbc_files_read_image(&f, "-i", in);
    pbc_fields_files(fields, &f);
    pbc_files_read(&f, "--motion", pbc_arg(&command, args, "--motion"));
    pbc_files_read(&f, "--calibration", pbc_arg(&command, args, "--calibration"));
    pbc_files_read(&f, "--frames-from", pbc_arg(&command, args, "--frames-from"));
    pbc_files_write(&f, "-o", out);
    pbc_files_write(&f, "--png", png);
    return pbc_files_check(&f);
}

/* Every path is checked before any work, so a typo costs no minutes of REF. */
static int check_paths(const pbc_args *args, const pbc_fields *fields, const char **in, const char **out,
                       const char **png)
{
    *in = pbc_arg(&command, args, "--input");
    *out = pbc_arg(&command, args, "--output");
    *png = pbc_arg(&command, args, "--png");
    if (!*in || !*out)
        return pbc_fail(PBC_EXIT_USAGE, "blur needs -i IN and -o OUT; see petblur blur --help");
    int rc = pbc_check_output("-o", *out, 0);
    if (!rc && *png)
        rc = pbc_check_output("--png", *png, 1);
    return rc ? rc : check_files(args, fields, *in, *out, *png);
}

static int read_input(const pbc_args *args, const char *in, int frames, pbc_image *img)
{
    size_t dims[3];
    double vs[3];
    pbc_read_hints hints;
    int rc = pbc_hints_from_args(&command, args, dims, vs, &hints);
    hints.allow_frames = frames;
    return rc ? rc : pbc_image_read(in, &hints, img);
}

/* --frames: the boundaries, checked against --frame, --sum-frames and the
 * output's format here, and against the input's frames once it is read. */
static int frame_bounds(const pbc_args *args, double **bounds, size_t *count)
{
    const char *v = pbc_arg(&command, args, "--frames"), *json = pbc_arg(&command, args, "--frames-from");
    if (v && json)
        return pbc_fail(PBC_EXIT_USAGE, "--frames and --frames-from: give one");
    v = v ? v : json;
    int sum = pbc_arg(&command, args, "--sum-frames") != NULL, gates = pbc_arg(&command, args, "--gates") != NULL;
    *bounds = NULL;
    *count = 0;
    if (sum && ((!v && !gates) || !pbc_arg(&command, args, "--adjoint")))
        return pbc_fail(PBC_EXIT_USAGE, "--sum-frames adds the frames' back projections into one volume: give it "
                        "with --adjoint and --frames T0,T1,... (or --gates)");
    if (v && gates)
        return pbc_fail(PBC_EXIT_USAGE, "--gates and --frames%s: give one; the gates are the frames, the span they "
                        "bin is --frame T0,T1", json && !pbc_arg(&command, args, "--frames") ? "-from" : "");
    char ext[16];
    const char *out = pbc_arg(&command, args, "--output");
    pbc_file_extension(out, ext, sizeof ext);
    if (gates && !sum && strcmp(ext, ".nii") && strcmp(ext, ".nii.gz"))
        return pbc_fail(PBC_EXIT_USAGE, "-o %s: --gates makes a 4-D image, a gate a frame, which only NIfTI holds; "
                        "name the output .nii or .nii.gz", out);
    if (!v)
        return 0;
    if (pbc_arg(&command, args, "--frame"))
        return pbc_fail(PBC_EXIT_USAGE, "--frame and --frames: give one; --frames T0,T1,... blurs every frame, "
                        "--frame T0,T1 one");
    if (!sum && strcmp(ext, ".nii") && strcmp(ext, ".nii.gz"))
        return pbc_fail(PBC_EXIT_USAGE, "-o %s: --frames makes a 4-D image, which only NIfTI holds; name the output "
                        ".nii or .nii.gz", out);
    return json ? pbc_bids_frames(json, bounds, count) : pbc_parse_bounds("--frames", v, bounds, count);
}

static int check_frames(const char *in_path, const pbc_image *in, size_t frames, int gated)
{
    size_t have = pbc_image_frame_count(in);
    if (have != 1 && have != frames)
        return pbc_fail(PBC_EXIT_USAGE, "%s has %zu frames and %s gives %zu (one %s more than %s); give %zu %ss, or "
                        "a 3-D volume to blur through every %s", in_path, have, gated ? "--gates" : "--frames", frames,
                        gated ? "edge" : "boundary", gated ? "gates" : "frames", have + 1,
                        gated ? "edge" : "boundarie", gated ? "gate" : "frame");
    return 0;
}

/* NIfTI's pixdim[4]: the frames' common length, or 0 when they differ. */
static double common_length(const double *bounds, size_t frames)
{
    double len = bounds[1] - bounds[0];
    for (size_t i = 1; i < frames; i++)
        if (fabs(bounds[i + 1] - bounds[i] - len) > 1e-9 * fabs(len))
            return 0.0;
    return len;
}

/* Input, output and their difference; with --frames the first frame's, so
 * labelled; with --sum-frames the output is the frames' sum, which has no
 * input of its own to subtract. */
static int write_picture(const char *png, const pbc_image *in, const float *out, int frames, int sum)
{
    size_t n = in->dims[0] * in->dims[1] * in->dims[2];
    float *diff = malloc(n * sizeof *diff);
    if (!diff)
        return pbc_fail(PBC_EXIT_RUNTIME, "out of memory for the picture's difference volume");
    for (size_t i = 0; i < n; i++)
        diff[i] = out[i] - in->data[i];
    pbc_picture_row rows[3] = {{frames ? "input, frame 0" : "input", in->data, 0},
                               {sum ? "output, the sum" : frames ? "output, frame 0" : "output", out, 0},
                               {frames ? "difference, frame 0" : "difference", diff, 1}};
    pbc_picture pic = {{in->dims[0], in->dims[1], in->dims[2]},
                       {in->voxel_size[0], in->voxel_size[1], in->voxel_size[2]}, rows, sum ? 2 : 3};
    int rc = pbc_picture_write(png, &pic);
    free(diff);
    return rc;
}

/* The motion placed on the input's grid and its frames checked: a track's
 * (motion_args.c; its gates over the span they bin) or the fields'
 * (src/cli/fields). */
static int place_motion(pbc_motion *motion, pbc_fields *fields, const pbc_image *in, const char *in_path,
                        const double *bounds, size_t frames)
{
    if (fields->table)
        return pbc_fields_load(fields, in, in_path, bounds, frames);
    int rc = pbc_motion_place(motion, in, in_path);
    if (!bounds && fields->gates)
        bounds = fields->frame, frames = 1;
    return rc ? rc : pbc_motion_check_frames(motion, bounds, frames, 1);
}

/* A blur is a weighted mean of the input's values, but a mass-preserving
 * blur (--jacobian) weighs them by how much the fields compress, and a
 * summed back projection adds the frames': near float32's top either can
 * leave its range. Such a result is not written (an image of infinities
 * with exit 0 would pass for one). */
static int check_result(const char *out_path, const pbc_image *in, const pbc_image *out, int jacobian, int sum)
{
    size_t n = out->dims[0] * out->dims[1] * out->dims[2] * pbc_image_frame_count(out), bad = 0, first = 0;
    for (size_t i = 0; i < n; i++)
        if (!isfinite(out->data[i]) && bad++ == 0)
            first = i;
    if (!bad)
        return 0;
    size_t m = in->dims[0] * in->dims[1] * in->dims[2] * pbc_image_frame_count(in);
    double top = 0.0;
    for (size_t i = 0; i < m; i++)
        top = fmax(top, fabs((double)in->data[i]));
    size_t nv = out->dims[0] * out->dims[1] * out->dims[2], v = first % nv;
    return pbc_fail(PBC_EXIT_USAGE, "%s: not written: the result leaves float32's range at %zu voxel%s (the first "
                    "at (%zu, %zu, %zu)), where the input's largest magnitude is %g%s; rescale the input (e.g. Bq/ml "
                    "to kBq/ml) and the result back", out_path, bad, bad == 1 ? "" : "s", v % out->dims[0],
                    v / out->dims[0] % out->dims[1], v / out->dims[0] / out->dims[1], top,
                    jacobian ? ", weighed by the fields' Jacobian determinants (--jacobian)"
                             : sum ? ", the frames' back projections summed (--sum-frames)" : "");
}

static int run(const pbc_args *args, pbc_fields *fields, const char *in_path, const char *out_path, const char *png)
{
    pb_blur_options opt;
    pbc_motion motion = {0};
    pbc_image in = {0}, out = {0};
    pb_context *ctx = NULL;
    double ms = 0.0, *bounds = NULL;
    size_t nb = 0;
    int quiet = pbc_arg(&command, args, "--quiet") != NULL;
    int adjoint = pbc_arg(&command, args, "--adjoint") != NULL;
    int sum = pbc_arg(&command, args, "--sum-frames") != NULL; /* checked with --frames */
    int rc = blur_options(args, &opt);
    if (rc || (rc = frame_bounds(args, &bounds, &nb)) ||
        (!fields->table && (rc = pbc_motion_from_args(&command, args, &motion)))) {
        free(bounds);
        return rc;
    }
    int gated = fields->gates > 0, framed = bounds || gated;
    size_t frames = bounds ? nb - 1 : gated ? fields->gates : 1;
    const char *label = pb_method_name(opt.method);
    size_t out_frames = framed && !sum ? frames : 1;
    if (!(rc = read_input(args, in_path, framed, &in)) &&
        !(rc = framed ? check_frames(in_path, &in, frames, gated) : 0) &&
        !(rc = pbc_image_check_output(out_path, in.dims, out_frames)) &&
        !(rc = place_motion(&motion, fields, &in, in_path, bounds, frames)) &&
        !(rc = pbc_image_alloc_frames(&out, in.dims, in.voxel_size, out_frames)) &&
        !(rc = pbc_open_device(pbc_arg(&command, args, "--device"), &ctx))) {
        out.orientation = in.orientation;
        if (bounds)
            out.frame_seconds = sum ? 0.0 : common_length(bounds, frames);
        if (fields->table && gated)
            rc = pbc_blur_fields_image(ctx, &in, fields, NULL, frames, &opt, adjoint, sum, label, out.data, &ms);
        else if (fields->table)
            rc = pbc_blur_fields_image(ctx, &in, fields, bounds, frames, &opt, adjoint, sum, label, out.data, &ms);
        else if (gated)
            rc = pbc_blur_gates_image(ctx, &in, &motion.motion, fields->intervals, fields->counts, frames, &opt,
                                      adjoint, sum, label, out.data, &ms);
        else if (bounds)
            rc = pbc_blur_frames_image(ctx, &in, &motion.motion, bounds, frames, &opt, adjoint, sum, label, out.data,
                                       &ms);
        else
            rc = pbc_blur_image(ctx, &in, &motion.motion, &opt, adjoint, label, out.data, &ms);
    }
    if (!rc)
        rc = check_result(out_path, &in, &out, opt.jacobian, sum);
    if (!rc)
        rc = pbc_image_write(out_path, &out);
    if (!rc && png)
        rc = write_picture(png, &in, out.data, framed, sum);
    if (!rc && !quiet) {
        char dev[600], shape[64] = "";
        pbc_describe_device(ctx, dev, sizeof dev);
        if (framed)
            snprintf(shape, sizeof shape, sum ? ", the sum of %zu %s" : " x %zu %s", frames,
                     gated ? "gates" : "frames");
        printf("%s: %zu x %zu x %zu%s, %s %s%s on %s, kernel %.2f ms\n", out_path, in.dims[0], in.dims[1], in.dims[2],
               shape, pb_method_name(opt.method), opt.method == PB_METHOD_REF ? "box" : pb_filter_name(opt.filter),
               adjoint ? " adjoint" : "", dev, ms);
    }
    pb_context_destroy(ctx);
    pbc_image_free(&in);
    pbc_image_free(&out);
    pbc_motion_free(&motion);
    free(bounds);
    return rc;
}

int pbc_cmd_blur(int argc, char **argv)
{
    pbc_args args;
    const char *in, *out, *png;
    int rc = pbc_parse_args(&command, argc, argv, &args);
    if (rc)
        return rc < 0 ? 0 : rc;
    pbc_fields fields;
    if ((rc = pbc_fields_from_args(&command, &args, &fields)))
        return rc;
    if (!(rc = pbc_fields_signal(&command, &args, &fields)) && !(rc = check_paths(&args, &fields, &in, &out, &png))) {
        if (pbc_arg(&command, &args, "--quiet"))
            pbc_show_progress = 0;
        rc = run(&args, &fields, in, out, png);
    }
    pbc_fields_free(&fields);
    return rc;
}
