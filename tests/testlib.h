/* Small helpers shared by the tests: checks that count, fresh random inputs,
 * and the backend named on the command line. */
#ifndef PB_TESTLIB_H
#define PB_TESTLIB_H

#include <stddef.h>
#include <stdint.h>

#include "petblur.h"

/* The HARDWARE filter's error, derived from how the texture unit interpolates.
 *
 * NVIDIA's texture unit (CUDA textures and NVIDIA's OpenCL images alike) keeps
 * each axis's interpolation weight alpha in 9-bit fixed point with 8 fractional
 * bits (CUDA C Programming Guide, "Linear Filtering"). Rounded to the nearest
 * step, the weight it uses is off by at most PB_TEX_WEIGHT_STEP / 2 = 2^-9; the
 * test `properties` measures this bound on the device (test_hardware_weights),
 * so the premise below is checked, not assumed.
 *
 * One linear interpolation (1 - a) v0 + a v1 with a off by d is off by
 * d (v1 - v0). Trilinear is three such stages, and a stage averages the errors
 * of the stage before with weights that sum to 1, so a trilinear fetch of
 * values in [0, vmax] is off by at most 3 x 2^-9 x vmax. AB's slice samples sit
 * on slice centres along the major axis, where the weight is 0 or 1 exactly (2
 * stages), so 3 stages bound every method. Every method returns an average of
 * fetches with weights summing to 1 (AB divides by its weight sum), which keeps
 * the bound. PoCL interpolates in float and stays far inside it.
 *
 * The model holds per axis (bench/texture_rounding.cu: every one-axis fetch
 * is the fraction rounded to 1/256, ties up), but NVIDIA's 3-D blend is not
 * the exact product of those weights: single trilinear fetches of values in
 * [0, 1) were measured up to 0.0070 off, above 3 x 2^-9 = 0.0059 (mean 8e-4,
 * unbiased). The blurs average many fetches and stay inside the bound (the
 * tests that use it pass with room); a test of single fetches would need
 * 1/128. */
#define PB_TEX_WEIGHT_STEP (1.0 / 256.0)
#define PB_TEX_STAGE_ERROR (PB_TEX_WEIGHT_STEP / 2.0)
#define PB_TEX_TRILINEAR_ERROR (3.0 * PB_TEX_STAGE_ERROR) /* times the largest input value */

/* Exit status that meson reads as "skipped". */
#define PB_TEST_SKIP 77

extern int pb_test_failed, pb_test_passed;

/* Records one check; prints the message when it fails. Returns cond. */
int pb_check(int cond, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* Prints "N passed, N failed" and returns the exit status. */
int pb_test_finish(void);

/* A call that must not block: from now on, if seconds pass before
 * pb_test_deadline(0, NULL), the test fails with "FAIL: <what> (killed after
 * N s)" instead of hanging. */
void pb_test_deadline(unsigned seconds, const char *what);

/* Seeds the generator from PB_TEST_SEED or the clock and prints the seed, so
 * every run draws fresh inputs and any failure can be replayed. */
void pb_test_seed(void);
double pb_rand_uniform(void); /* [0, 1) */
double pb_rand_range(double lo, double hi);

/* argv[1] names the backend ("host", "opencl", "cuda"). Creates a context on
 * it, or exits 77 (skipped) when the backend has no device. */
pb_context *pb_test_context(int argc, char **argv);
pb_backend pb_test_backend(int argc, char **argv);
/* Whether ctx runs on NVIDIA's texture unit (CUDA, or NVIDIA's OpenCL),
 * whose linear filter rounds its weights to steps of 1/256. */
int pb_test_nvidia(pb_context *ctx);

/* Blurs host data through a context: uploads, blurs, downloads. The device
 * output is poisoned with -1e30 and the host copy with NaN first, so that a
 * voxel the kernel never wrote shows. */
pb_status pb_test_blur(pb_context *ctx, const pb_geometry *g, const float *in, const pb_motion *m,
                       const pb_blur_options *opt, float *out);

/* The same for pb_blur_adjoint: in is tomograph-space, out object-space. */
pb_status pb_test_adjoint(pb_context *ctx, const pb_geometry *g, const float *in, const pb_motion *m,
                          const pb_blur_options *opt, float *out);

/* A two-pose motion over the frame [0, 1]. */
typedef struct pb_test_motion {
    double times[2];
    pb_pose poses[2];
    pb_motion motion;
} pb_test_motion;

void pb_test_motion_init(pb_test_motion *tm, const pb_pose *start, const pb_pose *end);
/* A pose of translation t (mm) and rotation deg about axis. */
pb_pose pb_test_pose(double tx, double ty, double tz, const double axis[3], double deg);

/* Records pb_progress_fn calls (pass pb_test_record_progress with a zeroed
 * log): how many, the last fraction, and how many broke the contract (a
 * fraction below the one before, above 1, or any call after 1). */
typedef struct pb_test_progress_log {
    int calls, bad;
    double last;
} pb_test_progress_log;

void pb_test_record_progress(double fraction, void *log);

/* Largest |a - b| and largest |b|. */
double pb_max_abs_diff(const float *a, const float *b, size_t n);
double pb_max_abs(const float *a, size_t n);
double pb_sum(const float *a, size_t n);
/* <a, b>, summed in double. */
double pb_dot(const float *a, const float *b, size_t n);
/* A fresh volume of n uniform values in [0, 1) (malloc'd). */
float *pb_random_volume(size_t n);

#endif
