/* The adjoint kernels: the transpose of the forward kernels in pb_blur.cl, for
 * back projection. One work item per tomograph voxel W walks W's path exactly
 * as the forward gather does (the same walk set-up, the same shares, the same
 * sample points) and adds y[W] times each weight into the object voxels the
 * forward would have read, with atomic adds.
 *
 * Why a scatter and not a gather: a gather per object voxel V would have to
 * find every W whose path passes near V (V's own path, mapped forward) and
 * then rebuild each such W's walk to learn its weight on V, that is about S
 * candidate walks of S slices each, S^2 work per voxel against the scatter's
 * S. Even with a fixed step count (RM and CL with steps > 0, where sample i of
 * every W lies on one affine map of W) a gather would map and weigh every
 * tomograph voxel in the box around each of V's n preimages, 8 under no turn
 * and dozens under an oblique one, where the scatter makes 8 adds a sample.
 * The scatter's price is its atomics: under
 * rotations they, not the texture unit, bound the adjoint (docs/performance.md).
 *
 * Weights are the forward's: computed in float as the EXACT filter computes
 * them, and for the HARDWARE filter on NVIDIA rounded per axis as its texture
 * unit rounds them (prm.weight_steps). That is as close as a scatter gets to
 * the forward the GPU ran: the unit's 3-D blend itself is not the exact
 * product of its rounded weights (tests/test_adjoint.c). */

/* An interpolation weight as the forward used it: f itself, or f rounded to
 * the texture unit's nearest step, ties up (measured: bench/texture_rounding.cu).
 * Rounding the fraction of x - 0.5 gives the same pair of weights as rounding
 * x - 0.5 itself to fixed point: a fraction that rounds up to 1 puts all the
 * weight on the upper voxel either way. */
PB_FN float pb_texture_weight(float f, pb_kparams prm)
{
    return prm.weight_steps > 0.0f ? floor(f * prm.weight_steps + 0.5f) * prm.weight_step : f;
}

/* Adds v into object voxel (i, j, k); outside the grid the forward read zero,
 * so the transpose drops it. */
PB_FN void pb_scatter(PB_GLOBAL float *out, pb_kparams prm, int i, int j, int k, float v)
{
    if (v != 0.0f && i >= 0 && j >= 0 && k >= 0 && i < prm.dims[0] && j < prm.dims[1] && k < prm.dims[2])
        PB_ATOMIC_ADD(&out[i + prm.dims[0] * (j + prm.dims[1] * k)], v);
}

/* Transpose of pb_trilinear: v spread over the eight voxels around (x, y, z). */
PB_FN void pb_trilinear_scatter(PB_GLOBAL float *out, pb_kparams prm, float x, float y, float z, float v)
{
    float cx = x - 0.5f, cy = y - 0.5f, cz = z - 0.5f;
    float x0 = floor(cx), y0 = floor(cy), z0 = floor(cz);
    float fx = pb_texture_weight(cx - x0, prm), fy = pb_texture_weight(cy - y0, prm);
    float fz = pb_texture_weight(cz - z0, prm);
    int i = pb_voxel_index(x0), j = pb_voxel_index(y0), k = pb_voxel_index(z0);
    for (int c = 0; c < 8; c++) {
        float w = ((c & 1) ? fx : 1.0f - fx) * ((c & 2) ? fy : 1.0f - fy) * ((c & 4) ? fz : 1.0f - fz);
        pb_scatter(out, prm, i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2), v * w);
    }
}

/* The eight voxels of one trilinear cell, summed in the work item's registers
 * while its samples stay in that cell, and added to the object once when a
 * sample leaves it (and at the end of the path). Under a sub-voxel path (a
 * still or drifting head) the exact chord's samples fall in one or two cells,
 * and scattered one by one each cost eight atomic adds (issue 46's drift,
 * a dense input: 38.4 ms so, 15.9 ms by cells; docs/performance.md).
 * The cell sums its samples' moments, not their eight weights: with f the
 * fractions (rounded as the forward's texture unit rounds them), m holds the
 * sums of v, v fx, v fy, v fz, v fx fy, v fx fz, v fy fz and v fx fy fz
 * (three products and eight adds a sample, four of them fused, where the
 * weights took twelve products, three subtractions and eight adds), and the
 * flush turns them into the eight weights as the forward's exact piece does
 * (pb_moment_weights): the same sums to float rounding of the cell's total
 * (a small weight is a difference of larger sums).
 * On a dense input the scatter is bound by issuing instructions, not by its
 * adds (docs/performance.md). The origin is held as the floored floats it is
 * found from, so that a piece's cell is told by three compares; the flush
 * alone makes the voxel indices. */
typedef struct pb_cell {
    float x0, y0, z0;
    int live;
    float m[8];
} pb_cell;

PB_FN void pb_cell_flush(PB_GLOBAL float *out, pb_kparams prm, pb_cell *cell)
{
    if (!cell->live)
        return;
    cell->live = 0;
    float w[8];
    pb_moment_weights(cell->m, w);
    const int i = pb_voxel_index(cell->x0), j = pb_voxel_index(cell->y0), k = pb_voxel_index(cell->z0);
    /* The usual case, the whole cell inside the grid: one bounds check and
     * one address for its eight adds, not eight (docs/methods.md has what the
     * checks cost). A weight of exactly 0 is not added: under a turn about an
     * axis every sample lies on a slice centre along it, half the weights
     * are 0, and their adds doubled the scatter's time (bench/gpu.sh
     * adjoints; a fraction of exactly 0 or 1 gives weights of exactly 0
     * from the moments too). */
    if (i >= 0 && j >= 0 && k >= 0 && i + 1 < prm.dims[0] && j + 1 < prm.dims[1] && k + 1 < prm.dims[2]) {
        const int sy = prm.dims[0], sz = prm.dims[0] * prm.dims[1];
        PB_GLOBAL float *p = out + (i + sy * (j + prm.dims[1] * k));
        for (int c = 0; c < 8; c++)
            if (w[c] != 0.0f)
                PB_ATOMIC_ADD(p + ((c & 1) + ((c >> 1) & 1) * sy + (c >> 2) * sz), w[c]);
        return;
    }
    for (int c = 0; c < 8; c++)
        pb_scatter(out, prm, i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2), w[c]);
}

/* The cell whose eight voxels are (i..i+1, j..j+1, k..k+1), from its
 * floored origin: the one held, or a new one (the held one added first). */
PB_FN void pb_cell_enter(PB_GLOBAL float *out, pb_kparams prm, pb_cell *cell, float x0, float y0, float z0)
{
    if (!cell->live || x0 != cell->x0 || y0 != cell->y0 || z0 != cell->z0) {
        pb_cell_flush(out, prm, cell);
        cell->x0 = x0;
        cell->y0 = y0;
        cell->z0 = z0;
        cell->live = 1;
        for (int c = 0; c < 8; c++)
            cell->m[c] = 0.0f;
    }
}

/* v at (x, y, z) into the held cell of origin (x0, y0, z0): the moments of
 * the weights pb_trilinear_scatter gives where the point lies in that cell. */
PB_FN void pb_cell_add(pb_kparams prm, pb_cell *cell, float x0, float y0, float z0, float x, float y, float z,
                       float v)
{
    const float fx = pb_texture_weight(x - 0.5f - x0, prm), fy = pb_texture_weight(y - 0.5f - y0, prm);
    const float fz = pb_texture_weight(z - 0.5f - z0, prm);
    const float vx = v * fx, vy = v * fy, vxy = vx * fy;
    cell->m[0] += v;
    cell->m[1] += vx;
    cell->m[2] += vy;
    cell->m[3] += v * fz;
    cell->m[4] += vxy;
    cell->m[5] += vx * fz;
    cell->m[6] += vy * fz;
    cell->m[7] += vxy * fz;
}

/* pb_trilinear_scatter through the cell. */
PB_FN void pb_cell_scatter(PB_GLOBAL float *out, pb_kparams prm, pb_cell *cell, float x, float y, float z, float v)
{
    float x0 = floor(x - 0.5f), y0 = floor(y - 0.5f), z0 = floor(z - 0.5f);
    pb_cell_enter(out, prm, cell, x0, y0, z0);
    pb_cell_add(prm, cell, x0, y0, z0, x, y, z, v);
}

/* Transpose of a piece of the exact chord (PB_CHORD_SAMPLES's two samples,
 * from t0, l long, of a + t d), v its share: a piece lies between kinks,
 * inside one trilinear cell, so the cell is found once, at its middle. A
 * sample that rounding puts a hair across the cell's face has a weight a hair
 * below 0 or above 1 there, the same adds to float rounding (and, rounded to
 * the texture unit's steps, the same adds). */
PB_FN void pb_cell_piece(PB_GLOBAL float *out, pb_kparams prm, pb_cell *cell, const float *a, const float *d,
                         float t0, float l, float v)
{
    const float mid = t0 + 0.5f * l;
    const float x0 = floor(a[0] + mid * d[0] - 0.5f), y0 = floor(a[1] + mid * d[1] - 0.5f);
    const float z0 = floor(a[2] + mid * d[2] - 0.5f);
    pb_cell_enter(out, prm, cell, x0, y0, z0);
    for (int g = -1; g <= 1; g += 2) {
        const float t = t0 + l * (0.5f + (float)g * PB_GAUSS_OFFSET);
        pb_cell_add(prm, cell, x0, y0, z0, a[0] + t * d[0], a[1] + t * d[1], a[2] + t * d[2], v * (0.5f * l));
    }
}

/* Transpose of pb_slice_sample: v spread over the four voxels of the slice
 * around the point, whose major coordinate is the slice's centre. */
PB_FN void pb_slice_scatter(PB_GLOBAL float *out, pb_kparams prm, int major, float x, float y, float z, float v)
{
    int km = pb_voxel_index(floor(major == 0 ? x : (major == 1 ? y : z)));
    float c1 = (major == 0 ? y : (major == 1 ? z : x)) - 0.5f;
    float c2 = (major == 0 ? z : (major == 1 ? x : y)) - 0.5f;
    float i1 = floor(c1), i2 = floor(c2);
    float f1 = pb_texture_weight(c1 - i1, prm), f2 = pb_texture_weight(c2 - i2, prm);
    /* The usual case, the four voxels inside the grid: one bounds check for
     * them, not one each (the scatter is bound by its instructions: ncu,
     * docs/performance.md). The same adds at the same addresses. */
    int j1 = pb_voxel_index(i1), j2 = pb_voxel_index(i2);
    int dm = major == 0 ? prm.dims[0] : (major == 1 ? prm.dims[1] : prm.dims[2]);
    int d1 = major == 0 ? prm.dims[1] : (major == 1 ? prm.dims[2] : prm.dims[0]);
    int d2 = major == 0 ? prm.dims[2] : (major == 1 ? prm.dims[0] : prm.dims[1]);
    if (km >= 0 && km < dm && j1 >= 0 && j1 + 1 < d1 && j2 >= 0 && j2 + 1 < d2) {
        int plane = prm.dims[0] * prm.dims[1];
        int s1 = major == 0 ? prm.dims[0] : (major == 1 ? plane : 1);
        int s2 = major == 0 ? plane : (major == 1 ? 1 : prm.dims[0]);
        int px = major == 0 ? km : (major == 1 ? j2 : j1);
        int py = major == 0 ? j1 : (major == 1 ? km : j2);
        int pz = major == 0 ? j2 : (major == 1 ? j1 : km);
        int base = px + prm.dims[0] * (py + prm.dims[1] * pz);
        for (int c = 0; c < 4; c++) {
            float w = ((c & 1) ? f1 : 1.0f - f1) * ((c >> 1) ? f2 : 1.0f - f2), vw = v * w;
            if (vw != 0.0f)
                PB_ATOMIC_ADD(&out[base + ((c & 1) ? s1 : 0) + ((c >> 1) ? s2 : 0)], vw);
        }
        return;
    }
    for (int c = 0; c < 4; c++) {
        int t1 = pb_voxel_index(i1) + (c & 1), t2 = pb_voxel_index(i2) + (c >> 1);
        float w = ((c & 1) ? f1 : 1.0f - f1) * ((c >> 1) ? f2 : 1.0f - f2);
        int px = major == 0 ? km : (major == 1 ? t2 : t1);
        int py = major == 0 ? t1 : (major == 1 ? km : t2);
        int pz = major == 0 ? t2 : (major == 1 ? t1 : km);
        pb_scatter(out, prm, px, py, pz, v * w);
    }
}

/* Transpose of pb_ab_walked. The forward divides by the float sum of the
 * shares at the end; the scatter needs that sum before its first slice, so it
 * walks the shares once first (a few flops a slice, against four atomics). */
PB_FN void pb_ab_walked_adjoint(PB_GLOBAL float *out, pb_kparams prm, int sweep, const float *a, const float *b,
                                 float v)
{
    pb_ab_walk w;
    if (pb_ab_walk_init(a, b, sweep, &w)) {
        float o[3];
        pb_midpoint(a, b, o);
        pb_trilinear_scatter(out, prm, o[0], o[1], o[2], v);
        return;
    }
    float wsum = (float)(w.f1 - w.f0 + 1);
    /* With one point a slice, the at most four partly covered slices' shares
     * once, kept for the scatter (pb_ab_segment's order). */
    int n = pb_ab_partial_count(&w);
    if (!w.two && n >= 0 && n <= 4) {
        float share[4], mean[4];
        for (int i = 0; i < 4; i++) {
            share[i] = 0.0f;
            mean[i] = 0.0f;
            if (i < n) {
                float kf = pb_ab_partial_slice(&w, i);
                share[i] = pb_tent_share(w.lo - kf, w.hi - kf, &mean[i]);
                wsum += share[i];
            }
        }
        float vw = PB_DIV(v, wsum);
        PB_AB_FULL_SLICES(w, pb_slice_scatter(out, prm, w.m, x, y, z, q * vw));
        for (int i = 0; i < 4; i++)
            if (i < n) {
                float kf = pb_ab_partial_slice(&w, i);
                PB_AB_POINT(w, kf, mean[i]);
                pb_slice_scatter(out, prm, w.m, x, y, z, share[i] * vw);
            }
        return;
    }
    PB_AB_PARTIAL_SLICES(w, (void)x; (void)y; (void)z; wsum += s * q);
    float vw = PB_DIV(v, wsum);
    PB_AB_FULL_SLICES(w, pb_slice_scatter(out, prm, w.m, x, y, z, q * vw));
    PB_AB_PARTIAL_SLICES(w, pb_slice_scatter(out, prm, w.m, x, y, z, s * q * vw));
}

/* Transpose of pb_ab_segment: the exact chord's share and the walk's. */
PB_FN void pb_ab_segment_adjoint(PB_GLOBAL float *out, pb_kparams prm, pb_cell *cell, int sweep, const float *a,
                                  const float *b, float v)
{
    float walk = prm.chord ? 0.0f : pb_ab_walk_weight(a, b);
    if (walk < 1.0f)
        PB_CHORD_PIECES(a, b, pb_cell_piece(out, prm, cell, a, pb_d, pb_t0, pb_l, v * (1.0f - walk)));
    if (walk > 0.0f)
        pb_ab_walked_adjoint(out, prm, sweep, a, b, v * walk);
}

/* Transpose of pb_ab_sampled (ab) or pb_rm_sampled: v spread along a-b. */
PB_FN void pb_segment_adjoint(PB_GLOBAL float *out, pb_kparams prm, pb_cell *cell, const float *a, const float *b,
                               int ab, float v)
{
    if (ab && prm.steps == 1) { /* the usual case: no pieces, no division */
        pb_ab_segment_adjoint(out, prm, cell, ab == PB_AB_SWEEP, a, b, v);
        return;
    }
    if (ab) {
        float inv = 1.0f / (float)prm.steps;
        PB_FOR_PIECES(prm.steps, inv, a, b,
                      pb_ab_segment_adjoint(out, prm, cell, ab == PB_AB_SWEEP, pa, pb, v * inv));
        return;
    }
    int n = prm.steps;
    if (n <= 0) { /* pb_rm_sampled's rule by length */
        float walk = pb_ab_walk_weight(a, b);
        if (walk < 1.0f)
            PB_CHORD_PIECES(a, b, pb_cell_piece(out, prm, cell, a, pb_d, pb_t0, pb_l, v * (1.0f - walk)));
        if (walk == 0.0f)
            return;
        v *= walk;
        n = pb_ab_slices(a, b);
    }
    float inv_n = 1.0f / (float)n;
    for (int i = 0; i < n; i++) {
        float s = pb_step_fraction(i, inv_n);
        pb_cell_scatter(out, prm, cell, a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1]),
                        a[2] + s * (b[2] - a[2]), v * inv_n);
    }
}

/* Transpose of pb_polyline: v = y[W], spread along every segment with the
 * segment's share of the frame. */
PB_FN void pb_polyline_adjoint(PB_GLOBAL float *out, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, int ix, int iy,
                               int iz, int ab, float v)
{
    const float u[3] = {(float)ix + 0.5f, (float)iy + 0.5f, (float)iz + 0.5f};
    pb_cell cell;
    cell.live = 0;
    if (ab && prm.steps == 1) { /* as pb_polyline: decided once a voxel */
        PB_FOR_SEGMENTS(poses, prm, u,
                        pb_ab_segment_adjoint(out, prm, &cell, ab == PB_AB_SWEEP, a, b, v * poses[j].weight));
    } else {
        PB_FOR_SEGMENTS(poses, prm, u, pb_segment_adjoint(out, prm, &cell, a, b, ab, v * poses[j].weight));
    }
    pb_cell_flush(out, prm, &cell);
}

/* Transpose of pb_classical. */
PB_FN void pb_classical_adjoint(PB_GLOBAL float *out, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, int ix, int iy,
                                int iz, float v)
{
    float u[3] = {(float)ix + 0.5f, (float)iy + 0.5f, (float)iz + 0.5f};
    pb_cell cell;
    cell.live = 0;
    for (int j = 0; j < prm.segments; j++) {
        if (poses[j].weight == 0.0f) /* clipped */
            continue;
        int n = pb_classical_steps(poses, j, prm, u);
        float inv_n = 1.0f / (float)n, vn = v * poses[j].weight * inv_n;
        for (int i = 0; i < n; i++) {
            float o[3];
            pb_classical_point(&poses[j], &poses[j + 1], pb_step_fraction(i, inv_n), prm, u, o);
            pb_cell_scatter(out, prm, &cell, o[0], o[1], o[2], vn);
        }
    }
    pb_cell_flush(out, prm, &cell);
}

/* The tomograph voxel's value, or 0 (nothing to spread) outside the grid. */
PB_FN float pb_adjoint_input(PB_GLOBAL_RO float *in, pb_kparams prm, int ix, int iy, int iz)
{
    return PB_IN_GRID(ix, iy, iz) ? in[ix + prm.dims[0] * (iy + prm.dims[1] * iz)] : 0.0f;
}

/* One kernel per method: the scatter reads no texture, so the filter does not
 * change it. out must hold zeros before the launch. */
PB_KERNEL void pb_adjoint_ab(PB_GLOBAL_RO float *in, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, PB_GLOBAL float *out)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;
    float v = pb_adjoint_input(in, prm, ix, iy, iz);
    if (v != 0.0f)
        pb_polyline_adjoint(out, poses, prm, ix, iy, iz, 1, v);
}

PB_KERNEL void pb_adjoint_ab_sweep(PB_GLOBAL_RO float *in, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm,
                                   PB_GLOBAL float *out)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;
    float v = pb_adjoint_input(in, prm, ix, iy, iz);
    if (v != 0.0f)
        pb_polyline_adjoint(out, poses, prm, ix, iy, iz, PB_AB_SWEEP, v);
}

PB_KERNEL void pb_adjoint_rm(PB_GLOBAL_RO float *in, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, PB_GLOBAL float *out)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;
    float v = pb_adjoint_input(in, prm, ix, iy, iz);
    if (v != 0.0f)
        pb_polyline_adjoint(out, poses, prm, ix, iy, iz, 0, v);
}

PB_KERNEL void pb_adjoint_cl(PB_GLOBAL_RO float *in, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, PB_GLOBAL float *out)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;
    float v = pb_adjoint_input(in, prm, ix, iy, iz);
    if (v != 0.0f)
        pb_classical_adjoint(out, poses, prm, ix, iy, iz, v);
}

/* Transpose of pb_blur_ref: each random point's share goes to the object voxel
 * that holds it (the point's texel coordinates, floored, as a nearest read). */
PB_KERNEL void pb_adjoint_ref(PB_GLOBAL_RO float *in, PB_GLOBAL_RO pb_kstep *steps, pb_kparams prm, PB_GLOBAL float *out)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;
    float v = pb_adjoint_input(in, prm, ix, iy, iz);
    if (v == 0.0f)
        return;
    int voxel = ix + prm.dims[0] * (iy + prm.dims[1] * iz);
    unsigned int key = pb_ref_key(prm.seed, (unsigned int)voxel);
    for (int s = 0; s < prm.ref_steps; s++) {
        PB_GLOBAL_RO float *m = steps[s].map;
        float base[3];
        pb_map_point(m, (float)ix, (float)iy, (float)iz, base);
        float vs = v * steps[s].weight / (float)prm.ref_points;
        for (int k = 0; k < prm.ref_points; k++) {
            float o[3];
            pb_ref_point(m, base, key, (unsigned int)(s * prm.ref_points + k), o);
            pb_scatter(out, prm, pb_voxel_index(floor(o[0])), pb_voxel_index(floor(o[1])), pb_voxel_index(floor(o[2])),
                       vs);
        }
    }
}
