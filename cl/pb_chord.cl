/* A short segment's exact reading: the chord cut at the trilinear filter's
 * kinks, and the trilinear cell that sums a path's pieces in a work item's
 * registers. The forward (pb_blur.cl) and the adjoint (pb_adjoint.cl) read
 * and scatter through these same helpers, so they stay each other's
 * transpose. Included by pb_blur.cl after pb_place. */

/* A voxel index from a floored texel coordinate, clamped so that paths far
 * outside the grid neither overflow int nor wrap into it. */
PB_FN int pb_voxel_index(float f)
{
    return (int)fmin(fmax(f, -2.0f), 16777216.0f);
}

/* Where the trilinear filter has its kinks: at texel centres (i + 0.5) along
 * each axis its slope jumps. The next fraction t > t0 at which p0 + t d
 * crosses a texel centre along one axis, or `none` where it does not move
 * along it; a crossing within PB_KINK_GAP voxels of the start is passed over,
 * so that rounding at a start on a centre makes no sliver and each call moves
 * on. */
#define PB_KINK_GAP 1e-4f
PB_FN float pb_next_kink(float p0, float d, float t0, float none)
{
    if (fabs(d) < 1e-6f)
        return none;
    float y = p0 + t0 * d - 0.5f;
    float n = d > 0.0f ? floor(y + PB_KINK_GAP) + 1.0f : ceil(y - PB_KINK_GAP) - 1.0f;
    return t0 + PB_DIV(n - y, d);
}

/* The chord a-b cut where any coordinate crosses a texel centre: inside each
 * piece the filter is a cubic along the chord (the product of three linear
 * weights). The body runs once a piece, with the chord's step pb_d, the
 * piece's start pb_t0 and length pb_l (fractions of the chord) in scope.
 * Pieces: one more than the centres crossed, about |b - a|_1 + 1; the cap
 * only guards against rounding. Variadic, so that a body may hold commas. */
#define PB_CHORD_PIECES(a, b, ...)                                                                               \
    {                                                                                                          \
        const float pb_d[3] = {(b)[0] - (a)[0], (b)[1] - (a)[1], (b)[2] - (a)[2]};                            \
        const int pb_cap = (int)(fabs(pb_d[0]) + fabs(pb_d[1]) + fabs(pb_d[2])) + 8;                           \
        float pb_t0 = 0.0f;                                                                                    \
        for (int pb_p = 0; pb_p < pb_cap && pb_t0 < 1.0f; pb_p++) {                                            \
            float pb_t1 = 1.0f;                                                                                \
            if (pb_p + 1 < pb_cap)                                                                             \
                for (int pb_i = 0; pb_i < 3; pb_i++)                                                           \
                    pb_t1 = fmin(pb_t1, pb_next_kink((a)[pb_i], pb_d[pb_i], pb_t0, 1.0f));                     \
            const float pb_l = pb_t1 - pb_t0;                                                                  \
            __VA_ARGS__;                                                                                       \
            pb_t0 = pb_t1;                                                                                     \
        }                                                                                                      \
    }

/* The filter's exact time average over the chord by sampling: two samples
 * in each piece, half its length each, at its Gauss-Legendre points (its
 * middle plus and minus 1/sqrt 12 of it), which integrate the piece's cubic
 * exactly. The body runs with a sample x, y, z and its weight q in scope;
 * the weights add up to 1. */
#define PB_GAUSS_OFFSET 0.28867513f
#define PB_CHORD_SAMPLES(a, b, ...)                                                                              \
    PB_CHORD_PIECES(a, b, for (int pb_g = -1; pb_g <= 1; pb_g += 2) {                                          \
        const float pb_t = pb_t0 + pb_l * (0.5f + (float)pb_g * PB_GAUSS_OFFSET);                              \
        const float x = (a)[0] + pb_t * pb_d[0];                                                               \
        const float y = (a)[1] + pb_t * pb_d[1];                                                               \
        const float z = (a)[2] + pb_t * pb_d[2];                                                               \
        const float q = 0.5f * pb_l;                                                                           \
        __VA_ARGS__;                                                                                           \
    })

/* Whether the chord a-b crosses no texel centre (PB_CHORD_PIECES makes one
 * piece of it): then it lies in one trilinear cell. */
PB_FN int pb_chord_in_one_cell(const float *a, const float *b)
{
    float t1 = 1.0f;
    for (int i = 0; i < 3; i++)
        t1 = fmin(t1, pb_next_kink(a[i], b[i] - a[i], 0.0f, 1.0f));
    return t1 >= 1.0f;
}

/* The trilinear cell of texels (i..i+1, j..j+1, k..k+1). Inside it the
 * filter is a polynomial in the fractions (x, y, z) with the terms 1, x, y,
 * z, xy, xz, yz and xyz, so a path's time average there is fixed by those
 * eight moments of its fractions, each weighed by its share of the frame. A
 * work item sums them while its path stays in the cell, and reads the cell's
 * eight texels once (the forward) or adds into them once (the adjoint) when
 * the path leaves it. Under a sub-voxel path (a still or drifting head) a
 * frame's path stays in one or two cells: eight point reads in all, where two
 * trilinear fetches a piece of every segment made about sixteen
 * (docs/methods.md). */
typedef struct pb_cell {
    int i, j, k, live;
    float m[8]; /* 1, x, y, z, xy, xz, yz, xyz */
} pb_cell;

/* The cell that holds texel coordinate c along one axis, and c's fraction
 * in it. */
PB_FN int pb_cell_axis(float c, float *f)
{
    float o = floor(c - 0.5f);
    *f = c - 0.5f - o;
    return pb_voxel_index(o);
}

/* Whether the path leaves the live cell for cell (i, j, k). */
PB_FN int pb_cell_leaves(const pb_cell *cell, int i, int j, int k)
{
    return cell->live && (i != cell->i || j != cell->j || k != cell->k);
}

/* Makes (i, j, k) the live cell, empty, unless it is already. */
PB_FN void pb_cell_enter(pb_cell *cell, int i, int j, int k)
{
    if (cell->live)
        return;
    cell->i = i;
    cell->j = j;
    cell->k = k;
    cell->live = 1;
    for (int c = 0; c < 8; c++)
        cell->m[c] = 0.0f;
}

/* A straight piece, uniform in time, with share q: its middle at fractions
 * (x, y, z) and its step s. Its moments are the middle's plus s_a s_b / 12 a
 * pair (the uniform's variance), and the product of three picks up each
 * pair's times the third coordinate's middle; a point is s = 0. */
PB_FN void pb_cell_add(pb_cell *cell, float x, float y, float z, const float *s, float q)
{
    const float cxy = s[0] * s[1] * (1.0f / 12.0f), cxz = s[0] * s[2] * (1.0f / 12.0f);
    const float cyz = s[1] * s[2] * (1.0f / 12.0f);
    cell->m[0] += q;
    cell->m[1] += q * x;
    cell->m[2] += q * y;
    cell->m[3] += q * z;
    cell->m[4] += q * (x * y + cxy);
    cell->m[5] += q * (x * z + cxz);
    cell->m[6] += q * (y * z + cyz);
    cell->m[7] += q * (x * y * z + x * cyz + y * cxz + z * cxy);
}

/* The eight texels' weights from the moments: corner c (bit 0 the upper x,
 * bit 1 y, bit 2 z) weighs the product of x or 1 - x, y or 1 - y, z or 1 - z,
 * expanded. */
PB_FN void pb_cell_weights(const pb_cell *cell, float *w)
{
    const float *m = cell->m;
    w[7] = m[7];
    w[3] = m[4] - m[7];
    w[5] = m[5] - m[7];
    w[6] = m[6] - m[7];
    w[1] = m[1] - m[4] - m[5] + m[7];
    w[2] = m[2] - m[4] - m[6] + m[7];
    w[4] = m[3] - m[5] - m[6] + m[7];
    w[0] = m[0] - m[1] - m[2] - m[3] + m[4] + m[5] + m[6] - m[7];
}

/* The forward's read of the live cell: its eight texels weighed, or 0 where
 * no cell is live. */
PB_FN float pb_cell_read(pb_image img, const pb_cell *cell)
{
    if (!cell->live)
        return 0.0f;
    float w[8], sum = 0.0f;
    pb_cell_weights(cell, w);
    for (int c = 0; c < 8; c++) {
        float x = (float)(cell->i + (c & 1)) + 0.5f, y = (float)(cell->j + ((c >> 1) & 1)) + 0.5f;
        float z = (float)(cell->k + (c >> 2)) + 0.5f;
        sum += w[c] * PB_FETCH_NEAREST(img, x, y, z);
    }
    return sum;
}

/* The chord a-b's exact time average, weighed by w, into the cells its
 * pieces lie in (each piece in the cell of its middle, placed by pl: a
 * mirror reverses a piece's step, which leaves its moments as they are).
 * LEAVE runs, with `cell` in scope, before the path moves on from a live
 * cell: the forward reads it, the adjoint adds it into the object. */
#define PB_CHORD_CELLS(cell, pl, a, b, w, LEAVE)                                                                 \
    PB_CHORD_PIECES(a, b, {                                                                                    \
        const float pb_mid = pb_t0 + 0.5f * pb_l;                                                              \
        float pb_c[3], pb_f[3], pb_s[3];                                                                       \
        int pb_o[3];                                                                                           \
        for (int pb_a = 0; pb_a < 3; pb_a++) {                                                                 \
            pb_c[pb_a] = (a)[pb_a] + pb_mid * pb_d[pb_a];                                                      \
            pb_s[pb_a] = pb_l * pb_d[pb_a];                                                                    \
        }                                                                                                      \
        pb_place_point(pl, &pb_c[0], &pb_c[1], &pb_c[2]);                                                      \
        for (int pb_a = 0; pb_a < 3; pb_a++)                                                                   \
            pb_o[pb_a] = pb_cell_axis(pb_c[pb_a], &pb_f[pb_a]);                                                \
        if (pb_cell_leaves(cell, pb_o[0], pb_o[1], pb_o[2])) {                                                 \
            LEAVE;                                                                                             \
            (cell)->live = 0;                                                                                  \
        }                                                                                                      \
        pb_cell_enter(cell, pb_o[0], pb_o[1], pb_o[2]);                                                        \
        pb_cell_add(cell, pb_f[0], pb_f[1], pb_f[2], pb_s, (w) * pb_l);                                        \
    })

/* The forward's exact average of a-b weighed by w: through the cell where
 * the kernel reads exact weights (each of its trilinear samples would be
 * eight point reads) or where the chord lies in one cell; else two trilinear
 * fetches a piece, the texture unit's (HARDWARE), which a chord that crosses
 * cells reads for fewer fetches than eight a cell. Returns what it read,
 * including any cell the path left. */
PB_FN float pb_chord(pb_image img, int exact, const pb_place *pl, pb_cell *cell, const float *a, const float *b,
                     float w)
{
    float sum = 0.0f;
    if (exact || pb_chord_in_one_cell(a, b)) {
        PB_CHORD_CELLS(cell, pl, a, b, w, sum += pb_cell_read(img, cell));
        return sum;
    }
    PB_CHORD_SAMPLES(a, b, sum += q * pb_placed_trilinear(img, 0, pl, x, y, z));
    return w * sum;
}
