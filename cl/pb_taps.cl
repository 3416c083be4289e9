/* Short motions of translations as a convolution read from the buffer itself.
 *
 * Under translations only every tomograph voxel W reads the object at W + p_s
 * for voxel 0's samples p_s (cl/pb_shift.cl), so the operator is a
 * convolution: W reads object voxel W + d with a weight c_d that is the same
 * for every W. The host measures the c_d once per plan, as the walk's own
 * response to a unit impulse (src/devices/shift_taps.c): they are the walk's
 * weights, the texture unit's rounding of them included, summed per object
 * voxel. Where the path is short they are few, and reading them here costs
 * less than the walk's per-voxel set-up plus the input's copy into a texture
 * (docs/performance.md, "Short translations"). The adjoint (prm.mirror) reads
 * V - d with the same weights: the exact transpose, as a gather of the
 * forward's cost. Outside the grid the object is zero, as through the
 * texture's border; voxels whose every tap lands inside (all but a rim
 * prm.tap_reach wide) skip the checks. A work item makes PB_TAP_RUN voxels
 * along z, reading each tap once for all of them. */
PB_KERNEL void pb_shift_taps(PB_GLOBAL_RO float *in, PB_GLOBAL_RO pb_ktap *taps, pb_kparams prm,
                             PB_GLOBAL float *out)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z * PB_TAP_RUN + prm.z0;
    if (!PB_IN_GRID(ix, iy, iz))
        return;
    int sign = prm.mirror ? -1 : 1, plane = prm.dims[0] * prm.dims[1];
    int here = ix + prm.dims[0] * iy + plane * iz;
    int run = prm.dims[2] - iz < PB_TAP_RUN ? prm.dims[2] - iz : PB_TAP_RUN;
    float sum[PB_TAP_RUN];
    for (int k = 0; k < PB_TAP_RUN; k++)
        sum[k] = 0.0f;
    if (run == PB_TAP_RUN && ix >= prm.tap_reach[0] && ix < prm.dims[0] - prm.tap_reach[0] &&
        iy >= prm.tap_reach[1] && iy < prm.dims[1] - prm.tap_reach[1] && iz >= prm.tap_reach[2] &&
        iz + PB_TAP_RUN - 1 < prm.dims[2] - prm.tap_reach[2]) {
        for (int t = 0; t < prm.taps; t++) {
            float w = taps[t].weight;
            int at = here + sign * taps[t].linear;
            for (int k = 0; k < PB_TAP_RUN; k++)
                sum[k] += w * in[at + k * plane];
        }
    } else {
        for (int t = 0; t < prm.taps; t++) {
            int x = ix + sign * taps[t].offset[0], y = iy + sign * taps[t].offset[1];
            if (x < 0 || y < 0 || x >= prm.dims[0] || y >= prm.dims[1])
                continue;
            float w = taps[t].weight;
            int at = here + sign * taps[t].linear;
            for (int k = 0; k < run; k++) {
                int z = iz + k + sign * taps[t].offset[2];
                if (z >= 0 && z < prm.dims[2])
                    sum[k] += w * in[at + k * plane];
            }
        }
    }
    for (int k = 0; k < run; k++) {
        int v = here + k * plane;
        out[v] = prm.accumulate ? out[v] + sum[k] : sum[k];
    }
}

/* The reads of pb_shift_taps_tile's tile by work item (lx, line), into
 * registers, without a branch: a voxel is read where it lies in the window
 * and, checked, in the grid; zero elsewhere. A line's rows step by
 * PB_TAP_LINES = PB_TAP_TY + 1, so its row's y and z and its place in the
 * grid step without a division. */
PB_FN void pb_tile_reads(PB_GLOBAL_RO float *in, const int *dims, int x0, int y0, int z0, int tx, int ty, int tz,
                         int lx, int line, int me, float *body, float *rim, int checked)
{
    int plane = dims[0] * dims[1], y = line % PB_TAP_TY, z = line / PB_TAP_TY, gx = x0 + lx;
    int at = gx + dims[0] * (y0 + y) + plane * (z0 + z), x_in = (gx >= 0) & (gx < dims[0]);
    for (int j = 0; j < PB_TAP_BODY_STEPS; j++) {
        int use = (y < ty) & (z < tz);
        if (checked)
            use &= x_in & (y0 + y >= 0) & (y0 + y < dims[1]) & (z0 + z >= 0) & (z0 + z < dims[2]);
        body[j] = use ? in[at] : 0.0f;
        /* The next row: y + 1 and z + 1, y wrapping past PB_TAP_TY - 1. */
        int wraps = y == PB_TAP_TY - 1;
        y = wraps ? 0 : y + 1;
        z += 1 + wraps;
        at += wraps ? 2 * plane - (PB_TAP_TY - 1) * dims[0] : plane + dims[0];
    }
    for (int j = 0; j < PB_TAP_RIM_STEPS; j++) {
        unsigned i = (unsigned)(me + PB_TAP_GROUP * j), r = i / PB_TAP_RIM; /* unsigned: no sign's fix-ups */
        int x = 32 + (int)(i % PB_TAP_RIM), ry = (int)(r % PB_TAP_TY), rz = (int)(r / PB_TAP_TY);
        int gy = y0 + ry, gz = z0 + rz, use = (x < tx) & (ry < ty) & (rz < tz);
        if (checked)
            use &= (x0 + x >= 0) & (x0 + x < dims[0]) & (gy >= 0) & (gy < dims[1]) & (gz >= 0) & (gz < dims[2]);
        rim[j] = use ? in[x0 + x + dims[0] * gy + plane * gz] : 0.0f;
    }
}

/* pb_shift_taps with the group's input held in local memory: its voxels and
 * the taps' window about them, zero outside the grid. Reading the input once
 * a tap from device memory took more instructions than reads: the rim checks
 * of the warps that straddle the rim (a quarter of them at 256 voxels a row),
 * and a 64-bit address a read (ncu, docs/performance.md "Short
 * translations"). Here the rim is checked once, as the tile is read, and a
 * tap's eight reads share one address. The taps are summed in the same
 * order as pb_shift_taps', a tap outside the grid adding w * 0. The host
 * chooses it where the window fits (src/devices/shift_taps.c) and places
 * each tap in the tile, forward and mirrored (pb_ktap.tile). */
PB_KERNEL void pb_shift_taps_tile(PB_GLOBAL_RO float *in, PB_GLOBAL_RO pb_ktap *taps, pb_kparams prm,
                                  PB_GLOBAL float *out)
{
    PB_LOCAL float tile[PB_TAP_TX * PB_TAP_TY * PB_TAP_TZ];
    int lx = PB_LID_X, ly = PB_LID_Y, lz = PB_LID_Z;
    /* The tile's extent and its least corner in the grid. */
    int tx = PB_LSIZE_X + prm.tap_size[0] - 1, ty = PB_LSIZE_Y + prm.tap_size[1] - 1;
    int tz = PB_LSIZE_Z * PB_TAP_RUN + prm.tap_size[2] - 1;
    int x0 = PB_GID_X - lx + prm.tap_lo[0], y0 = PB_GID_Y - ly + prm.tap_lo[1];
    int z0 = (PB_GID_Z - lz) * PB_TAP_RUN + prm.z0 + prm.tap_lo[2];
    int inside = x0 >= 0 && y0 >= 0 && z0 >= 0 && x0 + tx <= prm.dims[0] && y0 + ty <= prm.dims[1] &&
                 z0 + tz <= prm.dims[2];
    /* The tile's rows (y, z), r = y + PB_TAP_TY z: x below 32 read by the
     * eight lines of 32 work items a row each in turn, the rest of x (at
     * most 8) by all in turn. Every read is issued before any is stored, so
     * that a group waits for the device's memory once; a row outside the
     * window (y >= ty or z >= tz) is not read, and the grid's bounds are
     * checked only where the tile reaches past them. */
    int line = ly + PB_LSIZE_Y * lz, me = lx + PB_LSIZE_X * line;
    float body[PB_TAP_BODY_STEPS], rim[PB_TAP_RIM_STEPS];
    if (inside)
        pb_tile_reads(in, prm.dims, x0, y0, z0, tx, ty, tz, lx, line, me, body, rim, 0);
    else
        pb_tile_reads(in, prm.dims, x0, y0, z0, tx, ty, tz, lx, line, me, body, rim, 1);
    for (int j = 0; j < PB_TAP_BODY_STEPS; j++) {
        int r = line + PB_TAP_LINES * j;
        if (r < PB_TAP_TY * PB_TAP_TZ)
            tile[PB_TAP_TX * r + lx] = body[j];
    }
    for (int j = 0; j < PB_TAP_RIM_STEPS; j++) {
        int i = me + PB_TAP_GROUP * j;
        if (i < PB_TAP_RIM * PB_TAP_TY * PB_TAP_TZ)
            tile[PB_TAP_TX * (i / PB_TAP_RIM) + 32 + i % PB_TAP_RIM] = rim[j];
    }
    PB_BARRIER();
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z * PB_TAP_RUN + prm.z0;
    if (!PB_IN_GRID(ix, iy, iz))
        return;
    int here = lx + PB_TAP_TX * (ly + PB_TAP_TY * lz * PB_TAP_RUN), mirror = prm.mirror;
    float sum[PB_TAP_RUN];
    for (int k = 0; k < PB_TAP_RUN; k++)
        sum[k] = 0.0f;
    for (int t = 0; t < prm.taps; t++) {
        float w = taps[t].weight;
        int at = here + taps[t].tile[mirror];
        for (int k = 0; k < PB_TAP_RUN; k++)
            sum[k] += w * tile[at + k * PB_TAP_TX * PB_TAP_TY];
    }
    int run = prm.dims[2] - iz < PB_TAP_RUN ? prm.dims[2] - iz : PB_TAP_RUN;
    int plane = prm.dims[0] * prm.dims[1], v = ix + prm.dims[0] * iy + plane * iz;
    if (prm.accumulate)
        for (int k = 0; k < run; k++)
            out[v + k * plane] += sum[k];
    else
        for (int k = 0; k < run; k++)
            out[v + k * plane] = sum[k];
}
