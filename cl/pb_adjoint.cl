/* The adjoint kernels: the transpose of the forward kernels in pb_blur.cl, for
 * back projection. Each work item takes one tomograph voxel W, walks W's path
 * exactly as the forward gather does (the same walk set-up, the same shares,
 * the same sample points) and adds y[W] times each weight into the object
 * voxels the forward would have read.
 *
 * Why a scatter and not a gather: a gather per object voxel V would have to
 * find every W whose path passes near V (V's own path, mapped forward) and
 * then rebuild each such W's walk to learn its weight on V, that is about S
 * candidate walks of S slices each, S^2 work per voxel against the scatter's
 * S.
 *
 * Why the adds go through a window in local memory: a plain scatter makes 4
 * global float atomics per AB slice (8 per trilinear sample) where the forward
 * makes one texture fetch, and the L2's atomic rate (about 340 G/s on an
 * H200) made the adjoint up to 10x the forward (bench/results/
 * 2026-11-21_H200_f4f90bd). Neighbouring voxels' paths run side by side, so a
 * work group (a tile of PB_ADJ_TILE voxels) walks its paths in chunks of the
 * path parameter, adds each chunk into a window of local memory that covers
 * the tile's whole swept box for that chunk, then flushes the window with one
 * global atomic per touched voxel. The window is the box of the tile's corners
 * at the chunk's two ends (the sample points are bilinear in voxel and
 * parameter, so their extremes are at those corners) plus the filter's reach.
 * An add that falls outside the window (rounding, a window too big for local
 * memory) goes straight to global memory, so the result never depends on the
 * window's geometry, only the speed does.
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
    return prm.weight_steps > 0.0f ? floor(f * prm.weight_steps + 0.5f) / prm.weight_steps : f;
}

/* A voxel index from a floored texel coordinate, clamped so that paths far
 * outside the grid neither overflow int nor wrap into it. */
PB_FN int pb_voxel_index(float f)
{
    return (int)fmin(fmax(f, -2.0f), 16777216.0f);
}

/* Adds v into object voxel (i, j, k); outside the grid the forward read zero,
 * so the transpose drops it. */
PB_FN void pb_scatter(PB_GLOBAL float *out, pb_kparams prm, int i, int j, int k, float v)
{
    if (v != 0.0f && i >= 0 && j >= 0 && k >= 0 && i < prm.dims[0] && j < prm.dims[1] && k < prm.dims[2])
        PB_ATOMIC_ADD(&out[i + prm.dims[0] * (j + prm.dims[1] * k)], v);
}

/* The work group's window: object voxels o .. o + n - 1 (clipped to the grid),
 * x fastest in local memory; use 0 when every add goes to global memory. */
typedef struct pb_window {
    int o[3], n[3];
    int use;
} pb_window;

/* Where the adds go: the window in local memory, in fixed point (value times
 * scale, rounded), or the output. */
typedef struct pb_sink {
    PB_LOCAL int *win;
    pb_window w;
    float scale;
    PB_GLOBAL float *out;
} pb_sink;

PB_FN void pb_sink_add(pb_sink *s, pb_kparams prm, int i, int j, int k, float v)
{
    int li = i - s->w.o[0], lj = j - s->w.o[1], lk = k - s->w.o[2];
    if (s->w.use && li >= 0 && lj >= 0 && lk >= 0 && li < s->w.n[0] && lj < s->w.n[1] && lk < s->w.n[2]) {
        int q = (int)rint(v * s->scale);
        if (q != 0)
            PB_LOCAL_ATOMIC_ADD_INT(&s->win[li + s->w.n[0] * (lj + s->w.n[1] * lk)], q);
    } else {
        pb_scatter(s->out, prm, i, j, k, v);
    }
}

/* Transpose of pb_trilinear: v spread over the eight voxels around (x, y, z). */
PB_FN void pb_trilinear_scatter(pb_sink *s, pb_kparams prm, float x, float y, float z, float v)
{
    float cx = x - 0.5f, cy = y - 0.5f, cz = z - 0.5f;
    float x0 = floor(cx), y0 = floor(cy), z0 = floor(cz);
    float fx = pb_texture_weight(cx - x0, prm), fy = pb_texture_weight(cy - y0, prm);
    float fz = pb_texture_weight(cz - z0, prm);
    int i = pb_voxel_index(x0), j = pb_voxel_index(y0), k = pb_voxel_index(z0);
    for (int c = 0; c < 8; c++) {
        float w = ((c & 1) ? fx : 1.0f - fx) * ((c & 2) ? fy : 1.0f - fy) * ((c & 4) ? fz : 1.0f - fz);
        pb_sink_add(s, prm, i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2), v * w);
    }
}

/* Transpose of pb_slice_sample: v spread over the four voxels of the slice
 * around the point, whose major coordinate is the slice's centre. */
PB_FN void pb_slice_scatter(pb_sink *s, pb_kparams prm, int major, float x, float y, float z, float v)
{
    int km = pb_voxel_index(floor(major == 0 ? x : (major == 1 ? y : z)));
    float c1 = (major == 0 ? y : (major == 1 ? z : x)) - 0.5f;
    float c2 = (major == 0 ? z : (major == 1 ? x : y)) - 0.5f;
    float i1 = floor(c1), i2 = floor(c2);
    float f1 = pb_texture_weight(c1 - i1, prm), f2 = pb_texture_weight(c2 - i2, prm);
    for (int c = 0; c < 4; c++) {
        int t1 = pb_voxel_index(i1) + (c & 1), t2 = pb_voxel_index(i2) + (c >> 1);
        float w = ((c & 1) ? f1 : 1.0f - f1) * ((c >> 1) ? f2 : 1.0f - f2);
        int px = major == 0 ? km : (major == 1 ? t2 : t1);
        int py = major == 0 ? t1 : (major == 1 ? km : t2);
        int pz = major == 0 ? t2 : (major == 1 ? t1 : km);
        pb_sink_add(s, prm, px, py, pz, v * w);
    }
}

/* q = e / n and e % n for the window's small non-negative e: a float estimate
 * (off by at most one for e < 2^24) and one integer correction, cheaper than
 * a GPU's integer division in the flush loop. */
PB_FN int pb_divmod(int e, int n, float inv, int *rem)
{
    int q = (int)((float)e * inv), r = e - q * n;
    if (r < 0) {
        q--;
        r += n;
    } else if (r >= n) {
        q++;
        r -= n;
    }
    *rem = r;
    return q;
}

/* The window of parameters [t0, t1] from the 16 corner points in local memory
 * (the tile's 8 corners at two parameters), widened by the filter's reach: a
 * sample at x reads voxels floor(x - 0.5) and one above, and AB's end slices
 * sample up to one voxel off the chord along the major axis. chord: the
 * corners are at the sub-segment's ends and the points in between on the
 * chords, so the chunk's corners are interpolated (AB, RM); otherwise they are
 * the chunk's own (CL; t0 = 0, t1 = 1). Clipped to the grid; too big for
 * prm.window, or scale 0: not used. Every work item reads the same corners, so
 * every one gets the same window. */
PB_FN pb_window pb_window_from(PB_LOCAL const float *corner, float t0, float t1, float scale, pb_kparams prm)
{
    pb_window w;
    float vol = 1.0f;
    for (int i = 0; i < 3; i++) {
        float lo = 3.0e38f, hi = -3.0e38f;
        for (int q = 0; q < 8; q++) {
            float a = corner[3 * q + i], b = corner[3 * (q + 8) + i];
            float p0 = a + (b - a) * t0, p1 = a + (b - a) * t1;
            lo = fmin(lo, fmin(p0, p1));
            hi = fmax(hi, fmax(p0, p1));
        }
        int o = max(pb_voxel_index(floor(lo)) - 2, 0), e = min(pb_voxel_index(floor(hi)) + 2, prm.dims[i] - 1);
        w.o[i] = o;
        w.n[i] = e - o + 1;
        vol *= (float)max(w.n[i], 0);
    }
    w.use = scale > 0.0f && vol > 0.0f && vol <= (float)prm.window;
    return w;
}

/* Adds the window into the output, one global atomic per touched voxel, and
 * leaves it zero for the next chunk. */
PB_FN void pb_window_flush(PB_LOCAL int *win, pb_window w, float unscale, PB_GLOBAL float *out, pb_kparams prm,
                           int lid)
{
    if (!w.use)
        return;
    int vol = w.n[0] * w.n[1] * w.n[2];
    float inv0 = 1.0f / (float)w.n[0], inv1 = 1.0f / (float)w.n[1];
    for (int e = lid; e < vol; e += PB_ADJ_THREADS) {
        int q = win[e];
        if (q != 0) {
            win[e] = 0;
            int i, j, row = pb_divmod(e, w.n[0], inv0, &i);
            int k = pb_divmod(row, w.n[1], inv1, &j);
            PB_ATOMIC_ADD(&out[(w.o[0] + i) + prm.dims[0] * ((w.o[1] + j) + prm.dims[1] * (w.o[2] + k))],
                          (float)q * unscale);
        }
    }
}

/* Sub-segments per key-pose segment: AB's prm.steps; RM and CL sample the
 * whole segment. method: 0 AB, 1 RM, 2 CL (pb_method order). */
PB_FN int pb_adjoint_subs(pb_kparams prm, int method)
{
    return method == 0 ? prm.steps : 1;
}

/* The path's point at parameter tau of sub-segment r of segment j, for
 * tomograph texel coordinates u: the chord for AB and RM (as the forward
 * computes its sub-segment ends), the interpolated pose for CL. */
PB_FN void pb_adjoint_path_point(PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, int method, int j, int r, float tau,
                                 const float *u, float *o)
{
    if (method == 2) {
        pb_classical_point(&poses[j], &poses[j + 1], tau, prm, u, o);
        return;
    }
    float a[3], b[3];
    pb_map_point(poses[j].map, u[0], u[1], u[2], a);
    pb_map_point(poses[j + 1].map, u[0], u[1], u[2], b);
    float f = ((float)r + tau) / (float)pb_adjoint_subs(prm, method);
    for (int i = 0; i < 3; i++)
        o[i] = a[i] + (b[i] - a[i]) * f;
}

/* Whether a window for chunks of 1/chunks of the sub-segment fits in
 * prm.window floats: the tile's extent plus the centre's motion per chunk plus
 * the reach pb_window_from adds (5, and 1 for its floors), per axis. */
PB_FN int pb_window_fits(const float *extent, const float *motion, int chunks, pb_kparams prm)
{
    float vol = 1.0f;
    for (int i = 0; i < 3; i++)
        vol *= extent[i] + motion[i] / (float)chunks + 6.0f;
    return vol <= (float)prm.window;
}

/* Chunks for a sub-segment: the fewest whose windows fit in local memory, by
 * the tile's extent at both key poses (for chords the largest it reaches in
 * between) and its centre's motion along each axis (a CL arc measured as two
 * chords). Fewer chunks flush the tile's own footprint fewer times. A tile too
 * big for any window gets one chunk, and its adds go to global memory. */
PB_FN int pb_adjoint_chunks(PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, int method, int j, int r, const float *ulo,
                            const float *uhi)
{
    float uc[3], p0[3], p1[3], p2[3], extent[3], motion[3];
    for (int i = 0; i < 3; i++)
        uc[i] = 0.5f * (ulo[i] + uhi[i]);
    pb_adjoint_path_point(poses, prm, method, j, r, 0.0f, uc, p0);
    pb_adjoint_path_point(poses, prm, method, j, r, 0.5f, uc, p1);
    pb_adjoint_path_point(poses, prm, method, j, r, 1.0f, uc, p2);
    for (int i = 0; i < 3; i++) {
        motion[i] = fabs(p1[i] - p0[i]) + fabs(p2[i] - p1[i]);
        float e0 = 0.0f, e1 = 0.0f;
        for (int k = 0; k < 3; k++) {
            e0 += fabs(poses[j].map[4 * i + k]) * (uhi[k] - ulo[k]);
            e1 += fabs(poses[j + 1].map[4 * i + k]) * (uhi[k] - ulo[k]);
        }
        extent[i] = fmax(e0, e1);
    }
    int lo = 1, hi = 4096;
    if (!pb_window_fits(extent, motion, hi, prm))
        return 1;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (pb_window_fits(extent, motion, mid, prm))
            hi = mid;
        else
            lo = mid + 1;
    }
    return lo;
}

/* Corner point q (0..7) of the tile box [ulo, uhi] at the start (e = 0) or
 * end (e = 1) of chunk c, into corner[3 (8 e + q)]. */
PB_FN void pb_adjoint_corner(PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, int method, int j, int r, int c,
                             int chunks, int lid, const float *ulo, const float *uhi, PB_LOCAL float *corner)
{
    int q = lid & 7, e = lid >> 3;
    float u[3] = {(q & 1) ? uhi[0] : ulo[0], (q & 2) ? uhi[1] : ulo[1], (q & 4) ? uhi[2] : ulo[2]}, o[3];
    pb_adjoint_path_point(poses, prm, method, j, r, (float)(c + e) / (float)chunks, u, o);
    for (int i = 0; i < 3; i++)
        corner[3 * lid + i] = o[i];
}

/* The first of n samples at (i + 0.5) / n that falls in chunk c of `chunks`
 * (parameter c / chunks on), in exact integer arithmetic so that every sample
 * lands in exactly one chunk. */
PB_FN int pb_chunk_first(int c, int chunks, int n)
{
    long x = 2L * (long)c * (long)n - (long)chunks; /* > -2 chunks */
    return c >= chunks ? n : (int)((x + 2L * (long)chunks - 1L) / (2L * (long)chunks));
}

/* The tomograph voxel's value, or 0 (nothing to spread) outside the grid. */
PB_FN float pb_adjoint_input(PB_GLOBAL_RO float *in, pb_kparams prm, int ix, int iy, int iz)
{
    return PB_IN_GRID(ix, iy, iz) ? in[ix + prm.dims[0] * (iy + prm.dims[1] * iz)] : 0.0f;
}

/* The adjoint of AB, RM or CL for one work group (a tile of tomograph voxels).
 * Every work item runs every barrier, inside the grid or not.
 *
 * The window holds fixed point, because local memory adds integers natively
 * but floats only by a compare-and-swap loop (measured on the H200: a float
 * window was slower than no window). Its scale is the tile's own: in one chunk
 * an entry gathers at most the sum of the tile's |y| (each work item's
 * weights in a segment sum to at most 1), at most THREADS max|y|, so
 * 2^30 / (THREADS max|y|) can never overflow, and each add is rounded to
 * 2^-22 max|y| of the tile: about as fine as a float add of the tile's
 * largest value, and relative to each tile, not to the whole volume.
 *
 * Per sub-segment: the chunk count (from work item 16, through local memory,
 * so that all agree) and the tile's corners (work items 0-15); then per
 * chunk: the window, this voxel's samples in it, the flush. AB's walk is the
 * forward's (pb_ab_walk_init), its slices cut into chunks at the slice
 * coordinates the chunk's ends map to; RM and CL samples go by index. */
PB_FN void pb_adjoint_tiled(PB_GLOBAL_RO float *in, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm,
                            PB_GLOBAL float *out, PB_LOCAL int *win, PB_LOCAL float *corner, PB_LOCAL int *shared,
                            int method)
{
    int lx = PB_LID_X, ly = PB_LID_Y, lz = PB_LID_Z;
    int lid = lx + PB_ADJ_TILE_X * (ly + PB_ADJ_TILE_Y * lz);
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z;
    int first[3] = {ix - lx, iy - ly, iz - lz}, tile[3] = {PB_ADJ_TILE_X, PB_ADJ_TILE_Y, PB_ADJ_TILE_Z};
    float ulo[3], uhi[3];
    for (int i = 0; i < 3; i++) {
        ulo[i] = (float)first[i] + 0.5f;
        uhi[i] = (float)(min(first[i] + tile[i], prm.dims[i]) - 1) + 0.5f;
    }
    float v = pb_adjoint_input(in, prm, ix, iy, iz);
    float u[3] = {(float)ix + 0.5f, (float)iy + 0.5f, (float)iz + 0.5f};
    for (int e = lid; e < PB_ADJ_WINDOW; e += PB_ADJ_THREADS)
        win[e] = 0;
    if (lid == 0)
        shared[1] = 0;
    PB_BARRIER();
    /* The tile's largest |y|: non-negative floats order as their bits do. */
    PB_LOCAL_ATOMIC_MAX_INT(&shared[1], PB_FLOAT_AS_INT(fabs(v)));
    pb_sink s;
    s.win = win;
    s.out = out;
    s.scale = 0.0f;
    float unscale = 0.0f;
    int chord = method != 2, subs = pb_adjoint_subs(prm, method);
    for (int j = 0; j < prm.segments; j++) {
        float a[3], b[3];
        pb_map_point(poses[j].map, u[0], u[1], u[2], a);
        pb_map_point(poses[j + 1].map, u[0], u[1], u[2], b);
        float vj = v * poses[j].weight;
        /* RM and CL: n samples of the segment, each vj / n. */
        int n = prm.steps > 0 ? prm.steps : pb_ab_slices(a, b);
        float vn = vj / (float)n;
        for (int r = 0; r < subs; r++) {
            /* AB: this sub-segment's walk, set up once. */
            pb_ab_walk w;
            int point = 0, inc = 1;
            float vw = 0.0f, pa[3], pb[3];
            if (method == 0) {
                float inv = 1.0f / (float)prm.steps;
                for (int i = 0; i < 3; i++) {
                    pa[i] = a[i] + (b[i] - a[i]) * ((float)r * inv);
                    pb[i] = a[i] + (b[i] - a[i]) * ((float)(r + 1) * inv);
                }
                vw = vj * inv;
                point = pb_ab_walk_init(pa, pb, &w);
                if (!point) {
                    float wsum = (float)(w.f1 - w.f0 + 1), mean;
                    for (int k = w.k0; k <= w.k1; k = pb_ab_next_partial(&w, k))
                        wsum += pb_tent_share(w.lo - (float)k, w.hi - (float)k, &mean);
                    vw /= wsum;
                    inc = (w.m == 0 ? pb[0] - pa[0] : (w.m == 1 ? pb[1] - pa[1] : pb[2] - pa[2])) >= 0.0f;
                }
            }
            /* The barrier before the first sub-segment also completes the
             * tile's max; the one after each chunk frees the corners. */
            PB_BARRIER();
            if (lid == 16)
                shared[0] = pb_adjoint_chunks(poses, prm, method, j, r, ulo, uhi);
            if (chord && lid < 16) /* the sub-segment's ends */
                pb_adjoint_corner(poses, prm, method, j, r, 0, 1, lid, ulo, uhi, corner);
            PB_BARRIER();
            int chunks = shared[0];
            if (!chord) { /* CL: the first chunk's own ends */
                if (lid < 16)
                    pb_adjoint_corner(poses, prm, method, j, r, 0, chunks, lid, ulo, uhi, corner);
                PB_BARRIER();
            }
            if (j == 0 && r == 0) {
                /* 2^30 / (THREADS max|y|), and back: powers of two apart. */
                float vmax = PB_INT_AS_FLOAT(shared[1]);
                s.scale = vmax > 1e-30f ? (1073741824.0f / (float)PB_ADJ_THREADS) / vmax : 0.0f;
                unscale = vmax * ((float)PB_ADJ_THREADS / 1073741824.0f);
            }
            for (int c = 0; c < chunks; c++) {
                float t0 = chord ? (float)c / (float)chunks : 0.0f, t1 = chord ? (float)(c + 1) / (float)chunks : 1.0f;
                s.w = pb_window_from(corner, t0, t1, s.scale, prm);
                if (v != 0.0f && method == 0 && point) {
                    if (c == 0)
                        pb_trilinear_scatter(&s, prm, 0.5f * (pa[0] + pb[0]), 0.5f * (pa[1] + pb[1]),
                                             0.5f * (pa[2] + pb[2]), vw);
                } else if (v != 0.0f && method == 0) {
                    /* Chunk c of the path parameter, as slice numbers in
                     * increasing order (cc) on the major axis. */
                    int cc = inc ? c : chunks - 1 - c;
                    float len = w.hi - w.lo;
                    int ka = cc == 0 ? w.k0 : (int)ceil(w.lo + len * ((float)cc / (float)chunks));
                    int kb = cc + 1 == chunks ? w.k1 + 1 : (int)ceil(w.lo + len * ((float)(cc + 1) / (float)chunks));
                    for (int k = ka; k < kb; k++) {
                        float kf = (float)k, share = 1.0f, mean = 0.0f;
                        if (k < w.f0 || k > w.f1)
                            share = pb_tent_share(w.lo - kf, w.hi - kf, &mean);
                        pb_slice_scatter(&s, prm, w.m, kf * w.g[0] + w.c[0] + mean * w.h[0],
                                         kf * w.g[1] + w.c[1] + mean * w.h[1], kf * w.g[2] + w.c[2] + mean * w.h[2],
                                         share * vw);
                    }
                } else if (v != 0.0f) {
                    int ib = pb_chunk_first(c + 1, chunks, n);
                    for (int i = pb_chunk_first(c, chunks, n); i < ib; i++) {
                        float sp = ((float)i + 0.5f) / (float)n, o[3];
                        if (method == 2) {
                            pb_classical_point(&poses[j], &poses[j + 1], sp, prm, u, o);
                        } else {
                            for (int d = 0; d < 3; d++)
                                o[d] = a[d] + sp * (b[d] - a[d]);
                        }
                        pb_trilinear_scatter(&s, prm, o[0], o[1], o[2], vn);
                    }
                }
                PB_BARRIER();
                pb_window_flush(win, s.w, unscale, out, prm, lid);
                if (!chord && lid < 16 && c + 1 < chunks)
                    pb_adjoint_corner(poses, prm, method, j, r, c + 1, chunks, lid, ulo, uhi, corner);
                /* The next chunk's window moves: no add before the flush ends. */
                PB_BARRIER();
            }
        }
    }
}

/* One kernel per method: the scatter reads no texture, so the filter does not
 * change it. out must hold zeros before the launch. The work group must be
 * the tile (PB_ADJ_TILE_X x _Y x _Z). */
PB_TILE_KERNEL void pb_adjoint_ab(PB_GLOBAL_RO float *in, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm,
                                  PB_GLOBAL float *out)
{
    PB_LOCAL_ARRAY(int, win, PB_ADJ_WINDOW);
    PB_LOCAL_ARRAY(float, corner, 48);
    PB_LOCAL_ARRAY(int, shared, 2);
    pb_adjoint_tiled(in, poses, prm, out, win, corner, shared, 0);
}

PB_TILE_KERNEL void pb_adjoint_rm(PB_GLOBAL_RO float *in, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm,
                                  PB_GLOBAL float *out)
{
    PB_LOCAL_ARRAY(int, win, PB_ADJ_WINDOW);
    PB_LOCAL_ARRAY(float, corner, 48);
    PB_LOCAL_ARRAY(int, shared, 2);
    pb_adjoint_tiled(in, poses, prm, out, win, corner, shared, 1);
}

PB_TILE_KERNEL void pb_adjoint_cl(PB_GLOBAL_RO float *in, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm,
                                  PB_GLOBAL float *out)
{
    PB_LOCAL_ARRAY(int, win, PB_ADJ_WINDOW);
    PB_LOCAL_ARRAY(float, corner, 48);
    PB_LOCAL_ARRAY(int, shared, 2);
    pb_adjoint_tiled(in, poses, prm, out, win, corner, shared, 2);
}

/* Transpose of pb_blur_ref: each random point's share goes to the object voxel
 * that holds it (the point's texel coordinates, floored, as a nearest read).
 * The reference's points scatter at random, so there is nothing for a window
 * to gather; plain global atomics. */
PB_KERNEL void pb_adjoint_ref(PB_GLOBAL_RO float *in, PB_GLOBAL_RO pb_kstep *steps, pb_kparams prm, PB_GLOBAL float *out)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z;
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
