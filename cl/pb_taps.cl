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
