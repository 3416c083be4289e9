/* Motion from the frames (pb_motion_estimate, pb_blur_pose_derivative): the
 * one internal header of src/estimate, in sections by the file that
 * implements them. Host images are float, x fastest; poses are in the grid
 * frame (mm from the grid's corner) about one centre shared by every level. */
#ifndef PB_ESTIMATE_H
#define PB_ESTIMATE_H

#include "parallel.h"
#include "petblur.h"

/* The voxels from which a grid's loops run on the estimate's threads: two
 * chunks of a sum. Below it a loop is a few milliseconds, and waking the
 * threads for each (thousands in an estimate) costs more than they save. */
#define PBE_THREADS_FROM (2 * PB_CHUNK)

/* ---- image_ops.c: host image operations -------------------------------------- */

/* The grid of the next coarser level: ceil(n / 2) voxels of twice the size,
 * from the same corner, so that a position in mm means the same point on
 * every level. */
void pbe_coarser(const pb_geometry *fine, pb_geometry *coarse);
/* The grid's most voxels along one axis. */
size_t pbe_longest_side(const pb_geometry *g);
/* Corner `corner` (0-7; bit a: the far face along axis a) of the grid's box,
 * mm from its first voxel's outer corner: where the passes measure how far a
 * pose moves the grid. */
void pbe_grid_corner(const pb_geometry *g, int corner, double p[3]);
/* How far pose a takes the grid's corners (about c) from where pose b
 * takes them, mm, the most over the eight; NaN where a pose is. */
double pbe_corner_distance(const pb_geometry *g, const double c[3], const pb_pose *a, const pb_pose *b);
/* Whether pose p moves no corner of the grid farther from where pose from
 * puts it than the grid's diagonal: how far a fit's step may carry a pose.
 * Beyond it the views hold nothing of the frame's object, and on grids whose
 * voxels differ by orders of magnitude between axes the normal equations are
 * near singular: a step may carry a pose past the translations any view
 * accepts (1e12 mm), a failure of the whole estimate, not a step too long. */
int pbe_within_grid(const pb_geometry *g, const double c[3], const pb_pose *from, const pb_pose *p);
/* Whether the grid's corners, read at pose a and then at pose b, move no
 * farther along any of the object's axes than the grid's voxels along it
 * (pb_texel_map_walk, as the planner's walk check counts them): a blur along
 * the path between them walks at most the grid's width. The diagonal does not bound that on grids whose voxels differ
 * by orders of magnitude (fuzz_estimate: 0.0001 x 9761 x 10000 mm voxels, a
 * path of 1e9 voxels along x between two frames' poses, walked for
 * minutes). */
int pbe_within_extent(const pb_geometry *g, const double c[3], const pb_pose *a, const pb_pose *b);
/* The volume (voxels) over which the residual a - b is correlated, as
 * smoothed white noise's, from its correlation at one voxel along each
 * axis; at least 1. A sum over the grid of that residual times a smooth
 * image has about this many times white noise's variance. */
double pbe_correlation_volume(const pb_geometry *g, const float *a, const float *b);
/* 2x2x2 block means onto the coarser grid (a block cut by the edge averages
 * the voxels it holds). */
void pbe_downsample(const pb_geometry *fine, const float *in, const pb_geometry *coarse, float *out);
/* Separable Gaussian of full width at half maximum fwhm mm, zero outside the
 * grid, renormalised at the edges so that a constant stays constant. tmp
 * holds the grid's longest line (the loop runs on the caller alone where
 * memory for the threads' lines is short). */
void pbe_smooth(pb_pool *pool, const pb_geometry *g, float *v, double fwhm_mm, float *tmp);
/* The object's six derivative images about centre c (mm): dx/dp_j, and
 * ((p - c) x grad x)_j, by central differences with zero outside the grid. */
void pbe_pose_gradients(pb_pool *pool, const pb_geometry *g, const float *x, const double c[3],
                        float *const out[6]);

/* ---- view_jacobian.c: a still pose's view differentiated in the pose ---------- */

/* The derivative of a still pose's view (the reference read at one pose over
 * the frame) in pb_pose_perturb's six perturbations, voxel by voxel from the
 * view's own central differences: what the blurs of the reference's
 * derivative images give, without blurring them. */
typedef struct pbe_view_jacobian {
    const float *view;
    size_t dims[3], step[3];
    double voxel[3];
    double rows[3][3];   /* R: its row a turns the view's axis a into the object's */
    double origin[3];    /* P(y) - c at the first voxel's centre */
} pbe_view_jacobian;

/* The view of pose about c on grid g (level->host[0] after its blur). */
void pbe_view_jacobian_init(pbe_view_jacobian *J, const pb_geometry *g, const float *view, const pb_pose *pose,
                            const double c[3]);
/* Voxel at's six derivatives. */
void pbe_view_jacobian_at(const pbe_view_jacobian *J, size_t at, double out[6]);

/* ---- register.c: one frame against a reference ------------------------------ */

/* The level's images: the reference and where it is known (PBE_SUPPORT). */
enum { PBE_SUPPORT = 1, PBE_IMAGES = 2 };

/* A reference on one level, on the device: the image and its support, and
 * outputs for their blurs (with host copies).
 * The support is 1 on the grid's voxels but its outer layer, 0 there and
 * beyond: blurred under a pose it weighs each voxel of a frame by whether
 * the reference is known where that voxel's view reads it. Activity that a
 * pose moves in across the grid's faces is no evidence against the pose
 * (the grid cut the body, not the head moved), and the outer layer's
 * gradient reads the zeros beyond it. */
typedef struct pbe_level {
    pb_geometry g;
    size_t n;
    pb_volume *in[PBE_IMAGES];    /* x, its support */
    pb_volume *out[PBE_IMAGES];   /* B of each */
    float *host[PBE_IMAGES];      /* out downloaded */
    float *box;                   /* the grid's own support (host) */
    pb_pool *pool;      /* the estimate's threads (NULL: the caller's alone) */
    float *views;        /* the dwell's views (pbe_level_views), kept between frames */
    size_t views_held;
} pbe_level;

pb_status pbe_level_init(pb_context *ctx, pbe_level *level, const pb_geometry *g, pb_pool *pool);
/* Uploads a reference x (and the grid's box as its support). */
pb_status pbe_level_set_reference(pbe_level *level, const float *x);
void pbe_level_free(pbe_level *level);
/* Uploads where the reference is known, in [0, 1] (NULL: the grid's box,
 * which pbe_level_set_reference sets too). */
pb_status pbe_level_set_support(pbe_level *level, const float *support);

/* The rigid fit of one frame: f ~ scale * B(pose) x + offset. */
typedef struct pbe_fit {
    pb_pose pose;        /* grid frame, about the estimate's centre */
    double scale, offset;
    double sse;          /* sum of squared residuals at the end */
    unsigned iterations;
    /* What the fit knows of the pose: J^T J / sigma^2 of its six
     * perturbations (pb_pose_perturb's) at its best pose, scale and offset
     * eliminated, sigma^2 the residual's variance; all zero where that is not
     * defined (no residual, too few voxels, a degenerate scale). */
    double information[36];
} pbe_fit;

/* A motion holding pose still over [0, 1] about c (times and poses: two each). */
void pbe_static_motion(const pb_pose *pose, const double c[3], double times[2], pb_pose poses[2], pb_motion *m);
/* The blur of the level's reference only (level->host[0]) under motion m. */
pb_status pbe_blur_reference(pb_context *ctx, pbe_level *level, const pb_motion *m);
/* The same into out (n floats). */
pb_status pbe_blur_reference_to(pb_context *ctx, pbe_level *level, const pb_motion *m, float *out);
/* The blur of the level's support under motion m (level->host[PBE_SUPPORT]):
 * the weights of pbe_register and pbe_dwell. */
pb_status pbe_blur_support(pb_context *ctx, pbe_level *level, const pb_motion *m);
/* Room for m views of the level's grid, kept with the level (NULL: no memory). */
float *pbe_level_views(pbe_level *level, size_t m);
/* Levenberg-Marquardt on the pose (scale and offset refitted each step) from
 * fit->pose, at most iterations steps, on the voxels whose view reads the
 * reference inside its support (weighted by the support's blur at the
 * starting pose). fit->sse is the residual over every voxel at the pose
 * found. */
pb_status pbe_register(pb_context *ctx, pbe_level *level, const float *frame, const double c[3],
                       unsigned iterations, pbe_fit *fit);
/* Solves the n x n system (row-major a and b, both destroyed) for x by
 * Gaussian elimination with partial pivoting; 0 when singular. */
int pbe_solve(double *a, double *b, int n, double *x);
/* The weighted residual of f on [a, 1] (weights w), least squares. */
double pbe_weighted_sse(pb_pool *pool, const float *a, const float *f, const float *w, size_t n);
/* Least squares of f on [a, 1]: the scale, offset and residual. */
void pbe_fit_scale(pb_pool *pool, const float *a, const float *f, size_t n, double *scale, double *offset,
                   double *sse);

/* ---- mutual_information.c: one frame against a reference, by mutual information */

/* Mattes mutual information of the frame and the level reference's view at
 * pose (50 bins a side, the view's in cubic B-spline windows), each voxel
 * weighed by the support's blur at ranges_at, where the bins' ranges are
 * taken too; and its gradient in pb_pose_perturb's six perturbations (grad
 * NULL: the value only). PB_ERR_INVALID_ARGUMENT where the frame or the view
 * is constant on the weights. */
pb_status pbe_mutual_information(pb_context *ctx, pbe_level *level, const float *frame, const double c[3],
                                 const pb_pose *pose, const pb_pose *ranges_at, double *mi, double grad[6]);
/* The pose of greatest mutual information from *pose (replaced), at most
 * `iterations` quasi-Newton steps, turns weighed by r (mm a radian) against
 * shifts; the weights and ranges held at the starting pose. *mi (or NULL):
 * the measure at the end. */
pb_status pbe_register_mi(pb_context *ctx, pbe_level *level, const float *frame, const double c[3], double r,
                          unsigned iterations, pb_pose *pose, double *mi);

/* ---- references.c: a reference per frame ---------------------------------- */

/* Eigenvalues and vectors of a symmetric n x n matrix (row-major a, destroyed)
 * by cyclic Jacobi rotations: vectors in the columns of v. */
void pbe_eigen(double *a, size_t n, double *w, double *v);
/* The frames a frame's reference is built from: at most this many, the
 * nearest in time. Uptake changes slowly against a frame, so the nearest
 * frames hold the frame's contrast; the window bounds each frame's work, and
 * the series' work grows as its frames, not as their square. */
enum { PBE_REFERENCE_OTHERS = 32 };
/* How many principal images a window of frames gives each frame's reference:
 * at most PBE_RANK_MOST. */
enum { PBE_RANK_MOST = 3 };
size_t pbe_reference_rank(size_t frames);
/* The indices of the min(rank, m, PBE_RANK_MOST) largest of w[0..m) into
 * out, largest first, ties to the lower index: an eigen decomposition's
 * leading pairs. Returns how many. */
size_t pbe_leading(const double *w, size_t m, size_t rank, size_t *out);
/* Each of m frames' weight by its noise, 1 / sqrt of its energy beyond the
 * leading `rank` images of their Gram matrix gram (m x m, kept), that energy
 * held to at least NOISE_FLOOR_SHARE of the frames' median; a, w and v are
 * scratch of m x m, m and m x m. */
void pbe_noise_scales(const double *gram, size_t m, size_t rank, double *a, double *w, double *v, double *scale);
/* The weights of m frames from their noise's variances (in scale, replaced):
 * 1 / sqrt of each, held to at least NOISE_FLOOR_SHARE of the median; all 1
 * where the median is 0. sorted is scratch of m. */
void pbe_weights_of_variances(double *scale, size_t m, double *sorted);
/* Frame k's window, [*first, *end): it and its nearest frames, at most
 * PBE_REFERENCE_OTHERS + 1 in all. */
void pbe_reference_window(size_t frames, size_t k, size_t *first, size_t *end);
double pbe_dot(const float *a, const float *b, size_t n);
/* The frames' inner products (frames x frames, row-major), frames moved back
 * onto the reference, n voxels each, frame after frame. */
void pbe_gram(pb_pool *pool, const float *moved, size_t n, size_t frames, double *gram);
/* The inner products of frames within a window of one another: band[i (B +
 * 1) + d] = g_i . g_(i+d) for d <= B = PBE_REFERENCE_OTHERS. */
void pbe_gram_band(pb_pool *pool, const float *moved, size_t n, size_t frames, double *band);
/* A frame's noise from the frame alone (d its dims): the median absolute
 * finest Haar detail over the head's 2x2x2 blocks. 0 where no block is in
 * the head, -1 where host memory runs out. */
double pbe_frame_noise(const float *f, const size_t d[3]);
/* Whether the own references weigh the frames by their noise measured alone
 * (PETBLUR_ESTIMATE_REFERENCES=noise or =unshifted, for comparisons): then
 * pbe_frame_reference asks each frame's. */
int pbe_references_by_noise(void);
/* Frame k's reference: its projection onto the leading principal images of
 * the other frames of its window, each weighed by its noise's variance
 * (noise, a value per frame; NULL: by its energy beyond the leading images,
 * pbe_noise_scales). */
pb_status pbe_frame_reference(pb_pool *pool, const float *moved, size_t n, size_t frames, const double *band,
                              const double *noise, size_t k, float *out);

/* ---- intra_frame.c: motion inside a frame ---------------------------------------- */

/* The reference's view at a pose as the dwell and its one pose compare
 * them, into out. Trilinear sampling smooths a view by f (1 - f) voxel^2
 * an axis, f where between voxels a voxel's point falls: 0 at the
 * reference frame's own pose (its points fall on the grid), up to 1/4
 * elsewhere, while the frames are not resampled at all. A mixture with the
 * sharper view fitted still frames beside the reference frame better than
 * their own pose did, and the smoothing left every view further from the
 * frames than its pose alone made it (docs/estimate-log.md, "The reference
 * frame's sharp view"), so each voxel of a view is sharpened along each
 * axis by what its sampling smoothed it. The level's host[0] is
 * overwritten (the view as sampled). */
pb_status pbe_view(pb_context *ctx, pbe_level *level, const pb_pose *pose, const double c[3], float *out);

/* The most poses a dwell fits: its sums (a Gram matrix with the offset's
 * column, the products with the frame) within PB_MOST_SUMS. */
enum { PBE_DWELL_MOST = 13 };

/* The frame's dwell along the path from pose s to pose e: weights u[0..m-1]
 * of the poses at s + (e - s) i / (m - 1), non-negative, with an offset,
 * fitted by least squares to the frame, each voxel weighed by
 * level->host[PBE_SUPPORT] (pbe_blur_support); *sse is the fit's weighted
 * residual. The level's reference must be set. */
pb_status pbe_dwell(pb_context *ctx, pbe_level *level, const float *frame, const double c[3], const pb_pose *s,
                    const pb_pose *e, size_t m, double *u, double *sse);

/* The same at m poses given (a path of several legs), m at most
 * PBE_DWELL_MOST; the views stay in pbe_level_views(level, m). gram_out (or
 * NULL): the least squares' normal matrix, (m + 1) x (m + 1), the offset's
 * row and column last. */
pb_status pbe_dwell_at(pb_context *ctx, pbe_level *level, const float *frame, const double c[3],
                       const pb_pose *poses, size_t m, double *u, double *sse, double *gram_out);

/* Non-negative least squares on normal equations: minimises
 * |A u - f|^2 given G = A^T A (n x n, row-major), h = A^T f, with u[j] >= 0
 * for j < n_nonneg and the rest free. */
void pbe_nnls(const double *gram, const double *h, size_t n, size_t n_nonneg, double *u);

/* ---- two_poses.c: a frame as two poses held in turn ------------------------- */

/* The frame as a V(A) + b V(B) + o, a and b non-negative, each view pbe_view's,
 * A and B fitted from *a and *b (replaced) by at most `iterations`
 * Levenberg-Marquardt steps, each voxel weighed by level->host[PBE_SUPPORT]
 * as set. *share_a: a / (a + b), the share of the frame held at A, or -1
 * where no fit with both shares above zero was found (*a, *b kept); *sse:
 * the weighted residual. The level's reference must be set. */
pb_status pbe_two_poses(pb_context *ctx, pbe_level *level, const float *frame, const double c[3], pb_pose *a,
                        pb_pose *b, unsigned iterations, double *share_a, double *sse);
/* How much of the frame's time it dwells at a and b (*held, in [0, 1]), let
 * to dwell anywhere along the line through them, half as far again beyond
 * each (pbe_dwell at nine points, a quarter of their distance apart, a and b
 * the third and the seventh): what tells two poses held in turn from motion
 * spread over the frame. A point within `within` of a or b (in their
 * distance; at most 0.25, the points beside them) counts as theirs: views
 * less than a voxel apart are nearly alike, and a dwell splits between them
 * by the noise. The weights are level->host[PBE_SUPPORT] as set. */
pb_status pbe_two_poses_held(pb_context *ctx, pbe_level *level, const float *frame, const double c[3],
                             const pb_pose *a, const pb_pose *b, double within, double *held);

/* A fit of two poses' twelve numbers (A's six perturbations, pb_pose_perturb's,
 * then B's) by Levenberg-Marquardt, as two_poses.c and line_dwell.c take it:
 * normal() gives the normal equations at the fit so far, a and b (12 x 12,
 * row-major, and the gradient; 0 where there are none); trial() evaluates a
 * pair of poses and keeps it as its fit so far where it fits better, *gain
 * then what it took off the residual and *sse the residual (*gain left 0
 * where not kept). A step that moves a grid corner of g farther than the
 * grid's diagonal from a0 or b0 (pbe_within_grid) is not tried. */
typedef struct pbe_pair_steps {
    int (*normal)(void *user, double *A, double *grad);
    pb_status (*trial)(void *user, const pb_pose *a, const pb_pose *b, double *gain, double *sse);
    void *user;
    const pb_geometry *g;
    const double *c;
    pb_pose a0, b0; /* where the fit started */
    pb_pose a, b;   /* the fit so far, as trial() last kept it */
} pbe_pair_steps;
/* At most `iterations` steps; ends where a step gains under 1e-7 of the
 * residual or none is found. */
pb_status pbe_pair_descend(pbe_pair_steps *f, unsigned iterations);
/* The most linear unknowns pbe_pair_eliminate takes. */
enum { PBE_PAIR_LINEAR_MOST = 10 };
/* The twelve numbers' normal matrix A with nl linear unknowns eliminated (a
 * Schur complement): A -= X G^-1 X^T, X (12 x nl) their cross terms, G (nl
 * x nl) their normal matrix. 0 where G is singular or nl is over
 * PBE_PAIR_LINEAR_MOST. */
int pbe_pair_eliminate(double *A, const double *cross, const double *gram, size_t nl);

/* ---- line_dwell.c: a frame as a dwell along a line with fitted ends -------- */

/* The most points a line's dwell takes. */
enum { PBE_LINE_MOST = 9 };
/* The frame as sum_i u_i V(P_i) + o, the P_i m points spaced evenly from A to
 * B (pb_pose_interpolate), u non-negative, A and B fitted from *a and *b
 * (replaced) by at most `iterations` Levenberg-Marquardt steps a round, the
 * line trimmed to its first and last points held between rounds; each voxel
 * weighed by level->host[PBE_SUPPORT] as set. u: m dwells and the offset;
 * *sse: the weighted residual (infinite, *a, *b and u untouched, where no
 * dwell was found). m is 2 to PBE_LINE_MOST. The level's reference must be
 * set. */
pb_status pbe_line_dwell(pb_context *ctx, pbe_level *level, const float *frame, const double c[3], pb_pose *a,
                         pb_pose *b, size_t m, unsigned iterations, double *u, double *sse);

/* ---- sinc_shears.c: rigid moves that keep a volume's energy --------------------- */

/* The padded grid a volume on g is moved in: odd sizes, a margin each side. */
void pbe_unitary_dims(const pb_geometry *g, size_t pad[3]);
/* out (pad[0] x pad[1] x pad[2], g's volume in its middle) = f(T x) for the
 * pose T about c (mm from g's corner), by a shift and nine shears of
 * trigonometric interpolation: the energy of f, to rounding. */
pb_status pbe_move_unitary(const pb_geometry *g, const float *f, const size_t pad[3], const pb_pose *pose,
                           const double c[3], float *out);

/* ---- background.c: what the frames hold besides the object ---------------- */

/* Each frame's background, the median of its faces' voxels, and its peak. */
pb_status pbe_backgrounds(const pb_geometry *g, const float *frames, size_t count, double *level, double *peak);
/* The share of a frame's variance about its mean that a fit leaving sse explains. */
double pbe_explained(const float *frame, size_t n, double sse);

/* ---- smooth_poses.c: the still frames' poses seen together in time ---------- */

/* The poses of the frames not skipped (skip[k]), each fit's pose a sighting
 * of a head that moves as a random walk through it with that fit's
 * information, smoothed in time (mid-times t) by the walk's rate that makes
 * the sightings likeliest; a sighting too far from the walk so far to be
 * noise (a jerk between frames) starts the walk anew. r: a radius in mm
 * (the estimate passes the grid's RMS radius about its centre), which puts
 * turns and shifts on one scale. Returns the rate chosen
 * (r^2/s), or a negative number where nothing was smoothed:
 * PBE_SMOOTH_NO_MEMORY where memory ran out, -1 where too few sightings.
 * jumped (count, or NULL): 1 for a sighting the walk restarted at after an
 * earlier one, where something was smoothed. */
#define PBE_SMOOTH_NO_MEMORY (-2.0)
double pbe_smooth_poses(pbe_fit *fits, const int *skip, const double *t, size_t count, size_t base, double r,
                        int *jumped);

/* How far a fit's pose is sure: the variance (mm^2) of a point's place at
 * radius r from the turns' centre that its information leaves, shifts and
 * turns together; infinity where the information is not positive definite. */
double pbe_pose_spread(const pbe_fit *fit, double r);

/* x = log(P_base^-1 P), six numbers: the translation (mm) and rotation
 * vector (radians) of P_base^-1 P; rot (or NULL): its rotation matrix. */
void pbe_chart(const pb_pose *p, const pb_pose *base, double x[6], double rot[9]);
/* P = P_base exp(x), the inverse of pbe_chart. */
void pbe_unchart(const double x[6], const pb_pose *base, pb_pose *p);

/* ---- track_curve.c: the track between the still frames' middles ------------- */

/* Keys inserted between consecutive keys that are both still frames' middles
 * (middle[i]): PBE_CURVE_KEYS - 1 of them, on a monotone cubic through the
 * keys. */
enum { PBE_CURVE_KEYS = 8 };
/* The keys (t, p, n of them, middle[i] where key i is a still frame's pose at
 * its middle) with the curve's keys between such pairs, into t_out and p_out
 * (room for n + (n - 1) * (PBE_CURVE_KEYS - 1)); returns how many, 0 where
 * memory ran out. Times the doubles cannot hold apart are left out. */
size_t pbe_curve_keys(const double *t, const pb_pose *p, const unsigned char *middle, size_t n, double *t_out,
                      pb_pose *p_out);

/* ---- contrast_poses.c: the poses moved together along the contrast ------------- */

/* A frame's poses: one, or a path's ends where it moves (pass 3). */
typedef struct pbe_collective_pose {
    pb_pose pose, start, end;
    int moving;
} pbe_collective_pose;

/* At most this many evaluations of the series' residual in pbe_collective
 * (its Newton rounds' differences and halvings), each a tick. */
enum { PBE_COLLECTIVE_EVALUATIONS = 48 };

/* One rigid correction for every pose, scaled by the frame's contrast
 * against frame ref's, chosen to leave the least energy beyond the leading
 * principal images of the still frames moved back (sinc_shears.c) onto the
 * reference; raw: the frames on the fine grid. *moved_mm: the correction's
 * size (0: none taken). tick (may be NULL) hears each evaluation of the
 * residual, for progress. */
pb_status pbe_collective(pb_pool *pool, const pb_geometry *fine, const float *raw, size_t count, size_t ref,
                         const double c[3], pbe_collective_pose *poses, double *moved_mm, void (*tick)(void *),
                         void *tick_user);

#endif
