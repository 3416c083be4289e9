/* The shift-invariant kernels: AB, RM and CL under a motion of translations
 * only (every key pose's map has the identity as its linear part), where the
 * blur is a convolution. Each is both directions: the forward (prm.mirror 0)
 * and the adjoint as a gather (prm.mirror 1), with no atomics.
 *
 * Why they exist. Under such a motion every voxel's path is voxel 0's moved by
 * whole voxels, so its walk is voxel 0's walk moved too: the same slices, the
 * same shares, the same fractional sample points. The forward reads x at
 * W + p_s for voxel 0's samples p_s (texel coordinates, weights w_s), so the
 * weight that links tomograph voxel W to object voxel V is
 *   sum_s w_s tri(W + p_s - V - 1/2),
 * tri the trilinear tent. The adjoint reads y at V + 1 - p_s, voxel 0's walk
 * mirrored through V's centre, with weights
 *   sum_s w_s tri(V + 1 - p_s - W - 1/2) = sum_s w_s tri(-(W + p_s - V - 1/2)),
 * the same, as the tent is even: the exact transpose, computed as a gather of
 * the same cost as the forward. The scatter (pb_adjoint.cl) pays up to eight
 * atomic adds per sample where this pays one fetch (bench/results: the
 * adjoint rows of the translation scenarios).
 *
 * With the HARDWARE filter the texture unit rounds each axis's fraction f to
 * 1/256 (ties up) in both directions; the mirror reads fraction 1 - f, and
 * round(1 - f) = 1 - round(f) but at ties, so the two rounded operators are
 * transposes too, up to the unit's 3-D blend (tests/test_adjoint.c).
 *
 * Walking voxel 0 also makes the forward exactly shift invariant: a voxel's
 * own float coordinates can no longer tip a tie between two major axes or an
 * end point over a slice boundary one way for one voxel and the other way for
 * its neighbour. */

/* Voxel 0's walk, placed for voxel (ix, iy, iz) in the launch's direction. */
PB_FN void pb_shift_place(pb_kparams prm, int ix, int iy, int iz, pb_place *pl)
{
    float mirror = prm.mirror ? 1.0f : 0.0f;
    pl->on = 1;
    pl->sign = 1.0f - 2.0f * mirror;
    pl->base[0] = (float)ix + mirror;
    pl->base[1] = (float)iy + mirror;
    pl->base[2] = (float)iz + mirror;
}

/* The forward overwrites; frames that share an object add their adjoints. */
#define PB_SHIFT_STORE(v)                                                                                        \
    do {                                                                                                         \
        float pb_v_ = (v);                                                                                       \
        PB_OUT(ix, iy, iz) = prm.accumulate ? PB_OUT(ix, iy, iz) + pb_v_ : pb_v_;                                \
    } while (0)

#define PB_SHIFT_VOXEL                                                                                           \
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z;                                                             \
    if (!PB_IN_GRID(ix, iy, iz))                                                                                 \
        return;                                                                                                  \
    const float u[3] = {0.5f, 0.5f, 0.5f};                                                                       \
    pb_place pl;                                                                                                 \
    pb_shift_place(prm, ix, iy, iz, &pl)

PB_KERNEL void pb_shift_ab(pb_image img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, PB_GLOBAL float *out)
{
    PB_SHIFT_VOXEL;
    PB_SHIFT_STORE(pb_polyline(img, poses, prm, u, &pl, 1, 0));
}

PB_KERNEL void pb_shift_ab_exact(pb_image img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, PB_GLOBAL float *out)
{
    PB_SHIFT_VOXEL;
    PB_SHIFT_STORE(pb_polyline(img, poses, prm, u, &pl, 1, 1));
}

PB_KERNEL void pb_shift_rm(pb_image img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, PB_GLOBAL float *out)
{
    PB_SHIFT_VOXEL;
    PB_SHIFT_STORE(pb_polyline(img, poses, prm, u, &pl, 0, 0));
}

PB_KERNEL void pb_shift_rm_exact(pb_image img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, PB_GLOBAL float *out)
{
    PB_SHIFT_VOXEL;
    PB_SHIFT_STORE(pb_polyline(img, poses, prm, u, &pl, 0, 1));
}

PB_KERNEL void pb_shift_cl(pb_image img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, PB_GLOBAL float *out)
{
    PB_SHIFT_VOXEL;
    PB_SHIFT_STORE(pb_classical(img, poses, prm, u, &pl, 0));
}

PB_KERNEL void pb_shift_cl_exact(pb_image img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, PB_GLOBAL float *out)
{
    PB_SHIFT_VOXEL;
    PB_SHIFT_STORE(pb_classical(img, poses, prm, u, &pl, 1));
}
