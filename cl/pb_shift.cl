/* The shift-invariant kernels: AB, RM and CL under a motion of translations
 * only (every key pose's rotation the identity, so every map's linear part
 * is), where the blur is a convolution. Each is both directions: the forward (prm.mirror 0)
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
 * atomic adds per sample where this pays one fetch (docs/performance.md,
 * "How fast is the adjoint?").
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
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;                                                             \
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

PB_KERNEL void pb_shift_ab_sweep(pb_image img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, PB_GLOBAL float *out)
{
    PB_SHIFT_VOXEL;
    PB_SHIFT_STORE(pb_polyline(img, poses, prm, u, &pl, PB_AB_SWEEP, 0));
}

PB_KERNEL void pb_shift_ab_sweep_exact(pb_image img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm,
                                       PB_GLOBAL float *out)
{
    PB_SHIFT_VOXEL;
    PB_SHIFT_STORE(pb_polyline(img, poses, prm, u, &pl, PB_AB_SWEEP, 1));
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

/* AB HARDWARE under translations, through the object laid out as a 2-D image
 * array with one layer per slice along prm.layer_axis, every segment's major
 * axis (the host checks that they share one and picks it). A slice
 * sample is then one bilinear fetch in its layer, which the texture unit makes
 * at twice its trilinear rate (bench/fetch_rate.cu); the weights are the same
 * two rounded fractions, the slice's own weight exactly 1. The adjoint's
 * gather reads the tomograph through layers along y or z too, mirrored as
 * through the 3-D image: laying it out there saves more fetch time than it
 * costs. Along x the layout is a transpose that costs more than it saves on
 * one blur, so an input laid out anew every call (the gather's tomograph, the
 * caller's device memory) reads the 3-D image along x (src/devices/kernel_choice.c). */

/* Layer `layer` at (pa, pb), or 0 outside the volume along the axis (layers:
 * how many): an array clamps its layer index where a 3-D image reads its zero
 * border. */
PB_FN float pb_layer_fetch(pb_layers img, int layers, float pa, float pb, int layer)
{
    return layer >= 0 && layer < layers ? PB_FETCH_LAYER(img, pa, pb, layer) : 0.0f;
}

/* A point's coordinates along the layers' axis m and across it (the order of
 * pb_layer_across), and the layer count. Selected, not indexed: an indexed
 * kernel argument would be copied to local memory by nvcc. */
PB_FN int pb_layer_coords(pb_kparams prm, float x, float y, float z, float *pm, float *pa, float *pb)
{
    int m = prm.layer_axis;
    *pm = m == 0 ? x : (m == 1 ? y : z);
    *pa = m == 0 ? y : x;
    *pb = m == 2 ? y : z;
    return m == 0 ? prm.dims[0] : (m == 1 ? prm.dims[1] : prm.dims[2]);
}

/* pb_slice_sample through the layers; the major coordinate is a slice centre. */
PB_FN float pb_layer_slice(pb_layers img, pb_kparams prm, const pb_place *pl, float x, float y, float z)
{
    pb_place_point(pl, &x, &y, &z);
    float pm, pa, pb;
    int layers = pb_layer_coords(prm, x, y, z, &pm, &pa, &pb);
    return pb_layer_fetch(img, layers, pa, pb, (int)floor(pm));
}

/* pb_trilinear through the layers: two bilinear fetches, mixed in float. */
PB_FN float pb_layer_trilinear(pb_layers img, pb_kparams prm, const pb_place *pl, float x, float y, float z)
{
    pb_place_point(pl, &x, &y, &z);
    float pm, pa, pb;
    int layers = pb_layer_coords(prm, x, y, z, &pm, &pa, &pb);
    float l0 = floor(pm - 0.5f), f = pm - 0.5f - l0;
    int layer = (int)l0;
    return (1.0f - f) * pb_layer_fetch(img, layers, pa, pb, layer) +
           f * pb_layer_fetch(img, layers, pa, pb, layer + 1);
}

/* pb_ab_segment's walk along the layers' axis, each sample through them. */
PB_FN float pb_ab_segment_layers(pb_layers img, pb_kparams prm, int sweep, const pb_place *pl, const float *a,
                                  const float *b)
{
    pb_ab_walk w;
    if (pb_ab_walk_init_axis(a, b, prm.layer_axis, sweep, &w)) {
        float o[3];
        pb_midpoint(a, b, o);
        return pb_layer_trilinear(img, prm, pl, o[0], o[1], o[2]);
    }
    float sum = 0.0f;
    PB_AB_FULL_SLICES(w, sum += q * pb_layer_slice(img, prm, pl, x, y, z));
    float wsum = (float)(w.f1 - w.f0 + 1);
    PB_AB_PARTIAL_SLICES(w, sum += s * q * pb_layer_slice(img, prm, pl, x, y, z); wsum += s * q);
    return PB_DIV(sum, wsum);
}

/* AB over one segment through the layers: the sum over its prm.steps
 * sub-segments (the caller scales it, weight first, as it always has). */
PB_FN float pb_ab_pieces_layers(pb_layers img, pb_kparams prm, int sweep, const pb_place *pl, const float *a,
                                 const float *b)
{
    float sum = 0.0f, inv = 1.0f / (float)prm.steps;
    PB_FOR_PIECES(prm.steps, inv, a, b, sum += pb_ab_segment_layers(img, prm, sweep, pl, pa, pb));
    return sum;
}

/* Voxel 0's polyline through the layers, placed by pl. */
PB_FN float pb_shift_layered(pb_layers img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, int sweep,
                             const pb_place *pl)
{
    const float u[3] = {0.5f, 0.5f, 0.5f};
    float total = 0.0f;
    PB_FOR_SEGMENTS(poses, prm, u,
                    total += poses[j].weight * pb_ab_pieces_layers(img, prm, sweep, pl, a, b) *
                             (1.0f / (float)prm.steps));
    return total;
}

/* Layers along y or z: a work item per voxel, a warp's along x in one layer. */
PB_KERNEL void pb_shift_ab_layers(pb_layers img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, PB_GLOBAL float *out)
{
    PB_SHIFT_VOXEL;
    (void)u;
    PB_SHIFT_STORE(pb_shift_layered(img, poses, prm, 0, &pl));
}

PB_KERNEL void pb_shift_ab_sweep_layers(pb_layers img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm,
                                        PB_GLOBAL float *out)
{
    PB_SHIFT_VOXEL;
    (void)u;
    PB_SHIFT_STORE(pb_shift_layered(img, poses, prm, 1, &pl));
}

/* Layers along x. A warp whose work items lay along x would read 32 layers
 * at once, far apart in memory, so here they lie along y, in one layer at
 * neighbouring texels. Each walks a run of PB_X_RUN voxels along
 * x, one after the other, so that what a warp writes fills whole 32-byte
 * sectors of 8 floats instead of one float in each of 32. The host launches
 * pb_kernel_extent's work items: y first, then runs along x, then z. */
#define PB_SHIFT_LAYERS_X(sweep)                                                                                 \
    int iy = PB_GID_X, x0 = PB_GID_Y * PB_X_RUN, iz = PB_GID_Z + prm.z0;                                        \
    if (iy >= prm.dims[1] || iz >= prm.dims[2])                                                                \
        return;                                                                                                \
    for (int ix = x0; ix < x0 + PB_X_RUN && ix < prm.dims[0]; ix++) {                                          \
        pb_place pl;                                                                                           \
        pb_shift_place(prm, ix, iy, iz, &pl);                                                                  \
        PB_SHIFT_STORE(pb_shift_layered(img, poses, prm, sweep, &pl));                                         \
    }

PB_KERNEL void pb_shift_ab_layers_x(pb_layers img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm, PB_GLOBAL float *out)
{
    PB_SHIFT_LAYERS_X(0)
}

PB_KERNEL void pb_shift_ab_sweep_layers_x(pb_layers img, PB_GLOBAL_RO pb_kpose *poses, pb_kparams prm,
                                          PB_GLOBAL float *out)
{
    PB_SHIFT_LAYERS_X(1)
}

/* A volume laid out in layers along m = prm.layer_axis, for the copy into a
 * layered image: voxel v goes to layer v[m] at (v[a], v[b]), a and b from
 * pb_layer_across. Along y the rows still run along x, so reads and writes
 * are both coalesced; along z the buffer is already laid out so and is copied
 * as it is. It runs once per object and axis, outside the forward's time, and
 * for every tomograph the adjoint's gather reads along y, inside its time.
 * (The second argument only matches the launch's others.) */
PB_KERNEL void pb_permute(PB_GLOBAL_RO float *in, PB_GLOBAL_RO pb_kpose *unused, pb_kparams prm, PB_GLOBAL float *out)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;
    (void)unused;
    if (!PB_IN_GRID(ix, iy, iz))
        return;
    int m = prm.layer_axis, v[3] = {ix, iy, iz};
    int a = pb_layer_across(m, 0), b = pb_layer_across(m, 1);
    out[v[a] + prm.dims[a] * (v[b] + prm.dims[b] * v[m])] = in[ix + prm.dims[0] * (iy + prm.dims[1] * iz)];
}
