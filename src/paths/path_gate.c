/* Planning a frame of a pose track that is a union of time intervals (an
 * amplitude or phase gate: every visit of the breath to a bin). Each
 * interval is planned as a frame of its own is (path_plan.c: key poses,
 * error bound, clipping, REF's steps), and the pieces are laid end to end:
 * their weights scaled by each interval's share of the gate, the segment
 * from one interval's end to the next one's start skipped. The kernels and
 * the host walk skipped segments not at all, so the blur is the
 * time-weighted mean of the intervals' blurs and the transpose stays the
 * forward's walk scattered. */
#include "path.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"
#include "numbers.h"

/* The intervals' order and their total time (refused: none, or one of no time). */
static pb_status gate_time(struct pb_context *ctx, const double *iv, size_t intervals, double *total)
{
    *total = 0.0;
    for (size_t i = 0; i < intervals; i++) {
        if (i > 0 && iv[2 * i] < iv[2 * i - 1])
            return pb_error(ctx, PB_ERR_BAD_FRAME, "interval %zu starts at %s s, before interval %zu ends at %s s; "
                            "a gate's intervals increase and do not overlap", i, PB_NUM(iv[2 * i]), i - 1,
                            PB_NUM(iv[2 * i - 1]));
        if (!(iv[2 * i + 1] > iv[2 * i]))
            return pb_error(ctx, PB_ERR_BAD_FRAME, "interval %zu ends at %s s, not after its start at %s s; give end > "
                            "start", i, PB_NUM(iv[2 * i + 1]), PB_NUM(iv[2 * i]));
        *total += iv[2 * i + 1] - iv[2 * i];
    }
    if (intervals == 0 || !isfinite(*total))
        return pb_error(ctx, PB_ERR_BAD_FRAME, "the frame's %zu intervals last %g s together; give at least one "
                        "interval, in seconds of a scan", intervals, *total);
    return PB_OK;
}

/* Lays piece onto the end of plan (plan->count poses, ref_count steps so
 * far), its weights times share; last: the gate's last piece, whose end
 * leads nowhere. Takes piece's arrays' contents; piece is destroyed. */
static pb_status append_piece(struct pb_context *ctx, pb_path *plan, pb_path *piece, double share, int last)
{
    size_t count = plan->count + piece->count, steps = plan->ref_count + piece->ref_count;
    if (count - 1 > PB_MAX_SEGMENTS) {
        pb_path_destroy(piece);
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "the gate's intervals hold %zu segments together, more than "
                        "the %d one blur walks; use AB or RM with a path error bound (which merges a log's samples), "
                        "or fewer intervals", count - 1, PB_MAX_SEGMENTS);
    }
    pb_path_pose *poses = realloc(plan->poses, count * sizeof *poses);
    if (poses)
        plan->poses = poses;
    pb_path_step *ref = steps ? realloc(plan->ref_steps, steps * sizeof *ref) : plan->ref_steps;
    if (steps && ref)
        plan->ref_steps = ref;
    if (!poses || (steps && !ref)) {
        pb_path_destroy(piece);
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for a gate's %zu key poses", count);
    }
    for (size_t j = 0; j < piece->count; j++) {
        pb_path_pose *p = &plan->poses[plan->count + j];
        *p = piece->poses[j];
        p->weight *= share;
        /* From this interval's end to the next one's start: a gap, not walked. */
        if (j + 1 == piece->count && !last)
            p->skip = 1;
    }
    for (size_t s = 0; s < piece->ref_count; s++) {
        plan->ref_steps[plan->ref_count + s] = piece->ref_steps[s];
        plan->ref_steps[plan->ref_count + s].weight *= share;
    }
    plan->count = count;
    plan->ref_count = steps;
    pb_path_destroy(piece);
    return PB_OK;
}

pb_status pb_path_create_gate(struct pb_context *ctx, const pb_geometry *g, const pb_motion *track,
                              const double *iv, size_t intervals, const pb_blur_options *opt, pb_path *plan)
{
    memset(plan, 0, sizeof *plan);
    double total;
    pb_status st = gate_time(ctx, iv, intervals, &total);
    if (st != PB_OK)
        return st;
    /* Each interval's walk is checked alone as it is planned; a gate of many
     * walks them all, summed as each is laid on, before REF's steps pile up. */
    double walked[3] = {0.0, 0.0, 0.0};
    for (size_t i = 0; i < intervals && st == PB_OK; i++) {
        pb_motion part, whole = *track;
        pb_path piece;
        /* Checked as a frame is cut, but planned on the whole track, as a
         * frame is: the plan reads only the samples inside and those about
         * its ends, and a short interval's tracker noise is measured on the
         * log about it (path_fit.c), which the cut would not hold. */
        whole.frame_start = iv[2 * i];
        whole.frame_end = iv[2 * i + 1];
        if ((st = pb_motion_frame(track, iv[2 * i], iv[2 * i + 1], &part)) == PB_OK &&
            (st = pb_path_create(ctx, g, &whole, opt, &piece)) == PB_OK) {
            if (intervals == 1) { /* a plain frame: the very plan pb_path_create made */
                *plan = piece;
                return PB_OK;
            }
            if (i == 0) {
                plan->geometry = piece.geometry;
                memcpy(plan->center, piece.center, sizeof plan->center);
            }
            if ((st = pb_path_check_walk(ctx, opt, &piece, walked)) != PB_OK)
                pb_path_destroy(&piece);
            else
                st = append_piece(ctx, plan, &piece, (iv[2 * i + 1] - iv[2 * i]) / total, i + 1 == intervals);
        }
        if (st != PB_OK && intervals > 1) {
            char where[64];
            snprintf(where, sizeof where, " (interval %zu of %zu)", i, intervals);
            pb_error_append(ctx, where);
        }
    }
    if (st != PB_OK)
        pb_path_destroy(plan);
    return st;
}
