/* A short segment's exact reading: the chord cut at the trilinear filter's
 * kinks, its samples, and the EXACT filter's read of a piece's cell. The
 * forward (pb_blur.cl) and the adjoint (pb_adjoint.cl) cut and sample
 * through these same helpers, so they stay each other's transpose. Included
 * by pb_blur.cl after pb_place. */

/* A voxel index from a floored texel coordinate, clamped so that paths far
 * outside the grid neither overflow int nor wrap into it. */
PB_FN int pb_voxel_index(float f)
{
    return (int)fmin(fmax(f, -2.0f), 16777216.0f);
}

/* Where the trilinear filter has its kinks: at texel centres (i + 0.5) along
 * each axis its slope jumps. The chord p0 + t d (t from 0 to 1) crosses them
 * along one axis at equal steps of 1 / |d|, so each axis keeps its next
 * crossing and steps on from it: no division a piece, where the three
 * divisions were about half of a piece's instructions (docs/methods.md). A
 * crossing within PB_KINK_GAP voxels of the start, or of a piece's end, is
 * passed over, so that rounding at a start on a centre makes no sliver; an
 * axis along which the chord does not move has its next crossing beyond the
 * end. */
#define PB_KINK_GAP 1e-4f
PB_FN void pb_kinks_init(float p0, float d, float *next, float *step)
{
    const float ad = fabs(d);
    /* Mirrored where the chord runs down the axis, so that one floor finds
     * the next centre either way: floor(z + gap) + 1 is ceil(y - gap) - 1
     * mirrored, the same floats. */
    const float z = d > 0.0f ? p0 - 0.5f : 0.5f - p0;
    const float to = floor(z + PB_KINK_GAP) + 1.0f - z;
    /* No crossing on this chord (or no motion along the axis): no reciprocal. */
    if (to >= ad || ad < 1e-6f) {
        *next = 2.0f;
        *step = 0.0f;
        return;
    }
    *step = PB_RCP(ad);
    *next = to * *step;
}

/* After a piece ending at t1: an axis whose crossing that was (or lies
 * within the gap of it) steps to its next. */
PB_FN void pb_kinks_pass(float t1, float *next, float step)
{
    if (*next <= t1 + PB_KINK_GAP * step)
        *next += step;
}

/* The chord a-b cut where any coordinate crosses a texel centre: inside each
 * piece the filter is a cubic along the chord (the product of three linear
 * weights). The body runs once a piece, with the chord's step pb_d, the
 * piece's start pb_t0 and length pb_l (fractions of the chord) in scope.
 * Pieces: one more than the centres crossed, about |b - a|_1 + 1; the cap
 * only guards against rounding. A body's commas must lie inside parentheses
 * (OpenCL C 1.2 has no variadic macros). */
#define PB_CHORD_PIECES(a, b, BODY)                                                                                    \
    {                                                                                                                  \
        const float pb_d[3] = {(b)[0] - (a)[0], (b)[1] - (a)[1], (b)[2] - (a)[2]};                                     \
        const int pb_cap = (int)(fabs(pb_d[0]) + fabs(pb_d[1]) + fabs(pb_d[2])) + 8;                                   \
        float pb_next[3], pb_step[3];                                                                                  \
        for (int pb_i = 0; pb_i < 3; pb_i++)                                                                           \
            pb_kinks_init((a)[pb_i], pb_d[pb_i], &pb_next[pb_i], &pb_step[pb_i]);                                      \
        float pb_t0 = 0.0f;                                                                                            \
        for (int pb_p = 0; pb_p < pb_cap && pb_t0 < 1.0f; pb_p++) {                                                    \
            const float pb_t1 =                                                                                        \
                pb_p + 1 < pb_cap ? fmin(fmin(pb_next[0], pb_next[1]), fmin(pb_next[2], 1.0f)) : 1.0f;                 \
            const float pb_l = pb_t1 - pb_t0;                                                                          \
            BODY;                                                                                                      \
            for (int pb_i = 0; pb_i < 3; pb_i++)                                                                       \
                pb_kinks_pass(pb_t1, &pb_next[pb_i], pb_step[pb_i]);                                                   \
            pb_t0 = pb_t1;                                                                                             \
        }                                                                                                              \
    }

/* The filter's exact time average over the chord by sampling: two samples
 * in each piece, half its length each, at its Gauss-Legendre points (its
 * middle plus and minus 1/sqrt 12 of it), which integrate the piece's cubic
 * exactly. The body runs with a sample x, y, z and its weight q in scope;
 * the weights add up to 1. */
#define PB_GAUSS_OFFSET 0.28867513f
#define PB_CHORD_SAMPLES(a, b, BODY)                                                                                   \
    PB_CHORD_PIECES(a, b, for (int pb_g = -1; pb_g <= 1; pb_g += 2) {                                                  \
        const float pb_t = pb_t0 + pb_l * (0.5f + (float)pb_g * PB_GAUSS_OFFSET);                                      \
        const float x = (a)[0] + pb_t * pb_d[0];                                                                       \
        const float y = (a)[1] + pb_t * pb_d[1];                                                                       \
        const float z = (a)[2] + pb_t * pb_d[2];                                                                       \
        const float q = 0.5f * pb_l;                                                                                   \
        BODY;                                                                                                          \
    })

/* A trilinear cell's eight weights (texel c at (i + (c & 1), j + (c >> 1 & 1),
 * k + (c >> 2))) from the moments of the fractions over what it averages or
 * scatters: m the sums of v, v fx, v fy, v fz, v fx fy, v fx fz, v fy fz and
 * v fx fy fz (v the time or the values), w[0] that of v (1 - fx)(1 - fy)(1 - fz)
 * and so on. The forward's exact piece (total 1) and the adjoint's cells
 * (pb_adjoint.cl) both take their weights here, so the two stay alike; the
 * differences of neighbouring sums are taken first, a small weight being a
 * difference of larger sums. */
PB_FN void pb_moment_weights(const float *m, float *w)
{
    w[7] = m[7];
    w[3] = m[4] - m[7];
    w[5] = m[5] - m[7];
    w[6] = m[6] - m[7];
    w[1] = (m[1] - m[4]) - w[5];
    w[2] = (m[2] - m[4]) - w[6];
    w[4] = (m[3] - m[5]) - w[6];
    w[0] = ((m[0] - m[1]) - (m[2] - m[4])) - ((m[3] - m[5]) - (m[6] - m[7]));
}

/* One piece's exact time average with the EXACT filter: inside the
 * trilinear cell of texels (i..i+1, j..j+1, k..k+1) that holds it the filter
 * is a polynomial in the fractions (x, y, z) with the terms 1, x, y, z, xy,
 * xz, yz and xyz, and a straight piece, uniform in time, has the moments of
 * its middle plus s_a s_b / 12 a pair (the uniform's variance, s its step),
 * the product of three picking up each pair's times the third coordinate's
 * middle. So the cell's eight texels, each read once and weighed by those
 * moments, give the exact average: eight point reads a piece, where its two
 * Gauss-Legendre samples took eight each. The piece runs from fraction t0 of
 * the chord a + t d, l long; the middle is placed (pb_place: a mirror
 * reverses the step, which leaves the moments as they are). A piece's cell
 * is read in step with the samples it replaces; why not one cell for a
 * path's pieces across segments: docs/methods.md. */
PB_FN float pb_piece_exact(pb_image img, const pb_place *pl, const float *a, const float *d, float t0, float l)
{
    const float mid = t0 + 0.5f * l;
    float x = a[0] + mid * d[0], y = a[1] + mid * d[1], z = a[2] + mid * d[2];
    pb_place_point(pl, &x, &y, &z);
    const float ox = floor(x - 0.5f), oy = floor(y - 0.5f), oz = floor(z - 0.5f);
    x -= ox + 0.5f;
    y -= oy + 0.5f;
    z -= oz + 0.5f;
    const float l2 = l * l * (1.0f / 12.0f);
    const float cxy = d[0] * d[1] * l2, cxz = d[0] * d[2] * l2, cyz = d[1] * d[2] * l2;
    const float m[8] = {1.0f, x, y, z, x * y + cxy, x * z + cxz, y * z + cyz,
                        x * y * z + x * cyz + y * cxz + z * cxy};
    float w[8];
    pb_moment_weights(m, w);
    float sum = 0.0f;
    for (int c = 0; c < 8; c++)
        sum += w[c] * PB_FETCH_NEAREST(img, ox + (float)(c & 1) + 0.5f, oy + (float)((c >> 1) & 1) + 0.5f,
                                       oz + (float)(c >> 2) + 0.5f);
    return sum;
}

/* The filter's exact time average over the chord a-b: with the EXACT
 * filter each piece's eight texels (pb_piece_exact); with HARDWARE the
 * texture unit's two samples a piece (PB_CHORD_SAMPLES), two trilinear
 * fetches where the cell's eight point reads would cost four. */
PB_FN float pb_chord(pb_image img, int exact, const pb_place *pl, const float *a, const float *b)
{
    float sum = 0.0f;
    if (exact) {
        PB_CHORD_PIECES(a, b, sum += pb_l * pb_piece_exact(img, pl, a, pb_d, pb_t0, pb_l));
        return sum;
    }
    PB_CHORD_SAMPLES(a, b, sum += q * pb_placed_trilinear(img, 0, pl, x, y, z));
    return sum;
}
