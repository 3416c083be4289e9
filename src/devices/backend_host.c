/* The host backend: every method in plain C and double precision, written for
 * clarity and never for speed (the forward's voxels, each its own gather, on
 * the machine's cores). It is the reference the device backends are
 * tested against, so it shares no arithmetic with the kernels: where a kernel
 * computes a weight incrementally or piecewise, this file integrates it in
 * closed form. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "backend.h"
#include "parallel.h"
#include "pb_kernel_types.h"

/* The operator's two directions share every weight: the forward reads
 * weight times an object voxel, the adjoint adds weight times the tomograph
 * voxel's value into it. Each function below gets the product of the weights
 * above it as `scale` and hands every voxel weight to touch(). */
typedef struct host_io {
    const float *in; /* forward: the object volume */
    double *acc;     /* adjoint: the object volume being summed into */
    long n[3];
} host_io;

/* Forward: scale * w * activity of voxel (i, j, k); adjoint: adds scale * w
 * to it and returns 0. Outside the grid the activity is zero and nothing is
 * added. */
static double touch(const host_io *io, long i, long j, long k, double w)
{
    if (i < 0 || j < 0 || k < 0 || i >= io->n[0] || j >= io->n[1] || k >= io->n[2])
        return 0.0;
    size_t idx = (size_t)(i + io->n[0] * (j + io->n[1] * k));
    if (io->acc) {
        io->acc[idx] += w;
        return 0.0;
    }
    return w * (double)io->in[idx];
}

/* Trilinear interpolation at texel coordinates u (texel i's centre at i + 0.5). */
static double trilinear(const host_io *io, const double u[3], double scale)
{
    double f[3];
    long i0[3];
    for (int d = 0; d < 3; d++) {
        double c = u[d] - 0.5;
        i0[d] = (long)floor(c);
        f[d] = c - (double)i0[d];
    }
    double sum = 0.0;
    for (int corner = 0; corner < 8; corner++) {
        double w = scale;
        long idx[3];
        for (int d = 0; d < 3; d++) {
            int up = corner >> d & 1;
            idx[d] = i0[d] + up;
            w *= up ? f[d] : 1.0 - f[d];
        }
        sum += touch(io, idx[0], idx[1], idx[2], w);
    }
    return sum;
}

/* Bilinear interpolation inside slice k orthogonal to axis m, at the transverse
 * texel coordinates of u (u[m] is ignored). */
static double bilinear_in_slice(const host_io *io, int m, long k, const double u[3], double scale)
{
    int t1 = (m + 1) % 3, t2 = (m + 2) % 3;
    double c1 = u[t1] - 0.5, c2 = u[t2] - 0.5;
    long i1 = (long)floor(c1), i2 = (long)floor(c2);
    double f1 = c1 - (double)i1, f2 = c2 - (double)i2;
    double sum = 0.0;
    for (int corner = 0; corner < 4; corner++) {
        long idx[3];
        idx[m] = k;
        idx[t1] = i1 + (corner & 1);
        idx[t2] = i2 + (corner >> 1);
        double w = ((corner & 1) ? f1 : 1.0 - f1) * ((corner >> 1) ? f2 : 1.0 - f2);
        sum += touch(io, idx[0], idx[1], idx[2], scale * w);
    }
    return sum;
}

static void apply_map(const double m[12], const double u[3], double out[3])
{
    for (int r = 0; r < 3; r++)
        out[r] = m[4 * r] * u[0] + m[4 * r + 1] * u[1] + m[4 * r + 2] * u[2] + m[4 * r + 3];
}

/* Integral over [-1, u] of the tent 1 - |s| (u clamped to [-1, 1]), and of s
 * times the tent: the overlap of a unit box with a box centred on a slice, and
 * its first moment. */
static double tent_integral(double u)
{
    u = fmax(-1.0, fmin(1.0, u));
    return u <= 0.0 ? 0.5 * (u + 1.0) * (u + 1.0) : 1.0 - 0.5 * (1.0 - u) * (1.0 - u);
}

static double tent_moment(double u)
{
    u = fmax(-1.0, fmin(1.0, u));
    return u <= 0.0 ? u * u / 2.0 + u * u * u / 3.0 - 1.0 / 6.0 : u * u / 2.0 - u * u * u / 3.0 - 1.0 / 6.0;
}

/* Points (in voxel-centre coordinates: voxel i's centre at i) of a segment. */
static int major_axis(const double a[3], const double b[3])
{
    int m = 0;
    for (int d = 1; d < 3; d++)
        if (fabs(b[d] - a[d]) > fabs(b[m] - a[m]))
            m = d;
    return m;
}

/* Slices AB visits on the segment a-b (texel coordinates): all whose tent
 * weight is not zero. CL and RM take as many samples by default. */
static long ab_slice_count(const double a[3], const double b[3])
{
    int m = major_axis(a, b);
    double lo = fmin(a[m], b[m]) - 0.5, hi = fmax(a[m], b[m]) - 0.5;
    return (long)ceil(hi) - (long)floor(lo) + 1;
}

/* Integral over [-1, u] of s^2 times the tent: the second moment. */
static double tent_second(double u)
{
    u = fmax(-1.0, fmin(1.0, u));
    return u <= 0.0 ? u * u * u / 3.0 + u * u * u * u / 4.0 + 1.0 / 12.0
                    : 1.0 / 12.0 + u * u * u / 3.0 - u * u * u * u / 4.0;
}

/* Where AB reads slices at two points (cl/pb_blur.cl says why): from this
 * sideways sweep a slice, in voxels, moving apart until the second. */
#define AB_SWEEP_FROM 0.125
#define AB_SWEEP_FULL 0.25

/* Antialiased Bresenham along a-b (texel coordinates): slice k along the major
 * axis gets the share of the path that overlaps it, the time average of the
 * tent 1 - |x - k|; inside the slice, the four voxels around the path's
 * tent-weighted mean position get bilinear (the paper's A_S, A_T) weights.
 * With sweep, where the path moves sideways across the slice, the slice is
 * read at two points of the path instead, half each, at the mean plus and
 * minus the tent-weighted standard deviation. */
static double ab_segment(const host_io *io, const double a[3], const double b[3], int sweep, double scale)
{
    int m = major_axis(a, b);
    double am = a[m] - 0.5, bm = b[m] - 0.5;
    double lo = fmin(am, bm), hi = fmax(am, bm), len = hi - lo;
    if (len < 1e-9) {
        /* A point: the tent weights of its two slices times bilinear weights are
         * the trilinear weights. */
        double mid[3] = {0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])};
        return trilinear(io, mid, scale);
    }
    double side = 0.0;
    for (int d = 0; d < 3; d++)
        if (d != m)
            side = fmax(side, fabs((b[d] - a[d]) / (bm - am)));
    int two = sweep && side > AB_SWEEP_FROM;
    double apart = fmin(1.0, (side - AB_SWEEP_FROM) / (AB_SWEEP_FULL - AB_SWEEP_FROM));
    double sum = 0.0;
    for (long k = (long)floor(lo); k <= (long)ceil(hi); k++) {
        double w = tent_integral(hi - k) - tent_integral(lo - k);
        if (w <= 0.0)
            continue;
        double mean = (tent_moment(hi - k) - tent_moment(lo - k)) / w;
        double var = (tent_second(hi - k) - tent_second(lo - k)) / w - mean * mean;
        double spread = two && var > 0.0 ? sqrt(var) : 0.0;
        for (int i = two ? -1 : 0; i <= (two ? 1 : 0); i += 2) {
            double s = (k + mean + i * apart * spread - am) / (bm - am);
            double p[3];
            for (int d = 0; d < 3; d++)
                p[d] = a[d] + s * (b[d] - a[d]);
            sum += bilinear_in_slice(io, m, k, p, scale * w / len * (two ? 0.5 : 1.0));
        }
    }
    return sum;
}

/* The first point of a-b (texel coordinates) past fraction t at which a
 * coordinate crosses a texel centre (i + 0.5), as a fraction of the way, or
 * 1 where none is left: the trilinear filter's slope jumps there. A crossing
 * within 1e-9 voxels of t is passed over, so that each call moves on. */
static double next_kink(const double a[3], const double b[3], double t)
{
    double next = 1.0;
    for (int d = 0; d < 3; d++) {
        double step = b[d] - a[d];
        if (fabs(step) < 1e-12)
            continue;
        double c = a[d] + t * step - 0.5, i = step > 0.0 ? floor(c + 1e-9) + 1.0 : ceil(c - 1e-9) - 1.0;
        next = fmin(next, (i + 0.5 - a[d]) / step);
    }
    return next;
}

/* The trilinear filter's exact time average over the chord a-b: cut at every
 * texel centre it crosses, inside each piece a cubic, which two
 * Gauss-Legendre points integrate exactly (AB's and RM's on short segments;
 * CL on a field is RM, its chord the motion). */
static double chord_exact(const host_io *io, const double a[3], const double b[3], double scale)
{
    double sum = 0.0, t1;
    for (double t0 = 0.0; t0 < 1.0; t0 = t1) {
        t1 = next_kink(a, b, t0);
        if (!(t1 > t0)) /* rounding stalled: the rest is one piece */
            t1 = 1.0;
        for (int g = -1; g <= 1; g += 2) {
            double t = t0 + (t1 - t0) * (0.5 + g * 0.5 / sqrt(3.0)), p[3];
            for (int d = 0; d < 3; d++)
                p[d] = a[d] + t * (b[d] - a[d]);
            sum += trilinear(io, p, 0.5 * scale * (t1 - t0));
        }
    }
    return sum;
}

/* AB over a-b: exact on short segments, the walk on long ones, both in
 * between, weighed by the length along the major axis (PB_AB_EXACT_TO and
 * PB_AB_WALK_FROM; cl/pb_blur.cl says why); RM's default follows the same
 * rule with its S samples for the walk. */
static double ab_walk_weight(const double a[3], const double b[3])
{
    double along = fmax(fabs(b[0] - a[0]), fmax(fabs(b[1] - a[1]), fabs(b[2] - a[2])));
    if (along < 1e-4)
        return 1.0; /* a point */
    return fmin(1.0, fmax(0.0, (along - (double)PB_AB_EXACT_TO) / (double)(PB_AB_WALK_FROM - PB_AB_EXACT_TO)));
}

/* chord: every segment exact (PB_AB_SAMPLING_CHORD). */
static double ab_exact_or_walked(const host_io *io, const double a[3], const double b[3], int sweep, int chord,
                                 double scale)
{
    double walk = chord ? 0.0 : ab_walk_weight(a, b);
    double sum = 0.0;
    if (walk < 1.0)
        sum += chord_exact(io, a, b, scale * (1.0 - walk));
    if (walk > 0.0)
        sum += ab_segment(io, a, b, sweep, scale * walk);
    return sum;
}

/* Key point j of the voxel at texel coordinates u: under a pose track the
 * key pose's map, under a field the field there. */
static void key_point(const pb_path *plan, size_t j, const double u[3], double out[3])
{
    if (plan->field)
        pb_path_field_point(plan, &plan->field->knots[j], u, out);
    else
        apply_map(plan->poses[j].map, u, out);
}

/* I + dD/dr of a field knot at image voxel at[], row-major: differences of
 * the field between the voxel's neighbours, one-sided at the grid's faces
 * (the kernels' rule, cl/pb_field.cl). */
static void field_gradient(const pb_path *plan, const pb_path_knot *knot, const long at[3], double g[9])
{
    for (int a = 0; a < 3; a++) {
        long lo = at[a] > 0 ? at[a] - 1 : 0, hi = at[a] + 1 < (long)plan->geometry.dims[a] ? at[a] + 1 : at[a];
        double dl[3] = {0, 0, 0}, dh[3] = {0, 0, 0};
        for (int side = 0; side < 2 && hi > lo; side++) {
            double u[3] = {at[0] + 0.5, at[1] + 0.5, at[2] + 0.5}, o[3];
            u[a] = (side ? hi : lo) + 0.5;
            pb_path_field_point(plan, knot, u, o);
            for (int r = 0; r < 3; r++)
                (side ? dh : dl)[r] = o[r] - u[r];
        }
        for (int r = 0; r < 3; r++)
            g[3 * r + a] = (hi > lo ? (dh[r] - dl[r]) / (double)(hi - lo) : 0.0) + (r == a ? 1.0 : 0.0);
    }
}

static double abs_det(const double g[9])
{
    return fabs(g[0] * (g[4] * g[8] - g[5] * g[7]) - g[1] * (g[3] * g[8] - g[5] * g[6]) +
                g[2] * (g[3] * g[7] - g[4] * g[6]));
}

/* The mean over a segment's time of |det(I + dD/dr)|: the gradient is linear
 * in time along it and the determinant a cubic, which Simpson's rule
 * integrates exactly. The kernels' rule too: where a fold makes the
 * determinant change sign inside the segment its absolute value is no cubic,
 * and another rule would give another mean. */
static double segment_jacobian(const double A[9], const double B[9])
{
    double sum = 0.0;
    for (int k = 0; k < 3; k++) {
        double g[9], s = 0.5 * k;
        for (int i = 0; i < 9; i++)
            g[i] = (1.0 - s) * A[i] + s * B[i];
        sum += (k == 1 ? 4.0 : 1.0) * abs_det(g);
    }
    return sum / 6.0;
}

/* Tomograph voxel (ix, iy, iz) under the plan: its blurred value (forward), or
 * with io->acc, scale spread over the object voxels it reads (adjoint). */
static double blur_voxel(const host_io *io, const pb_path *plan, const pb_blur_options *opt, long ix, long iy,
                         long iz, double scale)
{
    const double u[3] = {ix + 0.5, iy + 0.5, iz + 0.5};
    double total = 0.0;

    if (opt->method == PB_METHOD_REF) {
        unsigned voxel = (unsigned)(ix + io->n[0] * (iy + io->n[1] * iz));
        unsigned key = pb_ref_key(opt->seed, voxel);
        for (size_t s = 0; s < plan->ref_count; s++) {
            double w = scale * plan->ref_steps[s].weight / opt->ref_points;
            if (plan->field && opt->jacobian) {
                double g[9];
                field_gradient(plan, &plan->field->ref_knots[s], (const long[3]){ix, iy, iz}, g);
                w *= abs_det(g);
            }
            for (unsigned k = 0; k < opt->ref_points; k++) {
                unsigned c = (unsigned)(s * opt->ref_points + k);
                double p[3] = {ix + (pb_ref_bits(key, c, 0) + 0.5) / 16777216.0,
                               iy + (pb_ref_bits(key, c, 1) + 0.5) / 16777216.0,
                               iz + (pb_ref_bits(key, c, 2) + 0.5) / 16777216.0};
                double o[3];
                if (plan->field)
                    pb_path_field_point(plan, &plan->field->ref_knots[s], p, o);
                else
                    apply_map(plan->ref_steps[s].map, p, o);
                /* Box model: the object voxel that holds the point. */
                total += touch(io, (long)floor(o[0]), (long)floor(o[1]), (long)floor(o[2]), w);
            }
        }
        return total;
    }

    for (size_t j = 0; j + 1 < plan->count; j++) {
        const pb_path_pose *p0 = &plan->poses[j], *p1 = &plan->poses[j + 1];
        if (p0->skip) /* clipped: reads nothing of the object (path_clip.c) */
            continue;
        double a[3], b[3];
        key_point(plan, j, u, a);
        key_point(plan, j + 1, u, b);
        double seg_scale = scale * p0->weight;
        if (plan->field && opt->jacobian) {
            const long at[3] = {ix, iy, iz};
            double ga[9], gb[9];
            field_gradient(plan, &plan->field->knots[j], at, ga);
            field_gradient(plan, &plan->field->knots[j + 1], at, gb);
            seg_scale *= segment_jacobian(ga, gb);
        }
        if (opt->method == PB_METHOD_AB) {
            unsigned parts = opt->steps ? opt->steps : 1;
            for (unsigned r = 0; r < parts; r++) {
                double pa[3], pb[3];
                for (int d = 0; d < 3; d++) {
                    pa[d] = a[d] + (b[d] - a[d]) * r / parts;
                    pb[d] = a[d] + (b[d] - a[d]) * (r + 1) / parts;
                }
                total += ab_exact_or_walked(io, pa, pb, opt->ab_sampling == PB_AB_SAMPLING_SWEEP,
                                            opt->ab_sampling == PB_AB_SAMPLING_CHORD, seg_scale / parts);
            }
        } else {
            /* RM's default (and CL's on a field, RM there): AB's rule by
             * length, the exact chord's share here, the samples' below. */
            if (!opt->steps && (opt->method == PB_METHOD_RM || plan->field)) {
                double walk = ab_walk_weight(a, b);
                if (walk < 1.0)
                    total += chord_exact(io, a, b, seg_scale * (1.0 - walk));
                seg_scale *= walk;
                if (walk == 0.0)
                    continue;
            }
            long n = opt->steps ? (long)opt->steps : ab_slice_count(a, b);
            for (long i = 0; i < n; i++) {
                double s = (i + 0.5) / n, o[3];
                /* A field is linear in time between its samples: the
                 * motion interpolated at every step is the chord's point. */
                if (opt->method == PB_METHOD_RM || plan->field) {
                    for (int d = 0; d < 3; d++)
                        o[d] = a[d] + s * (b[d] - a[d]);
                } else {
                    /* Classical: the pose itself is interpolated at every step. */
                    pb_pose pose;
                    double map[12];
                    pb_pose_interpolate(&p0->pose, &p1->pose, s, &pose);
                    pb_pose_texel_map(&pose, plan->center, plan->geometry.voxel_size, map);
                    apply_map(map, u, o);
                }
                total += trilinear(io, o, seg_scale / n);
            }
        }
    }
    return total;
}

/* ---- ops ----------------------------------------------------------------- */

static pb_status host_device_count(int *count)
{
    *count = 1;
    return PB_OK;
}

static pb_status host_device_info(int index, pb_device_info *info)
{
    (void)index;
    memset(info, 0, sizeof *info);
    strcpy(info->name, "host CPU (double precision reference)");
    strcpy(info->platform, "host");
    info->image_support = 1;
    info->compute_units = 1;
    return PB_OK;
}

static pb_status host_context_init(pb_device *dev, int index, const char *build_options)
{
    (void)build_options;
    if (index != 0)
        return pb_error(pb_owner(dev), PB_ERR_NO_DEVICE, "the host backend has one device, 0; device %d does not exist", index);
    return host_device_info(0, &dev->info);
}

static void host_context_release(pb_device *dev)
{
    (void)dev;
}

/* Buffers are host memory: the reference reads and writes them directly. */
static pb_status host_buffer_create(pb_device *dev, size_t bytes, void **buffer)
{
    *buffer = malloc(bytes);
    if (!*buffer)
        return pb_error(pb_owner(dev), PB_ERR_OUT_OF_MEMORY, "out of host memory for %.1f MiB", bytes / 1048576.0);
    return PB_OK;
}

static void host_buffer_release(pb_device *dev, void *buffer)
{
    (void)dev;
    free(buffer);
}

static pb_status host_buffer_write(pb_device *dev, void *buffer, const void *host, size_t bytes)
{
    (void)dev;
    memmove(buffer, host, bytes); /* host may be the volume's own memory (pb_volume_memory) */
    return PB_OK;
}

static pb_status host_buffer_read(pb_device *dev, const void *buffer, void *host, size_t bytes)
{
    (void)dev;
    memmove(host, buffer, bytes);
    return PB_OK;
}

static pb_status host_buffer_zero(pb_device *dev, void *buffer, size_t bytes)
{
    (void)dev;
    memset(buffer, 0, bytes);
    return PB_OK;
}

/* The caller's host memory: its size cannot be known here. */
static pb_status host_buffer_check(pb_device *dev, const void *buffer, size_t bytes, const char *what, int written)
{
    (void)bytes;
    (void)written;
    return buffer ? PB_OK : pb_error(pb_owner(dev), PB_ERR_INVALID_ARGUMENT, "the %s memory is NULL", what);
}

static double elapsed_ms(const struct timespec *t0)
{
    struct timespec t1;
    clock_gettime(CLOCK_MONOTONIC, &t1);
    return (t1.tv_sec - t0->tv_sec) * 1e3 + (t1.tv_nsec - t0->tv_nsec) * 1e-6;
}

/* The forward runs on the machine's cores from this many voxels on (32^3):
 * below it, starting the threads costs more than they save. */
#define HOST_THREADS_FROM 32768

typedef struct forward_job {
    host_io io;
    const pb_path *plan;
    const pb_blur_options *opt;
    float *out;
    long z0;
} forward_job;

/* Plane z0 + i of the forward: each voxel its own gather, the same bits on
 * any thread. */
static void forward_plane(void *arg, size_t i)
{
    const forward_job *j = arg;
    const long iz = j->z0 + (long)i, nx = j->io.n[0], ny = j->io.n[1];
    for (long iy = 0; iy < ny; iy++)
        for (long ix = 0; ix < nx; ix++)
            j->out[ix + nx * (iy + ny * iz)] = (float)blur_voxel(&j->io, j->plan, j->opt, ix, iy, iz, 1.0);
}

static pb_status host_forward(pb_device *dev, const float *in, const pb_path *plan, const pb_blur_options *opt,
                              const size_t *d, float *out)
{
    struct timespec t0;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    forward_job job = {{in, NULL, {(long)d[0], (long)d[1], (long)d[2]}}, plan, opt, out, 0};
    /* threads only for this call, joined before it returns */
    pb_pool *pool = d[0] * d[1] * d[2] >= HOST_THREADS_FROM ? pb_pool_create() : NULL;
    /* planes in batches, the progress reported between them on the caller's thread */
    const long batch = pool ? 4 * (long)pb_pool_threads(pool) : 1, nz = job.io.n[2];
    for (long z0 = 0; z0 < nz; z0 += batch) {
        job.z0 = z0;
        pb_pool_for(pool, (size_t)(z0 + batch < nz ? batch : nz - z0), forward_plane, &job);
        if (dev->progress && z0 + batch < nz)
            dev->progress((double)(z0 + batch) / (double)nz, dev->progress_user);
    }
    pb_pool_destroy(pool);
    dev->last_kernel_ms = elapsed_ms(&t0);
    return PB_OK;
}

/* The transpose, summed in double and rounded once (onto the object's own
 * values with accumulate). */
static pb_status host_adjoint(pb_device *dev, const float *in, const pb_path *plan, const pb_blur_options *opt,
                              const size_t *d, float *out, int accumulate)
{
    struct timespec t0;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    size_t count = d[0] * d[1] * d[2];
    double *acc = calloc(count, sizeof *acc);
    if (!acc)
        return pb_error(pb_owner(dev), PB_ERR_OUT_OF_MEMORY, "out of host memory for the adjoint's %.1f MiB sum",
                        count * 8.0 / 1048576.0);
    host_io io = {NULL, acc, {(long)d[0], (long)d[1], (long)d[2]}};
    for (size_t i = 0; accumulate && i < count; i++)
        acc[i] = (double)out[i];
    for (long iz = 0; iz < io.n[2]; iz++) {
        for (long iy = 0; iy < io.n[1]; iy++)
            for (long ix = 0; ix < io.n[0]; ix++) {
                double v = (double)in[ix + io.n[0] * (iy + io.n[1] * iz)];
                if (v != 0.0)
                    blur_voxel(&io, plan, opt, ix, iy, iz, v);
            }
        if (dev->progress && iz + 1 < io.n[2])
            dev->progress((double)(iz + 1) / (double)io.n[2], dev->progress_user);
    }
    for (size_t i = 0; i < count; i++)
        out[i] = (float)acc[i];
    free(acc);
    dev->last_kernel_ms = elapsed_ms(&t0);
    return PB_OK;
}

/* The per-frame operation: the path is all a frame needs here. */
static pb_status host_frame_prepare(pb_device *dev, const pb_blur_options *opt, pb_plan_frame *frame)
{
    (void)dev, (void)opt, (void)frame;
    return PB_OK;
}

static pb_status host_frame_apply(pb_device *dev, const pb_frame_set *plan, size_t index, int adjoint, const void *in,
                                  pb_images *in_images, void *out, int accumulate, int fresh_input)
{
    (void)in_images, (void)fresh_input;
    const pb_path *path = &plan->frame[index].path;
    dev->last_input_ms = 0.0;
    return adjoint ? host_adjoint(dev, in, path, &plan->options, plan->geometry.dims, out, accumulate)
                   : host_forward(dev, in, path, &plan->options, plan->geometry.dims, out);
}

static pb_status host_frames_forward(pb_device *dev, const pb_frame_set *plan, const pb_memory *const *ins,
                                     pb_memory *const *outs)
{
    double total = 0.0;
    pb_status st = PB_OK;
    for (size_t i = 0; i < plan->frames && st == PB_OK; i++) {
        st = host_frame_apply(dev, plan, i, 0, ins[i]->buffer, NULL, outs[i]->buffer, 0, 0);
        total += dev->last_kernel_ms;
    }
    dev->last_kernel_ms = total;
    return st;
}

const pb_backend_ops pb_backend_host_ops = {
    .id = PB_BACKEND_HOST,
    .addresses = 1,
    .device_count = host_device_count,
    .device_info = host_device_info,
    .context_init = host_context_init,
    .context_release = host_context_release,
    .buffer_create = host_buffer_create,
    .buffer_release = host_buffer_release,
    .buffer_write = host_buffer_write,
    .buffer_read = host_buffer_read,
    .buffer_zero = host_buffer_zero,
    .buffer_check = host_buffer_check,
    .frame_prepare = host_frame_prepare,
    .frame_apply = host_frame_apply,
    .frames_forward = host_frames_forward,
};
