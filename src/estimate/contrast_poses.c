/* The frames' poses moved together along their contrast. Where tracer
 * uptake changes fast (blood fading in the first minute), each frame's own
 * reference (references.c) is built from frames whose misregistration
 * follows the same contrast: the early frames shift together and confirm one
 * another, a fixed point of frame-by-frame registration half a millimetre
 * off. What tells them apart is the series as a whole: moved back onto the
 * reference, aligned frames span as few images as there are tissue curves,
 * and frames that are off add images of their edges. So every pose gets one
 * more rigid correction, the same six numbers scaled by how far the frame's
 * contrast lies from the reference frame's, chosen to leave the least energy
 * beyond the moved-back frames' leading principal images.
 *
 * Each frame counts by its noise: its energy beyond the leading images is
 * divided by its noise's variance. Frames of 3 s and of 60 s differ tenfold
 * in noise, and unweighted the sum is the noisiest frames' (docs/estimate-log.md:
 * a draw from injection whose short frames held 30-47 of the energy beyond,
 * its long ones 4-5, took a correction 1.3 mm wrong). The noise is measured
 * from each frame alone (pbe_frame_noise). Measured as the energy beyond at the
 * registered poses, it held the bias sought as well: the frames most off
 * weighed least, and on CI's series 3179720955 the pass took the track from
 * 0.932 to 0.990 mm, where it now takes it to 0.537 (on 24 fresh series on
 * CUDA, the mean 0.542 -> 0.469 mm median, 16 better and 8 worse;
 * bench/results/2026-12-02_H200_537f1cc_pass4-noise).
 *
 * The frames are moved by a resampler that keeps their energy (sinc_shears.c):
 * under trilinear resampling the noise's energy falls with the pose and the
 * minimum follows it (docs/estimate-log.md gives the runs). The contrast
 * must show in the earlier half of the frames alone (contrast_early): the
 * bias is the earliest frames', and a second image that only later frames
 * make was, where it was traced, slow nods' blur.
 * Frames that follow a path (pass 3) are not one pose's view and stay out of
 * the sum; they are corrected with the rest, by their neighbours' contrast. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "estimate.h"
#include "motion.h"

enum { NG = 6 };

/* The grid the frames are compared on: halved until its longest side is at
 * most LONGEST_SIDE, as the cost of an evaluation grows as the padded volume
 * times its longest line and six numbers for the whole series are found on
 * voxels of about 6 mm; but not to voxels coarser than COARSEST_MM along
 * every axis while the longest side is at most MOST_SIDE. The bias is a
 * fraction of a millimetre: issue 47's heads on 2-4 mm grids of 60-90 voxels
 * a side were halved twice, to voxels of 8-16 mm, where the pass took
 * corrections of 1-2 mm that lowered its residual by a thousandth and made
 * three draws from injection 0.3-0.7 mm worse (docs/estimate-log.md); halved once
 * (voxels of 4-8 mm) its own checks refused them. The grids halved once before
 * (their coarser voxels 6.1-7.3 mm at the smallest) stay so. */
#define LONGEST_SIDE 40
#define MOST_SIDE 64
#define COARSEST_MM 7.5
/* The still frames in the sum at most, spread evenly over the series: each
 * evaluation's cost grows as their square (and its eigenvalues as their
 * cube), and six numbers for the whole series are found from a few dozen
 * frames; frames out of the sum take their nearest's contrast. */
enum { MAX_SUM_FRAMES = 24 };
/* When a series shows a contrast to correct along (contrast_weights). */
#define CONTRAST_OVER_NOISE 10.0
#define EARLY_OVER_NOISE 5.0
#define CONTRAST_ROUGHNESS 0.5
/* The share of the weights' range that one step between neighbouring frames
 * of the sum may take where the head jumped between them
 * (weights_follow_uptake). */
#define JUMP_STEP_SHARE 0.5

typedef struct collective {
    pb_geometry g;          /* the grid the frames are compared on */
    size_t n, pad[3], padded, count, used, rank;
    pb_pool *pool;          /* the estimate's threads: a frame moved on each */
    double c[3], radius;
    float *frames;          /* every frame on g */
    float *moved;           /* the used frames moved back, padded */
    size_t *use;            /* the frames in the sum */
    const pbe_collective_pose *poses;
    double *weight, *gram, *a, *w, *v;
    double *scale;          /* per frame of the sum: 1 / its noise's RMS; NULL: 1 */
    void (*tick)(void *);   /* each evaluation of the residual, for progress */
    void *tick_user;
} collective;

/* The correction p (mm, and mm at the radius for the turn) scaled by w as
 * a pose about the centre, composed after (on the tomograph's side of) pose. */
static void corrected(const collective *cv, double w, const double p[NG], const pb_pose *pose, pb_pose *out)
{
    pb_pose g;
    double r[3], angle = 0.0;
    for (int i = 0; i < 3; i++) {
        g.translation[i] = w * p[i];
        r[i] = w * p[3 + i] / cv->radius;
        angle += r[i] * r[i];
    }
    angle = sqrt(angle);
    g.rotation[0] = cos(0.5 * angle);
    for (int i = 0; i < 3; i++)
        g.rotation[1 + i] = angle > 0 ? sin(0.5 * angle) / angle * r[i] : 0.0;
    pb_pose after;
    pb_pose_compose(&g, pose, &after);
    pb_pose_normalized(&after, out);
}

/* The top `rank` eigenvalues' sum and, with vectors, the trace; a and the
 * rest are scratch. */
static double energy_beyond(collective *cv)
{
    const size_t m = cv->used;
    double trace = 0.0, top = 0.0;
    memcpy(cv->a, cv->gram, sizeof(double) * m * m);
    for (size_t k = 0; k < m; k++)
        trace += cv->gram[k * m + k];
    pbe_eigen(cv->a, m, cv->w, cv->v);
    size_t lead[PBE_RANK_MOST];
    for (size_t c = 0, count = pbe_leading(cv->w, m, cv->rank, lead); c < count; c++)
        top += cv->w[lead[c]];
    return trace - top;
}

/* The frames moved back under one correction. */
typedef struct mover {
    collective *cv;
    const double *p;
    pb_status *st; /* one a frame of the sum */
} mover;

static void move_frame(void *arg, size_t i)
{
    const mover *mv = arg;
    collective *cv = mv->cv;
    size_t k = cv->use[i];
    /* frame k shows the object x at T x: moved back, it is f_k(T x) */
    pb_pose pose;
    corrected(cv, cv->weight[k], mv->p, &cv->poses[k].pose, &pose);
    mv->st[i] = pbe_move_unitary(&cv->g, cv->frames + k * cv->n, cv->pad, &pose, cv->c, cv->moved + i * cv->padded);
}

/* The energy the frames moved back under correction p hold beyond their
 * leading principal images. The frames are moved on the estimate's threads,
 * a frame each. */
static pb_status residual(collective *cv, const double p[NG], double *out)
{
    pb_status st[MAX_SUM_FRAMES];
    mover mv = {cv, p, st};
    pb_pool_for(cv->pool, cv->used, move_frame, &mv);
    for (size_t i = 0; i < cv->used; i++)
        if (st[i] != PB_OK)
            return st[i];
    pbe_gram(cv->pool, cv->moved, cv->padded, cv->used, cv->gram);
    if (cv->scale)
        for (size_t i = 0; i < cv->used; i++)
            for (size_t j = 0; j < cv->used; j++)
                cv->gram[i * cv->used + j] *= cv->scale[i] * cv->scale[j];
    *out = energy_beyond(cv);
    if (cv->tick)
        cv->tick(cv->tick_user);
    return PB_OK;
}

/* The two leading principal images of the frames whose Gram matrix is
 * gram (m of them), in cv->w and cv->v, and whether the second stands out
 * of the noise: its energy against the median of those beyond the
 * references' images (noise alone makes them nearly equal; the axial
 * validation's series gives 58). */
static int second_image(collective *cv, const double *gram, size_t m, size_t *first_out, size_t *second_out,
                        double bar)
{
    if (m < cv->rank + 3)
        return 0;
    memcpy(cv->a, gram, sizeof(double) * m * m);
    pbe_eigen(cv->a, m, cv->w, cv->v);
    size_t first = 0, second = m;
    for (size_t j = 1; j < m; j++)
        if (cv->w[j] > cv->w[first])
            first = j;
    for (size_t j = 0; j < m; j++)
        if (j != first && (second == m || cv->w[j] > cv->w[second]))
            second = j;
    if (second == m || !(cv->w[second] > 1e-12 * cv->w[first]))
        return 0;
    double *rest = malloc(sizeof(double) * m), noise;
    if (!rest)
        return 0;
    memcpy(rest, cv->w, sizeof(double) * m);
    for (size_t i = 0; i < m; i++)
        for (size_t j = i + 1; j < m; j++)
            if (rest[j] > rest[i]) {
                double t = rest[i];
                rest[i] = rest[j];
                rest[j] = t;
            }
    noise = rest[cv->rank + (m - cv->rank) / 2];
    free(rest);
    *first_out = first;
    *second_out = second;
    return cv->w[second] > bar * noise;
}

/* Whether the n frames of the sum at indices part show the second image by
 * themselves at bar times the noise's; too few of them to tell (fewer than
 * the whole series' test asks), the whole series decides: 1. 0 where host
 * memory runs out. */
static int part_shows(collective *cv, const size_t *part, size_t n, double bar)
{
    const size_t m = cv->used;
    size_t first, second;
    if (n < cv->rank + 3)
        return 1;
    double *sub = malloc(sizeof(double) * n * n);
    if (!sub)
        return 0;
    for (size_t i = 0; i < n; i++)
        for (size_t j = 0; j < n; j++)
            sub[i * n + j] = cv->gram[part[i] * m + part[j]];
    int shows = second_image(cv, sub, n, &first, &second, bar);
    free(sub);
    return shows;
}

/* Whether the frames that sit where the reference frame does (within a
 * voxel of the grid compared on, at its corners) show the second image too,
 * where there are enough of them to tell.
 * Uptake changes the image wherever the head is; a second image that only
 * frames far from the reference carry is how the grid samples a head turned
 * far, moved back (a 15 degree, 10 mm jerk on 6 mm voxels: one 15 times the
 * noise's, its scores stepping at the jerk), and a correction along it moved
 * every frame after the jerk by 4 mm (docs/estimate-log.md). Too few frames near
 * the reference to tell (fewer than the whole series' test asks): the whole
 * series decides, as before. A series from injection whose early jerk left
 * 5 of 16 frames near it kept a correction along its contrast that took it
 * from 1.10 to 0.96 mm; its frames together after the jerk, 10 of them,
 * showed no second image, so no grouping by pose tells that contrast from a
 * sampling difference where the two change together. */
static int contrast_near_reference(collective *cv, size_t ref)
{
    const size_t m = cv->used;
    double voxel = fmax(cv->g.voxel_size[0], fmax(cv->g.voxel_size[1], cv->g.voxel_size[2]));
    size_t *near = malloc(sizeof(size_t) * m), n = 0;
    if (!near)
        return 0;
    for (size_t i = 0; i < m; i++)
        if (pbe_corner_distance(&cv->g, cv->c, &cv->poses[cv->use[i]].pose, &cv->poses[ref].pose) <= voxel)
            near[n++] = i;
    int shows = part_shows(cv, near, n, CONTRAST_OVER_NOISE);
    free(near);
    return shows;
}

/* Whether the weights change as uptake does, not where the head jumped:
 * between neighbouring frames of the sum that lie more than a voxel apart
 * (at the grid's corners), the weights may not step by JUMP_STEP_SHARE of
 * their range. Frames far apart are sampled differently, and moved back
 * their differences are an image of their own whose scores step at the
 * jump: issue 47's draw 2935784270 (a late scan, a 5.8 degree jerk) had
 * weights 0 before its jerk and 0.78-1.00 after (the step 0.99 of the
 * range), and the correction moved every frame after it 1.8 mm off; pass
 * 4's own series, from injection, rise smoothly (0.29, 0.50, 0.64 ... in
 * the first frames) and step by 0.007 at a 30 mm jerk. */
static int weights_follow_uptake(const collective *cv)
{
    const size_t m = cv->used;
    double voxel = fmax(cv->g.voxel_size[0], fmax(cv->g.voxel_size[1], cv->g.voxel_size[2]));
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    for (size_t i = 0; i < m; i++) {
        lo = fmin(lo, cv->weight[cv->use[i]]);
        hi = fmax(hi, cv->weight[cv->use[i]]);
    }
    for (size_t i = 1; i < m; i++) {
        const size_t a = cv->use[i - 1], b = cv->use[i];
        if (pbe_corner_distance(&cv->g, cv->c, &cv->poses[a].pose, &cv->poses[b].pose) > voxel &&
            fabs(cv->weight[b] - cv->weight[a]) >= JUMP_STEP_SHARE * (hi - lo))
            return 0;
    }
    return 1;
}

/* Whether the earlier half of the frames in the sum (by count, in time)
 * shows the second image by itself, at EARLY_OVER_NOISE; too few frames
 * there to tell (as contrast_near_reference), the whole series decides.
 * Uptake from injection changes fastest in the first minutes, and the bias
 * this pass corrects is there: on 8 series of its own kind (equal frames of
 * 10 s) the earlier half showed the second image at 9.8-10.9 times the
 * noise's eigenvalue, the later half at 1.2, and 8 more kept their
 * corrections. On the five draws of issue 47's family on which the pass
 * acted (each with a nod of 53-186 s) the earlier half, their short frames
 * of the first 48-105 s, stood at 1.3-2.1 and the later at 5.0-13.8; on
 * one the nods' frames were shown to make it (docs/estimate-log.md). That
 * refuses the two of those corrections that helped (0.663 against 1.053
 * mm, 0.495 against 0.613) with the three that harmed (1.014 against
 * 0.382, 1.243 against 0.743, 0.568 against 0.559). */
static int contrast_early(collective *cv)
{
    const size_t n = cv->used / 2;
    size_t *early = malloc(sizeof(size_t) * (n + 1));
    if (!early)
        return 0;
    for (size_t i = 0; i < n; i++)
        early[i] = i;
    int shows = part_shows(cv, early, n, EARLY_OVER_NOISE);
    free(early);
    return shows;
}

/* Each frame's contrast against the reference frame's: the ratio of its
 * second principal score to its first, as a share of the series' widest; a
 * frame out of the sum takes its nearest neighbour's in the sum. 0 when
 * the series shows no second image, or only frames far from the reference
 * frame's pose show it, or its weights step where the head jumped. */
static int contrast_weights(collective *cv, size_t ref, int early)
{
    const size_t m = cv->used;
    size_t first, second;
    /* the whole series' second_image last: the weights below read its
     * eigenvectors, which the checks on parts of it overwrite */
    if (!contrast_near_reference(cv, ref) || (early && !contrast_early(cv)) ||
        !second_image(cv, cv->gram, m, &first, &second, CONTRAST_OVER_NOISE))
        return 0;
    for (size_t k = 0; k < cv->count; k++) {
        size_t near = 0;
        for (size_t i = 1; i < m; i++)
            if ((cv->use[i] > k ? cv->use[i] - k : k - cv->use[i]) <
                (cv->use[near] > k ? cv->use[near] - k : k - cv->use[near]))
                near = i;
        double s1 = cv->v[near * m + first];
        cv->weight[k] = fabs(s1) > 0 ? cv->v[near * m + second] / s1 : 0.0;
    }
    double at_ref = cv->weight[ref], widest = 0.0;
    for (size_t k = 0; k < cv->count; k++) {
        cv->weight[k] -= at_ref;
        widest = fmax(widest, fabs(cv->weight[k]));
    }
    if (!(widest > 0))
        return 0;
    for (size_t k = 0; k < cv->count; k++)
        cv->weight[k] /= widest;
    /* and follow a curve in time, as uptake does: the squared steps between
     * frames against the spread about the mean (2 for weights drawn at
     * random, 0.11 on the axial validation's series) */
    double mean = 0.0, spread = 0.0, steps = 0.0;
    for (size_t i = 0; i < m; i++)
        mean += cv->weight[cv->use[i]] / (double)m;
    for (size_t i = 0; i < m; i++) {
        double d = cv->weight[cv->use[i]] - mean;
        spread += d * d;
        if (i > 0)
            steps += (cv->weight[cv->use[i]] - cv->weight[cv->use[i - 1]]) *
                     (cv->weight[cv->use[i]] - cv->weight[cv->use[i - 1]]);
    }
    return steps <= CONTRAST_ROUGHNESS * spread && weights_follow_uptake(cv);
}

/* Solves h x = -g with h's eigenvalues held above a floor: the valley's flat
 * or bent directions take no step to infinity. */
static void newton_step(const double *h, const double *g, double *x)
{
    double a[NG * NG], w[NG], v[NG * NG], top = 0.0;
    memcpy(a, h, sizeof a);
    pbe_eigen(a, NG, w, v);
    for (int i = 0; i < NG; i++)
        top = fmax(top, fabs(w[i]));
    for (int i = 0; i < NG; i++)
        x[i] = 0.0;
    for (int j = 0; j < NG; j++) {
        double lam = fmax(fabs(w[j]), 1e-3 * top), d = 0.0;
        if (!(lam > 0))
            continue;
        for (int i = 0; i < NG; i++)
            d += v[i * NG + j] * g[i];
        for (int i = 0; i < NG; i++)
            x[i] -= v[i * NG + j] * d / lam;
    }
}

/* A quadratic model of the residual from central differences, a Newton
 * step on it, halved until the residual falls; e0 is the residual at p. The
 * second round keeps the first's cross terms (the residual is nearly
 * quadratic over a voxel): 12 evaluations instead of 27. */
static pb_status minimise(collective *cv, double p[NG], double e0)
{
    const double h = 0.25 * fmin(cv->g.voxel_size[0], fmin(cv->g.voxel_size[1], cv->g.voxel_size[2]));
    pb_status st = PB_OK;
    double hess[NG * NG];
    for (int round = 0; round < 2 && st == PB_OK; round++) {
        double plus[NG], minus[NG], grad[NG], q[NG], step[NG], len = 0.0;
        for (int i = 0; i < NG && st == PB_OK; i++) {
            memcpy(q, p, sizeof q);
            q[i] += h;
            st = residual(cv, q, &plus[i]);
            q[i] -= 2 * h;
            if (st == PB_OK)
                st = residual(cv, q, &minus[i]);
            if (st != PB_OK)
                break;
            grad[i] = (plus[i] - minus[i]) / (2 * h);
            hess[i * NG + i] = (plus[i] - 2 * e0 + minus[i]) / (h * h);
        }
        for (int i = 0; i < NG && st == PB_OK && round == 0; i++)
            for (int j = i + 1; j < NG && st == PB_OK; j++) {
                double both;
                memcpy(q, p, sizeof q);
                q[i] += h;
                q[j] += h;
                st = residual(cv, q, &both);
                hess[i * NG + j] = hess[j * NG + i] = (both - plus[i] - plus[j] + e0) / (h * h);
            }
        if (st != PB_OK)
            break;
        newton_step(hess, grad, step);
        for (int i = 0; i < NG; i++)
            len += step[i] * step[i];
        len = sqrt(len);
        /* no more than two voxels a round: the model is local */
        for (int i = 0; i < NG && len > 8.0 * h; i++)
            step[i] *= 8.0 * h / len;
        int taken = 0;
        for (int halve = 0; halve < 4 && st == PB_OK && !taken; halve++) {
            double e;
            for (int i = 0; i < NG; i++)
                q[i] = p[i] + step[i];
            st = residual(cv, q, &e);
            if (st == PB_OK && e < e0) {
                memcpy(p, q, sizeof(double) * NG);
                e0 = e;
                taken = 1;
            }
            for (int i = 0; i < NG; i++)
                step[i] *= 0.5;
        }
        if (!taken)
            break;
    }
    return st;
}

/* m of the still frames (of `still`), spread evenly from the first to the
 * last, in order. */
static void pick_still(const pbe_collective_pose *poses, size_t count, size_t still, size_t *use, size_t m)
{
    for (size_t k = 0, s = 0, i = 0; k < count && i < m; k++) {
        if (poses[k].moving)
            continue;
        /* the i-th pick is still frame round(i (still - 1) / (m - 1)) */
        size_t want = m > 1 ? (i * (still - 1) + (m - 1) / 2) / (m - 1) : 0;
        if (s == want)
            use[i++] = k;
        s++;
    }
}

pb_status pbe_collective(pb_pool *pool, const pb_geometry *fine, const float *raw, size_t count, size_t ref,
                         const double c[3], pbe_collective_pose *poses, double *moved_mm, void (*tick)(void *),
                         void *tick_user)
{
    collective cv;
    memset(&cv, 0, sizeof cv);
    cv.tick = tick;
    cv.tick_user = tick_user;
    *moved_mm = 0.0;
    cv.g = *fine;
    cv.count = count;
    cv.poses = poses;
    memcpy(cv.c, c, sizeof cv.c);
    /* PETBLUR_ESTIMATE_CONTRAST=0 leaves the poses as registered, =coarse
     * halves the grid to LONGEST_SIDE whatever its voxels, =unweighted counts
     * every frame alike, =residual weighs them by their energy beyond at the
     * registered poses (before pbe_frame_noise), =half takes a correction only
     * within half a voxel, =any whether or not the earlier half of the
     * frames shows the contrast alone (contrast_early), for comparisons */
    const char *env = getenv("PETBLUR_ESTIMATE_CONTRAST");
    if (env && strcmp(env, "0") == 0)
        return PB_OK;
    const int any_voxel = env && strcmp(env, "coarse") == 0;
    const int unweighted = env && strcmp(env, "unweighted") == 0;
    const int residual_weights = env && strcmp(env, "residual") == 0;
    size_t levels = 0;
    int slab = 0;
    while (pbe_longest_side(&cv.g) > LONGEST_SIDE) {
        pb_geometry coarse;
        pbe_coarser(&cv.g, &coarse);
        if (coarse.dims[0] < 8 || coarse.dims[1] < 8 || coarse.dims[2] < 8) {
            slab = 1;
            break;
        }
        if (!any_voxel && pbe_longest_side(&cv.g) <= MOST_SIDE &&
            fmin(coarse.voxel_size[0], fmin(coarse.voxel_size[1], coarse.voxel_size[2])) > COARSEST_MM)
            break;
        cv.g = coarse;
        levels++;
    }
    /* a grid that cannot be coarsened far enough (a thin slab) would cost
     * hours here: left as registered */
    if (slab)
        return PB_OK;
    cv.n = cv.g.dims[0] * cv.g.dims[1] * cv.g.dims[2];
    pbe_unitary_dims(&cv.g, cv.pad);
    cv.padded = cv.pad[0] * cv.pad[1] * cv.pad[2];
    size_t still = 0;
    for (size_t k = 0; k < count; k++)
        still += !poses[k].moving;
    cv.used = still < MAX_SUM_FRAMES ? still : MAX_SUM_FRAMES;
    cv.rank = pbe_reference_rank(count);
    cv.pool = pool;
    /* Measured on series of 24 frames, whose references have three images:
     * with fewer, the energy beyond them holds tissue curves the references
     * cannot, and a correction along the contrast would trade one for the
     * other. */
    if (cv.rank < 3 || cv.used < cv.rank + 3 || poses[ref].moving)
        return PB_OK;
    const size_t m = cv.used;
    cv.frames = malloc(sizeof(float) * cv.n * count);
    cv.moved = malloc(sizeof(float) * cv.padded * m);
    cv.use = malloc(sizeof(size_t) * m);
    cv.weight = calloc(count, sizeof(double));
    cv.gram = malloc(sizeof(double) * m * m);
    cv.a = malloc(sizeof(double) * m * m);
    cv.w = malloc(sizeof(double) * m);
    cv.v = malloc(sizeof(double) * m * m);
    double *scale = unweighted ? NULL : malloc(sizeof(double) * m);
    size_t fine_n = fine->dims[0] * fine->dims[1] * fine->dims[2];
    float *x = malloc(sizeof(float) * fine_n), *y = malloc(sizeof(float) * fine_n);
    pb_status st = cv.frames && cv.moved && cv.use && cv.weight && cv.gram && cv.a && cv.w && cv.v &&
                           (scale || unweighted) && x && y
                       ? PB_OK
                       : PB_ERR_OUT_OF_MEMORY;
    /* the frames as block means, unsmoothed: smoothing is the same for every
     * pose and tells nothing */
    for (size_t k = 0; k < count && st == PB_OK; k++) {
        pb_geometry g = *fine, coarse;
        memcpy(x, raw + k * fine_n, sizeof(float) * fine_n);
        for (size_t l = 0; l < levels; l++) {
            pbe_coarser(&g, &coarse);
            pbe_downsample(&g, x, &coarse, y);
            float *t = x;
            x = y;
            y = t;
            g = coarse;
        }
        memcpy(cv.frames + k * cv.n, x, sizeof(float) * cv.n);
    }
    if (cv.use)
        pick_still(poses, count, still, cv.use, m);
    for (int i = 0; i < 3; i++)
        cv.radius = fmax(cv.radius, 0.5 * (double)cv.g.dims[i] * cv.g.voxel_size[i]);
    /* at p = 0 every weight moves nothing: this residual, which the
     * contrast weights are read from, is also minimise's start, once the
     * frames are weighed by their noise (pbe_frame_noise). Under
     * PETBLUR_ESTIMATE_CONTRAST=residual the noise is read from it
     * unweighted instead (pbe_noise_scales: each frame's energy beyond,
     * which holds the bias sought as well), and weighted once, not iterated:
     * a frame weighted up becomes a leading image of its own, its energy
     * beyond them falls and its weight grows (an early frame of blood alone
     * went from 1.4 to 1e-4 of the others' in a second round). */
    double p[NG] = {0}, e0;
    if (st == PB_OK && scale && !residual_weights) {
        for (size_t i = 0; i < m && st == PB_OK; i++) {
            double s = pbe_frame_noise(cv.frames + cv.use[i] * cv.n, cv.g.dims);
            if (s < 0.0)
                st = PB_ERR_OUT_OF_MEMORY;
            scale[i] = s * s;
        }
        if (st == PB_OK) {
            pbe_weights_of_variances(scale, m, cv.w);
            cv.scale = scale;
        }
    }
    if (st == PB_OK)
        st = residual(&cv, p, &e0);
    if (st == PB_OK && scale && residual_weights) {
        pbe_noise_scales(cv.gram, m, cv.rank, cv.a, cv.w, cv.v, scale);
        cv.scale = scale;
        st = residual(&cv, p, &e0);
    }
    /* the bias is a fraction of a voxel: a correction beyond one voxel of
     * the frames' grid (a turn measured at the radius) is not this bias */
    double voxel = fmax(fine->voxel_size[0], fmax(fine->voxel_size[1], fine->voxel_size[2]));
    if (env && strcmp(env, "half") == 0)
        voxel *= 0.5;
    const int early = !(env && strcmp(env, "any") == 0);
    if (st == PB_OK && contrast_weights(&cv, ref, early) && (st = minimise(&cv, p, e0)) == PB_OK &&
        sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) <= voxel &&
        sqrt(p[3] * p[3] + p[4] * p[4] + p[5] * p[5]) <= voxel) {
        for (size_t k = 0; k < count; k++) {
            corrected(&cv, cv.weight[k], p, &poses[k].pose, &poses[k].pose);
            if (poses[k].moving) {
                corrected(&cv, cv.weight[k], p, &poses[k].start, &poses[k].start);
                corrected(&cv, cv.weight[k], p, &poses[k].end, &poses[k].end);
            }
        }
        for (int i = 0; i < NG; i++)
            *moved_mm += p[i] * p[i];
        *moved_mm = sqrt(*moved_mm);
    }
    free(cv.frames);
    free(cv.moved);
    free(cv.use);
    free(cv.weight);
    free(cv.gram);
    free(cv.a);
    free(cv.w);
    free(cv.v);
    free(scale);
    free(x);
    free(y);
    return st;
}
