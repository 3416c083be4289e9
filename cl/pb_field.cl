/* The field kernels: the blur and its transpose along the paths a
 * deformation field gives, for non-rigid motion (breathing, the heart).
 * Voxel W's key points are its centre plus the field at the frame's ends and
 * at the field samples inside it; between them the field is linear in time,
 * so its path is the polyline through them and the walks of pb_blur.cl and
 * pb_adjoint.cl (AB, RM) run on it unchanged. CL interpolates the motion at
 * every step, which for a field is the chord's point: the host maps CL to
 * RM's kernels. REF reads dense time steps and random points in W, the field
 * interpolated at each point. */

/* The frame's fields, stored after its knots. */
PB_FN PB_GLOBAL_RO float *pb_field_data(PB_GLOBAL_RO pb_kknot *knots, pb_kparams prm)
{
    return (PB_GLOBAL_RO float *)(knots + prm.field_start);
}

PB_FN long pb_field_voxels(pb_kparams prm)
{
    return (long)prm.field_dims[0] * (long)prm.field_dims[1] * (long)prm.field_dims[2];
}

/* Field f trilinearly at field voxel coordinates q (voxel i's centre at i),
 * held at its edge values beyond the outer centres, into d (adds w times it). */
PB_FN void pb_field_sample(PB_GLOBAL_RO float *fields, pb_kparams prm, int f, const float *q, float w, float *d)
{
    PB_GLOBAL_RO float *F = fields + (long)f * pb_field_voxels(prm) * 3;
    int i0[3];
    float fr[3];
    for (int a = 0; a < 3; a++) {
        int n = prm.field_dims[a];
        float c = fmin(fmax(q[a], 0.0f), (float)(n - 1));
        int i = (int)floor(c);
        i0[a] = n >= 2 ? min(i, n - 2) : 0;
        fr[a] = n >= 2 ? c - (float)i0[a] : 0.0f;
    }
    long sy = prm.field_dims[0], sz = (long)prm.field_dims[0] * prm.field_dims[1];
    long base = i0[0] + sy * i0[1] + sz * i0[2];
    long step[3] = {prm.field_dims[0] >= 2 ? 1 : 0, prm.field_dims[1] >= 2 ? sy : 0, prm.field_dims[2] >= 2 ? sz : 0};
    for (int c = 0; c < 8; c++) {
        float wc = w * ((c & 1) ? fr[0] : 1.0f - fr[0]) * ((c & 2) ? fr[1] : 1.0f - fr[1]) *
                   ((c & 4) ? fr[2] : 1.0f - fr[2]);
        long at = 3 * (base + ((c & 1) ? step[0] : 0) + ((c & 2) ? step[1] : 0) + ((c & 4) ? step[2] : 0));
        d[0] += wc * F[at];
        d[1] += wc * F[at + 1];
        d[2] += wc * F[at + 2];
    }
}

/* The object texel coordinates of the point at texel coordinates u under
 * knot k: u plus its field. own >= 0: u is the centre of image voxel own and
 * the field grid is the image grid, so the field is read there, not
 * interpolated. */
PB_FN void pb_field_point(PB_GLOBAL_RO pb_kknot *knots, PB_GLOBAL_RO float *fields, pb_kparams prm, int k,
                          const float *u, long own, float *o)
{
    pb_kknot kn = knots[k];
    float d[3] = {0.0f, 0.0f, 0.0f};
    if (own >= 0) {
        long n3 = pb_field_voxels(prm) * 3;
        PB_GLOBAL_RO float *a = fields + (long)kn.f0 * n3 + 3 * own, *b = fields + (long)kn.f1 * n3 + 3 * own;
        for (int i = 0; i < 3; i++)
            d[i] = kn.f0 == kn.f1 ? a[i] : (1.0f - kn.alpha) * a[i] + kn.alpha * b[i];
    } else {
        float q[3];
        for (int r = 0; r < 3; r++)
            q[r] = prm.field_map[4 * r] * u[0] + prm.field_map[4 * r + 1] * u[1] + prm.field_map[4 * r + 2] * u[2] +
                   prm.field_map[4 * r + 3];
        pb_field_sample(fields, prm, kn.f0, q, kn.f0 == kn.f1 ? 1.0f : 1.0f - kn.alpha, d);
        if (kn.f0 != kn.f1)
            pb_field_sample(fields, prm, kn.f1, q, kn.alpha, d);
    }
    for (int i = 0; i < 3; i++)
        o[i] = u[i] + d[i];
}

/* Image voxel (ix, iy, iz)'s own index where the field grid is the image
 * grid, else -1 (interpolate). */
PB_FN long pb_field_own(pb_kparams prm, int ix, int iy, int iz)
{
    return prm.field_same ? ix + (long)prm.dims[0] * (iy + (long)prm.dims[1] * iz) : -1;
}

/* The field of knot k at the centre of image voxel at[] (texel units). */
PB_FN void pb_field_at_voxel(PB_GLOBAL_RO pb_kknot *knots, PB_GLOBAL_RO float *fields, pb_kparams prm, int k,
                             const int *at, float *d)
{
    const float u[3] = {(float)at[0] + 0.5f, (float)at[1] + 0.5f, (float)at[2] + 0.5f};
    float o[3];
    pb_field_point(knots, fields, prm, k, u, pb_field_own(prm, at[0], at[1], at[2]), o);
    for (int i = 0; i < 3; i++)
        d[i] = o[i] - u[i];
}

/* I + dD/dr of knot k at image voxel (ix, iy, iz), row-major: differences of
 * the field between the voxel's neighbours along each axis, one-sided at the
 * grid's faces (texel units on both sides: its determinant is the same in
 * mm). */
PB_FN void pb_field_gradient(PB_GLOBAL_RO pb_kknot *knots, PB_GLOBAL_RO float *fields, pb_kparams prm, int k, int ix,
                             int iy, int iz, float *g)
{
    for (int a = 0; a < 3; a++) {
        int at[3] = {ix, iy, iz}, c = at[a];
        int lo = max(c - 1, 0), hi = min(c + 1, prm.dims[a] - 1);
        float dl[3] = {0.0f, 0.0f, 0.0f}, dh[3] = {0.0f, 0.0f, 0.0f};
        if (hi > lo) {
            at[a] = lo;
            pb_field_at_voxel(knots, fields, prm, k, at, dl);
            at[a] = hi;
            pb_field_at_voxel(knots, fields, prm, k, at, dh);
        }
        float inv = hi > lo ? 1.0f / (float)(hi - lo) : 0.0f;
        for (int r = 0; r < 3; r++)
            g[3 * r + a] = (dh[r] - dl[r]) * inv + (r == a ? 1.0f : 0.0f);
    }
}

/* |det| of (1 - s) A + s B, 3x3 row-major. */
PB_FN float pb_blend_det(const float *A, const float *B, float s)
{
    float g[9];
    for (int i = 0; i < 9; i++)
        g[i] = (1.0f - s) * A[i] + s * B[i];
    return fabs(g[0] * (g[4] * g[8] - g[5] * g[7]) - g[1] * (g[3] * g[8] - g[5] * g[6]) +
                g[2] * (g[3] * g[7] - g[4] * g[6]));
}

/* The mean over a segment's time of the mass-preserving weight |det(I +
 * dD/dr)|: the field is linear in time along the segment, so is its
 * gradient, and the determinant is a cubic in time, which Simpson's rule
 * integrates exactly. */
PB_FN float pb_segment_jacobian(const float *A, const float *B)
{
    return (pb_blend_det(A, B, 0.0f) + 4.0f * pb_blend_det(A, B, 0.5f) + pb_blend_det(A, B, 1.0f)) * (1.0f / 6.0f);
}

/* The segments of voxel W's polyline through the frame's key points: BODY
 * runs with the segment's ends a and b (object texel coordinates), its index
 * j and jac, the mean of its ends' Jacobian determinants (1 unless mass, a
 * literal in each kernel: the blur of concentrations carries none of the
 * gradients' registers), in scope; a segment of no weight, the gap between
 * two of a gate's intervals, is skipped. */
#define PB_FOR_FIELD_SEGMENTS(knots, fields, prm, u, own, ix, iy, iz, mass, BODY)                                \
    {                                                                                                          \
        float a[3], b[3], pb_ga[9], pb_gb[9];                                                                  \
        if (mass)                                                                                              \
            pb_field_gradient((knots), (fields), (prm), 0, (ix), (iy), (iz), pb_gb);                           \
        pb_field_point((knots), (fields), (prm), 0, (u), (own), b);                                            \
        for (int j = 0; j < (prm).segments; j++) {                                                             \
            for (int pb_i = 0; pb_i < 3; pb_i++)                                                               \
                a[pb_i] = b[pb_i];                                                                             \
            pb_field_point((knots), (fields), (prm), j + 1, (u), (own), b);                                    \
            float jac = 1.0f;                                                                                  \
            if (mass) {                                                                                        \
                for (int pb_i = 0; pb_i < 9; pb_i++)                                                           \
                    pb_ga[pb_i] = pb_gb[pb_i];                                                                 \
                pb_field_gradient((knots), (fields), (prm), j + 1, (ix), (iy), (iz), pb_gb);                   \
                jac = pb_segment_jacobian(pb_ga, pb_gb);                                                       \
            }                                                                                                  \
            if ((knots)[j].weight == 0.0f) /* the gap between a gate's intervals */                             \
                continue;                                                                                      \
            BODY;                                                                                              \
        }                                                                                                      \
    }

/* The forward of voxel W: ab 0 RM, 1 AB, PB_AB_SWEEP AB with two points a
 * slice, a literal in each kernel. */
PB_FN float pb_field_polyline(pb_image img, PB_GLOBAL_RO pb_kknot *knots, pb_kparams prm, int ix, int iy, int iz,
                              int ab, int exact, int mass)
{
    const float u[3] = {(float)ix + 0.5f, (float)iy + 0.5f, (float)iz + 0.5f};
    const pb_place pl = {0, {0.0f, 0.0f, 0.0f}, 1.0f};
    PB_GLOBAL_RO float *fields = pb_field_data(knots, prm);
    long own = pb_field_own(prm, ix, iy, iz);
    float total = 0.0f;
    PB_FOR_FIELD_SEGMENTS(knots, fields, prm, u, own, ix, iy, iz, mass,
                          total += knots[j].weight * jac *
                                   (ab ? pb_ab_sampled(img, prm, exact, ab == PB_AB_SWEEP, &pl, a, b)
                                       : pb_rm_sampled(img, prm, exact, &pl, a, b)));
    return total;
}

/* Its transpose: y[W] spread along every segment with the segment's share. */
PB_FN void pb_field_polyline_adjoint(PB_GLOBAL float *out, PB_GLOBAL_RO pb_kknot *knots, pb_kparams prm, int ix,
                                     int iy, int iz, int ab, int mass, float v)
{
    const float u[3] = {(float)ix + 0.5f, (float)iy + 0.5f, (float)iz + 0.5f};
    PB_GLOBAL_RO float *fields = pb_field_data(knots, prm);
    long own = pb_field_own(prm, ix, iy, iz);
    pb_cell cell;
    cell.live = 0;
    PB_FOR_FIELD_SEGMENTS(knots, fields, prm, u, own, ix, iy, iz, mass,
                          pb_segment_adjoint(out, prm, &cell, a, b, ab, v * knots[j].weight * jac));
    pb_cell_flush(out, prm, &cell);
}

#define PB_FIELD_FORWARD(name, ab, exact, mass)                                                                  \
    PB_KERNEL void name(pb_image img, PB_GLOBAL_RO pb_kknot *knots, pb_kparams prm, PB_GLOBAL float *out)     \
    {                                                                                                          \
        int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;                                              \
        if (!PB_IN_GRID(ix, iy, iz))                                                                           \
            return;                                                                                            \
        PB_OUT(ix, iy, iz) = pb_field_polyline(img, knots, prm, ix, iy, iz, (ab), (exact), (mass));            \
    }

#define PB_FIELD_ADJOINT(name, ab, mass)                                                                         \
    PB_KERNEL void name(PB_GLOBAL_RO float *in, PB_GLOBAL_RO pb_kknot *knots, pb_kparams prm, PB_GLOBAL float *out) \
    {                                                                                                          \
        int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;                                              \
        float v = pb_adjoint_input(in, prm, ix, iy, iz);                                                       \
        if (v != 0.0f)                                                                                         \
            pb_field_polyline_adjoint(out, knots, prm, ix, iy, iz, (ab), (mass), v);                           \
    }

PB_FIELD_FORWARD(pb_field_ab, 1, 0, 0)
PB_FIELD_FORWARD(pb_field_ab_exact, 1, 1, 0)
PB_FIELD_FORWARD(pb_field_ab_sweep, PB_AB_SWEEP, 0, 0)
PB_FIELD_FORWARD(pb_field_ab_sweep_exact, PB_AB_SWEEP, 1, 0)
PB_FIELD_FORWARD(pb_field_rm, 0, 0, 0)
PB_FIELD_FORWARD(pb_field_rm_exact, 0, 1, 0)
PB_FIELD_ADJOINT(pb_field_adjoint_ab, 1, 0)
PB_FIELD_ADJOINT(pb_field_adjoint_ab_sweep, PB_AB_SWEEP, 0)
PB_FIELD_ADJOINT(pb_field_adjoint_rm, 0, 0)
/* The mass-preserving ones (pb_blur_options.jacobian). */
PB_FIELD_FORWARD(pb_field_mass_ab, 1, 0, 1)
PB_FIELD_FORWARD(pb_field_mass_ab_exact, 1, 1, 1)
PB_FIELD_FORWARD(pb_field_mass_ab_sweep, PB_AB_SWEEP, 0, 1)
PB_FIELD_FORWARD(pb_field_mass_ab_sweep_exact, PB_AB_SWEEP, 1, 1)
PB_FIELD_FORWARD(pb_field_mass_rm, 0, 0, 1)
PB_FIELD_FORWARD(pb_field_mass_rm_exact, 0, 1, 1)
PB_FIELD_ADJOINT(pb_field_mass_adjoint_ab, 1, 1)
PB_FIELD_ADJOINT(pb_field_mass_adjoint_ab_sweep, PB_AB_SWEEP, 1)
PB_FIELD_ADJOINT(pb_field_mass_adjoint_rm, 0, 1)

/* REF's mass-preserving weight at its time step s: the determinant there
 * (1 unless prm.jacobian). */
PB_FN float pb_field_step_jacobian(PB_GLOBAL_RO pb_kknot *knots, PB_GLOBAL_RO float *fields, pb_kparams prm, int s,
                                   int ix, int iy, int iz)
{
    if (!prm.jacobian)
        return 1.0f;
    float g[9];
    pb_field_gradient(knots, fields, prm, s, ix, iy, iz, g);
    return pb_blend_det(g, g, 0.0f);
}

/* REF's random point c of voxel (ix, iy, iz) at time step s, in object texel
 * coordinates: the point (texel coordinates, inside the voxel) plus the field
 * interpolated there. */
PB_FN void pb_field_ref_point(PB_GLOBAL_RO pb_kknot *knots, PB_GLOBAL_RO float *fields, pb_kparams prm, int s,
                              int ix, int iy, int iz, unsigned int key, unsigned int c, float *o)
{
    const float scale = 1.0f / 16777216.0f;
    float p[3] = {(float)ix + ((float)pb_ref_bits(key, c, 0u) + 0.5f) * scale,
                  (float)iy + ((float)pb_ref_bits(key, c, 1u) + 0.5f) * scale,
                  (float)iz + ((float)pb_ref_bits(key, c, 2u) + 0.5f) * scale};
    pb_field_point(knots, fields, prm, s, p, -1, o);
}

PB_KERNEL void pb_field_ref(pb_image img, PB_GLOBAL_RO pb_kknot *knots, pb_kparams prm, PB_GLOBAL float *out)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;
    if (!PB_IN_GRID(ix, iy, iz))
        return;
    PB_GLOBAL_RO float *fields = pb_field_data(knots, prm);
    unsigned int key = pb_ref_key(prm.seed, (unsigned int)(ix + prm.dims[0] * (iy + prm.dims[1] * iz)));
    float total = 0.0f;
    for (int s = 0; s < prm.ref_steps; s++) {
        float acc = 0.0f;
        for (int k = 0; k < prm.ref_points; k++) {
            float o[3];
            pb_field_ref_point(knots, fields, prm, s, ix, iy, iz, key, (unsigned int)(s * prm.ref_points + k), o);
            acc += PB_FETCH_NEAREST(img, o[0], o[1], o[2]);
        }
        total += knots[s].weight * pb_field_step_jacobian(knots, fields, prm, s, ix, iy, iz) * acc /
                 (float)prm.ref_points;
    }
    PB_OUT(ix, iy, iz) = total;
}

PB_KERNEL void pb_field_adjoint_ref(PB_GLOBAL_RO float *in, PB_GLOBAL_RO pb_kknot *knots, pb_kparams prm,
                                    PB_GLOBAL float *out)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z + prm.z0;
    float v = pb_adjoint_input(in, prm, ix, iy, iz);
    if (v == 0.0f)
        return;
    PB_GLOBAL_RO float *fields = pb_field_data(knots, prm);
    unsigned int key = pb_ref_key(prm.seed, (unsigned int)(ix + prm.dims[0] * (iy + prm.dims[1] * iz)));
    for (int s = 0; s < prm.ref_steps; s++) {
        float vs = v * knots[s].weight * pb_field_step_jacobian(knots, fields, prm, s, ix, iy, iz) /
                   (float)prm.ref_points;
        for (int k = 0; k < prm.ref_points; k++) {
            float o[3];
            pb_field_ref_point(knots, fields, prm, s, ix, iy, iz, key, (unsigned int)(s * prm.ref_points + k), o);
            pb_scatter(out, prm, pb_voxel_index(floor(o[0])), pb_voxel_index(floor(o[1])), pb_voxel_index(floor(o[2])),
                       vs);
        }
    }
}
