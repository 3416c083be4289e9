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
 * texture's border; a voxel whose every tap lands inside (all but a rim
 * prm.tap_reach wide) skips the checks. */
PB_KERNEL void pb_shift_taps(PB_GLOBAL_RO float *in, PB_GLOBAL_RO pb_ktap *taps, pb_kparams prm,
                             PB_GLOBAL float *out)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;
    if (!PB_IN_GRID(ix, iy, iz))
        return;
    int sign = prm.mirror ? -1 : 1;
    int here = ix + prm.dims[0] * (iy + prm.dims[1] * iz);
    float sum = 0.0f;
    if (ix >= prm.tap_reach[0] && ix < prm.dims[0] - prm.tap_reach[0] && iy >= prm.tap_reach[1] &&
        iy < prm.dims[1] - prm.tap_reach[1] && iz >= prm.tap_reach[2] && iz < prm.dims[2] - prm.tap_reach[2]) {
        for (int t = 0; t < prm.taps; t++)
            sum += taps[t].weight * in[here + sign * taps[t].linear];
    } else {
        for (int t = 0; t < prm.taps; t++) {
            int x = ix + sign * taps[t].offset[0], y = iy + sign * taps[t].offset[1];
            int z = iz + sign * taps[t].offset[2];
            if (x >= 0 && y >= 0 && z >= 0 && PB_IN_GRID(x, y, z))
                sum += taps[t].weight * in[here + sign * taps[t].linear];
        }
    }
    PB_SHIFT_STORE(sum);
}
