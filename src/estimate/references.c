/* A reference for each frame that has the frame's own contrast. Tracer
 * uptake changes from frame to frame, and not by one factor: blood fades as
 * grey matter fills. A registration to one fixed image then trades contrast
 * for motion (a bias of about a millimetre over four minutes of FDG). But the
 * frames, moved back onto the reference, span few dimensions (one per tissue
 * curve), so frame k's reference is its projection onto the leading
 * principal images of the other frames: its own contrast, the others'
 * counts, none of its own noise. The others are its nearest in time, at most
 * PBE_REFERENCE_OTHERS: uptake changes slowly against a frame, and a window
 * keeps each frame's work fixed however long the series. Each other frame
 * counts by its noise: a frame of 3 s holds ten times the noise of one of
 * 60 s, and unweighted the principal images after the first are the short
 * frames' noise. By default that noise is the frame's energy beyond the
 * leading images (pbe_noise_scales), which holds a frame's misregistration
 * and its contrast's change too: on a series from injection the frames whose
 * uptake differs most, the first minutes', weigh least, their contrast leaves
 * the leading images, and a frame's reference takes a later frame's contrast.
 * Given each frame's noise measured alone (pbe_frame_noise), the frames weigh
 * by it and the noise's eigenvalue is taken off each leading image's: the
 * references then hold the frame's own contrast, and more noise
 * (docs/estimate-log.md, "The own references' weights", measures both and
 * says why that is not the default). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "estimate.h"
#include "motion.h"

void pbe_eigen(double *a, size_t n, double *w, double *v)
{
    for (size_t i = 0; i < n; i++)
        for (size_t j = 0; j < n; j++)
            v[i * n + j] = i == j;
    for (int sweep = 0; sweep < 60; sweep++) {
        double off = 0.0, diag = 0.0;
        for (size_t i = 0; i < n; i++) {
            diag += a[i * n + i] * a[i * n + i];
            for (size_t j = i + 1; j < n; j++)
                off += a[i * n + j] * a[i * n + j];
        }
        if (off <= 1e-24 * diag)
            break;
        for (size_t p = 0; p < n; p++)
            for (size_t q = p + 1; q < n; q++) {
                double apq = a[p * n + q];
                if (fabs(apq) < 1e-300)
                    continue;
                double theta = (a[q * n + q] - a[p * n + p]) / (2.0 * apq);
                double t = (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
                double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
                for (size_t k = 0; k < n; k++) {
                    double akp = a[k * n + p], akq = a[k * n + q];
                    a[k * n + p] = c * akp - s * akq;
                    a[k * n + q] = s * akp + c * akq;
                }
                for (size_t k = 0; k < n; k++) {
                    double apk = a[p * n + k], aqk = a[q * n + k];
                    a[p * n + k] = c * apk - s * aqk;
                    a[q * n + k] = s * apk + c * aqk;
                }
                for (size_t k = 0; k < n; k++) {
                    double vkp = v[k * n + p], vkq = v[k * n + q];
                    v[k * n + p] = c * vkp - s * vkq;
                    v[k * n + q] = s * vkp + c * vkq;
                }
            }
    }
    for (size_t i = 0; i < n; i++)
        w[i] = a[i * n + i];
}

size_t pbe_reference_rank(size_t frames)
{
    size_t r = frames / 4;
    return r < 1 ? 1 : r > PBE_RANK_MOST ? PBE_RANK_MOST : r;
}

size_t pbe_leading(const double *w, size_t m, size_t rank, size_t *out)
{
    size_t count = rank < m ? rank : m;
    if (count > PBE_RANK_MOST) /* out holds that many: the ranks are pbe_reference_rank's */
        count = PBE_RANK_MOST;
    for (size_t c = 0; c < count; c++) {
        size_t best = m;
        for (size_t j = 0; j < m; j++) {
            int taken = 0;
            for (size_t d = 0; d < c; d++)
                taken |= out[d] == j;
            if (!taken && (best == m || w[j] > w[best]))
                best = j;
        }
        out[c] = best;
    }
    return count;
}

void pbe_reference_window(size_t frames, size_t k, size_t *first, size_t *end)
{
    size_t width = frames < PBE_REFERENCE_OTHERS + 1 ? frames : PBE_REFERENCE_OTHERS + 1;
    size_t lo = k > width / 2 ? k - width / 2 : 0;
    if (lo + width > frames)
        lo = frames - width;
    *first = lo;
    *end = lo + width;
}

/* g_i . g_j from the band, |i - j| <= PBE_REFERENCE_OTHERS. */
static double band_at(const double *band, size_t i, size_t j)
{
    return i <= j ? band[i * (PBE_REFERENCE_OTHERS + 1) + (j - i)] : band[j * (PBE_REFERENCE_OTHERS + 1) + (i - j)];
}

/* The inner products of frames, n voxels each, a row of them per item of
 * a loop on the pool: into a band (pbe_gram_band) or a square (pbe_gram). */
typedef struct products_job {
    const float *moved;
    size_t n, frames;
    double *out;
} products_job;

static void band_row(void *arg, size_t i)
{
    const products_job *j = arg;
    for (size_t d = 0; d <= PBE_REFERENCE_OTHERS && i + d < j->frames; d++)
        j->out[i * (PBE_REFERENCE_OTHERS + 1) + d] = pbe_dot(j->moved + i * j->n, j->moved + (i + d) * j->n, j->n);
}

void pbe_gram_band(pb_pool *pool, const float *moved, size_t n, size_t frames, double *band)
{
    products_job j = {moved, n, frames, band};
    pb_pool_for(pool, frames, band_row, &j);
}

double pbe_dot(const float *a, const float *b, size_t n)
{
    double s = 0.0;
    for (size_t v = 0; v < n; v++)
        s += (double)a[v] * (double)b[v];
    return s;
}

static void gram_row(void *arg, size_t i)
{
    const products_job *j = arg;
    for (size_t k = i; k < j->frames; k++)
        j->out[i * j->frames + k] = j->out[k * j->frames + i] =
            pbe_dot(j->moved + i * j->n, j->moved + k * j->n, j->n);
}

void pbe_gram(pb_pool *pool, const float *moved, size_t n, size_t frames, double *gram)
{
    products_job j = {moved, n, frames, gram};
    pb_pool_for(pool, frames, gram_row, &j);
}

/* The reference's voxels of one chunk: the other frames weighed. */
typedef struct weigh_job {
    const float *moved;
    size_t n, m;
    const size_t *other;
    const double *coef;
    float *out;
} weigh_job;

static void weigh_chunk(void *arg, size_t c)
{
    const weigh_job *j = arg;
    const size_t begin = c * PB_CHUNK, end = begin + PB_CHUNK < j->n ? begin + PB_CHUNK : j->n;
    memset(j->out + begin, 0, sizeof(float) * (end - begin));
    for (size_t i = 0; i < j->m; i++) {
        const float *g = j->moved + j->other[i] * j->n;
        float w = (float)j->coef[i];
        for (size_t p = begin; p < end; p++)
            j->out[p] += w * g[p];
    }
}

/* A frame's energy beyond the leading images is its noise where the frames
 * differ by their noise alone; where two frames share theirs (a frame given
 * twice) or have none (a series without noise) it is rounding, and its
 * weight would be without bound; so would a frame's whose noise measured
 * alone is none (contrast_poses.c). Held to this share of the median, no
 * frame weighs more than ten times the median frame (the weights of frames
 * of 2 s and of 60 s differ about fivefold). */
#define NOISE_FLOOR_SHARE 0.01

void pbe_noise_scales(const double *gram, size_t m, size_t rank, double *a, double *w, double *v, double *scale)
{
    memcpy(a, gram, sizeof(double) * m * m);
    pbe_eigen(a, m, w, v);
    for (size_t i = 0; i < m; i++)
        scale[i] = gram[i * m + i];
    size_t lead[PBE_RANK_MOST];
    for (size_t c = 0, count = pbe_leading(w, m, rank, lead); c < count; c++)
        for (size_t i = 0; i < m; i++)
            scale[i] -= w[lead[c]] * v[i * m + lead[c]] * v[i * m + lead[c]];
    pbe_weights_of_variances(scale, m, w);
}

void pbe_weights_of_variances(double *scale, size_t m, double *sorted)
{
    memcpy(sorted, scale, sizeof(double) * m);
    qsort(sorted, m, sizeof(double), pb_compare_doubles);
    const double least = NOISE_FLOOR_SHARE * sorted[m / 2];
    for (size_t i = 0; i < m; i++)
        scale[i] = least > 0 ? 1.0 / sqrt(fmax(scale[i], least)) : 1.0;
}

/* A frame's noise from the frame alone: the median absolute finest Haar
 * detail (the 2x2x2 block's voxels with alternating signs, which a smooth
 * image and a plane edge leave near zero, so a misregistration does not
 * change it) over the blocks brighter than the frame's mean (the head: the
 * air outside holds no counts and no noise). 0 where no block qualifies,
 * -1 where host memory runs out. */
double pbe_frame_noise(const float *f, const size_t d[3])
{
    size_t bx = d[0] / 2, by = d[1] / 2, bz = d[2] / 2, n = d[0] * d[1] * d[2], used = 0;
    double mean = 0.0;
    for (size_t i = 0; i < n; i++)
        mean += (double)f[i];
    mean /= (double)n;
    double *det = malloc(sizeof(double) * (bx * by * bz + 1));
    if (!det)
        return -1.0;
    for (size_t z = 0; z < bz; z++)
        for (size_t y = 0; y < by; y++)
            for (size_t x = 0; x < bx; x++) {
                double sum = 0.0, hhh = 0.0;
                for (int c = 0; c < 8; c++) {
                    size_t i = (2 * x + (c & 1)) + d[0] * ((2 * y + (c >> 1 & 1)) + d[1] * (2 * z + (c >> 2 & 1)));
                    sum += (double)f[i];
                    hhh += ((c & 1) ^ (c >> 1 & 1) ^ (c >> 2 & 1)) ? -(double)f[i] : (double)f[i];
                }
                if (sum > 8.0 * mean)
                    det[used++] = fabs(hhh);
            }
    double med = 0.0;
    if (used) {
        qsort(det, used, sizeof(double), pb_compare_doubles);
        med = det[used / 2];
    }
    free(det);
    return med;
}

/* PETBLUR_ESTIMATE_REFERENCES, for comparisons: =unweighted counts every
 * other frame alike, =noise weighs them by their noise measured alone with the
 * noise's eigenvalue taken off, =unshifted so weighs them without it; unset,
 * by their energy beyond the leading images. */
enum { WEIGHED_BY_ENERGY, WEIGHED_ALIKE, WEIGHED_BY_NOISE, WEIGHED_BY_NOISE_UNSHIFTED };

static int reference_weights(void)
{
    const char *env = getenv("PETBLUR_ESTIMATE_REFERENCES");
    if (!env)
        return WEIGHED_BY_ENERGY;
    return strcmp(env, "unweighted") == 0  ? WEIGHED_ALIKE
           : strcmp(env, "noise") == 0     ? WEIGHED_BY_NOISE
           : strcmp(env, "unshifted") == 0 ? WEIGHED_BY_NOISE_UNSHIFTED
                                           : WEIGHED_BY_ENERGY;
}

int pbe_references_by_noise(void)
{
    const int kind = reference_weights();
    return kind == WEIGHED_BY_NOISE || kind == WEIGHED_BY_NOISE_UNSHIFTED;
}

/* The noise's eigenvalue of a whitened Gram matrix: the median of its
 * eigenvalues beyond the leading ones (lead, count of them), those of frames
 * without energy (noise alone, zeroed) left out. 0 where none is left. */
static double noise_eigenvalue(const double *w, size_t m, const size_t *lead, size_t count, double top, double *tail)
{
    size_t t = 0;
    for (size_t j = 0; j < m; j++) {
        int leading = 0;
        for (size_t c = 0; c < count; c++)
            leading |= lead[c] == j;
        if (!leading && w[j] > 1e-12 * top)
            tail[t++] = w[j];
    }
    if (!t)
        return 0.0;
    qsort(tail, t, sizeof(double), pb_compare_doubles);
    return t % 2 ? tail[t / 2] : 0.5 * (tail[t / 2 - 1] + tail[t / 2]);
}

pb_status pbe_frame_reference(pb_pool *pool, const float *moved, size_t n, size_t frames, const double *band,
                              const double *noise, size_t k, float *out)
{
    size_t first, end;
    pbe_reference_window(frames, k, &first, &end);
    const size_t m = end - first - 1, r = pbe_reference_rank(m + 1);
    double *gram = malloc(sizeof(double) * m * m), *a = malloc(sizeof(double) * m * m);
    double *v = malloc(sizeof(double) * m * m), *w = malloc(sizeof(double) * m), *scale = malloc(sizeof(double) * m);
    double *coef = calloc(m, sizeof(double)); /* a weight per other frame of the window */
    size_t *other = malloc(sizeof(size_t) * m);
    if (!gram || !a || !v || !w || !scale || !coef || !other) {
        free(gram), free(a), free(v), free(w), free(scale), free(coef), free(other);
        return PB_ERR_OUT_OF_MEMORY;
    }
    for (size_t i = first, j = 0; i < end; i++)
        if (i != k)
            other[j++] = i;
    /* the other frames weighed by their noise measured alone (noise), or by
     * their energy beyond the leading images where noise is NULL, or alike
     * (reference_weights) */
    const int kind = reference_weights();
    for (size_t i = 0; i < m; i++)
        for (size_t j = 0; j < m; j++)
            gram[i * m + j] = band_at(band, other[i], other[j]);
    if (kind == WEIGHED_ALIKE) {
        for (size_t i = 0; i < m; i++)
            scale[i] = 1.0;
    } else if (noise) {
        for (size_t i = 0; i < m; i++)
            scale[i] = noise[other[i]];
        pbe_weights_of_variances(scale, m, w);
    } else {
        pbe_noise_scales(gram, m, r, a, w, v, scale);
    }
    for (size_t i = 0; i < m; i++)
        for (size_t j = 0; j < m; j++)
            a[i * m + j] = scale[i] * scale[j] * gram[i * m + j];
    pbe_eigen(a, m, w, v);
    /* The principal images of the frames g_i weighed by s_i are
     * U_j = sum_i s_i g_i v_ij / sqrt(w_j); frame k's projection onto them is
     * sum_j U_j (U_j . g_k), a weight per other frame:
     * s_i sum_j v_ij (sum_l v_lj s_l g_l . g_k) / w_j.
     * Each U_j . U_j holds the noise of the frames in it, which g_k . U_j
     * (other frames' noise) does not: with the frames weighed by their noise,
     * that is the same share of every eigenvalue, the noise's own (those
     * beyond the leading ones), and a projection that divides by the whole
     * w_j falls short by it, most on the images of the contrast's change,
     * which stand a few times the noise's eigenvalue. So the noise's
     * eigenvalue is taken off each w_j, at most half of it. */
    double top = 0.0;
    for (size_t j = 0; j < m; j++)
        top = fmax(top, w[j]);
    size_t lead[PBE_RANK_MOST];
    const size_t count = pbe_leading(w, m, r, lead);
    const int shift = noise && kind != WEIGHED_BY_NOISE_UNSHIFTED;
    const double floor = shift ? noise_eigenvalue(w, m, lead, count, top, gram) : 0.0;
    for (size_t c = 0; c < count; c++) {
        const size_t best = lead[c];
        if (!(w[best] > 1e-12 * top))
            continue;
        double dot = 0.0; /* v_j . G^T g_k */
        for (size_t i = 0; i < m; i++)
            dot += v[i * m + best] * scale[i] * band_at(band, other[i], k);
        for (size_t i = 0; i < m; i++)
            coef[i] += scale[i] * v[i * m + best] * dot / fmax(w[best] - floor, 0.5 * w[best]);
    }
    weigh_job job = {moved, n, m, other, coef, out};
    pb_pool_for(pool, pb_chunks(n), weigh_chunk, &job);
    free(gram), free(a), free(v), free(w), free(scale), free(coef), free(other);
    return PB_OK;
}
