/* What blur and demo share: a device opened from --device, motions built from
 * the command line, and one blur of a host volume with progress and errors in
 * the program's terms. */
#ifndef PBC_BLUR_RUN_H
#define PBC_BLUR_RUN_H

#include "image_io.h"
#include "options.h"
#include "petblur.h"
#include "motion_args.h"

/* The exit status for a library status: bad inputs (-1 .. -99) are the
 * user's to fix (2); devices, builds, launches and memory are runtime (3). */
int pbc_exit_for(pb_status st);

/* Opens spec ("auto", "host", "opencl:1", ...; NULL = auto). Prints the
 * library's message and returns an exit status on failure. */
int pbc_open_device(const char *spec, pb_context **ctx);

/* A pb_progress_fn: "petblur: LABEL  42%" on one line of stderr (label: a
 * const char *), cleared at 1. */
void pbc_progress_line(double fraction, void *label);

/* "opencl:0  pthread-... [Portable Computing Language]" */
void pbc_describe_device(pb_context *ctx, char *text, size_t size);

/* Blurs in into out (the same geometry) on ctx, or with adjoint applies the
 * transpose (in tomograph space, out object space). label names the run in
 * progress lines and messages; *ms gets the kernel time. */
int pbc_blur_image(pb_context *ctx, const pbc_image *in, const pb_motion *motion, const pb_blur_options *options,
                   int adjoint, const char *label, float *out, double *ms);

/* Dynamic frames: frame i (bounds[i] to bounds[i + 1] of the track) of in
 * (a 4-D image with `frames` frames, or a 3-D one that serves them all)
 * blurred in one pb_blur_frames call, or with adjoint its transpose frame by
 * frame, into out (frames volumes, frame after frame). With adjoint and sum,
 * every frame's back projection is added into one volume, out: the transpose
 * of one object blurred through every frame. *ms: the kernels' total. */
int pbc_blur_frames_image(pb_context *ctx, const pbc_image *in, const pb_motion *track, const double *bounds,
                          size_t frames, const pb_blur_options *options, int adjoint, int sum, const char *label,
                          float *out, double *ms);

/* Gates: frame i the union of counts[i] intervals of the track, the next
 * ones of intervals[] (a start and an end each; pb_plan_create_gates), as
 * pbc_blur_frames_image blurs frames. */
int pbc_blur_gates_image(pb_context *ctx, const pbc_image *in, const pb_motion *track, const double *intervals,
                         const size_t *counts, size_t frames, const pb_blur_options *options, int adjoint, int sum,
                         const char *label, float *out, double *ms);

/* Frames 0 .. frames - 1 of plan (made on ctx for in's grid), or the status
 * its making returned (st; plan NULL then): in (frames frames, or one for
 * all) blurred or, with adjoint, back projected into out as
 * pbc_blur_frames_image does. Destroys plan. */
int pbc_blur_plan_image(pb_context *ctx, pb_status st, pb_plan *plan, const pbc_image *in, size_t frames, int adjoint,
                        int sum, const char *label, float *out, double *ms);

#endif
