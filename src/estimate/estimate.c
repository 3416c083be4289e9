/* pb_motion_estimate: the patient's motion from the frames themselves.
 *
 * Four passes, the first three registering each frame coarse to fine
 * (register.c):
 *  1. every frame against its neighbour towards the reference frame, whose
 *     contrast is nearly its own, the poses chained;
 *  2. twice, every frame against its own reference (references.c): the
 *     frame's projection onto the principal images of its nearest frames moved
 *     back onto the reference, which has the frame's contrast (uptake changes
 *     from frame to frame) and the noise of its window's counts; then the
 *     frames before a late frame linked to it by mutual information
 *     (mutual_information.c), which the contrast does not bias;
 *  3. inside frames (intra_frame.c): a frame between two neighbours is fitted as
 *     a dwell along a path that starts or ends at a still neighbour's pose
 *     (between the two, from one on through its own pose, or out from one
 *     and back to the other); where that explains it clearly better than one
 *     pose, the frame gets the path;
 *  4. together (contrast_poses.c): one rigid correction for every pose, scaled
 *     by each frame's contrast against the reference frame's, which takes
 *     out the bias that uptake changing leaves the frames of passes 2 and 3.
 * Poses live in the grid frame about the grid's centre until the track is
 * written, in the world of the affine. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "objects.h"
#include "error.h"
#include "estimate.h"
#include "numbers.h"
#include "motion.h"

/* The points of a path a frame may dwell at, and how much better than one
 * pose (relative residual) a dwell must explain a frame to be believed:
 * docs/estimate-log.md, "How, in full" (pass 3), gives the measurement. */
enum { DWELL_POINTS = 9 };
/* PATH_BACK's points: each leg's, the far end shared. */
enum { BACK_LEG = 7, BACK_POINTS = 2 * BACK_LEG - 1 };
_Static_assert((int)DWELL_POINTS <= (int)PBE_DWELL_MOST && (int)BACK_POINTS <= (int)PBE_DWELL_MOST,
               "a dwell of more poses than it has sums for");
#define DWELL_GAIN 0.05
/* A path into a neighbour that shows no motion of its own, where the path
 * between fails, must gain three times that: on issue 47's draws such paths
 * that gained 0.07-0.08 laid a jump inside slow nods (0.73 -> 0.82 mm and
 * 2.30 -> 2.41 mm), those that gained 0.20-0.83 were jerks (docs/estimate-log.md). */
#define UNSUPPORTED_GAIN (3 * DWELL_GAIN)
/* How near each other a frame's neighbours must lie, against its own pose's
 * distance from them, for PATH_BACK to call its motion a return on the
 * fixed bar; further apart, it asks more in proportion (back_path). */
#define BACK_RETURN 0.5
/* A path into a neighbour stops short of it where its far end holds less
 * than this share of the frame's dwell (stops_short). */
#define SHORT_SHARE 0.05
/* The bar a series sets itself (series_gain). */
#define SERIES_GAIN_TIMES 8.0
#define SERIES_GAIN_FLOOR 0.01
enum { SERIES_GAIN_FRAMES = 8 };
/* How far apart, in standard deviations of the frames' noise, a ramp's
 * images and one pose's must be for the frames to tell them apart
 * (boundary_steps): at 6 the evidence's noise is a sixth of the gap between
 * a step and a ramp. At 4 three of 44 draws of issue 47's family got steps
 * inside slow nods, where the frames' evidence stood at 17-22 (a ramp
 * between frame poses is not a nod's curve, so neither model fits there),
 * while their jumps at boundaries stood at 100-1100 (docs/estimate-log.md). */
#define SEPARATION 6.0
/* The share of what a one-way path leaves that PATH_BACK on neighbours a
 * voxel apart or more must explain beside it (inside_frames), as PATH_TWO
 * must in place of a path (TWO_BEYOND_PATH): docs/estimate-log.md,
 * "PATH_BACK beside a one-way path". */
#define BACK_BEYOND_PATH 0.05
/* The Levenberg-Marquardt steps of a frame's two poses (PATH_TWO). */
enum { TWO_POSE_STEPS = 30 };
/* The share of a frame's time its two poses must hold (pbe_two_poses_held):
 * a jerk inside a long frame dwells there (issue 47's draw 142718924, a
 * jerk of 0.8 s in a frame of 58 s: 1.000), motion spread over the frame
 * does not (nods, one with a jerk of 1.1-1.4 s inside: 0.23-0.80), and two
 * poses in turn would misplace it. Clean two-pose frames of jerks of 5-8 mm
 * at 2-3 mm voxels stand at 0.82-0.99 (tests/test_two_poses.c): the bar
 * refuses about half of them (docs/estimate-log.md). */
#define TWO_HELD_SHARE 0.9
/* In place of a path, the share of what that path leaves unexplained that
 * PATH_TWO must explain: its twelve pose numbers fit some of the
 * reference's misfit and of the transit wherever they are. On 23 frames of
 * fresh family draws where it beat the path, of the eleven it left under
 * 0.95 of the path's residual ten were better (0.78-2.93 mm -> 0.46-1.04)
 * and one worse (2705319617, at 0.81: a double jerk of 1.4 s in a frame of
 * 8.9 s, its transit fitted as poses 1.3 mm off); of the twelve at
 * 0.968-0.997, eight were worse (0.21-2.32 mm -> 0.44-2.99) and four better
 * by 0.06-0.25 mm (docs/estimate-log.md, "A frame as two poses of its own"). */
#define TWO_BEYOND_PATH 0.05
/* The most of its dwell a line with fitted ends through a frame's two poses
 * may hold between them (line_dwell.c; its points 2 to DWELL_POINTS - 3)
 * for PATH_TWO to take them: a frame held at two poses in turn dwells at the
 * line's ends, one whose head ramped from one pose towards the other over
 * much of it dwells along the way, and two poses held in turn put the ramp
 * at a pose inside it. On 30 fresh series of a jerk of 12-16 degrees and
 * 10-14 mm over 5-7 s of a 10 s frame (test_a_jerk_that_ends_at_a_boundary_
 * steps_there's kind), two poses replaced the path on 8, each worse (the
 * jerk's frame 0.37-1.09 -> 1.05-1.49 mm); six of their lines held
 * 0.29-0.42 between the ends, two 0.00 and 0.15 (those still take two
 * poses). The six family frames traced where two poses won or were taken
 * held 0.00-0.02 (docs/estimate-log.md, "A line with fitted ends"). */
#define TWO_LINE_BETWEEN 0.2
/* The shortest time a path's step takes, as a fraction of its frame. */
#define STEP_FRACTION 0.01
/* A background at least this share of a frame's peak is warned about (it is
 * subtracted whatever its level). */
#define BACKGROUND_WARNED 0.05
/* The share of a frame's variance its registration must explain for the
 * frame to show structure: frames of noise alone gave at most 0.24 (8^3
 * voxels, where a rigid fit of a smoothed frame has the most room) and 0.07
 * from 16^3 up; the test series (heads at 2e4 to 1e6 counts a frame, blobs
 * under noise a third of their peak) at least 0.64. */
#define STRUCTURE_EXPLAINED 0.4
/* The least share of the most counts of a frame held still that the
 * automatic reference is taken from (best_anchor): a quarter, noise twice
 * the best frame's. */
#define ANCHOR_COUNTS 0.25

typedef struct estimate {
    pb_context *ctx;
    pb_geometry g;
    size_t count, levels;
    unsigned iterations;
    double fwhm, c[3];
    const float *raw;       /* the frames as given, or less their background (owned) */
    float *owned;
    int *flat;              /* per frame: shows no structure above its noise */
    double *noise;          /* per frame: its noise's variance, measured on the frame as given (pbe_frame_noise) */
    pb_warnings *warnings;
    float *frames[8];       /* per level: every frame, smoothed */
    unsigned char *known;   /* per frame, level 0: where its move back onto the reference reads inside its grid (/255) */
    pbe_level level[8];
    float *scratch, *tmp;   /* two volumes of level 0 (the levels' supports); one line */
    pb_pool *pool;         /* threads: pass 4's frames; each level's loops where it is large enough (pbe_level's) */
    pb_progress_fn progress;
    void *progress_user;
    double done, total;
    double together;        /* pass 4's share of total, reported as it evaluates */
} estimate;

static void report_progress(estimate *e, double units)
{
    e->done += units;
    if (e->progress)
        e->progress(fmin(1.0, e->done / e->total), e->progress_user);
}

static size_t voxels(const pb_geometry *g)
{
    return g->dims[0] * g->dims[1] * g->dims[2];
}

/* Smoothed copies of src (level 0) on every level. */
static void pyramid(estimate *e, const float *src, float *const *out)
{
    memcpy(out[0], src, sizeof(float) * voxels(&e->level[0].g));
    for (size_t l = 1; l < e->levels; l++)
        pbe_downsample(&e->level[l - 1].g, out[l - 1], &e->level[l].g, out[l]);
    for (size_t l = 0; l < e->levels; l++) {
        double fwhm = e->fwhm > 0 ? e->fwhm : 2.0 * fmax(e->level[l].g.voxel_size[0],
                                                           fmax(e->level[l].g.voxel_size[1],
                                                                e->level[l].g.voxel_size[2]));
        pbe_smooth(e->level[l].pool, &e->level[l].g, out[l], fwhm, e->tmp);
    }
}

/* The reference on every level from its pyramid (pyramid's levels). */
static pb_status set_reference_levels(estimate *e, const float *const *levels)
{
    pb_status st = PB_OK;
    for (size_t l = 0; l < e->levels && st == PB_OK; l++)
        st = pbe_level_set_reference(&e->level[l], levels[l]);
    return st;
}

static pb_status set_reference(estimate *e, const float *reference)
{
    float *ref[8];
    pb_status st = PB_OK;
    for (size_t l = 0; l < e->levels; l++)
        if (!(ref[l] = malloc(sizeof(float) * e->level[l].n)))
            st = PB_ERR_OUT_OF_MEMORY;
    if (st == PB_OK) {
        pyramid(e, reference, ref);
        st = set_reference_levels(e, (const float *const *)ref);
    }
    for (size_t l = 0; l < e->levels; l++)
        free(ref[l]);
    return st;
}

static pb_status register_frame(estimate *e, size_t k, pbe_fit *fit)
{
    for (size_t l = e->levels; l-- > 0;) {
        const float *f = e->frames[l] + k * e->level[l].n;
        pb_status st = pbe_register(e->ctx, &e->level[l], f, e->c, e->iterations, fit);
        if (st != PB_OK)
            return st;
    }
    report_progress(e, 1.0);
    return PB_OK;
}

/* Whether frame k shows structure above its noise: its registration,
 * leaving sse on level 0, explains STRUCTURE_EXPLAINED of its variance. */
static int shows_structure(const estimate *e, size_t k, double sse)
{
    const size_t n = e->level[0].n;
    return pbe_explained(e->frames[0] + k * n, n, sse) >= STRUCTURE_EXPLAINED;
}

/* Pass 1: each frame against its neighbour towards the reference frame,
 * whose contrast is nearly its own, and the poses chained: f_k = B(D) f_j
 * for the neighbour j makes T_k = D T_j. A frame of noise alone would pass
 * its noise's pose on down the chain: the frames beyond it register to the
 * last frame that showed structure, and it holds that frame's pose. */
static pb_status register_chain(estimate *e, size_t ref, pbe_fit *fits, int keep_fits)
{
    pb_status st = PB_OK;
    /* PETBLUR_ESTIMATE_CHAIN=star registers every frame to the reference
     * frame itself, from its neighbour's pose, for comparisons */
    const char *env = getenv("PETBLUR_ESTIMATE_CHAIN");
    const int star = env && strcmp(env, "star") == 0;
    size_t held = SIZE_MAX; /* the frame whose pyramid the levels hold (a fit leaves them as they were) */
    for (int side = 0; side < 2 && st == PB_OK; side++) {
        size_t j = ref;
        for (size_t k = side ? ref : ref + 1; (side ? k-- > 0 : k < e->count) && st == PB_OK; k += side ? 0 : 1) {
            pbe_fit step = fits[k];
            memset(&step.pose, 0, sizeof step.pose);
            step.pose.rotation[0] = 1.0;
            if (star)
                step.pose = fits[j].pose;
            /* frame j's pyramid, made once at the start, set where the
             * levels hold another's */
            const size_t against = star ? ref : j;
            if (against != held) {
                const float *levels[8];
                for (size_t l = 0; l < e->levels; l++)
                    levels[l] = e->frames[l] + against * e->level[l].n;
                st = set_reference_levels(e, levels);
                held = against;
            }
            if (st == PB_OK)
                st = register_frame(e, k, &step);
            if (st != PB_OK)
                break;
            e->flat[k] = !shows_structure(e, k, step.sse);
            if (e->flat[k]) {
                fits[k].pose = fits[j].pose;
                continue;
            }
            /* without pass 2 the smoothing weighs each pose by this fit
             * (a chained pose by its last link's alone) */
            if (keep_fits)
                fits[k] = step;
            if (star)
                fits[k].pose = step.pose;
            else
                pb_pose_compose(&step.pose, &fits[j].pose, &fits[k].pose);
            pb_pose_normalized(&fits[k].pose, &fits[k].pose);
            j = k;
        }
    }
    return st;
}

/* One chunk of a frame's support moved back, as a share of 255. */
typedef struct known_job {
    const float *moved;
    unsigned char *known;
    size_t n;
} known_job;

static void known_chunk(void *arg, size_t c)
{
    const known_job *j = arg;
    const size_t begin = c * PB_CHUNK, end = begin + PB_CHUNK < j->n ? begin + PB_CHUNK : j->n;
    for (size_t i = begin; i < end; i++)
        j->known[i] = (unsigned char)lrint(255.0 * fmin(1.0, fmax(0.0, (double)j->moved[i])));
}

/* The raw frames moved back onto the reference: B(T_k^-1) f_k, level 0;
 * and where each is known (e->known: the grid's box moved back alike). */
static pb_status move_back(estimate *e, const pbe_fit *fits, float *moved)
{
    const size_t n = e->level[0].n;
    pbe_level *lv = &e->level[0];
    if (!e->known && !(e->known = malloc(n * e->count)))
        return PB_ERR_OUT_OF_MEMORY;
    pb_status box = pbe_level_set_support(lv, NULL);
    if (box != PB_OK)
        return box;
    for (size_t k = 0; k < e->count; k++) {
        pb_pose inverse, poses[2];
        double times[2];
        pb_motion m;
        pb_pose_invert(&fits[k].pose, &inverse);
        pbe_static_motion(&inverse, e->c, times, poses, &m);
        pb_status st = pb_volume_upload(lv->in[0], e->raw + k * n);
        if (st == PB_OK)
            st = pb_blur(e->ctx, lv->in[0], &m, NULL, lv->out[0]);
        if (st == PB_OK)
            st = pb_volume_download(lv->out[0], moved + k * n);
        if (st == PB_OK)
            st = pb_blur(e->ctx, lv->in[PBE_SUPPORT], &m, NULL, lv->out[PBE_SUPPORT]);
        if (st == PB_OK)
            st = pb_volume_download(lv->out[PBE_SUPPORT], lv->host[PBE_SUPPORT]);
        if (st != PB_OK)
            return st;
        known_job job = {lv->host[PBE_SUPPORT], e->known + k * n, n};
        pb_pool_for(lv->pool, pb_chunks(n), known_chunk, &job);
    }
    return PB_OK;
}

/* One chunk of a window's support: the least of its frames' known shares
 * (frames of noise alone left out), within the grid's box. */
typedef struct support_job {
    const unsigned char *known;
    const int *flat;
    const float *box;
    float *out;
    size_t n, first, end;
} support_job;

static void support_chunk(void *arg, size_t c)
{
    const support_job *j = arg;
    const size_t begin = c * PB_CHUNK, end = begin + PB_CHUNK < j->n ? begin + PB_CHUNK : j->n;
    unsigned char least[PB_CHUNK];
    memset(least, 255, end - begin);
    for (size_t f = j->first; f < j->end; f++) {
        if (j->flat[f])
            continue;
        const unsigned char *known = j->known + f * j->n + begin;
        for (size_t i = 0; i < end - begin; i++)
            least[i] = known[i] < least[i] ? known[i] : least[i];
    }
    for (size_t i = begin; i < end; i++)
        j->out[i] = fminf((float)least[i - begin] / 255.0f, j->box[i]);
}

/* Where frame k's reference is known: where every frame of its window
 * that shows structure was, moved back (the reference is a sum of them),
 * and never beyond the grid's own box, on every level. The levels' supports
 * lie one after another in e->scratch (at most twice level 0 in all). */
static pb_status set_frame_support(estimate *e, size_t k)
{
    const size_t n = e->level[0].n;
    size_t first, end;
    pbe_reference_window(e->count, k, &first, &end);
    float *s[8];
    s[0] = e->scratch;
    for (size_t l = 1; l < e->levels; l++)
        s[l] = s[l - 1] + e->level[l - 1].n;
    support_job job = {e->known, e->flat, e->level[0].box, s[0], n, first, end};
    pb_pool_for(e->level[0].pool, pb_chunks(n), support_chunk, &job);
    for (size_t l = 1; l < e->levels; l++)
        pbe_downsample(&e->level[l - 1].g, s[l - 1], &e->level[l].g, s[l]);
    pb_status st = PB_OK;
    for (size_t l = 0; l < e->levels && st == PB_OK; l++)
        st = pbe_level_set_support(&e->level[l], s[l]);
    return st;
}

/* Frame k's own reference (references.c) on every level, with its support. */
static pb_status frame_reference(estimate *e, const float *moved, const double *gram, size_t k, float *reference)
{
    /* by default the frames weigh by their energy beyond the leading images:
     * references of the frames' own contrast, weighed by their noise, left the
     * family's draws as they were, better on some and worse on more, as pass 3
     * followed other frames (docs/estimate-log.md, "The own references'
     * weights") */
    pb_status st = pbe_frame_reference(e->level[0].pool, moved, e->level[0].n, e->count, gram,
                                       pbe_references_by_noise() ? e->noise : NULL, k, reference);
    if (st == PB_OK)
        st = set_reference(e, reference);
    return st == PB_OK ? set_frame_support(e, k) : st;
}

/* The frames moved back onto the reference by their poses, those of noise
 * alone zeroed (they add only noise to the others' references, and at a
 * higher level than theirs would be their leading image), each frame's noise
 * where the references weigh by it, and the band of their inner products the
 * references are built from. The noise is measured on the frame as given: trilinear resampling takes noise
 * off by the pose, and weighed by what is left, the frames moved furthest
 * weighed most, a frame that moved inside it (registered between its poses)
 * among them (test_motion_held_across_a_frame_boundary failed so). */
static pb_status frames_moved_back(estimate *e, const pbe_fit *fits, float *moved, double *gram)
{
    pb_status st = move_back(e, fits, moved);
    if (st != PB_OK)
        return st;
    for (size_t k = 0; k < e->count; k++)
        if (e->flat[k])
            memset(moved + k * e->level[0].n, 0, sizeof(float) * e->level[0].n);
    for (size_t k = 0; k < e->count && pbe_references_by_noise(); k++) {
        if (e->flat[k]) {
            e->noise[k] = 0.0; /* zeroed above */
        } else if (e->noise[k] == 0.0) { /* measured once: the frames as given stay */
            double s = pbe_frame_noise(e->raw + k * e->level[0].n, e->level[0].g.dims);
            if (s < 0.0)
                return PB_ERR_OUT_OF_MEMORY;
            e->noise[k] = s * s;
        }
    }
    pbe_gram_band(e->level[0].pool, moved, e->level[0].n, e->count, gram);
    return PB_OK;
}

/* Passes 2 and on: every frame against its own reference, from its pose. */
static pb_status register_own(estimate *e, pbe_fit *fits, float *moved, double *gram, float *reference)
{
    pb_status st = frames_moved_back(e, fits, moved, gram);
    for (size_t k = 0; k < e->count && st == PB_OK; k++) {
        st = frame_reference(e, moved, gram, k, reference);
        if (st == PB_OK)
            st = register_frame(e, k, &fits[k]);
    }
    return st;
}

/* Pass 3: which frames dwell along a path, and which path. A path starts
 * or ends at a still neighbour's pose: between the two neighbours (the
 * motion began and ended inside the frame), or from one neighbour on
 * through the frame's own pose as far again (the motion went on into the
 * other neighbour, which then moves too: a nod held across a frame's end;
 * or, in the series' first or last frame, which has one neighbour, the
 * motion that the frame holds after or before it). A frame whose own pose
 * lies off the line between its still neighbours' went out and came back
 * inside it (a nod, or two jerks): PATH_BACK, from the frame before's pose
 * out and on to the frame after's (back_path). */
/* PATH_TWO: two poses of the frame's own, held in turn (two_pose_frames),
 * fitted after the others are chosen. */
enum { PATH_BETWEEN, PATH_ON, PATH_FROM, PATH_BACK, PATH_TWO, PATHS };

typedef struct frame_path {
    double gain;       /* 1 - its residual / one pose's; 0: not tried, or refused */
    double fitted;     /* the gain as fitted, before any refusal */
    int replaced;      /* PATH_TWO: 1 + the kind of the path it replaced, 0 for none */
    pb_pose start, end;
    double dwell[PBE_DWELL_MOST + 1]; /* DWELL_POINTS, PATH_BACK's BACK_POINTS, and the offset */
} frame_path;

/* Whether frame k of count has the neighbours a path of a kind starts or
 * ends at: the first frame only a path from its successor, the last only
 * one on from its predecessor. */
static int path_defined(size_t k, size_t count, int kind)
{
    return (kind == PATH_FROM || k > 0) && (kind == PATH_ON || k + 1 < count);
}

/* Whether a path of a kind starts at the frame before's pose, ends at the
 * frame after's (so that frame may not move itself). */
static int starts_at_before(int kind)
{
    return kind != PATH_FROM;
}

static int ends_at_after(int kind)
{
    return kind == PATH_BETWEEN || kind == PATH_FROM || kind == PATH_BACK;
}

/* The path of a kind for frame k (path_defined), from its neighbours' and
 * its own poses. */
static void path_ends(const pbe_fit *fits, size_t k, int kind, pb_pose *start, pb_pose *end)
{
    const pb_pose *own = &fits[k].pose;
    if (kind == PATH_ON)
        pb_pose_interpolate(&fits[k - 1].pose, own, 2.0, end);
    else
        *end = fits[k + 1].pose;
    if (kind == PATH_FROM)
        pb_pose_interpolate(&fits[k + 1].pose, own, 2.0, start);
    else
        *start = fits[k - 1].pose;
    pb_pose_normalized(start, start);
    pb_pose_normalized(end, end);
}

/* How far a point (the grid's far corner) moves along a path, mm. */
static double path_span(const estimate *e, const double far[3], const pb_pose *a, const pb_pose *b)
{
    double pa[3], pb[3], d = 0.0;
    pb_pose_apply(a, e->c, far, pa);
    pb_pose_apply(b, e->c, far, pb);
    for (int i = 0; i < 3; i++)
        d += (pa[i] - pb[i]) * (pa[i] - pb[i]);
    return sqrt(d);
}

/* How far frame k's neighbours' poses lie apart (apart) and how far its own
 * lies from the nearer of them (out), at the far corner, mm: whether the
 * head came back inside the frame (back_path, jumped_beside). */
static void neighbours_apart(const estimate *e, const pbe_fit *fits, size_t k, const double far[3], double *apart,
                             double *out)
{
    *apart = path_span(e, far, &fits[k - 1].pose, &fits[k + 1].pose);
    *out = fmin(path_span(e, far, &fits[k].pose, &fits[k - 1].pose),
                path_span(e, far, &fits[k].pose, &fits[k + 1].pose));
}

/* Whether two poses are far enough apart for a frame to tell a motion
 * between them from one pose: a tenth of a voxel at the far corner. */
static int poses_apart(const estimate *e, const double far[3], const pb_pose *a, const pb_pose *b)
{
    return path_span(e, far, a, b) > 0.1 * e->g.voxel_size[0];
}

/* Whether the motion went on into neighbour n = k + dir: its pose lies on
 * the far side of frame k's own from the other neighbour's, at least half
 * as far again (the grid's corners moved, summed). What a path into a
 * neighbour claims, shown by the poses where the neighbour moves too slowly
 * for its own paths to gain (the end of a slow nod). */
static int motion_went_on(const estimate *e, const pbe_fit *fits, size_t k, int dir)
{
    const pb_pose *own = &fits[k].pose, *into = &fits[dir > 0 ? k + 1 : k - 1].pose,
                  *from = &fits[dir > 0 ? k - 1 : k + 1].pose;
    double along = 0.0, length = 0.0;
    for (int corner = 0; corner < 8; corner++) {
        double p[3], a[3], b[3], c[3];
        pbe_grid_corner(&e->g, corner, p);
        pb_pose_apply(from, e->c, p, a);
        pb_pose_apply(own, e->c, p, b);
        pb_pose_apply(into, e->c, p, c);
        for (int i = 0; i < 3; i++) {
            along += (c[i] - b[i]) * (b[i] - a[i]);
            length += (b[i] - a[i]) * (b[i] - a[i]);
        }
    }
    return along > 0.5 * length;
}

/* Whether frame k may follow a path of a kind: the neighbours it starts or
 * ends at stay still, and no moving frame's path starts or ends at k.
 * moving[k] is 1 + the kind a frame follows, 0 for a still one. */
static int path_free(const int *moving, const int *anchor, size_t k, size_t count, int kind)
{
    return path_defined(k, count, kind) && !moving[k] && !anchor[k] && (!starts_at_before(kind) || !moving[k - 1]) &&
           (!ends_at_after(kind) || !moving[k + 1]);
}

/* The gain a path must show in this series to be taken (a neighbour shows
 * motion of its own at DWELL_GAIN still). What a mixture of views gains
 * on a still frame is what it fits of interpolation, uptake and noise, and
 * that depends on the series (counts, grid, contrast): on issue 47's draws
 * the still frames' best gains stood at 0.0004-0.005 where a jerk a third
 * into its frame gained 0.037-0.051, under DWELL_GAIN. So the bar is
 * SERIES_GAIN_TIMES the upper quartile of the frames' best gains (most
 * frames of a series are still), within SERIES_GAIN_FLOOR and DWELL_GAIN;
 * a series of fewer than SERIES_GAIN_FRAMES frames with paths tried keeps
 * DWELL_GAIN, as does PETBLUR_ESTIMATE_DWELL=fixed (for comparisons).
 * docs/estimate-log.md gives the measurement. */
static double series_gain(const frame_path *paths, const unsigned char *tried, size_t count)
{
    const char *env = getenv("PETBLUR_ESTIMATE_DWELL");
    if (env && strcmp(env, "fixed") == 0)
        return DWELL_GAIN;
    double *g = malloc(count * sizeof *g), bar = DWELL_GAIN;
    size_t n = 0;
    if (!g)
        return DWELL_GAIN;
    for (size_t k = 0; k < count; k++) {
        if (!tried[k])
            continue;
        double best = -HUGE_VAL;
        for (int kind = 0; kind < PATHS; kind++)
            if (paths[k * PATHS + (size_t)kind].gain != 0.0)
                best = fmax(best, paths[k * PATHS + (size_t)kind].gain);
        g[n++] = best > -HUGE_VAL ? fabs(best) : 0.0;
    }
    if (n >= SERIES_GAIN_FRAMES) {
        qsort(g, n, sizeof *g, pb_compare_doubles);
        bar = fmin(DWELL_GAIN, fmax(SERIES_GAIN_FLOOR, SERIES_GAIN_TIMES * g[3 * (n - 1) / 4]));
    }
    free(g);
    return bar;
}

/* Whether frame k has evidence to give on a side (0 its start, 1 its end):
 * a neighbour there with structure, at a pose apart from its own, and not
 * beyond the grid's reach from it (pbe_within_extent: a ramp to it is
 * blurred). */
static int side_defined(const estimate *e, const pbe_fit *fits, size_t k, int side, const double far[3])
{
    if (!(side ? k + 1 < e->count : k > 0))
        return 0;
    const size_t n = side ? k + 1 : k - 1;
    return !e->flat[n] && poses_apart(e, far, &fits[k].pose, &fits[n].pose) &&
           pbe_within_extent(&e->g, e->c, &fits[k].pose, &fits[n].pose);
}

/* Between two still frames the track is linear from one's middle to the
 * other's: each frame's half beside their boundary holds a ramp along the
 * line between their poses. A head that jumped at the boundary (a jerk
 * across it) holds each pose to the boundary instead, and each frame then
 * shows its pose alone. What frame k shows on a side: its reference blurred
 * along a ramp of that half's length toward the neighbour's pose, laid so
 * that its mean is the frame's own pose (where its registration puts a
 * ramp), against one pose, in units of the frame's noise (its residual's
 * variance a voxel times the volume it is correlated over): the two models'
 * images apart by g, the ramp's residual above one pose's by h. A frame that
 * holds its pose to the boundary shows h about g, one that ramps about -g,
 * give or take 2 sqrt(g) of noise. ev[4 * k + 2 * side] = g, + 1 = h (side 0
 * the start, 1 the end); 0 where there is no neighbour or the poses are
 * within a tenth of a voxel at the far corner (nothing to tell). */
static pb_status side_evidence(estimate *e, const pbe_fit *fits, size_t k, const double far[3], double ev[4])
{
    const pb_pose *own = &fits[k].pose;
    pbe_level *level = &e->level[0];
    const float *frame = e->frames[0] + k * level->n;
    double times[2], ramp_times[3] = {0.0, 0.5, 1.0}, scale, offset, one_sse = 0.0, noise = 0.0;
    pb_pose poses[2], ramp_poses[3];
    pb_motion m, ramp;
    float *one = NULL;
    pb_status st = PB_OK;
    memset(ev, 0, 4 * sizeof *ev);
    pbe_static_motion(own, e->c, times, poses, &m);
    ramp = m;
    ramp.times = ramp_times;
    ramp.poses = ramp_poses;
    ramp.count = 3;
    for (int side = 0; side < 2 && st == PB_OK; side++) {
        if (!side_defined(e, fits, k, side, far))
            continue;
        const pb_pose *other = &fits[side ? k + 1 : k - 1].pose;
        if (!one) {
            if (!(one = malloc(sizeof(float) * level->n)))
                return PB_ERR_OUT_OF_MEMORY;
            if ((st = pbe_blur_reference(e->ctx, level, &m)) != PB_OK)
                break;
            pbe_fit_scale(level->pool, level->host[0], frame, level->n, &scale, &offset, &one_sse);
            for (size_t v = 0; v < level->n; v++)
                one[v] = (float)(scale * (double)level->host[0][v] + offset);
            noise = pbe_correlation_volume(&level->g, frame, one) * one_sse / (double)level->n;
        }
        /* a ramp over the half to the poses' midpoint, its mean at the own pose */
        pb_pose back, on;
        pb_pose_interpolate(own, other, -0.125, &back);
        pb_pose_interpolate(own, other, 0.375, &on);
        pb_pose_normalized(&back, &back);
        pb_pose_normalized(&on, &on);
        ramp_poses[0] = side ? back : on;
        ramp_poses[1] = back;
        ramp_poses[2] = side ? on : back;
        if ((st = pbe_blur_reference(e->ctx, level, &ramp)) != PB_OK)
            break;
        double ramp_sse, a, b, dist;
        pbe_fit_scale(level->pool, level->host[0], frame, level->n, &scale, &offset, &ramp_sse);
        pbe_fit_scale(level->pool, level->host[0], one, level->n, &a, &b, &dist);
        if (noise > 0) {
            ev[2 * side] = dist / noise;
            ev[2 * side + 1] = (ramp_sse - one_sse) / noise;
        }
    }
    free(one);
    return st;
}

/* Frame k's weights for its paths (level 0's host[PBE_SUPPORT]: its
 * reference's support blurred at its own pose, as pbe_register's) and one
 * pose's weighted residual under them, which a path's must beat. */
static pb_status one_pose_weighted(estimate *e, const pb_pose *own, const float *frame, double *sse)
{
    pbe_level *level = &e->level[0];
    double times[2];
    pb_pose poses[2];
    pb_motion m;
    pbe_static_motion(own, e->c, times, poses, &m);
    float *view = pbe_level_views(level, 1);
    pb_status st = view ? pbe_view(e->ctx, level, own, e->c, view) : PB_ERR_OUT_OF_MEMORY;
    if (st == PB_OK)
        st = pbe_blur_support(e->ctx, level, &m);
    if (st == PB_OK)
        *sse = pbe_weighted_sse(level->pool, view, frame, level->host[PBE_SUPPORT], level->n);
    return st;
}

/* PATH_BACK's poses: from the frame before's pose s out to the far end f
 * and on to the frame after's r, BACK_LEG points a leg, f shared. */
static void back_poses(const pb_pose *s, const pb_pose *f, const pb_pose *r, pb_pose p[BACK_POINTS])
{
    for (int i = 0; i < BACK_LEG; i++) {
        double t = (double)i / (BACK_LEG - 1);
        pb_pose_interpolate(s, f, t, &p[i]);
        pb_pose_interpolate(r, f, t, &p[BACK_POINTS - 1 - i]);
    }
}

/* PATH_BACK for a frame between still neighbours whose poses show that its
 * motion went on into neither (motion_went_on, both ways: its own pose lies
 * off the line between theirs, where for a pose on it one of the two holds)
 * while a path on from one of them through its own pose gains DWELL_GAIN:
 * the motion went out and came back inside the frame, all the way or part of
 * it (a nod, or two jerks), and the path on, taken as it is, would carry it
 * into the neighbour. The poses are its support, as a moving neighbour is a
 * path into it's; the bar is the fixed one, as for such paths (a series'
 * own bar can be 1 %, which a frame held still reaches with a mixture of
 * views; a short nod out and back gained 6.8 %,
 * test_a_nod_that_turns_back_inside_a_frame's seed 1213781347). The frame
 * is fitted as a dwell along two legs: from the frame before's pose out to
 * that path's far end, and from there to the frame after's, in that order,
 * so that a head that went out at the frame's start and came part of the
 * way back near its end (issue 47's 668173037) dwells where it did. Where
 * the legs' points pair up (each within a voxel of its twin at the far
 * corner: their views nearly alike, their dwells split between them by the
 * noise; the neighbours holding one pose, give or take their fits' noise)
 * a time average cannot tell the way out from the way back: each pair's
 * dwell is split evenly, a nod centred in the frame, the guess that errs
 * least over where it came (with twins within a tenth of a voxel, the nods
 * of that test stood at 0.7-1.05 of one pose's error where an even split
 * put them at 0.16-0.63).
 * A frame held still at a pose of its own off the line between its
 * neighbours' (each frame at a pose of its own) gains on a dwell straddling
 * its pose: test_jerk_in_the_series_first_or_last_frame's seed 654568544,
 * neighbours 5.3 mm apart on 4 mm voxels, 6.5 %, and seed 2013452446,
 * neighbours 2.7 mm apart and the frame 2.9 mm from the nearer, 17.6 %, each
 * 1.9 mm off where one pose stood 0.06-0.22. So where the neighbours lie
 * within a voxel of each other (at the far corner) and within BACK_RETURN
 * of the frame's distance from the nearer, the head came back on the fixed
 * bar; further apart against that distance, the neighbours' own noise
 * competes with the frame's excursion and the path must gain
 * UNSUPPORTED_GAIN at BACK_RETURN and more in proportion (0.28 for
 * 2013452446's 0.93). The nods of test_a_nod_that_turns_back_inside_a_frame
 * lay at 0.005-0.31 on 38 of 40 fresh seeds, gaining 0.26-0.96; a short
 * nod's did not: seeds 2696831048 (0.63, the path gaining 72 %) and
 * 2642348095 (1.04, 72 %), still neighbours 1.25 and 1.49 mm apart against
 * a frame 1.98 and 1.43 mm out, each held at one pose 2.4-2.5 mm off under
 * a refusal at BACK_RETURN. Where the neighbours lie a voxel apart or more
 * the head came part of the way back, and the path must gain
 * UNSUPPORTED_GAIN, as a path into a neighbour that shows no motion does
 * (issue 47's 668173037 and 2014871130, neighbours 10.2 and 15.9 mm apart,
 * gained 19.5 % and 77 %).
 * PETBLUR_ESTIMATE_BACK=0 turns it off, =even lets it stand beside a one-way
 * path on its gain alone (back_yields), for comparisons. Fitted for frame k
 * against its reference as its other paths were (one: one pose's weighted
 * residual there); whether its neighbours hold still is known only once
 * every frame's paths are (inside_frames). */
static pb_status back_path(estimate *e, const pbe_fit *fits, size_t k, double one, const double far[3],
                           frame_path *paths)
{
    const char *env = getenv("PETBLUR_ESTIMATE_BACK");
    const frame_path *on = &paths[k * PATHS + PATH_ON], *from = &paths[k * PATHS + PATH_FROM];
    frame_path *back = &paths[k * PATHS + PATH_BACK];
    if ((env && strcmp(env, "0") == 0) || !path_defined(k, e->count, PATH_BACK) || !(one > 0) ||
        fmax(on->gain, from->gain) <= DWELL_GAIN || motion_went_on(e, fits, k, +1) || motion_went_on(e, fits, k, -1))
        return PB_OK;
    double apart, out;
    neighbours_apart(e, fits, k, far, &apart, &out);
    pb_pose p[BACK_POINTS];
    back->start = fits[k - 1].pose;
    back->end = on->gain >= from->gain ? on->end : from->start;
    back_poses(&back->start, &back->end, &fits[k + 1].pose, p);
    double sse = 0.0;
    pb_status st = pbe_dwell_at(e->ctx, &e->level[0], e->frames[0] + k * e->level[0].n, e->c, p, BACK_POINTS,
                                back->dwell, &sse, NULL);
    if (st != PB_OK)
        return st;
    back->gain = back->fitted = 1.0 - sse / one;
    if (apart >= e->g.voxel_size[0] ? back->gain <= UNSUPPORTED_GAIN
                                    : apart > BACK_RETURN * out &&
                                          back->gain * BACK_RETURN * out <= UNSUPPORTED_GAIN * apart)
        back->gain = 0.0;
    for (int i = 0; i + 1 < BACK_LEG; i++) {
        double *a = &back->dwell[i], *b = &back->dwell[BACK_POINTS - 1 - i];
        if (path_span(e, far, &p[i], &p[BACK_POINTS - 1 - i]) < e->g.voxel_size[0])
            *a = *b = 0.5 * (*a + *b);
    }
    return PB_OK;
}

static void far_corner(const estimate *e, double far[3]);

/* A path's far end towards dir (+1 its last point, -1 its first: the point
 * beside that neighbour) into end[i]: that point and those within a voxel
 * of it at the far corner, where a frame cannot tell one from the other
 * (PATH_BACK's twins, held alike), and within a quarter of the path, so
 * that a short path's far end stays an end. Under PETBLUR_ESTIMATE_SHORT=end
 * the far end's point alone, for comparisons. */
static void far_end(const estimate *e, const frame_path *p, int dir, unsigned char end[DWELL_POINTS])
{
    const int last = dir > 0 ? DWELL_POINTS - 1 : 0;
    const char *env = getenv("PETBLUR_ESTIMATE_SHORT");
    const int alone = env && strcmp(env, "end") == 0;
    double far[3];
    pb_pose b;
    far_corner(e, far);
    pb_pose_interpolate(&p->start, &p->end, (double)last / (DWELL_POINTS - 1), &b);
    const double reach = fmin(e->g.voxel_size[0], 0.25 * path_span(e, far, &p->start, &p->end));
    for (int i = 0; i < DWELL_POINTS; i++) {
        pb_pose a;
        pb_pose_interpolate(&p->start, &p->end, (double)i / (DWELL_POINTS - 1), &a);
        end[i] = i == last || (!alone && path_span(e, far, &a, &b) < reach);
    }
}

/* Whether a path on into the frame after (dir +1, PATH_ON) or from the
 * frame before (-1, PATH_FROM) stops short of that neighbour: the frame
 * dwells at its far end (far_end, into end[]) for under SHORT_SHARE of its
 * time. Such a path does not claim that the motion went on into the
 * neighbour, and the poses need not show it (motion_went_on): it holds the
 * poses the head took inside the frame, and where the neighbour is still
 * its pose holds from the boundary, as the path between's does (path_keys;
 * the far end's remnant is dropped, a nod's spread or the noise: issue 47's
 * draw 2167208435, a jerk inside a nod, dwelt there 3.5 % of its frame). A
 * jerk inside a frame during a slow nod (issue 47's draw 3171377247, frame
 * 6 of 84-114 s, a jerk of 8 degrees at 92.4 s): the path between the
 * neighbours' poses misses the nod's turn (-24 %), the path on from the
 * frame before gains 26 %, dwelling at that frame's pose for 0.27 of the
 * frame and at 0.62-0.75 of the way for the rest; the frame after's pose
 * lies short of where it would were the motion going on, and held to one
 * pose the frame stood 3.71 mm off. The far end is its points within a
 * voxel, not its last point alone: on a nod out and back inside a frame,
 * the path from the frame before (its far end the frame's own pose taken as
 * far again from the frame after's) dwelt 0.04 at that end and 0.50 at the
 * next point, 3.1 mm on along 24.5 mm on 4 mm voxels
 * (test_a_nod_that_turns_back_inside_a_frame's seed 2063815128), and, taken
 * as stopping short, laid the nod as a ramp 4.08 mm off where one pose
 * stands at 3.31 and its path out and back at 0.83.
 * PETBLUR_ESTIMATE_SHORT=0 asks every path into a still neighbour for the
 * motion going on, for comparisons. */
static int stops_short(const estimate *e, const frame_path *p, int dir, unsigned char end[DWELL_POINTS])
{
    const char *env = getenv("PETBLUR_ESTIMATE_SHORT");
    if (env && strcmp(env, "0") == 0)
        return 0;
    far_end(e, p, dir, end);
    double total = 0.0, there = 0.0;
    for (int i = 0; i < DWELL_POINTS; i++) {
        total += fmax(p->dwell[i], 0.0);
        there += end[i] ? fmax(p->dwell[i], 0.0) : 0.0;
    }
    return total > 0 && there < SHORT_SHARE * total;
}

/* Whether frame k moves by a path of its own, as a neighbour's support: one
 * of its paths gains over DWELL_GAIN. */
static int shows_motion(const frame_path *paths, size_t k)
{
    for (int kind = 0; kind < PATHS; kind++)
        if (paths[k * PATHS + (size_t)kind].gain > DWELL_GAIN)
            return 1;
    return 0;
}

/* Where the passes measure how far poses lie apart: a point half the grid's
 * longest extent from the centre along every axis. */
static void far_corner(const estimate *e, double far[3])
{
    double ext = 0.0;
    for (int i = 0; i < 3; i++)
        ext = fmax(ext, (double)e->g.dims[i] * e->g.voxel_size[i]);
    for (int i = 0; i < 3; i++)
        far[i] = e->c[i] + 0.5 * ext;
}

/* Whether frame k's PATH_BACK yields to a one-way path of its own
 * (PATH_ON, PATH_FROM) that still stands. Where the neighbours lie a voxel
 * apart or more, PATH_BACK says the head came part of the way back towards
 * the frame after's pose. Its two legs hold more points than a one-way
 * path, and their mixture of views fits some of what no path explains (a
 * drift off the line, the uptake), so beside such a path it must explain
 * BACK_BEYOND_PATH of what that path leaves.
 * test_a_jerk_inside_a_drift_is_followed's seed 3480099802: a jerk of 10.6
 * mm with a drift across it, PATH_ON gaining 0.569 and PATH_BACK 0.574,
 * which laid the jerk out past its end and back: the frame 2.674 mm off
 * where one pose stands at 2.659 and PATH_ON at 1.934. It does not yield
 * where a neighbour's path that ends (starts) at the frame's pose gains
 * more than the one-way path: taken first (the clearest first), that path
 * would hold the frame still, which PATH_BACK, the clearer of the two, had
 * not let it (the series' first and last frames, whose own paths are never
 * asked whether they hold still). */
static int back_yields(const estimate *e, const pbe_fit *fits, const frame_path *paths, size_t k, double bar,
                       const double far[3])
{
    const frame_path *back = &paths[k * PATHS + PATH_BACK];
    const double one_way = fmax(paths[k * PATHS + PATH_ON].gain, paths[k * PATHS + PATH_FROM].gain);
    for (int kind = 0; kind < PATHS; kind++)
        if ((ends_at_after(kind) && paths[(k - 1) * PATHS + (size_t)kind].gain > one_way) ||
            (starts_at_before(kind) && paths[(k + 1) * PATHS + (size_t)kind].gain > one_way))
            return 0;
    return back->gain > 0.0 && one_way > bar &&
           path_span(e, far, &fits[k - 1].pose, &fits[k + 1].pose) >= e->g.voxel_size[0] &&
           !(back->gain > one_way + BACK_BEYOND_PATH * (1.0 - one_way));
}

/* PETBLUR_ESTIMATE_JUMP_PATH=0 turns off the jump's support of a one-way
 * path (jumped_beside) and the step it puts in the track (path_neighbours),
 * for comparisons. */
static int jump_paths(void)
{
    const char *env = getenv("PETBLUR_ESTIMATE_JUMP_PATH");
    return !(env && strcmp(env, "0") == 0);
}

static int shows_step(const int *jumped, const double *sides, size_t b, const int lean[2]);

/* Whether the head jumped at the boundary before frame b, as the frames
 * beside it show (shows_step, as boundary_steps asks between still frames),
 * the still one (still: b - 1 or b) not leaning to the ramp. The other
 * frame moves inside, and its side's one pose fits it as badly either way
 * (h = -2.4 at g = 20 on test_a_move_after_a_jump_at_a_boundary_is_followed's
 * seed 774117969, beside the still frame's 877 at 374); the two frames'
 * evidence together still parts a jump called inside a slow nod, where the
 * frame holding the nod's turn ramps through the boundary (issue 47's draw
 * 3617464807: g = 58, h = -97 together, the frame after's side h = -223 at
 * g = 27). */
static int jumped_at(const int *jumped, const double *sides, size_t b, size_t still)
{
    const int lean[2] = {still < b, still == b};
    return jump_paths() && shows_step(jumped, sides, b, lean);
}

/* Whether frame k's one-way path (dir +1: PATH_ON, -1: PATH_FROM) stands on
 * a jump at its far end's boundary in place of the neighbour's motion. A
 * jump there (smooth_poses.c restarted its walk at the frame after the
 * boundary: a jerk across it) leaves the neighbour's pose at the boundary,
 * so the path starts (or ends) where the head jumped to and asks no motion
 * of that neighbour: issue 47's draw 1364193535, a 10.6 degree jerk across
 * a boundary inside a 5 degree nod, the frame after it returning along the
 * nod; its path from the jump gained 13 % with its dwell spread along it,
 * refused at UNSUPPORTED_GAIN, and the frame held one pose 2.69 mm off. So:
 * the frames show the jump (jumped_at), the path between does not explain
 * the frame, the path gains the fixed bar, and the neighbours' poses do
 * not show the head came back (back_path's measure: apart by more than
 * BACK_RETURN of the frame's distance from the nearer). A nod out and back
 * inside a frame between still neighbours shows a jump at a boundary too,
 * and a one-way path into it lays the dwell in the wrong order
 * (test_a_nod_that_turns_back_inside_a_frame's seed 2872828855 with
 * PATH_BACK off: 4.31 mm where one pose stands at 3.63; with it on, PATH_ON
 * gained within 0.0004 of PATH_BACK). */
static int jumped_beside(const estimate *e, const pbe_fit *fits, const double far[3], const int *jumped,
                         const double *sides, size_t k, int dir, int between, double gain)
{
    if (k == 0 || k + 1 >= e->count || between || !(gain > DWELL_GAIN) ||
        !(dir > 0 ? jumped_at(jumped, sides, k + 1, k + 1) : jumped_at(jumped, sides, k, k - 1)))
        return 0;
    double apart, out;
    neighbours_apart(e, fits, k, far, &apart, &out);
    return apart > BACK_RETURN * out;
}

static pb_status inside_frames(estimate *e, const pbe_fit *fits, size_t reference, const float *moved,
                               const double *gram, float *own, frame_path *paths, int *moving, size_t *moving_count,
                               double *sides, double *unfollowed, const int *jumped)
{
    int *anchor = calloc(e->count, sizeof(int)), *moves = calloc(e->count, sizeof(int));
    unsigned char *tried = calloc(e->count, 1);
    double *back_gain = calloc(e->count, sizeof(double));
    if (!anchor || !moves || !tried || !back_gain) {
        free(anchor);
        free(moves);
        free(tried);
        free(back_gain);
        return PB_ERR_OUT_OF_MEMORY;
    }
    pb_status st = PB_OK;
    double far[3];
    far_corner(e, far);
    for (size_t k = 0; k < e->count && st == PB_OK; k++) {
        int referenced = 0;
        double one = 0.0; /* one pose's weighted residual */
        /* the paths along one line; PATH_BACK after them (back_path) */
        for (int kind = 0; kind < PATH_BACK && st == PB_OK && k != reference && !e->flat[k]; kind++) {
            frame_path *p = &paths[k * PATHS + (size_t)kind];
            if (!path_defined(k, e->count, kind))
                continue;
            path_ends(fits, k, kind, &p->start, &p->end);
            if (!poses_apart(e, far, &p->start, &p->end))
                continue;
            if (!referenced) {
                st = frame_reference(e, moved, gram, k, own);
                if (st == PB_OK)
                    st = one_pose_weighted(e, &fits[k].pose, e->frames[0] + k * e->level[0].n, &one);
                referenced = 1;
            }
            double sse;
            if (st == PB_OK)
                st = pbe_dwell(e->ctx, &e->level[0], e->frames[0] + k * e->level[0].n, e->c, &p->start, &p->end,
                               DWELL_POINTS, p->dwell, &sse);
            if (st == PB_OK && one > 0)
                p->gain = p->fitted = 1.0 - sse / one;
            tried[k] = 1;
        }
        if (st == PB_OK && referenced)
            st = back_path(e, fits, k, one, far, paths);
        /* ramps or steps at its boundaries, against the same reference */
        if (st == PB_OK && !e->flat[k] && (side_defined(e, fits, k, 0, far) || side_defined(e, fits, k, 1, far))) {
            if (!referenced)
                st = frame_reference(e, moved, gram, k, own);
            if (st == PB_OK)
                st = side_evidence(e, fits, k, far, &sides[4 * k]);
        }
        report_progress(e, 1.0);
    }
    /* A path into a neighbour is for motion that neighbour holds too: where
     * it shows none and the path between the neighbours explains the frame
     * (a jerk between still frames), that is the model, and a longer path
     * would only spread the dwell over coarser points. Where the path between
     * does not (a neighbour moves, but too slowly for its own paths to gain:
     * a slow nod's end beside a jerk, whose path between then fit worse than
     * one pose), a path into a neighbour stands on its own gain, if that is
     * UNSUPPORTED_GAIN, where the poses show the motion went on into that
     * neighbour; where they do not (a nod that turned back inside the
     * frame), a path on into it would lay keys where the head never was.
     * The first and last frames have no path between and no neighbour for
     * the motion to go on into: their one path stands on its own gain, if
     * that is UNSUPPORTED_GAIN (a jerk inside the series' last frame), and
     * is no neighbour's support (issue 47's draw 164924818: the last frame's
     * path gained, and so took the frame before on into it, where a nod had
     * turned back, 1.875 -> 2.281 mm). */
    /* A neighbour's support (it moves) and a path without it keep the fixed
     * bars: a frame held still may gain on a path into a neighbour 1-9 %
     * where its series sets 1-3 % (series of frames each at a pose of its
     * own, test_frames_held_still_take_no_path_in_a_longer_series), and two
     * such neighbours would support each other. */
    double dwell_gain = series_gain(paths, tried, e->count);
    for (size_t k = 0; k < e->count; k++)
        for (int kind = 0; kind < PATHS; kind++)
            unfollowed[k] = fmax(unfollowed[k], paths[k * PATHS + (size_t)kind].gain);
    for (size_t k = 1; k + 1 < e->count; k++)
        moves[k] = shows_motion(paths, k);
    /* PATH_BACK ends at both neighbours' poses, which must hold still. A
     * neighbour whose motion the loop below refuses holds still after all,
     * and the frame's PATH_BACK gets its gain back (test_a_nod_that_turns_
     * back_inside_a_frame's seed 3938814174: frame 1's 5.3 % path from a
     * still frame 0 was refused, frame 2's nod kept one pose, 2.245 mm off
     * where its path stands at 1.383). */
    for (size_t k = 1; k + 1 < e->count; k++)
        if (moves[k - 1] || moves[k + 1]) {
            back_gain[k] = paths[k * PATHS + PATH_BACK].gain; /* 0 where none is held back */
            paths[k * PATHS + PATH_BACK].gain = 0.0;
        }
    /* A neighbour supports a path into it only while a path of its own
     * stands: one whose every path was refused here holds one pose in the
     * track, and a path into it would lay the motion where the track has
     * none. Refusals only take support away (a frame's moves[] only falls,
     * and PATH_BACK's gain, given back where both neighbours end still, is
     * given back once), so they are repeated until none changes. Issue
     * 47's draw 123620333: frame 13's path (6.1 %, a jerk near its end) was
     * refused at 15 %, yet it supported frame 14's path from it at the
     * series' 1 % (4.2 %, a nod out and back), which laid a jump of 2.5 mm
     * at the frame's middle: 3.95 mm where one pose stood 2.45.
     * PETBLUR_ESTIMATE_SUPPORT=gain keeps the support of a gain alone,
     * refused or not, for comparisons. */
    const char *support_env = getenv("PETBLUR_ESTIMATE_SUPPORT");
    const int support_by_gain = support_env && strcmp(support_env, "gain") == 0;
    for (int changed = 1; changed;) {
        changed = 0;
        for (size_t k = 0; k < e->count; k++) {
            frame_path *on = &paths[k * PATHS + PATH_ON], *from = &paths[k * PATHS + PATH_FROM];
            int between = paths[k * PATHS + PATH_BETWEEN].gain > dwell_gain;
            unsigned char end[DWELL_POINTS];
            const int jump_on = jumped_beside(e, fits, far, jumped, sides, k, +1, between, on->gain),
                      jump_from = jumped_beside(e, fits, far, jumped, sides, k, -1, between, from->gain);
            if (k + 1 == e->count ? on->gain <= UNSUPPORTED_GAIN
                                  : !moves[k + 1] && !jump_on &&
                                        (between || on->gain <= UNSUPPORTED_GAIN ||
                                         !(motion_went_on(e, fits, k, +1) || stops_short(e, on, +1, end))))
                on->gain = 0.0;
            if (k == 0 ? from->gain <= UNSUPPORTED_GAIN
                       : !moves[k - 1] && !jump_from &&
                             (between || from->gain <= UNSUPPORTED_GAIN ||
                              !(motion_went_on(e, fits, k, -1) || stops_short(e, from, -1, end))))
                from->gain = 0.0;
        }
        for (size_t k = 1; k + 1 < e->count; k++)
            if (back_gain[k] != 0.0 && !moves[k - 1] && !moves[k + 1]) {
                paths[k * PATHS + PATH_BACK].gain = back_gain[k];
                back_gain[k] = 0.0;
                changed = 1;
            }
        for (size_t k = 1; k + 1 < e->count && !support_by_gain; k++)
            if (moves[k] && !shows_motion(paths, k)) {
                moves[k] = 0;
                changed = 1;
            }
    }
    /* PETBLUR_ESTIMATE_BACK=even: PATH_BACK stands beside a one-way path on
     * its gain alone, for comparisons */
    const char *back_env = getenv("PETBLUR_ESTIMATE_BACK");
    const int back_even = back_env && strcmp(back_env, "even") == 0;
    for (size_t k = 1; k + 1 < e->count && !back_even; k++)
        if (back_yields(e, fits, paths, k, dwell_gain, far))
            paths[k * PATHS + PATH_BACK].gain = 0.0;
    /* the clearest first, of the paths still free */
    *moving_count = 0;
    for (;;) {
        size_t best = SIZE_MAX;
        for (size_t i = 0; i < e->count * PATHS; i++)
            if (paths[i].gain > dwell_gain && path_free(moving, anchor, i / PATHS, e->count, (int)(i % PATHS)) &&
                (best == SIZE_MAX || paths[i].gain > paths[best].gain))
                best = i;
        if (best == SIZE_MAX)
            break;
        size_t k = best / PATHS;
        int kind = (int)(best % PATHS);
        moving[k] = 1 + kind;
        if (starts_at_before(kind))
            anchor[k - 1] = 1;
        if (ends_at_after(kind))
            anchor[k + 1] = 1;
        ++*moving_count;
    }
    /* what the series' bar calls motion, in a frame the track holds still
     * (its path refused, or its neighbour's taken): the frame's pose is the
     * mean of poses it does not show. The series' first and last frames,
     * whose one path is held to UNSUPPORTED_GAIN, only above that: a first
     * frame held still 0.13 mm off gained 7.5 % on its path
     * (test_recovers_known_motion's seed 3902185740) */
    for (size_t k = 0; k < e->count; k++) {
        double bar = k == 0 || k + 1 == e->count ? fmax(dwell_gain, UNSUPPORTED_GAIN) : dwell_gain;
        if (moving[k] || !(unfollowed[k] > bar))
            unfollowed[k] = 0.0;
    }
    free(anchor);
    free(moves);
    free(tried);
    free(back_gain);
    return st;
}

/* Where a path of frame k's dwells: the first and second of its points
 * split where the two groups' mean places along it lie furthest apart,
 * weighed by their dwells (a jerk's two poses, a nod's two halves), as
 * fractions of the path. 0 where the path holds no dwell. */
static int dwell_halves(const frame_path *p, int points, double *first, double *second)
{
    double best = -1.0;
    for (int cut = 1; cut < points; cut++) {
        double w[2] = {0.0, 0.0}, t[2] = {0.0, 0.0};
        for (int i = 0; i < points; i++) {
            const double u = fmax(p->dwell[i], 0.0), at = (double)i / (points - 1);
            w[i >= cut] += u;
            t[i >= cut] += u * at;
        }
        if (!(w[0] > 0) || !(w[1] > 0))
            continue;
        const double apart = w[0] * w[1] * (t[1] / w[1] - t[0] / w[0]) * (t[1] / w[1] - t[0] / w[0]);
        if (apart > best) {
            best = apart;
            *first = t[0] / w[0];
            *second = t[1] / w[1];
        }
    }
    return best >= 0.0;
}

/* Where PATH_TWO is tried: 2 (the default) on frames reported unfollowed
 * and in place of a path, where the path is badly wrong because the
 * neighbours it runs between move themselves (on fresh family draws the
 * worst frame at the median draw fell by up to 0.42 mm; docs/estimate-log.md,
 * "A frame as two poses of its own"); PETBLUR_ESTIMATE_TWO=1 on unfollowed
 * frames only, =0 nowhere, for comparisons. */
static int two_poses_tried(void)
{
    const char *env = getenv("PETBLUR_ESTIMATE_TWO");
    return env && (strcmp(env, "0") == 0 || strcmp(env, "1") == 0) ? env[0] - '0' : 2;
}

/* The number environment variable `name` holds where it is one in [low,
 * high], else `otherwise`: a bar set for comparisons. */
static double env_number(const char *name, double low, double high, double otherwise)
{
    const char *env = getenv(name);
    char *end = NULL;
    const double v = env ? strtod(env, &end) : 0.0;
    return env && end != env && *end == '\0' && v >= low && v <= high ? v : otherwise;
}

/* The share of the frame PATH_TWO's two poses must hold (TWO_HELD_SHARE;
 * PETBLUR_ESTIMATE_TWO_HELD=S, 0.5 to 1, for comparisons). */
static double two_held_share(void)
{
    return env_number("PETBLUR_ESTIMATE_TWO_HELD", 0.5, 1.0, TWO_HELD_SHARE);
}

/* The share of a path's unexplained residual that PATH_TWO must explain
 * in its place (TWO_BEYOND_PATH; PETBLUR_ESTIMATE_TWO_BEYOND=S, 0 to 0.5,
 * for comparisons: 0 asks only that it beat the path). */
static double two_beyond_path(void)
{
    return env_number("PETBLUR_ESTIMATE_TWO_BEYOND", 0.0, 0.5, TWO_BEYOND_PATH);
}

/* Whether PATH_TWO asks a line with fitted ends whether its frame dwelt at
 * the two poses (TWO_LINE_BETWEEN; PETBLUR_ESTIMATE_LINE=0 does not, for
 * comparisons). */
static int line_judges(void)
{
    const char *env = getenv("PETBLUR_ESTIMATE_LINE");
    return !(env && strcmp(env, "0") == 0);
}

_Static_assert((int)DWELL_POINTS <= (int)PBE_LINE_MOST, "a line of more points than its fit takes");
/* The share of a frame's dwell between its two poses a and b along a line
 * with fitted ends through them (pbe_line_dwell, from a quarter beyond
 * either), its points 2 to DWELL_POINTS - 3: what a ramp leaves there and a
 * jump between two poses held does not. */
static pb_status dwell_between(estimate *e, const float *frame, const pb_pose *a, const pb_pose *b, double *between)
{
    pb_pose s, t;
    double u[DWELL_POINTS + 1], sse, total = 0.0, inside = 0.0;
    pb_pose_interpolate(a, b, -0.25, &s);
    pb_pose_interpolate(a, b, 1.25, &t);
    pb_pose_normalized(&s, &s);
    pb_pose_normalized(&t, &t);
    pb_status st = pbe_line_dwell(e->ctx, &e->level[0], frame, e->c, &s, &t, DWELL_POINTS, TWO_POSE_STEPS, u, &sse);
    for (int i = 0; i < DWELL_POINTS && st == PB_OK && isfinite(sse); i++) {
        total += fmax(u[i], 0.0);
        inside += i >= 2 && i + 2 < DWELL_POINTS ? fmax(u[i], 0.0) : 0.0;
    }
    *between = total > 0 ? inside / total : 1.0;
    return st;
}

/* The pose the track holds at frame k's start (side 0) or end (side 1),
 * from the neighbour there: a still one's pose, or where a moving one's
 * path ends (starts). NULL: no neighbour. */
static const pb_pose *held_at_boundary(const pbe_fit *fits, const frame_path *paths, const int *moving, size_t k,
                                       size_t count, int side)
{
    if (side ? k + 1 >= count : k == 0)
        return NULL;
    const size_t n = side ? k + 1 : k - 1;
    if (!moving[n])
        return &fits[n].pose;
    const frame_path *p = &paths[n * PATHS + (size_t)(moving[n] - 1)];
    return side ? &p->start : &p->end;
}

/* Whether a frame of two poses held in turn holds a first: the order that
 * lies nearer the poses its neighbours hold at its boundaries, both summed.
 * A moving neighbour's own pose is a mean of the poses it held, and where
 * the head went down inside one frame and came back inside the next, each
 * frame's mean lies halfway: by it the order was a toss, and the wrong one
 * put the frame back by the nod (test_motion_held_across_a_frame_boundary,
 * seed 403092325: 4.90 mm where the path stood at 0.18). */
static int held_first(const estimate *e, const double far[3], const pbe_fit *fits, const frame_path *paths,
                      const int *moving, size_t k, const pb_pose *a, const pb_pose *b)
{
    const pb_pose *before = held_at_boundary(fits, paths, moving, k, e->count, 0),
                  *after = held_at_boundary(fits, paths, moving, k, e->count, 1);
    double a_first = 0.0, b_first = 0.0;
    if (before) {
        a_first += path_span(e, far, a, before);
        b_first += path_span(e, far, b, before);
    }
    if (after) {
        a_first += path_span(e, far, b, after);
        b_first += path_span(e, far, a, after);
    }
    return a_first <= b_first;
}

/* PATH_TWO: the frame as two poses of its own held in turn (two_poses.c),
 * from the two halves of its best path, for each frame that shows motion
 * inside it that no path follows (unfollowed: its best path gained above
 * the series' bar and was refused, its neighbours moving themselves or the
 * path unsupported). Taken where it explains the frame better than that
 * path did, holds each pose for at least SHORT_SHARE of the frame, each
 * pose stays within half the halves' distance of its half (a pose that
 * leaves fits the reference's misfit, not the motion: issue 47's draw
 * 2895735097, a frame of 60 s still but for 0.4 s, gained 22 % on a second
 * pose 190 mm from the first, held 7 % of the frame, where its paths gained
 * 3 %), and the frame dwells at the two poses (pbe_two_poses_held) and not
 * between them along a line with fitted ends (TWO_LINE_BETWEEN); no
 * neighbour's path may start or end at the frame's pose. Which pose came
 * first the frame cannot tell: the order nearer the poses its neighbours
 * hold at its boundaries (held_first). By default a
 * frame on a path (not PATH_BACK) tries it too, where it explains
 * TWO_BEYOND_PATH of what that path leaves, and steps from and to the
 * still neighbours that path stepped from and to (path_keys). The series'
 * first and last frames' one path (PATH_ON, PATH_FROM), whose far end is the
 * frame's own pose taken as far again, was fitted so too and not kept: on
 * 20 series of test_jerk_in_the_series_first_or_last_frame, 1 of 40 frames
 * better, 2 worse (docs/estimate-log.md). */
static pb_status two_pose_frames(estimate *e, const pbe_fit *fits, const float *moved, const double *gram,
                                 float *own, frame_path *paths, int *moving, size_t *moving_count,
                                 double *unfollowed)
{
    double far[3];
    far_corner(e, far);
    pb_status st = PB_OK;
    const int in_place_of_paths = two_poses_tried() == 2;
    const double beyond = two_beyond_path(), held_bar = two_held_share();
    for (size_t k = 0; k < e->count && st == PB_OK; k++) {
        const int on_path = in_place_of_paths && moving[k] && moving[k] - 1 != PATH_BACK;
        if (!(on_path || (!moving[k] && unfollowed[k] > 0.0)) || e->flat[k] ||
            (k > 0 && moving[k - 1] && ends_at_after(moving[k - 1] - 1)) ||
            (k + 1 < e->count && moving[k + 1] && starts_at_before(moving[k + 1] - 1)))
            continue;
        const frame_path *best = on_path ? &paths[k * PATHS + (size_t)(moving[k] - 1)] : NULL;
        for (int kind = 0; kind < PATH_BACK && !on_path; kind++) {
            const frame_path *p = &paths[k * PATHS + (size_t)kind];
            if (p->fitted != 0.0 && (!best || p->fitted > best->fitted))
                best = p;
        }
        double first = 0.0, second = 1.0;
        if (!best || !dwell_halves(best, DWELL_POINTS, &first, &second))
            continue;
        pb_pose a, b;
        pb_pose_interpolate(&best->start, &best->end, first, &a);
        pb_pose_interpolate(&best->start, &best->end, second, &b);
        pb_pose_normalized(&a, &a);
        pb_pose_normalized(&b, &b);
        const float *frame = e->frames[0] + k * e->level[0].n;
        const pb_pose a0 = a, b0 = b;
        double one = 0.0, share_a, sse;
        st = frame_reference(e, moved, gram, k, own);
        if (st == PB_OK)
            st = one_pose_weighted(e, &fits[k].pose, frame, &one);
        if (st == PB_OK)
            st = pbe_two_poses(e->ctx, &e->level[0], frame, e->c, &a, &b, TWO_POSE_STEPS, &share_a, &sse);
        if (st != PB_OK || !(one > 0) || share_a < SHORT_SHARE || share_a > 1.0 - SHORT_SHARE ||
            !(1.0 - sse / one > (on_path ? best->fitted + beyond * (1.0 - best->fitted) : unfollowed[k])) ||
            !poses_apart(e, far, &a, &b) ||
            fmax(path_span(e, far, &a0, &a), path_span(e, far, &b0, &b)) > 0.5 * path_span(e, far, &a0, &b0))
            continue;
        double held = 0.0, between = 0.0;
        if ((st = pbe_two_poses_held(e->ctx, &e->level[0], frame, e->c, &a, &b,
                                     e->g.voxel_size[0] / path_span(e, far, &a, &b), &held)) != PB_OK ||
            !(held >= held_bar))
            continue;
        if (line_judges() && ((st = dwell_between(e, frame, &a, &b, &between)) != PB_OK || between > TWO_LINE_BETWEEN))
            continue;
        const int a_first = held_first(e, far, fits, paths, moving, k, &a, &b);
        frame_path *two = &paths[k * PATHS + PATH_TWO];
        two->replaced = on_path ? moving[k] : 0;
        two->gain = 1.0 - sse / one;
        two->start = a_first ? a : b;
        two->end = a_first ? b : a;
        two->dwell[0] = a_first ? share_a : 1.0 - share_a;
        two->dwell[1] = 1.0 - two->dwell[0];
        *moving_count += !moving[k];
        moving[k] = 1 + PATH_TWO;
        unfollowed[k] = 0.0;
    }
    return st;
}

/* The frames as given, each less its background where it has one
 * (background.c), warned about where it is over BACKGROUND_WARNED of the
 * frame's peak. */
static pb_status remove_background(estimate *e)
{
    const size_t n = voxels(&e->g);
    double *level = malloc(sizeof(double) * 2 * e->count);
    if (!level)
        return PB_ERR_OUT_OF_MEMORY;
    double *peak = level + e->count, low = (double)INFINITY, high = 0.0;
    pb_status st = pbe_backgrounds(&e->g, e->raw, e->count, level, peak);
    size_t any = 0, warned = 0;
    for (size_t k = 0; k < e->count && st == PB_OK; k++) {
        double share = fabs(level[k]) / peak[k];
        any += level[k] != 0;
        if (share > BACKGROUND_WARNED) {
            warned++;
            low = fmin(low, share);
            high = fmax(high, share);
        }
    }
    if (st == PB_OK && any && !(e->owned = malloc(sizeof(float) * n * e->count)))
        st = PB_ERR_OUT_OF_MEMORY;
    for (size_t k = 0; k < e->count && st == PB_OK && any; k++)
        for (size_t i = 0; i < n; i++)
            e->owned[k * n + i] = (float)((double)e->raw[k * n + i] - level[k]);
    if (st == PB_OK && any)
        e->raw = e->owned;
    if (st == PB_OK && warned)
        pb_warn(e->warnings, PB_WARN_BACKGROUND, "motion estimate: %zu of %zu frames sit on a uniform background "
                "that reaches the grid's faces, %.3g to %.3g %% of their peak (the median of the faces' voxels); "
                "it was subtracted from each frame before registration, where it would have held the poses near "
                "the grid's. Where the background is not uniform, subtract it before estimating", warned, e->count,
                100.0 * low, 100.0 * high);
    free(level);
    return st;
}

/* "3, 7, 9" for the frames marked, the first eight of them. */
static void frame_list(const int *mark, size_t count, char *out, size_t size)
{
    size_t listed = 0, used = 0;
    out[0] = '\0';
    for (size_t k = 0; k < count && used + 24 < size; k++) {
        if (!mark[k])
            continue;
        if (listed < 8)
            used += (size_t)snprintf(out + used, size - used, "%s%zu", listed ? ", " : "", k);
        else if (listed == 8)
            used += (size_t)snprintf(out + used, size - used, ", ...");
        listed++;
    }
}

/* The frame nearest k that is not flat, the earlier of two as near; count
 * where every frame is flat. */
static size_t nearest_structured(const int *flat, size_t count, size_t k)
{
    for (size_t d = 1; d < count; d++) {
        if (k >= d && !flat[k - d])
            return k - d;
        if (k + d < count && !flat[k + d])
            return k + d;
    }
    return count;
}

/* Each frame of noise alone takes its nearest structured frame's pose (the
 * identity where no frame has structure). */
static void give_flat_frames_poses(const estimate *e, pbe_fit *fits)
{
    for (size_t k = 0; k < e->count; k++) {
        if (!e->flat[k])
            continue;
        size_t near = nearest_structured(e->flat, e->count, k);
        memset(&fits[k].pose, 0, sizeof fits[k].pose);
        fits[k].pose.rotation[0] = 1.0;
        if (near < e->count)
            fits[k].pose = fits[near].pose;
    }
}

/* Frames whose registration explains less than STRUCTURE_EXPLAINED of their
 * variance show nothing but noise: each takes its nearest structured
 * frame's pose (the identity where no frame has structure), and is warned
 * about. */
static pb_status hold_flat_frames(estimate *e, pbe_fit *fits)
{
    const size_t n = e->level[0].n;
    size_t flat = 0;
    double low = 1.0, high = 0.0;
    for (size_t k = 0; k < e->count; k++) {
        double explained = pbe_explained(e->frames[0] + k * n, n, fits[k].sse);
        e->flat[k] = !shows_structure(e, k, fits[k].sse);
        if (e->flat[k]) {
            flat++;
            low = fmin(low, explained);
            high = fmax(high, explained);
        }
    }
    if (!flat)
        return PB_OK;
    give_flat_frames_poses(e, fits);
    char list[256];
    frame_list(e->flat, e->count, list, sizeof list);
    pb_warn(e->warnings, PB_WARN_NO_STRUCTURE, "motion estimate: %zu of %zu frames (%s) show no structure above "
            "their noise (registration explains %.0f to %.0f %% of their variance, frames with structure over "
            "%.0f %%): %s", flat, e->count, list, fmax(0.0, 100.0 * low), fmax(0.0, 100.0 * high),
            100.0 * STRUCTURE_EXPLAINED,
            flat < e->count ? "each was given its nearest structured frame's pose" :
                              "every pose was left at the identity; check that these are the series' frames");
    return PB_OK;
}

/* The still frames' poses seen together in time (smooth_poses.c), the
 * reference frame's among them; a frame of noise alone then takes its
 * nearest structured frame's smoothed pose. PETBLUR_ESTIMATE_SMOOTH=0
 * leaves the poses as registered, for comparisons. */
static double mid_time(double a, double b);

/* The grid's RMS radius about its centre, mm: what puts turns and shifts on
 * one scale (a turn of x radians moves a point there by about r x). */
static double rms_radius(const pb_geometry *g)
{
    double r2 = 0.0;
    for (int a = 0; a < 3; a++) {
        double side = (double)g->dims[a] * g->voxel_size[a];
        r2 += side * side / 12.0;
    }
    return sqrt(r2);
}

static pb_status smooth_still_poses(estimate *e, pbe_fit *fits, const double *bounds, size_t ref, int *jumped)
{
    const char *env = getenv("PETBLUR_ESTIMATE_SMOOTH");
    if (env && strcmp(env, "0") == 0)
        return PB_OK;
    double *t = malloc(sizeof(double) * e->count);
    if (!t)
        return PB_ERR_OUT_OF_MEMORY;
    for (size_t k = 0; k < e->count; k++)
        t[k] = mid_time(bounds[k], bounds[k + 1]);
    /* turns weighed by the grid's RMS radius about its centre */
    double rate = pbe_smooth_poses(fits, e->flat, t, e->count, ref, rms_radius(&e->g), jumped);
    free(t);
    if (rate == PBE_SMOOTH_NO_MEMORY)
        return PB_ERR_OUT_OF_MEMORY;
    give_flat_frames_poses(e, fits);
    return PB_OK;
}

/* Which frames the link by mutual information moves: PETBLUR_ESTIMATE_LINK
 * =0 none, =all every frame that shows structure, else (the default) those
 * before the late frame they are linked to. */
enum { LINK_NONE, LINK_BEFORE, LINK_ALL };

static int link_kind(void)
{
    const char *env = getenv("PETBLUR_ESTIMATE_LINK");
    if (env && strcmp(env, "0") == 0)
        return LINK_NONE;
    return env && strcmp(env, "all") == 0 ? LINK_ALL : LINK_BEFORE;
}

/* The levels the link runs on: the finest two. Its start, pass 2's pose,
 * lies within a voxel or two, and a coarser level's few voxels spread a
 * histogram of 50 bins thin. */
enum { LINK_LEVELS = 2 };

/* The frames' poses linked to a late frame by mutual information
 * (mutual_information.c): pass 2 fits each frame to a reference of its own
 * contrast, so its pose carries the bias that the contrast gives least
 * squares, and the frames of the first minutes, whose blood and tissue
 * stand in another ratio than a late frame's, carry it most. Mutual
 * information lets each tissue keep its own intensity. The frame it links
 * to is the one whose fit knows its pose best (the least spread), late and
 * long in a dynamic scan; each frame's pose relative to it, D = T_k T_L^-1,
 * is fitted from pass 2's, coarse to fine, and the frame keeps pass 2's
 * information for the smoothing. */
static pb_status link_by_information(estimate *e, pbe_fit *fits, int kind)
{
    const double r = rms_radius(&e->g);
    size_t late = SIZE_MAX;
    double least = (double)INFINITY;
    for (size_t k = 0; k < e->count; k++) {
        double spread = e->flat[k] ? (double)INFINITY : pbe_pose_spread(&fits[k], r);
        if (spread < least) {
            least = spread;
            late = k;
        }
    }
    if (late == SIZE_MAX) {
        report_progress(e, (double)e->count);
        return PB_OK;
    }
    const float *levels[8];
    for (size_t l = 0; l < e->levels; l++)
        levels[l] = e->frames[l] + late * e->level[l].n;
    pb_status st = set_reference_levels(e, levels);
    pb_pose back;
    pb_pose_invert(&fits[late].pose, &back);
    const size_t top = e->levels < LINK_LEVELS ? e->levels : LINK_LEVELS;
    for (size_t k = 0; k < e->count && st == PB_OK; k++) {
        if (k == late || e->flat[k] || (kind == LINK_BEFORE && k > late)) {
            report_progress(e, 1.0);
            continue;
        }
        pb_pose d;
        pb_pose_compose(&fits[k].pose, &back, &d);
        pb_pose_normalized(&d, &d);
        for (size_t l = top; l-- > 0 && st == PB_OK;)
            st = pbe_register_mi(e->ctx, &e->level[l], e->frames[l] + k * e->level[l].n, e->c, r, e->iterations,
                                 &d, NULL);
        /* a frame without contrast on the reference's support keeps pass 2's pose */
        if (st == PB_ERR_INVALID_ARGUMENT) {
            st = PB_OK;
            report_progress(e, 1.0);
            continue;
        }
        if (st == PB_OK) {
            pb_pose_compose(&d, &fits[late].pose, &fits[k].pose);
            pb_pose_normalized(&fits[k].pose, &fits[k].pose);
        }
        report_progress(e, 1.0);
    }
    return st;
}

/* One of pass 4's evaluations done: its share of the pass's progress. */
static void together_tick(void *user)
{
    estimate *e = user;
    report_progress(e, e->together / PBE_COLLECTIVE_EVALUATIONS);
}

/* Pass 4 (contrast_poses.c): the poses of frames whose contrast is far from
 * the reference frame's share a bias that frame-by-frame registration cannot
 * see; one correction along the contrast, fitted to the series as a whole. */
static pb_status correct_together(estimate *e, size_t ref, pbe_fit *fits, frame_path *paths, const int *moving)
{
    pbe_collective_pose *p = calloc(e->count, sizeof *p);
    if (!p)
        return PB_ERR_OUT_OF_MEMORY;
    for (size_t k = 0; k < e->count; k++) {
        p[k].pose = fits[k].pose;
        p[k].moving = moving[k] != 0;
        if (moving[k]) {
            p[k].start = paths[k * PATHS + (size_t)(moving[k] - 1)].start;
            p[k].end = paths[k * PATHS + (size_t)(moving[k] - 1)].end;
        }
    }
    double moved_mm, given = e->done;
    pb_status st = pbe_collective(e->pool, &e->g, e->raw, e->count, ref, e->c, p, &moved_mm, together_tick, e);
    for (size_t k = 0; k < e->count && st == PB_OK; k++) {
        fits[k].pose = p[k].pose;
        if (moving[k]) {
            paths[k * PATHS + (size_t)(moving[k] - 1)].start = p[k].start;
            paths[k * PATHS + (size_t)(moving[k] - 1)].end = p[k].end;
        }
    }
    report_progress(e, fmax(0.0, e->together - (e->done - given)));
    free(p);
    return st;
}

/* A frame's mid-time: the same double as (a + b) / 2, without the sum's
 * overflow for frames near the largest doubles. */
static double mid_time(double a, double b)
{
    return 0.5 * a + 0.5 * b;
}

typedef struct keys {
    double *t;
    pb_pose *p;
    unsigned char *middle; /* a still frame's pose at its middle */
    size_t n;
} keys;

static void key_of(keys *k, double t, const pb_pose *p, int middle)
{
    if (k->n > 0 && !(t > k->t[k->n - 1]))
        return;
    k->t[k->n] = t;
    k->middle[k->n] = (unsigned char)middle;
    k->p[k->n++] = *p;
}

static void key(keys *k, double t, const pb_pose *p)
{
    key_of(k, t, p, 0);
}

/* The keys with the curve through the still frames' middles (track_curve.c)
 * in place of lines, into c; PETBLUR_ESTIMATE_CURVE=line keeps the lines
 * (no key is taken for a middle, so every key is copied), for comparisons. */
static pb_status curve_keys(keys *k, keys *c)
{
    const char *env = getenv("PETBLUR_ESTIMATE_CURVE");
    if (env && strcmp(env, "line") == 0)
        memset(k->middle, 0, k->n);
    c->n = pbe_curve_keys(k->t, k->p, k->middle, k->n, c->t, c->p);
    return c->n > 0 ? PB_OK : PB_ERR_OUT_OF_MEMORY;
}

/* A path's dwell as shares of the frame: each point's share of the total,
 * 0 below twice STEP_FRACTION (a point held for less than its steps take). */
static void dwell_shares(const double *u, int n, double *w)
{
    double total = 0.0;
    for (int i = 0; i < n; i++)
        total += u[i];
    for (int i = 0; i < n; i++)
        w[i] = total > 0 && u[i] / total >= 2.0 * STEP_FRACTION ? u[i] / total : 0.0;
    total = 0.0;
    for (int i = 0; i < n; i++)
        total += w[i];
    for (int i = 0; i < n; i++)
        w[i] = total > 0 ? w[i] / total : 0.0;
}

/* A moving frame's poses: it holds each of n poses for its share w of the
 * frame in turn, stepping between them in STEP_FRACTION of the frame; where
 * before (after) is given, the frame starts (ends) with a step from (to)
 * that pose, its neighbour's, which the frame does not dwell at. *from and
 * *to: when the first pose held ends and the last begins (the frame's ends
 * where it steps there), the report's motion inside the frame (both the
 * frame's middle where one pose is held). */
static void hold_keys(keys *out, double t0, double t1, const pb_pose *p, const double *w, int n,
                      const pb_pose *before, const pb_pose *after, double *from, double *to)
{
    double len = t1 - t0, step = STEP_FRACTION * len, at = t0;
    int held = 0;
    if (before) {
        key(out, t0, before);
        *from = t0;
        held++;
    }
    for (int i = 0; i < n; i++) {
        if (w[i] <= 0)
            continue;
        double hold = w[i] * len;
        double a = at == t0 && !before ? t0 : at + 0.5 * step;
        double b = at + hold >= t1 - 1e-9 * len && !after ? t1 : at + hold - 0.5 * step;
        key(out, a, &p[i]);
        key(out, b, &p[i]);
        if (held++ == 0)
            *from = b;
        *to = a;
        at += hold;
    }
    if (after) {
        key(out, t1, after);
        *to = t1;
        held++;
    }
    if (held < 2)
        *from = *to = mid_time(t0, t1);
}

/* Whether a path that does not dwell at a still neighbour's pose steps
 * from (to) it at the boundary (path_keys); PETBLUR_ESTIMATE_PATH_ENDS=ramp
 * leaves the track to ramp through the neighbour to its middle, for
 * comparisons. */
static int path_ends_step(void)
{
    const char *env = getenv("PETBLUR_ESTIMATE_PATH_ENDS");
    return !(env && strcmp(env, "ramp") == 0);
}

/* The points of a path from s to e in path order, each for its dwell u.
 * A path that starts at the frame before's pose (ends at the frame after's)
 * but does not dwell there steps from (to) that pose at the boundary, as
 * back_keys: the neighbour holds still to its ends, so the motion between
 * its pose and the path's first (last) point held took place inside this
 * frame. Without that step the track ramped from the last point held to the
 * neighbour's middle, half a still frame of motion the frame does not show
 * (issue 47's draw 3414265662: a jerk across the boundary of frames 2 and
 * 3, frame 3 5.64 mm off on a ramp of 5 s). before (after): that still
 * neighbour's pose, where the path starts (ends) there or stops short of it
 * (stops_short) or the frames show the head jumped at that boundary
 * (jumps[0], jumps[1]: the track steps there whether or not the path dwells
 * at that end, and PETBLUR_ESTIMATE_PATH_ENDS=ramp does not ramp it), else
 * NULL (the motion goes on into the neighbour, or the neighbour moves
 * itself). */
static void path_keys(keys *out, double t0, double t1, const pb_pose *s, const pb_pose *e, const pb_pose *before,
                      const pb_pose *after, const int jumps[2], const double *u, double *from, double *to)
{
    double w[DWELL_POINTS];
    pb_pose p[DWELL_POINTS];
    dwell_shares(u, DWELL_POINTS, w);
    for (int i = 0; i < DWELL_POINTS; i++)
        pb_pose_interpolate(s, e, (double)i / (DWELL_POINTS - 1), &p[i]);
    const int step = path_ends_step();
    hold_keys(out, t0, t1, p, w, DWELL_POINTS, jumps[0] || (step && !(w[0] > 0)) ? before : NULL,
              jumps[1] || (step && !(w[DWELL_POINTS - 1] > 0)) ? after : NULL, from, to);
}

/* The still neighbours' poses a moving frame f's path p of a kind steps
 * from and to where it holds no dwell at its ends (path_keys): the
 * neighbour it starts or ends at, or one it stops short of (stops_short),
 * still and not where the motion went on (motion_went_on); u: p's dwell,
 * less the remnant at an end it stops short at (far_end). Else a still
 * neighbour across a boundary where the frames show the head jumped
 * (jumped_at), whatever the path's dwell there and however it was taken
 * (on the jump, or on its own gain where the poses show the motion went
 * on): jumps[] says which, for path_keys. The rule before left the frame
 * before such a path ramping from its middle to the path's start, 2.4-3.4
 * mm off on 7 of 20 fresh seeds of
 * test_a_move_after_a_jump_at_a_boundary_is_followed. */
static void path_neighbours(const estimate *e, const pbe_fit *fits, const int *moving, const int *jumped,
                            const double *sides, size_t f, int kind, const frame_path *p, double u[DWELL_POINTS],
                            const pb_pose **before, const pb_pose **after, int jumps[2])
{
    memcpy(u, p->dwell, DWELL_POINTS * sizeof *u);
    *before = *after = NULL;
    jumps[0] = jumps[1] = 0;
    unsigned char end[DWELL_POINTS];
    if (f > 0 && starts_at_before(kind))
        *before = &fits[f - 1].pose;
    else if (f > 0 && !moving[f - 1] && !motion_went_on(e, fits, f, -1) && stops_short(e, p, -1, end)) {
        *before = &fits[f - 1].pose;
        for (int i = 0; i < DWELL_POINTS; i++)
            u[i] = end[i] ? 0.0 : u[i];
    } else if (f > 0 && !moving[f - 1] && jumped_at(jumped, sides, f, f - 1)) {
        *before = &fits[f - 1].pose;
        jumps[0] = 1;
    }
    if (f + 1 < e->count && ends_at_after(kind))
        *after = &fits[f + 1].pose;
    else if (f + 1 < e->count && !moving[f + 1] && !motion_went_on(e, fits, f, +1) && stops_short(e, p, +1, end)) {
        *after = &fits[f + 1].pose;
        for (int i = 0; i < DWELL_POINTS; i++)
            u[i] = end[i] ? 0.0 : u[i];
    } else if (f + 1 < e->count && !moving[f + 1] && jumped_at(jumped, sides, f + 1, f + 1)) {
        *after = &fits[f + 1].pose;
        jumps[1] = 1;
    }
}

/* PATH_BACK's points (back_poses) in order, each for its dwell u. Where it
 * dwells at neither neighbour's pose, the head went out at (came back at)
 * the boundary, and the still neighbour holds its pose to it: the frame
 * steps from (to) that pose (668173037's frame 14, out as it began: the
 * frame before, ramping to the path's first pose held over its second half,
 * stood 2.74 mm off where it had stood 0.21). */
static void back_keys(keys *out, double t0, double t1, const pb_pose *s, const pb_pose *f, const pb_pose *r,
                      const double *u, double *from, double *to)
{
    double w[BACK_POINTS];
    pb_pose p[BACK_POINTS];
    dwell_shares(u, BACK_POINTS, w);
    back_poses(s, f, r, p);
    hold_keys(out, t0, t1, p, w, BACK_POINTS, w[0] > 0 ? NULL : s, w[BACK_POINTS - 1] > 0 ? NULL : r, from, to);
}

/* Whether a frame's side (g, h: side_evidence) is not nearer a ramp than a
 * step by more than two standard deviations of its noise: h at least
 * halfway from -g to g, less 2 sqrt(g). */
static int leans_to_step(const double side[2])
{
    return side[1] > 0.5 * side[0] - 2.0 * sqrt(side[0]);
}

/* Whether the head jumped at the boundary before frame b as its two frames
 * show it (boundary_steps, below, says how), the frame before asked to lean
 * to the step where lean[0] is set, frame b where lean[1] is. */
static int shows_step(const int *jumped, const double *sides, size_t b, const int lean[2])
{
    const double *before = &sides[4 * (b - 1) + 2], *after = &sides[4 * b];
    const double g = before[0] + after[0], h = before[1] + after[1];
    return jumped[b] && g >= SEPARATION * SEPARATION && h > 0.5 * g && (!lean[0] || leans_to_step(before)) &&
           (!lean[1] || leans_to_step(after));
}

/* Where the head jumped at a boundary between still frames: steps[b] for
 * the boundary before frame b, where the poses jumped into frame b (more than
 * the walk of smooth_poses.c goes, jumped[b]: none where the poses were not
 * smoothed, PETBLUR_ESTIMATE_SMOOTH=0 or under three frames with
 * structure) and the two frames together
 * show their poses held to the boundary (side_evidence: the sum of their h
 * over half the sum of their g, where that sum is at least SEPARATION^2),
 * neither frame nearer the ramp beyond its noise (leans_to_step: a frame
 * whose h stood at 0 with g at 20, inside a slow nod, vetoed its neighbour's
 * h of 162 there; issue 47's draw 1614930606). A boundary beside a moving
 * frame keeps its path's keys.
 * PETBLUR_ESTIMATE_BOUNDARY=ramp keeps every ramp, for comparisons. */
static void boundary_steps(const estimate *e, const int *moving, const int *jumped, const double *sides,
                           unsigned char *steps)
{
    const char *env = getenv("PETBLUR_ESTIMATE_BOUNDARY");
    memset(steps, 0, e->count + 1);
    if (env && strcmp(env, "ramp") == 0)
        return;
    for (size_t b = 1; b < e->count; b++)
        steps[b] = !moving[b - 1] && !moving[b] && !e->flat[b - 1] && !e->flat[b] &&
                   shows_step(jumped, sides, b, (const int[2]){1, 1});
}

/* A grid pose about c as a world map about the world's origin:
 * R_w = D R D^T, t_w = D (c - R c + t) + o - R_w o. */
static pb_status world_pose(const double d[9], const double o[3], const double c[3], const pb_pose *grid,
                            pb_pose *world)
{
    double m[16], r[9], rw[9] = {0}, w[16] = {0};
    pb_pose_to_matrix(grid, m);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            r[3 * i + j] = m[4 * i + j];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 3; b++)
                    rw[3 * i + j] += d[3 * i + a] * r[3 * a + b] * d[3 * j + b];
    double v[3];
    for (int i = 0; i < 3; i++) {
        v[i] = c[i] + grid->translation[i];
        for (int j = 0; j < 3; j++)
            v[i] -= r[3 * i + j] * c[j];
    }
    for (int i = 0; i < 3; i++) {
        double t = o[i];
        for (int j = 0; j < 3; j++)
            t += d[3 * i + j] * v[j] - rw[3 * i + j] * o[j];
        for (int j = 0; j < 3; j++)
            w[4 * i + j] = rw[3 * i + j];
        w[4 * i + 3] = t;
    }
    w[15] = 1.0;
    return pb_pose_from_matrix(w, world);
}

static pb_status check_input(const pb_geometry *g, const float *frames, size_t count, const double *bounds,
                             const pb_estimate_options *o)
{
    if (count < 2)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "motion from the frames needs at least two frames, got %zu: "
                        "a 3-D image or a single frame has nothing to register; give a 4-D series", count);
    if (o->reference != PB_ESTIMATE_REFERENCE_AUTO && o->reference >= count)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "the reference frame %zu is out of range: the series has "
                        "frames 0 to %zu (or PB_ESTIMATE_REFERENCE_AUTO)", o->reference, count - 1);
    if (o->iterations > 1000)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "iterations is %u; give 1 to 1000 (0: the default)",
                        o->iterations);
    if (o->levels > 6)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "levels is %u; give 1 to 6 (0: the default)", o->levels);
    if (!isfinite(o->fwhm_mm) || o->fwhm_mm < 0 || o->fwhm_mm > 1000)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "fwhm_mm is %s; give 0 (the default) to 1000 mm",
                        PB_NUM(o->fwhm_mm));
    for (int a = 0; a < 3; a++)
        if (g->dims[a] < 8)
            return pb_error(NULL, PB_ERR_ZERO_DIMS, "the grid is %zu x %zu x %zu voxels: registration needs at "
                            "least 8 a side", g->dims[0], g->dims[1], g->dims[2]);
    /* The library's voxel-size range, checked before anything is sized from
     * it: the smoothing's width, the pyramid's levels, the turns' centre. */
    size_t n_voxels;
    pb_status st = pb_geometry_check(NULL, g, &n_voxels);
    if (st == PB_OK)
        st = pb_frame_bounds_check(NULL, bounds, count);
    if (st != PB_OK)
        return st;
    const size_t n = voxels(g);
    for (size_t k = 0; k < count; k++) {
        const float *f = frames + k * n;
        float top = 0.0f;
        for (size_t i = 0; i < n; i++) {
            if (!isfinite(f[i]))
                return pb_error(NULL, PB_ERR_NOT_FINITE, "frame %zu holds %s at voxel (%zu, %zu, %zu); replace NaN "
                                "and infinite voxels (with 0) before estimating motion", k,
                                isnan(f[i]) ? "NaN" : "an infinity", i % g->dims[0], i / g->dims[0] % g->dims[1],
                                i / (g->dims[0] * g->dims[1]));
            top = fmaxf(top, f[i]);
        }
        if (!(top > 0.0f))
            return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "frame %zu (%g to %g s) holds no counts (no voxel above "
                            "0): it has nothing to register; leave it out of the series", k, bounds[k],
                            bounds[k + 1]);
    }
    return PB_OK;
}

/* The call's failure in ctx, from this call's text only: a part that failed
 * without one (no failure written since entry, serial) is named by its status. */
static void failed(pb_context *ctx, pb_status st, unsigned long serial)
{
    const char *why = pb_error_serial() != serial ? pb_last_error(NULL) : "";
    pb_error(ctx, st, "estimating motion from the frames: %s", why[0] ? why : pb_status_string(st));
}

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Frame k's counts: its sum times its length (the frames are rates). */
static double frame_counts(const estimate *e, const double *bounds, size_t k)
{
    const float *f = e->frames[0] + k * e->level[0].n;
    double sum = 0.0;
    for (size_t i = 0; i < e->level[0].n; i++)
        sum += (double)f[i];
    return sum * (bounds[k + 1] - bounds[k]);
}

/* The frame the track is relative to where the caller leaves it to the
 * estimate: of the frames held still that show structure and no motion
 * inside, the one whose pose its registration determines best (the least
 * spread of a point at the grid's RMS radius). Every pose is expressed
 * against the reference frame's, so its error moves every frame, and an
 * early frame of few counts or blood-dominated contrast is off by several
 * times a late frame's (docs/estimate-log.md, "What anchors the track").
 * A frame that shows motion inside that the track does not follow is taken
 * only where it is surer than every other by more than twice the spread's
 * standard deviation (a quarter of the variance): on series of noise alone
 * every other frame but a faint first one showed such motion, and that
 * first frame, five times less sure, was taken (tests/test_estimate_input.c,
 * seed 1796408343821053).
 * A frame of under ANCHOR_COUNTS of the most counts among the frames held
 * still is taken only where no other qualifies: its noise is twice the
 * best's or more, whatever its fit's residual says. A residual holds the
 * misfit of the frame's reference as well as its noise, and a faint
 * frame's misfit is faint too: on tests/test_estimate_input.c's series
 * (a first frame of a tenth the signal) the faint frame's pose looked as
 * sure as the bright frames' on one seed in ten, by the spread alone.
 * The passes run against frame 0 as before; this only re-expresses the
 * poses. Under frame_poses_only motion inside frames is not looked for, and
 * a frame that holds some is passed over only by its fit's lesser
 * information. fallback where no frame qualifies. */
static size_t best_anchor(const estimate *e, const pbe_fit *fits, const int *moving, const double *unfollowed,
                          const double *bounds, size_t fallback)
{
    double least = (double)INFINITY, least_any = (double)INFINITY, r = rms_radius(&e->g), most = 0.0;
    size_t best = fallback, best_any = fallback;
    /* each frame's counts once (no room: no floor) */
    double *counts = calloc(e->count, sizeof(double));
    for (size_t k = 0; k < e->count && counts; k++)
        if (!e->flat[k] && !moving[k]) {
            counts[k] = frame_counts(e, bounds, k);
            most = fmax(most, counts[k]);
        }
    for (int floor_kept = counts != NULL; floor_kept >= 0 && !(least_any < (double)INFINITY); floor_kept--)
        for (size_t k = 0; k < e->count; k++) {
            if (e->flat[k] || moving[k] || (floor_kept && counts[k] < ANCHOR_COUNTS * most))
                continue;
            double spread = pbe_pose_spread(&fits[k], r);
            if (spread < least_any) {
                least_any = spread;
                best_any = k;
            }
            if (unfollowed[k] <= 0.0 && spread < least) {
                least = spread;
                best = k;
            }
        }
    free(counts);
    return least_any < 0.25 * least ? best_any : best;
}

/* The frame of the most counts: its sum (level 0) times its length. */
static size_t most_counts(const estimate *e, const double *bounds)
{
    double most = -1.0;
    size_t frame = 0;
    for (size_t k = 0; k < e->count; k++) {
        const double sum = frame_counts(e, bounds, k);
        if (sum > most) {
            most = sum;
            frame = k;
        }
    }
    return frame;
}

static pb_status estimate_run(estimate *e, const double *bounds, const pb_estimate_options *o, const double d[9],
                              const double corner[3], pb_track **track, pb_estimate_report *report)
{
    const int chosen = o->reference == PB_ESTIMATE_REFERENCE_AUTO;
    const size_t count = e->count;
    /* PETBLUR_ESTIMATE_ANCHOR=counts: under the estimate's choice, the passes
     * run against the frame of the most counts rather than frame 0, for
     * comparisons */
    const char *anchor_env = getenv("PETBLUR_ESTIMATE_ANCHOR");
    const size_t ref = !chosen ? o->reference
                               : anchor_env && strcmp(anchor_env, "counts") == 0 ? most_counts(e, bounds) : 0;
    pbe_fit *fits = calloc(count, sizeof *fits);
    int *moving = calloc(count, sizeof(int));
    frame_path *paths = calloc(count * PATHS, sizeof *paths);
    double *sides = calloc(4 * count, sizeof *sides);
    unsigned char *steps = calloc(count + 1, 1);
    int *jumped = calloc(count, sizeof(int));
    double *unfollowed = calloc(count, sizeof(double));
    float *moved = malloc(sizeof(float) * e->level[0].n * count), *own = malloc(sizeof(float) * e->level[0].n);
    double *gram = malloc(sizeof(double) * count * (PBE_REFERENCE_OTHERS + 1));
    /* a frame's keys: at most two a point of PATH_BACK, its steps from and
     * to its neighbours, and two at its end's jump; the series' ends */
    const size_t most_keys = count * (2 * BACK_POINTS + 4) + 2, most_curved = most_keys * PBE_CURVE_KEYS;
    keys k = {malloc(sizeof(double) * most_keys), malloc(sizeof(pb_pose) * most_keys), malloc(most_keys), 0};
    keys curved = {malloc(sizeof(double) * most_curved), malloc(sizeof(pb_pose) * most_curved), NULL, 0};
    size_t moving_count = 0;
    pb_status st = fits && moving && paths && sides && steps && jumped && unfollowed && moved && own && gram && k.t &&
                           k.p && k.middle && curved.t && curved.p
                       ? PB_OK
                       : PB_ERR_OUT_OF_MEMORY;
    for (size_t i = 0; i < count && fits; i++) {
        fits[i].pose.rotation[0] = 1.0;
        fits[i].scale = 1.0;
    }
    /* PETBLUR_ESTIMATE_OWN=0 or 1 runs pass 2 so many times, for
     * comparisons (at 0 the later passes' references are built from the
     * chain's poses, and the smoothing weighs them by the chain's fits) */
    const char *own_env = getenv("PETBLUR_ESTIMATE_OWN");
    const int rounds = own_env && (!strcmp(own_env, "0") || !strcmp(own_env, "1")) ? own_env[0] - '0' : 2;
    /* 1: along the chain of neighbours */
    if (st == PB_OK)
        st = register_chain(e, ref, fits, rounds == 0);
    /* 2: each frame against its own reference, twice (the second from
     * references moved back by better poses); the reference frame gets a
     * pose too, which is then taken out */
    for (int round = 0; round < rounds && st == PB_OK; round++)
        st = register_own(e, fits, moved, gram, own);
    if (rounds == 0 && st == PB_OK)
        st = frames_moved_back(e, fits, moved, gram);
    /* frames of noise alone: their poses are noise's, and their neighbours' paths are not to be built on them */
    if (st == PB_OK)
        st = hold_flat_frames(e, fits);
    /* the poses linked to a late frame by a measure the contrast does not
     * bias (pass 3's references stay pass 2's, its frames moved back by its
     * first round's poses: moved again by the linked poses they changed no
     * draw of 4 by more than 0.001 mm) */
    const int link = link_kind();
    if (st == PB_OK && link != LINK_NONE)
        st = link_by_information(e, fits, link);
    /* the still frames' poses, each as sure as its registration, together in time */
    if (st == PB_OK)
        st = smooth_still_poses(e, fits, bounds, ref, jumped);
    /* 3: inside frames, against the same references */
    if (st == PB_OK && !o->frame_poses_only)
        st = inside_frames(e, fits, ref, moved, gram, own, paths, moving, &moving_count, sides, unfollowed, jumped);
    if (st == PB_OK && !o->frame_poses_only && two_poses_tried())
        st = two_pose_frames(e, fits, moved, gram, own, paths, moving, &moving_count, unfollowed);
    if (st == PB_OK && !o->frame_poses_only)
        boundary_steps(e, moving, jumped, sides, steps);
    /* 4: every pose corrected along the contrast, together */
    if (st == PB_OK)
        st = correct_together(e, ref, fits, paths, moving);
    const size_t anchor = chosen && st == PB_OK ? best_anchor(e, fits, moving, unfollowed, bounds, ref) : ref;
    if (report)
        report->reference = anchor;
    if (st == PB_OK) {
        pb_pose back;
        pb_pose_invert(&fits[anchor].pose, &back);
        /* a moving first or last frame's keys reach the series' ends */
        if (!moving[0])
            key(&k, bounds[0], &fits[0].pose);
        for (size_t f = 0; f < count; f++) {
            if (moving[f]) {
                const frame_path *p = &paths[f * PATHS + (size_t)(moving[f] - 1)];
                double from = 0.0, to = 0.0;
                if (moving[f] - 1 == PATH_TWO) {
                    /* in place of a path, the still neighbours it stepped from and to */
                    const pb_pose held[2] = {p->start, p->end}, *before = NULL, *after = NULL;
                    double u[DWELL_POINTS];
                    int jumps[2];
                    if (p->replaced)
                        path_neighbours(e, fits, moving, jumped, sides, f, p->replaced - 1,
                                        &paths[f * PATHS + (size_t)(p->replaced - 1)], u, &before, &after, jumps);
                    hold_keys(&k, bounds[f], bounds[f + 1], held, p->dwell, 2, before, after, &from, &to);
                } else if (moving[f] - 1 == PATH_BACK)
                    back_keys(&k, bounds[f], bounds[f + 1], &p->start, &p->end, &fits[f + 1].pose, p->dwell, &from,
                              &to);
                else {
                    const pb_pose *before, *after;
                    double u[DWELL_POINTS];
                    int jumps[2];
                    path_neighbours(e, fits, moving, jumped, sides, f, moving[f] - 1, p, u, &before, &after, jumps);
                    path_keys(&k, bounds[f], bounds[f + 1], &p->start, &p->end, before, after, jumps, u, &from, &to);
                }
                if (o->frames) {
                    o->frames[f].motion_from = from;
                    o->frames[f].motion_to = to;
                }
            }
            else
                key_of(&k, mid_time(bounds[f], bounds[f + 1]), &fits[f].pose, 1);
            if (steps[f + 1]) {
                double h = 0.5 * STEP_FRACTION * fmin(bounds[f + 1] - bounds[f], bounds[f + 2] - bounds[f + 1]);
                key(&k, bounds[f + 1] - h, &fits[f].pose);
                key(&k, bounds[f + 1] + h, &fits[f + 1].pose);
            }
        }
        if (!moving[count - 1])
            key(&k, bounds[count], &fits[count - 1].pose);
        st = curve_keys(&k, &curved);
        for (size_t i = 0; i < curved.n && st == PB_OK; i++) {
            pb_pose rel;
            pb_pose_compose(&curved.p[i], &back, &rel);
            pb_pose_normalized(&rel, &rel);
            st = world_pose(d, corner, e->c, &rel, &curved.p[i]);
        }
        if (st == PB_OK)
            st = pb_track_create("the motion estimated from the frames", PB_TRACK_MATRIX_CSV, curved.t, curved.p,
                                 NULL, NULL, curved.n, track);
    }
    if (report)
        report->moving_frames = moving_count;
    for (size_t f = 0; f < count && o->frames && st == PB_OK; f++) {
        pb_estimate_frame *r = &o->frames[f];
        r->explained = fmin(1.0, fmax(0.0, pbe_explained(e->frames[0] + f * e->level[0].n, e->level[0].n,
                                                          fits[f].sse)));
        r->structure = !e->flat[f];
        r->moving = moving[f] != 0;
        r->jumped_at_start = steps[f] != 0;
        r->unfollowed = unfollowed[f];
        if (!moving[f]) /* a moving frame's times come with its keys */
            r->motion_from = r->motion_to = mid_time(bounds[f], bounds[f + 1]);
    }
    free(fits);
    free(moving);
    free(paths);
    free(sides);
    free(steps);
    free(jumped);
    free(unfollowed);
    free(moved);
    free(own);
    free(gram);
    free(k.t);
    free(k.p);
    free(k.middle);
    free(curved.t);
    free(curved.p);
    return st;
}

pb_status pb_motion_estimate(pb_context *ctx, const pb_geometry *geometry, const double affine[16],
                             const float *frames, size_t count, const double *bounds,
                             const pb_estimate_options *options, pb_track **track, pb_estimate_report *report)
{
    double started = now_seconds();
    if (track)
        *track = NULL;
    if (!ctx || !geometry || !frames || !bounds || !track)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "context, geometry, frames, bounds and track must not be NULL");
    if (report)
        memset(report, 0, sizeof *report);
    pb_estimate_options o = {0};
    if (options)
        o = *options;
    unsigned long serial = pb_error_serial();
    double grid_affine[16], d[9], corner[3];
    pb_status st = check_input(geometry, frames, count, bounds, &o);
    if (st == PB_OK && !affine) {
        pb_geometry_grid_affine(geometry, grid_affine);
        affine = grid_affine;
    }
    if (st == PB_OK)
        st = pb_affine_frame(geometry, affine, d, corner);
    if (st != PB_OK)
        return pb_error(ctx, st, "%s", pb_error_serial() != serial ? pb_last_error(NULL) : pb_status_string(st));
    if ((st = pb_context_enter(ctx)) != PB_OK)
        return st;

    estimate e;
    memset(&e, 0, sizeof e);
    e.ctx = ctx;
    e.g = *geometry;
    e.count = count;
    e.raw = frames;
    e.warnings = report ? &report->warnings : NULL;
    if (report)
        memset(&report->warnings, 0, sizeof report->warnings);
    if (!(e.flat = calloc(count, sizeof(int))) || !(e.noise = calloc(count, sizeof(double))))
        st = PB_ERR_OUT_OF_MEMORY;
    if (st == PB_OK)
        st = remove_background(&e);
    e.pool = pb_pool_create();
    e.iterations = o.iterations ? o.iterations : 12;
    e.fwhm = o.fwhm_mm;
    for (int a = 0; a < 3; a++)
        e.c[a] = 0.5 * (double)geometry->dims[a] * geometry->voxel_size[a];
    pb_geometry g = *geometry;
    e.levels = 1;
    for (;;) {
        pb_geometry c;
        pbe_coarser(&g, &c);
        size_t want = o.levels ? o.levels : 3;
        /* a level coarser than the volumes' largest voxel would be refused
         * deep in the registration, naming a size the caller never gave */
        int fits = c.dims[0] >= (o.levels ? 4 : 12) && c.dims[1] >= (o.levels ? 4 : 12) &&
                   c.dims[2] >= (o.levels ? 4 : 12) &&
                   fmax(c.voxel_size[0], fmax(c.voxel_size[1], c.voxel_size[2])) <= PB_MAX_VOXEL_MM;
        if (e.levels >= want || !fits)
            break;
        g = c;
        e.levels++;
    }
    /* the progress report hears this call's progress, not each blur's */
    e.progress = ctx->dev.progress;
    e.progress_user = ctx->dev.progress_user;
    ctx->dev.progress = NULL;
    /* progress in units of a frame's registration: passes 1 and 3 one a
     * frame, pass 2 two; pass 4, where its references have the images it
     * needs, about as long as the three together (24 frames on the host: 34
     * of 65 s), reported as it evaluates */
    e.together = (double)count * (pbe_reference_rank(count) >= 3 ? 4.0 : 1.0);
    e.total = (link_kind() != LINK_NONE ? 5.0 : 4.0) * (double)count + e.together;

    g = *geometry;
    for (size_t l = 0; l < e.levels && st == PB_OK; l++) {
        if (l > 0)
            pbe_coarser(&e.level[l - 1].g, &g);
        st = pbe_level_init(ctx, &e.level[l], &g, e.pool);
        if (st == PB_OK && !(e.frames[l] = malloc(sizeof(float) * e.level[l].n * count)))
            st = PB_ERR_OUT_OF_MEMORY;
    }
    if (st == PB_OK && (!(e.scratch = malloc(sizeof(float) * 2 * e.level[0].n)) ||
                        !(e.tmp = malloc(sizeof(float) * pbe_longest_side(geometry)))))
        st = PB_ERR_OUT_OF_MEMORY;
    for (size_t k = 0; k < count && st == PB_OK; k++) {
        float *levels[8];
        for (size_t l = 0; l < e.levels; l++)
            levels[l] = e.frames[l] + k * e.level[l].n;
        pyramid(&e, e.raw + k * e.level[0].n, levels);
    }
    if (st == PB_OK)
        st = estimate_run(&e, bounds, &o, d, corner, track, report);
    for (size_t l = 0; l < e.levels; l++) {
        pbe_level_free(&e.level[l]);
        free(e.frames[l]);
    }
    free(e.scratch);
    free(e.owned);
    free(e.known);
    free(e.flat);
    free(e.noise);
    free(e.tmp);
    pb_pool_destroy(e.pool);
    ctx->dev.progress = e.progress;
    ctx->dev.progress_user = e.progress_user;
    if (st == PB_OK && e.progress)
        e.progress(1.0, e.progress_user);
    if (st == PB_ERR_OUT_OF_MEMORY)
        pb_error(ctx, st, "out of host memory estimating motion from %zu frames of %zu x %zu x %zu voxels", count,
                 geometry->dims[0], geometry->dims[1], geometry->dims[2]);
    else if (st != PB_OK)
        failed(ctx, st, serial);
    if (report)
        report->seconds = now_seconds() - started;
    pb_context_leave(ctx);
    return st;
}
