/* The plan's internals that frames.c and field_plan.c share with plan.c. */
#ifndef PB_PLAN_H
#define PB_PLAN_H

#include "objects.h"

/* An empty plan of `frames` frames for geometry under options (checked, with
 * their defaults filled in); each frame is then added with
 * pb_plan_set_frame. */
pb_status pb_plan_new(pb_context *ctx, const pb_geometry *geometry, const pb_blur_options *options, size_t frames,
                      pb_plan **plan);
/* Plans frame i from its part of the motion: key poses, kernels, parameters,
 * and the key poses uploaded to the device. */
pb_status pb_plan_set_frame(pb_plan *plan, size_t i, const pb_motion *motion);

/* Frames given by frames + 1 bounds as the intervals the planners take, two
 * numbers a frame, in *intervals (the caller frees it); the bounds checked. */
pb_status pb_frame_intervals(pb_context *ctx, const double *bounds, size_t frames, double **intervals);
/* Gates' interval counts: 1 to 2^24 each. */
pb_status pb_gate_counts_check(pb_context *ctx, const size_t *counts, size_t frames);

/* Whether in and out may be one frame's arguments in that direction on grids
 * of geometry g: of the context ctx, of that geometry, and two volumes. */
pb_status pb_check_volumes(pb_context *ctx, const pb_geometry *g, const pb_volume *in, const pb_volume *out,
                           int adjoint);

#endif
