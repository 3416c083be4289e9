/* The key poses a frame's blur walks (src/paths): made from a validated
 * motion, cut so that every voxel stays within the error bound of its true
 * path, and clipped to the grid. No backend knows how a path was made. */
#ifndef PB_PATH_H
#define PB_PATH_H

#include "motion.h"

/* ---- path_plan.c: the plan ----------------------------------------------- */

/* One key pose of a plan. */
typedef struct pb_path_pose {
    double time;
    pb_pose pose;      /* unit quaternion on the same hemisphere as the previous key pose */
    double map[12];    /* pb_pose_texel_map of the pose */
    double weight;     /* fraction of the frame spent on the segment to the next key pose; 0 when skipped */
    int skip;          /* the segment to the next key pose reads nothing of the object: not walked */
} pb_path_pose;

/* One REF time step: where it is, and its share of the frame. */
typedef struct pb_path_step {
    double map[12];
    double weight;
} pb_path_step;

/* Where a key point of a field motion's frame is: the field
 * (1 - alpha) D_f0 + alpha D_f1, indices into the frame's own fields. */
typedef struct pb_path_knot {
    size_t f0, f1;
    double alpha;
} pb_path_knot;

/* What a frame of a field motion walks (path_field.c): the fields its time
 * covers, in texel units of the image grid, and where its key points and
 * REF's time steps lie between them. */
typedef struct pb_path_field {
    size_t fields;         /* fields kept */
    size_t dims[3];        /* the field grid */
    int same;              /* the field grid is the image grid */
    double map[12];        /* field voxel coordinates (centre at i) from image texel coordinates (centre at i + 0.5) */
    float *data;           /* fields * voxels vectors of 3: displacement / image voxel size */
    pb_path_knot *knots;   /* one per key pose */
    pb_path_knot *ref_knots; /* one per REF time step */
} pb_path_field;

typedef struct pb_path {
    pb_geometry geometry;
    double center[3];        /* mm */
    size_t count;            /* key poses: frame start, tracked poses inside, frame end */
    pb_path_pose *poses;
    size_t ref_count;        /* REF time steps over the whole frame (0 unless REF) */
    pb_path_step *ref_steps;
    pb_path_field *field;    /* a field motion's frame; NULL for a pose track (poses then hold only times and
                              * weights, ref_steps only weights) */
    double noise_mm;         /* the tracker's noise pb_path_fit measured and did not follow: the largest corner's
                              * RMS of its 3D scatter; 0 where it followed every sample */
} pb_path;

/* Validates the motion and options and builds the plan. */
pb_status pb_path_create(struct pb_context *ctx, const pb_geometry *geometry, const pb_motion *motion,
                         const pb_blur_options *options, pb_path *plan);
void pb_path_destroy(pb_path *plan);

/* The plan of a frame of a pose track that is the union of `intervals` time
 * intervals (a start and an end each, finite, increasing, not overlapping)
 * (path_gate.c): each interval planned as pb_path_create plans a frame of
 * track, the pieces laid end to end with their weights (and REF's steps')
 * scaled by the interval's share of the frame's time, the gaps between them
 * skipped. One interval gives pb_path_create's plan itself. */
pb_status pb_path_create_gate(struct pb_context *ctx, const pb_geometry *geometry, const pb_motion *track,
                              const double *intervals, size_t count, const pb_blur_options *options, pb_path *plan);

/* The plan of a frame of a validated field motion that is the union of
 * `intervals` time intervals (a start and an end each, increasing, not
 * overlapping; one for a plain frame) (path_field.c): key points at each
 * interval's ends and the field times (or surrogate samples) inside, each
 * segment weighed by its time, the gaps between intervals skipped; for REF,
 * dense time steps. */
pb_status pb_path_create_field(struct pb_context *ctx, const pb_geometry *geometry, const pb_field_motion *field,
                               const double *intervals, size_t count, const pb_blur_options *options, pb_path *plan);
/* A surrogate's frame planned by value (path_surrogate.c): a segment per bin
 * of surrogate values the frame visits, each bin inside one interval between
 * fields and no voxel moving more than max_move voxels across it, weighed by
 * the frame's time there (of `total`); the plan's field, key points (global
 * field indices) and weights set, its fields not yet gathered. */
pb_status pb_path_surrogate_knots(struct pb_context *ctx, const pb_field_motion *field, const double *intervals,
                                  size_t count, double total, double max_move, pb_path *plan);
/* A surrogate's value bins against the path bound: no voxel moves more than
 * this many bounds across one (docs/motion.md gives the measurements). */
#define PB_VALUE_BIN_MOVES 2.5

/* Key point j of a field path for the voxel at texel coordinates u, in
 * object texel coordinates: u plus the field there (the voxel's own sample
 * on the image grid, else trilinear on the field's). */
void pb_path_field_point(const pb_path *plan, const pb_path_knot *knot, const double u[3], double out[3]);

/* The most segments one blur may walk; far above what any sane bound needs (a
 * full turn at 0.01 voxels on a 512^3 grid takes about 6000). */
enum { PB_MAX_SEGMENTS = 100000 };
/* The most voxels one segment's walk (AB, RM, CL) crosses along an axis,
 * as a multiple of the grid's voxels along it (PB_WALK_GRIDS), and never
 * fewer than PB_WALK_LEAST; a frame's segments together PB_WALK_SEGMENTS
 * times that. A head moves a few of its widths at most, and a walk of
 * millions (a grid of 0.0001 mm voxels across a turn of degrees) runs for
 * hours. */
enum { PB_WALK_GRIDS = 16, PB_WALK_LEAST = 1024, PB_WALK_SEGMENTS = 64 };
/* Whether a blur's cost follows its walks: AB steps a slice at a time
 * (its steps cut a segment into pieces walked alike), RM and CL without
 * fixed steps too, REF without fixed time steps takes two a voxel. */
int pb_path_walk_counts(const pb_blur_options *options);
/* One segment's walk of `most` voxels along object axis `axis` (from `place`,
 * a time in s, or with by_value a surrogate's value), added to the frame's
 * `total` along it: refused beyond the limits above, the message naming the
 * axis, the voxels and `what` moved (a "motion", the "fields") to check the
 * units of. */
pb_status pb_path_walk_check(struct pb_context *ctx, const pb_geometry *geometry, const char *what, int axis,
                             double most, double *total, double place, int by_value);
/* Fixed steps (RM and CL's steps, REF's time steps) cost steps times the
 * walked segments a voxel, whatever the motion: each is capped (100000), and
 * so is a frame's segments (PB_MAX_SEGMENTS), but not their product, which
 * reached 1e10 samples a voxel (days on a host) where a dense reference
 * takes thousands to a million. Refused beyond PB_FIXED_SAMPLES a frame, the
 * sum added to *total (a gate's running sum). */
enum { PB_FIXED_SAMPLES = 10000000 };
pb_status pb_path_check_samples(struct pb_context *ctx, const pb_blur_options *options, const pb_path *plan,
                                double *total);
/* A planned track's walks (its key poses' texel maps; skipped segments not
 * walked) through pb_path_walk_check, added to total[3] (zeros for a frame;
 * a gate's running sums across its intervals); with fixed steps, its samples
 * through pb_path_check_samples, summed in total[0]. */
pb_status pb_path_check_walk(struct pb_context *ctx, const pb_blur_options *options, const pb_path *plan,
                             double total[3]);

/* Error-bounded polylines (path_split.c): the plan with every interval cut
 * into the equal pieces that keep each voxel centre within max_error voxels of
 * its chord, then runs of pieces merged into chords within the same bound
 * (maps and weights still to fill); with merge 0, only cut. */
pb_status pb_path_split(struct pb_context *ctx, pb_path *plan, double max_error, int merge);

/* Key poses fitted to the track (path_fit.c): the plan's key poses (the
 * frame's ends and its samples) replaced by the knots of a continuous
 * polyline fitted to them by least squares, its knots where the samples
 * leave a line by more than max_error voxels beyond the tracker's noise:
 * sigma_mm per axis where the caller knows it, and what the track's own
 * samples show of white noise (the frame's, or where it holds too few, those
 * of track, the whole log, about the frame; track may be NULL). */
pb_status pb_path_fit(struct pb_context *ctx, pb_path *plan, const pb_motion *track, double sigma_mm,
                      double max_error);

/* Walks clipped to the grid (path_clip.c): each segment cut to the part of it
 * during which a sample can land in the object grid, the rest marked skip,
 * so that a blur's cost is bounded by the grid whatever the motion. */
pb_status pb_path_clip(struct pb_context *ctx, pb_path *plan);

#endif
