/* petblur motion: what a track holds, frame by frame, before a blur trusts it. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "commands.h"
#include "fields.h"
#include "motion_args.h"
#include "motion_plot.h"

static const pbc_option options[] = {
    {"--input", "-i", "IN", "the image the track moves (its placement and grid; .raw needs --dims)"},
    {"--dims", NULL, "NX,NY,NZ", "the grid, without -i (or of a .raw input)"},
    {"--voxel-size", NULL, "DX,DY,DZ", "voxel size in mm (default 1,1,1)"},
    {"--frames", NULL, "T0,T1,...", "frame boundaries, seconds (default: the --frame, else the whole track)"},
    {"--frames-from", NULL, "SIDECAR.json", "the frames from a BIDS-PET sidecar (FrameTimesStart, FrameDuration)"},
    {"--motion", NULL, "TRACK", NULL}, /* the argument, read as --motion; not typed */
    PBC_TRACK_OPTIONS,
    PBC_FIELD_OPTIONS,
    {"--png", NULL, "PICTURE.png", "translation and rotation against time, with the frames' boundaries"},
};

static const pbc_command command = {
    "motion", "TRACK [-i IN] [--frames T0,T1,...] [--png motion.png] [options] | --fields TABLE.csv [-i IN] [...]",
    "Summarises a pose track: duration, sampling rate, gaps, and per frame the largest rotation and the\n"
    "largest displacement of the grid's corners from the frame's first pose, in the coordinates petblur blur\n"
    "would use (the same options); and the tracker's noise a blur measures there and does not follow, and the\n"
    "segments its default path walks. Look at a track before trusting a blur to it. With --fields, the fields\n"
    "a blur would read, checked as it checks them, and per frame the largest displacement of any field\n"
    "voxel from where the frame's first field puts it.",
    options, (int)(sizeof options / sizeof options[0]), 0, 1,
    "examples:\n"
    "  petblur motion head.mt -i head.nii.gz --calibration cal.txt --reference-time 65900 --png motion.png\n"
    "  petblur motion track.csv --frames-from sub-01_pet.json --dims 128,128,64 --voxel-size 2.2,2.2,2.8\n"
    "  petblur motion --fields breathing.csv -i act.nii.gz --frames 0,1,2,3,4"};

/* The grid: the input's, or --dims/--voxel-size with no placement. */
static int grid_image(const pbc_args *args, pbc_image *img)
{
    size_t dims[3] = {1, 1, 1};
    double vs[3] = {1, 1, 1};
    pbc_read_hints hints;
    int rc = pbc_hints_from_args(&command, args, dims, vs, &hints);
    const char *in = pbc_arg(&command, args, "--input");
    if (rc)
        return rc;
    /* Only the grid and its placement are used: a dynamic series' 4-D image
     * (the one --frames blurs) gives them as well as a 3-D one. */
    hints.allow_frames = 1;
    if (in)
        return pbc_image_read(in, &hints, img);
    if (!pbc_arg(&command, args, "--dims"))
        fprintf(stdout, "no grid (-i or --dims): corner displacements are of a 1 mm voxel\n");
    return pbc_image_alloc(img, dims, vs);
}

/* One frame's row. A frame the default path cannot walk (more segments
 * than a blur takes) is still shown, its last two columns '-', and the
 * first such frame's reason kept in *unplanned for after the table. */
static int frame_summary(const pbc_motion *m, const pbc_image *img, size_t index, double t0, double t1,
                         char *unplanned, size_t size)
{
    pb_geometry g = {{img->dims[0], img->dims[1], img->dims[2]},
                     {img->voxel_size[0], img->voxel_size[1], img->voxel_size[2]}};
    pb_frame_summary f;
    if (pb_motion_frame_summary(&m->motion, &g, t0, t1, &f) != PB_OK)
        return pbc_fail(PBC_EXIT_RUNTIME, "frame %zu: %s", index, pb_last_error(NULL));
    printf("%5zu %12.6g %12.6g %8zu %10.3f %12.3f", index, t0, t1, f.samples, f.max_turn_deg, f.max_corner_mm);
    pb_motion frame = m->motion;
    frame.frame_start = t0;
    frame.frame_end = t1;
    double noise = 0.0;
    size_t segments = 0;
    if (pb_path_noise(&g, &frame, NULL, &noise, &segments) == PB_OK)
        printf(" %9.3f %9zu\n", noise, segments);
    else {
        printf(" %9s %9s\n", "-", "-");
        if (!unplanned[0])
            snprintf(unplanned, size, "frame %zu: %s", index, pb_last_error(NULL));
    }
    return 0;
}

static int track_summary(const pbc_motion *m)
{
    pb_track_summary s;
    if (pb_track_summarize(m->track, &s) != PB_OK)
        return pbc_fail(PBC_EXIT_RUNTIME, "%s: %s", m->source, pb_last_error(NULL));
    printf("%s: %s, %zu poses from %.9g to %.9g s (%.6g s), median step %.6g s (%.4g Hz)\n", m->source,
           pb_track_format_name(pb_track_get_format(m->track)), s.samples, s.first, s.last, s.last - s.first,
           s.median_step, s.median_step > 0 ? 1.0 / s.median_step : 0.0);
    printf("missing samples: %zu in %zu gap%s, the longest %.6g s\n", s.missing, s.gaps, s.gaps == 1 ? "" : "s",
           s.longest_gap);
    return 0;
}

/* Every file motion reads, and its one output, for the rule that no output
 * names a file the command reads (pbc_files_check). */
static int check_files(const pbc_args *args, const pbc_fields *fields, const char *png)
{
    pbc_files f = {0};
    pbc_files_read(&f, "the track", args->positional[0]);
    pbc_fields_files(fields, &f);
    pbc_files_read_image(&f, "-i", pbc_arg(&command, args, "--input"));
    pbc_files_read(&f, "--calibration", pbc_arg(&command, args, "--calibration"));
    pbc_files_read(&f, "--frames-from", pbc_arg(&command, args, "--frames-from"));
    pbc_files_write(&f, "--png", png);
    return pbc_files_check(&f);
}

/* --fields: the fields the frames read, loaded as blur loads them (onto
 * -i's grid, or their own), and each frame's largest displacement. */
static int fields_summary(const pbc_args *args, pbc_fields *f, const double *bounds, size_t nb)
{
    const char *in = pbc_arg(&command, args, "--input");
    static const char *const refused[] = {"--dims", "--voxel-size", "--png"};
    for (size_t i = 0; i < sizeof refused / sizeof refused[0]; i++)
        if (pbc_arg(&command, args, refused[i]))
            return pbc_fail(PBC_EXIT_USAGE, "%s applies to a track; the fields bring their own grid (or -i's): leave "
                            "%s out", refused[i], refused[i]);
    pbc_read_hints hints = {NULL, NULL, 1};
    pbc_image img = {0};
    size_t frames = bounds ? nb - 1 : 1;
    int rc = in ? pbc_image_read(in, &hints, &img) : 0;
    if (!rc)
        rc = pbc_fields_load(f, in ? &img : NULL, in, bounds, frames);
    if (!rc) {
        const pb_field_motion *m = &f->motion;
        printf("%s: %zu fields from %.9g to %.9g s; the frames read %zu (%.9g to %.9g s) of %zux%zux%zu voxels\n",
               f->table, f->rows, f->times[0], f->times[f->rows - 1], m->count, m->times[0], m->times[m->count - 1],
               m->dims[0], m->dims[1], m->dims[2]);
        printf("frame        start          end  samples max disp mm\n");
        double whole[2] = {m->frame_start, m->frame_end};
        const double *b = bounds ? bounds : whole;
        for (size_t i = 0; i < frames; i++) {
            size_t samples;
            double mm;
            pbc_fields_frame_summary(f, b[i], b[i + 1], &samples, &mm);
            printf("%5zu %12.6g %12.6g %8zu %11.3f\n", i, b[i], b[i + 1], samples, mm);
        }
    }
    pbc_image_free(&img);
    return rc;
}

int pbc_cmd_motion(int argc, char **argv)
{
    /* a track named "estimate" is ./estimate */
    if (argc > 0 && !strcmp(argv[0], "estimate"))
        return pbc_cmd_motion_estimate(argc - 1, argv + 1);
    pbc_args args;
    int rc = pbc_parse_args(&command, argc, argv, &args);
    if (rc)
        return rc < 0 ? 0 : rc;
    pbc_fields fields;
    if (args.positional_count && pbc_arg(&command, &args, "--fields"))
        return pbc_fail(PBC_EXIT_USAGE, "petblur motion takes a TRACK or --fields TABLE.csv, not both");
    if (!args.positional_count && !pbc_arg(&command, &args, "--fields"))
        return pbc_fail(PBC_EXIT_USAGE, "petblur motion needs a TRACK (or --fields TABLE.csv); see petblur motion "
                        "--help");
    if ((rc = pbc_fields_from_args(&command, &args, &fields)))
        return rc;
    /* The track is the positional argument; the motion options read it as --motion. */
    for (int i = 0; i < command.option_count; i++)
        if (!strcmp(command.options[i].name, "--motion")) {
            if (args.value[i])
                return pbc_fail(PBC_EXIT_USAGE, "petblur motion takes the track as its argument; drop --motion");
            args.value[i] = args.positional[0];
        }
    const char *png = pbc_arg(&command, &args, "--png"), *fv = pbc_arg(&command, &args, "--frames"),
               *json = pbc_arg(&command, &args, "--frames-from");
    if ((png && (rc = pbc_check_output("--png", png, 1))) || (rc = check_files(&args, &fields, png))) {
        pbc_fields_free(&fields);
        return rc;
    }
    if (fv && json)
        rc = pbc_fail(PBC_EXIT_USAGE, "--frames and --frames-from: give one");
    else if ((fv || json) && pbc_arg(&command, &args, "--frame"))
        rc = pbc_fail(PBC_EXIT_USAGE, "--frame and --frames: give one; --frames T0,T1,... lists every frame, "
                      "--frame T0,T1 one");
    if (rc || fields.table) {
        double *b = NULL;
        size_t n = 0;
        if (!rc && !(rc = fv ? pbc_parse_bounds("--frames", fv, &b, &n) : json ? pbc_bids_frames(json, &b, &n) : 0))
            rc = fields_summary(&args, &fields, b, n);
        free(b);
        pbc_fields_free(&fields);
        return rc;
    }
    pbc_motion m;
    pbc_image img = {0};
    double *bounds = NULL;
    size_t nb = 0;
    if ((rc = pbc_motion_from_args(&command, &args, &m)))
        return rc;
    if (!(rc = fv ? pbc_parse_bounds("--frames", fv, &bounds, &nb) : json ? pbc_bids_frames(json, &bounds, &nb) : 0) &&
        !(rc = grid_image(&args, &img)) && !(rc = pbc_motion_place(&m, &img, pbc_arg(&command, &args, "--input")
                                                                              ? pbc_arg(&command, &args, "--input")
                                                                              : "the grid"))) {
        double whole[2] = {m.motion.frame_start, m.motion.frame_end};
        const double *b = bounds ? bounds : whole;
        size_t frames = bounds ? nb - 1 : 1;
        if (!(rc = pbc_motion_check_frames(&m, b, frames, 0))) {
            if (!(rc = track_summary(&m)))
                printf("frame        start          end  samples  max rot deg max disp mm  noise mm  segments\n");
            char unplanned[1024] = "";
            for (size_t i = 0; i < frames && !rc; i++)
                rc = frame_summary(&m, &img, i, b[i], b[i + 1], unplanned, sizeof unplanned);
            if (!rc && unplanned[0])
                printf("-: no path at the default bound; %s\n", unplanned);
            if (!rc)
                printf("noise mm: the tracker's noise a blur measures in the frame and does not follow as motion (RMS "
                       "of the grid corners' 3-D scatter, on the 512 samples about a frame of fewer than 64; 0: every "
                       "sample followed, as in a log of fewer than 64 or where the scatter is not white); segments: what the default path walks (docs/methods.md, \"Tracker "
                       "noise\")\n");
            if (png && !rc)
                rc = pbc_motion_plot(png, &m, b, frames + 1);
        }
    }
    pbc_image_free(&img);
    pbc_motion_free(&m);
    free(bounds);
    return rc;
}
