/* The kernels: one work item per tomograph-space voxel W (gather form, no
 * atomics). W's centre is mapped into object space at the key poses; the
 * methods differ in how they sample the object volume along the path.
 *
 * Compiled as OpenCL C (the library embeds this file with its includes inlined)
 * and as CUDA (cuda/ includes this very file); pb_shim.h is the only difference. */
#include "pb_shim.h"
#include "pb_kernel_types.h"

/* Object texel coordinates of tomograph texel coordinates u under a 3x4 map. */
PB_FN void pb_map_point(PB_GLOBAL_RO float *m, float ux, float uy, float uz, float *o)
{
    o[0] = m[0] * ux + m[1] * uy + m[2] * uz + m[3];
    o[1] = m[4] * ux + m[5] * uy + m[6] * uz + m[7];
    o[2] = m[8] * ux + m[9] * uy + m[10] * uz + m[11];
}

/* pb_map_point through a key pose's map, its rows read as three float4
 * (pb_kpose's 96 bytes keep them aligned). */
PB_FN void pb_map_pose(PB_GLOBAL_RO pb_kpose *p, float ux, float uy, float uz, float *o)
{
    const float4 r0 = PB_LOAD4(p->map), r1 = PB_LOAD4(p->map + 4), r2 = PB_LOAD4(p->map + 8);
    o[0] = r0.x * ux + r0.y * uy + r0.z * uz + r0.w;
    o[1] = r1.x * ux + r1.y * uy + r1.z * uz + r1.w;
    o[2] = r2.x * ux + r2.y * uy + r2.z * uz + r2.w;
}

/* Trilinear sample at texel coordinates: one linear fetch, or eight nearest
 * reads weighted in float. */
PB_FN float pb_trilinear(pb_image img, int exact, float x, float y, float z)
{
    if (!exact)
        return PB_FETCH_LINEAR(img, x, y, z);
    float cx = x - 0.5f, cy = y - 0.5f, cz = z - 0.5f;
    float x0 = floor(cx), y0 = floor(cy), z0 = floor(cz);
    float fx = cx - x0, fy = cy - y0, fz = cz - z0;
    x0 += 0.5f;
    y0 += 0.5f;
    z0 += 0.5f;
    float c00 = (1.0f - fx) * PB_FETCH_NEAREST(img, x0, y0, z0) + fx * PB_FETCH_NEAREST(img, x0 + 1.0f, y0, z0);
    float c10 = (1.0f - fx) * PB_FETCH_NEAREST(img, x0, y0 + 1.0f, z0) +
                fx * PB_FETCH_NEAREST(img, x0 + 1.0f, y0 + 1.0f, z0);
    float c01 = (1.0f - fx) * PB_FETCH_NEAREST(img, x0, y0, z0 + 1.0f) +
                fx * PB_FETCH_NEAREST(img, x0 + 1.0f, y0, z0 + 1.0f);
    float c11 = (1.0f - fx) * PB_FETCH_NEAREST(img, x0, y0 + 1.0f, z0 + 1.0f) +
                fx * PB_FETCH_NEAREST(img, x0 + 1.0f, y0 + 1.0f, z0 + 1.0f);
    return (1.0f - fz) * ((1.0f - fy) * c00 + fy * c10) + fz * ((1.0f - fy) * c01 + fy * c11);
}

/* Bilinear sample inside one slice, at texel coordinates whose major
 * coordinate is the slice's centre. HARDWARE: the trilinear fetch's weight along
 * the major axis is exactly 1 there, so the sampler's weights are AB's four
 * weights (the paper, section 3.2). EXACT: the same four voxels read and
 * weighted in float. */
PB_FN float pb_slice_sample(pb_image img, int exact, int major, float x, float y, float z)
{
    if (!exact)
        return PB_FETCH_LINEAR(img, x, y, z);
    /* The two transverse coordinates, in the order (t1, t2) = (major+1, major+2). */
    float c1 = (major == 0 ? y : (major == 1 ? z : x)) - 0.5f;
    float c2 = (major == 0 ? z : (major == 1 ? x : y)) - 0.5f;
    float i1 = floor(c1), i2 = floor(c2);
    float f1 = c1 - i1, f2 = c2 - i2;
    i1 += 0.5f;
    i2 += 0.5f;
    float v[4];
    for (int c = 0; c < 4; c++) {
        float t1 = i1 + (float)(c & 1), t2 = i2 + (float)(c >> 1);
        float px = major == 0 ? x : (major == 1 ? t2 : t1);
        float py = major == 0 ? t1 : (major == 1 ? y : t2);
        float pz = major == 0 ? t2 : (major == 1 ? t1 : z);
        v[c] = PB_FETCH_NEAREST(img, px, py, pz);
    }
    return (1.0f - f2) * ((1.0f - f1) * v[0] + f1 * v[1]) + f2 * ((1.0f - f1) * v[2] + f1 * v[3]);
}

/* Where a walk's samples are read. The general kernels walk voxel W's own path
 * and read where the walk lands (on = 0). Under a motion of translations only
 * every voxel's path is voxel 0's moved by whole voxels, so the shift-invariant
 * kernels (pb_shift.cl) walk voxel 0 and read at base + sign p: base W and sign
 * +1 for the forward; for the adjoint's gather base V + 1 and sign -1, voxel
 * 0's walk mirrored through V's centre (why that is the transpose: pb_shift.cl). */
typedef struct pb_place {
    int on;
    float base[3];
    float sign;
} pb_place;

PB_FN void pb_place_point(const pb_place *pl, float *x, float *y, float *z)
{
    if (pl->on) {
        *x = pl->base[0] + pl->sign * *x;
        *y = pl->base[1] + pl->sign * *y;
        *z = pl->base[2] + pl->sign * *z;
    }
}

PB_FN float pb_placed_trilinear(pb_image img, int exact, const pb_place *pl, float x, float y, float z)
{
    pb_place_point(pl, &x, &y, &z);
    return pb_trilinear(img, exact, x, y, z);
}

/* Mirroring keeps a slice centre a slice centre: base and k + 0.5 are whole
 * and half, so (base + 1) - (k + 0.5) is exact and half again. */
PB_FN float pb_placed_slice(pb_image img, int exact, const pb_place *pl, int major, float x, float y, float z)
{
    pb_place_point(pl, &x, &y, &z);
    return pb_slice_sample(img, exact, major, x, y, z);
}

/* The axis along which the segment a-b changes most (ties: the lower axis). */
PB_FN int pb_major_axis(float dx, float dy, float dz)
{
    float ax = fabs(dx), ay = fabs(dy), az = fabs(dz);
    int m = ay > ax ? 1 : 0;
    float am = ay > ax ? ay : ax;
    return az > am ? 2 : m;
}

/* Slices AB visits on a segment: those whose tent weight is not zero. */
PB_FN int pb_ab_slices(const float *a, const float *b)
{
    int m = pb_major_axis(b[0] - a[0], b[1] - a[1], b[2] - a[2]);
    float am = (m == 0 ? a[0] : (m == 1 ? a[1] : a[2])) - 0.5f;
    float bm = (m == 0 ? b[0] : (m == 1 ? b[1] : b[2])) - 0.5f;
    return (int)ceil(fmax(am, bm)) - (int)floor(fmin(am, bm)) + 1;
}

/* Share of a slice in a path [r0, r1] (relative to the slice's centre, in
 * voxels along the major axis): the integral of the tent 1 - |r|, which is the
 * overlap of the moving voxel with the slice. *mean receives the tent-weighted
 * mean of r, where the slice is sampled. Summed piecewise over the tent's two
 * linear halves (midpoint rule plus the exact moment correction) so that short
 * pieces lose no precision to cancellation. Free of branches: a half the piece
 * misses has length l = 0 and adds zero, so the sums are those that skipping
 * it gives, and a short path's walk is mostly this (docs/performance.md). */
PB_FN float pb_tent_share(float r0, float r1, float *mean)
{
    float p0 = fmax(r0, -1.0f), p1 = fmin(r1, 0.0f);
    float l = fmax(p1 - p0, 0.0f), c = 0.5f * (p0 + p1), t = 1.0f + c;
    float w = l * t, mo = l * (c * t + l * l * (1.0f / 12.0f));
    p0 = fmax(r0, 0.0f);
    p1 = fmin(r1, 1.0f);
    l = fmax(p1 - p0, 0.0f);
    c = 0.5f * (p0 + p1);
    t = 1.0f - c;
    w += l * t;
    mo += l * (c * t - l * l * (1.0f / 12.0f));
    int full = r0 <= -1.0f && r1 >= 1.0f;
    *mean = full || !(w > 0.0f) ? 0.0f : PB_DIV(mo, w);
    return full ? 1.0f : w;
}

/* The tent-weighted standard deviation of r over the same piece, given its
 * share w and mean (1 / sqrt 6 over the whole tent): about the mean, each
 * half's second moment about its own centre, its first moment's cross term
 * and its share times its centre's distance squared, so that short pieces
 * lose nothing to cancellation either. */
#define PB_TENT_SPREAD 0.40824829f
PB_FN float pb_tent_spread(float r0, float r1, float w, float mean)
{
    if (r0 <= -1.0f && r1 >= 1.0f)
        return PB_TENT_SPREAD;
    float m2 = 0.0f;
    for (int i = 0; i < 2; i++) {
        float p0 = i ? fmax(r0, 0.0f) : fmax(r0, -1.0f), p1 = i ? fmin(r1, 1.0f) : fmin(r1, 0.0f);
        if (p1 > p0) {
            float l = p1 - p0, c = 0.5f * (p0 + p1), t = i ? 1.0f - c : 1.0f + c, d = c - mean;
            float l3 = l * l * l * (1.0f / 12.0f);
            m2 += t * l3 + 2.0f * d * (i ? -l3 : l3) + d * d * l * t;
        }
    }
    return w > 0.0f && m2 > 0.0f ? sqrt(PB_DIV(m2, w)) : 0.0f;
}

/* AB reads a slice at the point where the path crosses its centre plane
 * (the paper's A_R = 0: the path's sideways sweep across the slice is not
 * seen). Where a path sweeps sideways by more than PB_AB_SWEEP_FROM voxels a
 * slice, the sweep kernels read the slice at two points of the
 * path instead, half each, at its tent-weighted mean plus and minus its
 * standard deviation: the two-point rule that keeps the tent's first three
 * moments, exact for a sample that varies quadratically along the sweep.
 * The points move apart from the mean as the sweep grows to
 * PB_AB_SWEEP_FULL, so that the blur is continuous in the motion.
 * docs/methods.md gives the measurement. */
#define PB_AB_SWEEP_FROM 0.125f
#define PB_AB_SWEEP_FULL 0.25f

/* Antialiased Bresenham walk along a-b (texel coordinates): one slice at a
 * time along the major axis, one sample per slice. Slice k is sampled on its
 * centre plane (major coordinate k + 0.5 exactly, so the filter's weight along
 * the major axis is 0 or 1) where the path crosses it; that point is linear in
 * k, C + k G. Slices the moving voxel covers fully have share 1; the at most two
 * partly covered slices at each end get their tent share and are sampled at the
 * share's weighted mean position, shifted along the path by H (G without its
 * major component). The forward gather and the adjoint's scatter both start
 * here, so they visit the same slices at the same points. */
typedef struct pb_ab_walk {
    int m;                 /* major axis */
    float lo, hi;          /* the path's extent along it, voxel k's centre at k */
    float g[3], c[3], h[3];
    int k0, k1;            /* every slice with a share */
    int f0, f1;            /* the fully covered ones (f0 = k1 + 1, f1 = k1: none) */
    int two;               /* two points a slice (PB_AB_SWEEP_FROM) */
    float apart;           /* their distance from the mean, in standard deviations */
} pb_ab_walk;

/* Sets up the walk along axis m, with two points a slice where sweep asks
 * for them and the path sweeps sideways enough; returns 1 when a-b is a
 * point there, which has no walk. */
PB_FN int pb_ab_walk_init_axis(const float *a, const float *b, int m, int sweep, pb_ab_walk *w)
{
    float am = (m == 0 ? a[0] : (m == 1 ? a[1] : a[2])) - 0.5f;
    float bm = (m == 0 ? b[0] : (m == 1 ? b[1] : b[2])) - 0.5f;
    w->m = m;
    w->lo = fmin(am, bm);
    w->hi = fmax(am, bm);
    if (w->hi - w->lo < 1e-4f)
        return 1;
    float inv = PB_DIV(1.0f, bm - am);
    /* G: the path's step per slice; C: its point on plane k = 0. */
    for (int i = 0; i < 3; i++) {
        float g = (b[i] - a[i]) * inv;
        w->h[i] = i == m ? 0.0f : g;
        w->g[i] = i == m ? 1.0f : g;
        w->c[i] = i == m ? 0.5f : a[i] - am * g;
    }
    float side = fmax(fabs(w->h[0]), fmax(fabs(w->h[1]), fabs(w->h[2])));
    w->two = sweep && side > PB_AB_SWEEP_FROM;
    w->apart = fmin(1.0f, (side - PB_AB_SWEEP_FROM) * (1.0f / (PB_AB_SWEEP_FULL - PB_AB_SWEEP_FROM)));
    w->k0 = (int)floor(w->lo);
    w->k1 = (int)ceil(w->hi);
    /* Fully covered slices: k - 1 >= lo and k + 1 <= hi. */
    w->f0 = (int)ceil(w->lo + 1.0f);
    w->f1 = (int)floor(w->hi - 1.0f);
    if (w->f1 < w->f0) {
        w->f0 = w->k1 + 1; /* none: the end-slice loop takes every slice */
        w->f1 = w->k1;
    }
    return 0;
}

/* The walk along the segment's own major axis. */
PB_FN int pb_ab_walk_init(const float *a, const float *b, int sweep, pb_ab_walk *w)
{
    return pb_ab_walk_init_axis(a, b, pb_major_axis(b[0] - a[0], b[1] - a[1], b[2] - a[2]), sweep, w);
}

/* The partly covered slices, k0 .. f0 - 1 and f1 + 1 .. k1 (at most two at
 * each end): how many, and the i-th of them in the walk's order, for the
 * loops of a fixed four that keep a short path's slices in registers
 * (pb_ab_segment, pb_ab_segment_adjoint). */
PB_FN int pb_ab_partial_count(const pb_ab_walk *w)
{
    return w->f0 - w->k0 + w->k1 - w->f1;
}

PB_FN float pb_ab_partial_slice(const pb_ab_walk *w, int i)
{
    int n0 = w->f0 - w->k0;
    return (float)(i < n0 ? w->k0 + i : w->f1 + 1 + i - n0);
}

/* The next partly covered slice after k: the loop over k0 .. f0 - 1 and
 * f1 + 1 .. k1 steps over the fully covered ones. */
PB_FN int pb_ab_next_partial(const pb_ab_walk *w, int k)
{
    return k + 1 == w->f0 ? w->f1 + 1 : k + 1;
}

/* The AB walk, written once, in two loops: PB_AB_FULL_SLICES visits the
 * fully covered slices (share 1; a loop of their own, free of branches, so the
 * compiler keeps several fetches in flight), PB_AB_PARTIAL_SLICES the partly
 * covered ones, with their share s. BODY runs with a sample point (x, y, z)
 * and its weight q within the slice in scope: once a slice with q = 1, or
 * twice with q = 1/2 where the walk takes two points. Its three callers
 * supply what happens there: the forward samples the 3-D image
 * (pb_ab_segment) or the layers (cl/pb_shift.cl), the adjoint scatters
 * (cl/pb_adjoint.cl); so all three visit the same slices at the same points
 * with the same shares. */
/* The point r voxels along the path from where it crosses slice kf's centre
 * plane, whose major coordinate stays the slice's centre (H has no major
 * component): x, y and z in scope. */
#define PB_AB_POINT(w, kf, r)                                                                                    \
    const float x = (kf) * (w).g[0] + (w).c[0] + (r) * (w).h[0];                                               \
    const float y = (kf) * (w).g[1] + (w).c[1] + (r) * (w).h[1];                                               \
    const float z = (kf) * (w).g[2] + (w).c[2] + (r) * (w).h[2]

/* The sweep's two points of slice kf, at mean - d and mean + d: BODY at each. */
#define PB_AB_TWO_POINTS(w, kf, mean, d, BODY)                                                                   \
    for (int pb_s = -1; pb_s <= 1; pb_s += 2) {                                                                \
        const float pb_r = (mean) + (float)pb_s * (d);                                                         \
        PB_AB_POINT(w, kf, pb_r);                                                                              \
        BODY;                                                                                                  \
    }

#define PB_AB_FULL_SLICES(w, BODY)                                                                               \
    if (!(w).two) {                                                                                            \
        for (int pb_k = (w).f0; pb_k <= (w).f1; pb_k++) {                                                     \
            const float pb_kf = (float)pb_k, q = 1.0f;                                                         \
            const float x = pb_kf * (w).g[0] + (w).c[0], y = pb_kf * (w).g[1] + (w).c[1];                      \
            const float z = pb_kf * (w).g[2] + (w).c[2];                                                       \
            BODY;                                                                                              \
        }                                                                                                      \
    } else {                                                                                                   \
        const float pb_d = (w).apart * PB_TENT_SPREAD;                                                         \
        for (int pb_k = (w).f0; pb_k <= (w).f1; pb_k++) {                                                     \
            const float pb_kf = (float)pb_k, q = 0.5f;                                                         \
            PB_AB_TWO_POINTS(w, pb_kf, 0.0f, pb_d, BODY)                                                       \
        }                                                                                                      \
    }

#define PB_AB_PARTIAL_SLICES(w, BODY)                                                                            \
    if (!(w).two) {                                                                                            \
        for (int pb_k = (w).k0; pb_k <= (w).k1; pb_k = pb_ab_next_partial(&(w), pb_k)) {                      \
            float pb_kf = (float)pb_k, pb_mean;                                                                \
            const float s = pb_tent_share((w).lo - pb_kf, (w).hi - pb_kf, &pb_mean), q = 1.0f;                \
            PB_AB_POINT(w, pb_kf, pb_mean);                                                                    \
            BODY;                                                                                              \
        }                                                                                                      \
    } else {                                                                                                   \
        for (int pb_k = (w).k0; pb_k <= (w).k1; pb_k = pb_ab_next_partial(&(w), pb_k)) {                      \
            float pb_kf = (float)pb_k, pb_mean;                                                                \
            const float s = pb_tent_share((w).lo - pb_kf, (w).hi - pb_kf, &pb_mean), q = 0.5f;                \
            const float pb_d = (w).apart * pb_tent_spread((w).lo - pb_kf, (w).hi - pb_kf, s, pb_mean);         \
            PB_AB_TWO_POINTS(w, pb_kf, pb_mean, pb_d, BODY)                                                    \
        }                                                                                                      \
    }

/* The segments of the polyline of the voxel centred at u (texel coordinates)
 * through the key poses: BODY runs with the segment's ends a and b (object
 * texel coordinates) and its index j in scope; segments clipped away
 * (src/paths/path_clip.c: weight 0) read nothing of the object and are skipped. */
#define PB_FOR_SEGMENTS(poses, prm, u, BODY)                                                                     \
    {                                                                                                          \
        float a[3], b[3];                                                                                      \
        pb_map_pose(&(poses)[0], (u)[0], (u)[1], (u)[2], b);                                                   \
        for (int j = 0; j < (prm).segments; j++) {                                                             \
            for (int pb_i = 0; pb_i < 3; pb_i++)                                                               \
                a[pb_i] = b[pb_i];                                                                             \
            pb_map_pose(&(poses)[j + 1], (u)[0], (u)[1], (u)[2], b);                                           \
            if ((poses)[j].weight == 0.0f)                                                                     \
                continue;                                                                                      \
            BODY;                                                                                              \
        }                                                                                                      \
    }

/* Piece r of a-b cut into `steps` equal pieces; the first starts at a and the
 * last ends at b exactly (with one piece, the usual case, that is all). */
PB_FN void pb_ab_piece(const float *a, const float *b, int r, int steps, float inv, float *pa, float *pb)
{
    for (int i = 0; i < 3; i++) {
        pa[i] = r == 0 ? a[i] : a[i] + (b[i] - a[i]) * ((float)r * inv);
        pb[i] = r + 1 == steps ? b[i] : a[i] + (b[i] - a[i]) * ((float)(r + 1) * inv);
    }
}

/* AB's sub-segments of a-b, `steps` of them, inv = 1 / steps: BODY runs once
 * per piece pa-pb. */
#define PB_FOR_PIECES(steps, inv, a, b, BODY)                                                                    \
    for (int pb_r = 0; pb_r < (steps); pb_r++) {                                                               \
        float pa[3], pb[3];                                                                                    \
        pb_ab_piece((a), (b), pb_r, (steps), (inv), pa, pb);                                                   \
        BODY;                                                                                                  \
    }

/* The midpoint of a-b, where a segment too short to walk (a point along its
 * major axis) is sampled: the tent weights of its two slices times the
 * bilinear weights are the trilinear weights, one fetch. */
PB_FN void pb_midpoint(const float *a, const float *b, float *o)
{
    for (int i = 0; i < 3; i++)
        o[i] = 0.5f * (a[i] + b[i]);
}

#include "pb_chord.cl"

/* AB's short segments. AB's one sample a slice misses the filter's kinks
 * across the slice; on a segment of a few voxels that is most of its error
 * (2-5 % of the largest value on sharp edges), while the exact average costs
 * only a few samples more. So a segment that moves at most PB_AB_EXACT_TO
 * voxels along its major axis is read exactly (pb_chord), one of at
 * least PB_AB_WALK_FROM by the paper's walk, and one between by both,
 * weighed linearly in its length, so that the blur stays continuous in the
 * motion (PB_AB_EXACT_TO and PB_AB_WALK_FROM: pb_kernel_types.h).
 * docs/methods.md gives the measurements. */
PB_FN float pb_ab_walk_weight(const float *a, const float *b)
{
    float along = fmax(fabs(b[0] - a[0]), fmax(fabs(b[1] - a[1]), fabs(b[2] - a[2])));
    if (along < 1e-4f)
        return 1.0f; /* a point: the walk reads it once, exactly */
    return fmin(1.0f, fmax(0.0f, (along - PB_AB_EXACT_TO) * (1.0f / (PB_AB_WALK_FROM - PB_AB_EXACT_TO))));
}

/* AB's walk over a-b through the 3-D image. The shares add up to the path length;
 * dividing by their float sum makes the weights sum to 1 exactly as the walk
 * computed them. */
PB_FN float pb_ab_walked(pb_image img, int exact, int sweep, const pb_place *pl, const float *a, const float *b)
{
    pb_ab_walk w;
    if (pb_ab_walk_init(a, b, sweep, &w)) {
        float o[3];
        pb_midpoint(a, b, o);
        return pb_placed_trilinear(img, exact, pl, o[0], o[1], o[2]);
    }
    float sum = 0.0f;
    PB_AB_FULL_SLICES(w, sum += q * pb_placed_slice(img, exact, pl, w.m, x, y, z));
    float wsum = (float)(w.f1 - w.f0 + 1);
    /* The partly covered slices, at most two at each end: with one point a
     * slice their fetches are made first and summed after, in the walk's
     * order, so that they are in flight together rather than one texture
     * latency each (a short path is nothing but these: ncu,
     * docs/performance.md). */
    int n = pb_ab_partial_count(&w);
    if (!w.two && n >= 0 && n <= 4) {
        float share[4], v[4];
        for (int i = 0; i < 4; i++) {
            share[i] = 0.0f;
            v[i] = 0.0f;
            if (i < n) {
                float kf = pb_ab_partial_slice(&w, i), mean;
                share[i] = pb_tent_share(w.lo - kf, w.hi - kf, &mean);
                PB_AB_POINT(w, kf, mean);
                v[i] = pb_placed_slice(img, exact, pl, w.m, x, y, z);
            }
        }
        for (int i = 0; i < 4; i++)
            if (i < n) {
                sum += share[i] * v[i];
                wsum += share[i];
            }
        return PB_DIV(sum, wsum);
    }
    PB_AB_PARTIAL_SLICES(w, sum += s * q * pb_placed_slice(img, exact, pl, w.m, x, y, z); wsum += s * q);
    return PB_DIV(sum, wsum);
}

/* AB over a-b through the 3-D image: exact, walked or both by its length
 * (pb_ab_walk_weight), or exact whatever its length (chord: prm.chord). */
PB_FN float pb_ab_segment(pb_image img, int exact, int sweep, int chord, const pb_place *pl, const float *a,
                          const float *b)
{
    float walk = chord ? 0.0f : pb_ab_walk_weight(a, b);
    if (walk == 1.0f)
        return pb_ab_walked(img, exact, sweep, pl, a, b);
    float sum = pb_chord(img, exact, pl, a, b);
    return walk == 0.0f ? sum : (1.0f - walk) * sum + walk * pb_ab_walked(img, exact, sweep, pl, a, b);
}

/* p' = R(q)^T p for a unit quaternion q = (w, v): p - 2w (v x p) + 2 v x (v x p). */
PB_FN void pb_rotate_inverse(const float *q, const float *p, float *o)
{
    float cx = q[2] * p[2] - q[3] * p[1], cy = q[3] * p[0] - q[1] * p[2], cz = q[1] * p[1] - q[2] * p[0];
    float ccx = q[2] * cz - q[3] * cy, ccy = q[3] * cx - q[1] * cz, ccz = q[1] * cy - q[2] * cx;
    o[0] = p[0] - 2.0f * q[0] * cx + 2.0f * ccx;
    o[1] = p[1] - 2.0f * q[0] * cy + 2.0f * ccy;
    o[2] = p[2] - 2.0f * q[0] * cz + 2.0f * ccz;
}

/* Classical motion blur's step: the pose at fraction s of segment p0-p1,
 * LERP of translations and SLERP of rotations, then W's centre u (texel
 * coordinates) into object texel coordinates. */
PB_FN void pb_classical_point(PB_GLOBAL_RO pb_kpose *p0, PB_GLOBAL_RO pb_kpose *p1, float s, pb_kparams prm,
                              const float *u, float *o)
{
    float wa = 1.0f - s, wb = s;
    if (p0->angle > 1e-4f) {
        /* sin((1 - s) A) / sin A = cos sA - cos A sin sA / sin A: one sincos a
         * step. An absolute error e in wa or wb turns the pose by about e A,
         * so the cancellation near s = 1 costs nothing that matters. */
        float c, sn = PB_SINCOS(s * p0->angle, &c);
        wb = sn * p0->inv_sin_angle;
        wa = c - p0->cos_angle * wb;
    }
    float q[4], n = 0.0f;
    for (int i = 0; i < 4; i++) {
        q[i] = wa * p0->rotation[i] + wb * p1->rotation[i];
        n += q[i] * q[i];
    }
    n = PB_RSQRT(n);
    for (int i = 0; i < 4; i++)
        q[i] *= n;
    float d[3], r[3];
    for (int i = 0; i < 3; i++)
        d[i] = u[i] * prm.voxel[i] - prm.center[i] - ((1.0f - s) * p0->translation[i] + s * p1->translation[i]);
    pb_rotate_inverse(q, d, r);
    for (int i = 0; i < 3; i++)
        o[i] = (r[i] + prm.center[i]) * prm.inv_voxel[i];
}

/* The middle of step i of a segment cut into n, as a fraction of it: a
 * multiply by 1 / n, which the caller divides once a segment, not once a
 * step. The forward and the adjoint both step through here. */
PB_FN float pb_step_fraction(int i, float inv_n)
{
    return ((float)i + 0.5f) * inv_n;
}

/* AB over one segment, split into prm.steps equal sub-segments; sweep: two
 * points a slice where the path sweeps sideways (a literal in each kernel). */
PB_FN float pb_ab_sampled(pb_image img, pb_kparams prm, int exact, int sweep, const pb_place *pl, const float *a,
                          const float *b)
{
    if (prm.steps == 1) /* the usual case: no pieces, no division */
        return pb_ab_segment(img, exact, sweep, prm.chord, pl, a, b);
    float sum = 0.0f, inv = 1.0f / (float)prm.steps;
    PB_FOR_PIECES(prm.steps, inv, a, b, sum += pb_ab_segment(img, exact, sweep, prm.chord, pl, pa, pb));
    return sum * inv;
}

/* RM's S equidistant trilinear samples of a-b. */
PB_FN float pb_rm_equidistant(pb_image img, int n, int exact, const pb_place *pl, const float *a, const float *b)
{
    float sum = 0.0f, inv_n = 1.0f / (float)n;
    for (int i = 0; i < n; i++) {
        float s = pb_step_fraction(i, inv_n);
        sum += pb_placed_trilinear(img, exact, pl, a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1]),
                                   a[2] + s * (b[2] - a[2]));
    }
    return sum * inv_n;
}

/* RM over one segment: prm.steps equidistant samples where the caller asks
 * for a count (the paper's RM); by default AB's rule by length
 * (pb_ab_walk_weight): a short segment's exact average over the chord, a
 * long one's S = AB's slices equidistant samples (the paper's choice), both
 * weighed between. */
PB_FN float pb_rm_sampled(pb_image img, pb_kparams prm, int exact, const pb_place *pl, const float *a,
                          const float *b)
{
    if (prm.steps > 0)
        return pb_rm_equidistant(img, prm.steps, exact, pl, a, b);
    float walk = pb_ab_walk_weight(a, b);
    if (walk == 1.0f)
        return pb_rm_equidistant(img, pb_ab_slices(a, b), exact, pl, a, b);
    float sum = pb_chord(img, exact, pl, a, b);
    return walk == 0.0f ? sum
                        : (1.0f - walk) * sum + walk * pb_rm_equidistant(img, pb_ab_slices(a, b), exact, pl, a, b);
}

/* The polyline methods: the object-space path of the voxel centred at u (texel
 * coordinates) through the key poses, one straight segment per pair, each
 * weighed by its share of the frame. ab: 0 RM, 1 AB, PB_AB_SWEEP AB with two
 * points a slice where the path sweeps sideways; a literal in each kernel, so
 * that the paper's AB carries none of the sweep's code or registers. */
#define PB_AB_SWEEP 2
PB_FN float pb_polyline(pb_image img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, const float *u,
                        const pb_place *pl, int ab, int exact)
{
    float total = 0.0f;
    /* AB of one sub-segment, the usual case, decided once a voxel rather than
     * at every segment (the check was a few of a short segment's hundred
     * instructions, docs/methods.md). */
    if (ab && prm.steps == 1) {
        PB_FOR_SEGMENTS(poses, prm, u,
                        total += poses[j].weight *
                                 pb_ab_segment(img, exact, ab == PB_AB_SWEEP, prm.chord, pl, a, b));
        return total;
    }
    PB_FOR_SEGMENTS(poses, prm, u,
                    total += poses[j].weight * (ab ? pb_ab_sampled(img, prm, exact, ab == PB_AB_SWEEP, pl, a, b)
                                                   : pb_rm_sampled(img, prm, exact, pl, a, b)));
    return total;
}

/* Classical motion blur's steps on segment j: prm.steps, or as many as AB has
 * slices between the segment's end points. */
PB_FN int pb_classical_steps(PB_GLOBAL_RO pb_kpose *poses, int j, pb_kparams prm, const float *u)
{
    if (prm.steps > 0)
        return prm.steps;
    float a[3], b[3];
    pb_map_pose(&poses[j], u[0], u[1], u[2], a);
    pb_map_pose(&poses[j + 1], u[0], u[1], u[2], b);
    return pb_ab_slices(a, b);
}

/* Classical motion blur: the pose interpolated at every step. */
PB_FN float pb_classical(pb_image img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, const float *u,
                         const pb_place *pl, int exact)
{
    float total = 0.0f;
    for (int j = 0; j < prm.segments; j++) {
        if (poses[j].weight == 0.0f) /* clipped */
            continue;
        int n = pb_classical_steps(poses, j, prm, u);
        float seg = 0.0f, inv_n = 1.0f / (float)n;
        for (int i = 0; i < n; i++) {
            float o[3];
            pb_classical_point(&poses[j], &poses[j + 1], pb_step_fraction(i, inv_n), prm, u, o);
            seg += pb_placed_trilinear(img, exact, pl, o[0], o[1], o[2]);
        }
        total += poses[j].weight * seg * inv_n;
    }
    return total;
}

/* One kernel per method and filter: the filter is a compile-time constant in
 * each, so a HARDWARE kernel carries none of EXACT's code or registers (more
 * threads in flight to hide texture latency). Each has its row in cl/pb_kernel_table.h. */
#define PB_IN_GRID(ix, iy, iz) ((ix) < prm.dims[0] && (iy) < prm.dims[1] && (iz) < prm.dims[2])
#define PB_OUT(ix, iy, iz) out[(ix) + prm.dims[0] * ((iy) + prm.dims[1] * (iz))]
/* W's own centre, and reads where its walk lands. */
#define PB_OWN_VOXEL                                                                                             \
    float u[3] = {(float)ix + 0.5f, (float)iy + 0.5f, (float)iz + 0.5f};                                       \
    pb_place pl = {0, {0.0f, 0.0f, 0.0f}, 1.0f}

PB_KERNEL_FULL void pb_blur_ab(pb_image img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, PB_GLOBAL float *out)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;
    if (!PB_IN_GRID(ix, iy, iz))
        return;
    PB_OWN_VOXEL;
    PB_OUT(ix, iy, iz) = pb_polyline(img, poses, prm, u, &pl, 1, 0);
}

PB_KERNEL void pb_blur_ab_exact(pb_image img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, PB_GLOBAL float *out)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;
    if (!PB_IN_GRID(ix, iy, iz))
        return;
    PB_OWN_VOXEL;
    PB_OUT(ix, iy, iz) = pb_polyline(img, poses, prm, u, &pl, 1, 1);
}

PB_KERNEL void pb_blur_ab_sweep(pb_image img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, PB_GLOBAL float *out)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;
    if (!PB_IN_GRID(ix, iy, iz))
        return;
    PB_OWN_VOXEL;
    PB_OUT(ix, iy, iz) = pb_polyline(img, poses, prm, u, &pl, PB_AB_SWEEP, 0);
}

PB_KERNEL void pb_blur_ab_sweep_exact(pb_image img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm,
                                      PB_GLOBAL float *out)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;
    if (!PB_IN_GRID(ix, iy, iz))
        return;
    PB_OWN_VOXEL;
    PB_OUT(ix, iy, iz) = pb_polyline(img, poses, prm, u, &pl, PB_AB_SWEEP, 1);
}

PB_KERNEL void pb_blur_rm(pb_image img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, PB_GLOBAL float *out)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;
    if (!PB_IN_GRID(ix, iy, iz))
        return;
    PB_OWN_VOXEL;
    PB_OUT(ix, iy, iz) = pb_polyline(img, poses, prm, u, &pl, 0, 0);
}

PB_KERNEL void pb_blur_rm_exact(pb_image img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, PB_GLOBAL float *out)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;
    if (!PB_IN_GRID(ix, iy, iz))
        return;
    PB_OWN_VOXEL;
    PB_OUT(ix, iy, iz) = pb_polyline(img, poses, prm, u, &pl, 0, 1);
}

PB_KERNEL void pb_blur_cl(pb_image img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, PB_GLOBAL float *out)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;
    if (!PB_IN_GRID(ix, iy, iz))
        return;
    PB_OWN_VOXEL;
    PB_OUT(ix, iy, iz) = pb_classical(img, poses, prm, u, &pl, 0);
}

PB_KERNEL void pb_blur_cl_exact(pb_image img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, PB_GLOBAL float *out)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;
    if (!PB_IN_GRID(ix, iy, iz))
        return;
    PB_OWN_VOXEL;
    PB_OUT(ix, iy, iz) = pb_classical(img, poses, prm, u, &pl, 1);
}

/* REF's random point c inside a tomograph voxel, in object texel coordinates:
 * the step's map m applied to the voxel's corner (base, once per step, so the
 * small in-voxel offsets keep their precision) plus the mapped offset. */
PB_FN void pb_ref_point(PB_GLOBAL_RO float *m, const float *base, unsigned int key, unsigned int c, float *o)
{
    const float scale = 1.0f / 16777216.0f;
    float px = ((float)pb_ref_bits(key, c, 0u) + 0.5f) * scale;
    float py = ((float)pb_ref_bits(key, c, 1u) + 0.5f) * scale;
    float pz = ((float)pb_ref_bits(key, c, 2u) + 0.5f) * scale;
    o[0] = base[0] + m[0] * px + m[1] * py + m[2] * pz;
    o[1] = base[1] + m[4] * px + m[5] * py + m[6] * pz;
    o[2] = base[2] + m[8] * px + m[9] * py + m[10] * pz;
}

/* The reference: dense time steps, and at each, ref_points random points inside
 * W, each reading the object voxel that holds it (box model). */
PB_KERNEL void pb_blur_ref(pb_image img, PB_GLOBAL_RO pb_kstep *steps, pb_kparams prm, PB_GLOBAL float *out)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;
    if (ix >= prm.dims[0] || iy >= prm.dims[1] || iz >= prm.dims[2])
        return;
    int voxel = ix + prm.dims[0] * (iy + prm.dims[1] * iz);
    unsigned int key = pb_ref_key(prm.seed, (unsigned int)voxel);
    float total = 0.0f;
    for (int s = 0; s < prm.ref_steps; s++) {
        PB_GLOBAL_RO float *m = steps[s].map;
        /* The voxel's corner once, the small in-voxel offsets per point, so the
         * offsets keep their precision. */
        float base[3];
        pb_map_point(m, (float)ix, (float)iy, (float)iz, base);
        float acc = 0.0f;
        for (int k = 0; k < prm.ref_points; k++) {
            float o[3];
            pb_ref_point(m, base, key, (unsigned int)(s * prm.ref_points + k), o);
            acc += PB_FETCH_NEAREST(img, o[0], o[1], o[2]);
        }
        total += steps[s].weight * acc / (float)prm.ref_points;
    }
    out[voxel] = total;
}

#include "pb_adjoint.cl"
#include "pb_shift.cl"
#include "pb_taps.cl"
#include "pb_field.cl"
