/* The frames' poses moved together along their contrast. Where tracer
 * uptake changes fast (blood fading in the first minute), each frame's own
 * reference (references.c) is built from frames whose misregistration
 * follows the same contrast: the early frames shift together and confirm
 * one another, a fixed point of frame-by-frame registration a millimetre
 * wide. What does tell them apart is the series as a whole: moved back onto
 * the reference, aligned frames span as few images as there are tissue
 * curves, and frames that are off add images of their edges. So the poses
 * get one more rigid correction each, the same six parameters scaled by
 * how far each frame's contrast lies from the reference frame's, chosen to
 * minimise what the frames hold beyond their leading principal images. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "estimate.h"
#include "motion.h"

enum { NG = 6 };
static int g_skip[256];

typedef struct collective {
    pb_context *ctx;
    pbe_level *level;
    const float *frames;
    size_t count, rank;
    const double *c;
    const pb_pose *poses;
    const double *weight; /* per frame: its share of the correction */
    double radius;        /* mm: one unit of turn moves a point this far out by 1 mm */
    float *moved, *ref;
    double *gram, *a, *w, *v;
} collective;

/* Frame k's pose under the correction p (mm, and mm at the radius). */
static void corrected(const collective *cv, size_t k, const double p[NG], pb_pose *out)
{
    double step[NG];
    for (int i = 0; i < NG; i++)
        step[i] = cv->weight[k] * p[i] / (i < 3 ? 1.0 : cv->radius);
    pbe_perturb(&cv->poses[k], step, out);
}

/* What the frames moved back under the correction hold beyond their leading
 * principal images: the trace of their Gram matrix less its top eigenvalues. */
static pb_status residual(collective *cv, const double p[NG], double *out)
{
    const size_t n = cv->level->n, m = cv->count;
    for (size_t k = 0; k < m; k++) {
        pb_pose pose, inverse, poses[2];
        double times[2];
        pb_motion motion;
        corrected(cv, k, p, &pose);
        pb_pose_invert(&pose, &inverse);
        pbe_static_motion(&inverse, cv->c, times, poses, &motion);
        pb_status st = pb_volume_upload(cv->level->in[0], cv->frames + k * n);
        if (st == PB_OK)
            st = pbe_blur_reference(cv->ctx, cv->level, &motion);
        if (st != PB_OK)
            return st;
        memcpy(cv->moved + k * n, cv->level->host[0], sizeof(float) * n);
    }
    pbe_gram(cv->moved, n, m, cv->gram);
    if (getenv("PBE_OBJ") && atoi(getenv("PBE_OBJ")) == 3) {
        /* the principal images moved forward onto each frame, fitted there:
         * the data are never resampled */
        /* the principal images of the frames not left out */
        size_t kept[256], mk = 0;
        for (size_t k = 0; k < m; k++)
            if (!g_skip[k] || getenv("PBE_PCAALL"))
                kept[mk++] = k;
        for (size_t i = 0; i < mk; i++)
            for (size_t j = 0; j < mk; j++)
                cv->a[i * mk + j] = cv->gram[kept[i] * m + kept[j]];
        pbe_eigen(cv->a, mk, cv->w, cv->v);
        size_t r = cv->rank < mk ? cv->rank : mk, idx[8];
        for (size_t q = 0; q < r; q++) {
            size_t best = mk;
            for (size_t j = 0; j < mk; j++) {
                int used = 0;
                for (size_t u = 0; u < q; u++)
                    used |= idx[u] == j;
                if (!used && (best == mk || cv->w[j] > cv->w[best]))
                    best = j;
            }
            idx[q] = best;
        }
        float *U = malloc(sizeof(float) * n * r), *A = malloc(sizeof(float) * n * r);
        for (size_t q = 0; q < r; q++) {
            double norm = 1.0 / sqrt(fmax(cv->w[idx[q]], 1e-300));
            for (size_t v = 0; v < n; v++) {
                double acc = 0.0;
                for (size_t i = 0; i < mk; i++)
                    acc += cv->v[i * mk + idx[q]] * (double)cv->moved[kept[i] * n + v];
                U[q * n + v] = (float)(acc * norm);
            }
        }
        double total = 0.0;
        for (size_t k = 0; k < m; k++) {
            pb_pose pose, poses[2];
            double times[2];
            pb_motion motion;
            corrected(cv, k, p, &pose);
            pbe_static_motion(&pose, cv->c, times, poses, &motion);
            for (size_t q = 0; q < r; q++) {
                pb_status st = pb_volume_upload(cv->level->in[0], U + q * n);
                if (st == PB_OK)
                    st = pbe_blur_reference(cv->ctx, cv->level, &motion);
                if (st != PB_OK) {
                    free(U), free(A);
                    return st;
                }
                memcpy(A + q * n, cv->level->host[0], sizeof(float) * n);
            }
            /* least squares of f_k on the r moved images and 1 */
            double g[81] = {0}, h[9] = {0}, ff = 0.0;
            const size_t np = r + 1;
            const float *f = cv->frames + k * n;
            for (size_t v = 0; v < n; v++) {
                double x[9];
                for (size_t q = 0; q < r; q++)
                    x[q] = (double)A[q * n + v];
                x[r] = 1.0;
                for (size_t a = 0; a < np; a++) {
                    h[a] += x[a] * (double)f[v];
                    for (size_t b = 0; b < np; b++)
                        g[a * np + b] += x[a] * x[b];
                }
                ff += (double)f[v] * (double)f[v];
            }
            double cg[81], cc[9], coef[9];
            memcpy(cg, g, sizeof cg);
            memcpy(cc, h, sizeof cc);
            /* Gaussian elimination */
            int ok = 1;
            for (size_t c = 0; c < np && ok; c++) {
                size_t piv = c;
                for (size_t rr = c + 1; rr < np; rr++)
                    if (fabs(cg[rr * np + c]) > fabs(cg[piv * np + c]))
                        piv = rr;
                if (!(fabs(cg[piv * np + c]) > 0)) {
                    ok = 0;
                    break;
                }
                for (size_t kk = 0; kk < np; kk++) {
                    double t = cg[c * np + kk];
                    cg[c * np + kk] = cg[piv * np + kk];
                    cg[piv * np + kk] = t;
                }
                double t = cc[c];
                cc[c] = cc[piv];
                cc[piv] = t;
                for (size_t rr = c + 1; rr < np; rr++) {
                    double fct = cg[rr * np + c] / cg[c * np + c];
                    for (size_t kk = c; kk < np; kk++)
                        cg[rr * np + kk] -= fct * cg[c * np + kk];
                    cc[rr] -= fct * cc[c];
                }
            }
            for (size_t c = np; ok && c-- > 0;) {
                double sum = cc[c];
                for (size_t kk = c + 1; kk < np; kk++)
                    sum -= cg[c * np + kk] * coef[kk];
                coef[c] = sum / cg[c * np + c];
            }
            /* the residual summed directly */
            double sse = 0.0;
            for (size_t v = 0; ok && v < n; v++) {
                double model = coef[r];
                for (size_t q = 0; q < r; q++)
                    model += coef[q] * (double)A[q * n + v];
                sse += (model - (double)f[v]) * (model - (double)f[v]);
            }
            if (!g_skip[k])
                total += ok ? sse : ff;
        }
        free(U);
        free(A);
        *out = total;
        return PB_OK;
    }
    if (getenv("PBE_OBJ") && atoi(getenv("PBE_OBJ")) == 1 && cv->weight) {
        double total = 0.0;
        for (size_t k = 0; k < m; k++) {
            pb_pose pose, poses[2];
            double times[2], sc, off, sse;
            pb_motion motion;
            pb_status st = pbe_frame_reference(cv->moved, n, m, cv->gram, k, cv->ref);
            if (st == PB_OK)
                st = pb_volume_upload(cv->level->in[0], cv->ref);
            corrected(cv, k, p, &pose);
            pbe_static_motion(&pose, cv->c, times, poses, &motion);
            if (st == PB_OK)
                st = pbe_blur_reference(cv->ctx, cv->level, &motion);
            if (st != PB_OK)
                return st;
            pbe_fit_scale(cv->level->host[0], cv->frames + k * n, n, &sc, &off, &sse);
            total += sse;
        }
        *out = total;
        return PB_OK;
    }
    if (getenv("PBE_OBJ") && atoi(getenv("PBE_OBJ")) == 2) {
        /* the diagonal holds each frame's own noise: replaced by the rank-r
         * fit's, the off-diagonal misfit is what the poses can change */
        double *g = cv->a, *fit = malloc(sizeof(double) * m * m), *aa = malloc(sizeof(double) * m * m);
        memcpy(g, cv->gram, sizeof(double) * m * m);
        for (int it = 0; it < 30; it++) {
            memcpy(aa, g, sizeof(double) * m * m);
            pbe_eigen(aa, m, cv->w, cv->v);
            memset(fit, 0, sizeof(double) * m * m);
            for (size_t r = 0; r < cv->rank && r < m; r++) {
                size_t best = 0;
                for (size_t j = 1; j < m; j++)
                    if (cv->w[j] > cv->w[best])
                        best = j;
                for (size_t i = 0; i < m; i++)
                    for (size_t j = 0; j < m; j++)
                        fit[i * m + j] += cv->w[best] * cv->v[i * m + best] * cv->v[j * m + best];
                cv->w[best] = -INFINITY;
            }
            for (size_t i = 0; i < m; i++)
                g[i * m + i] = fit[i * m + i];
        }
        double e = 0.0, norm = 0.0;
        for (size_t i = 0; i < m; i++)
            for (size_t j = 0; j < m; j++)
                if (i != j) {
                    e += (cv->gram[i * m + j] - fit[i * m + j]) * (cv->gram[i * m + j] - fit[i * m + j]);
                    norm += cv->gram[i * m + j] * cv->gram[i * m + j];
                }
        free(fit);
        free(aa);
        *out = e / norm;
        return PB_OK;
    }
    memcpy(cv->a, cv->gram, sizeof(double) * m * m);
    double trace = 0.0;
    for (size_t k = 0; k < m; k++)
        trace += cv->gram[k * m + k];
    pbe_eigen(cv->a, m, cv->w, cv->v);
    /* the top rank eigenvalues, by selection: m is a few dozen */
    double top = 0.0;
    for (size_t r = 0; r < cv->rank && r < m; r++) {
        size_t best = 0;
        for (size_t j = 1; j < m; j++)
            if (cv->w[j] > cv->w[best])
                best = j;
        top += cv->w[best];
        cv->w[best] = -INFINITY;
    }
    *out = trace - top;
    return PB_OK;
}

/* Each frame's contrast against the reference frame's: the ratio of its
 * second principal score to its first, as a share of the series' widest. */
static int contrast_weights(const double *gram, size_t m, size_t ref, double *a, double *w, double *v,
                            double *weight)
{
    memcpy(a, gram, sizeof(double) * m * m);
    pbe_eigen(a, m, w, v);
    size_t first = 0, second = m;
    for (size_t j = 1; j < m; j++)
        if (w[j] > w[first])
            first = j;
    for (size_t j = 0; j < m; j++)
        if (j != first && (second == m || w[j] > w[second]))
            second = j;
    if (second == m || !(w[second] > 1e-12 * w[first]))
        return 0;
    double widest = 0.0;
    for (size_t k = 0; k < m; k++) {
        double s1 = v[k * m + first];
        weight[k] = fabs(s1) > 0 ? v[k * m + second] / s1 : 0.0;
    }
    /* frames the rank-r model explains worst (motion inside them): left out */
    if (getenv("PBE_TRIM")) {
        double frac[256], sorted[256];
        size_t r = 3;
        for (size_t k = 0; k < m; k++) {
            /* energy of frame k outside the top r eigenvectors' span, from the Gram's eigen-decomposition:
               |m_k|^2 - sum_top w_j v_kj^2 */
            double top = 0.0;
            int used[256] = {0};
            for (size_t q = 0; q < r; q++) {
                size_t best = m;
                for (size_t j = 0; j < m; j++)
                    if (!used[j] && (best == m || w[j] > w[best]))
                        best = j;
                used[best] = 1;
                top += w[best] * v[k * m + best] * v[k * m + best];
            }
            frac[k] = 1.0 - top / gram[k * m + k];
            sorted[k] = frac[k];
        }
        for (size_t i = 0; i < m; i++)
            for (size_t j = i + 1; j < m; j++)
                if (sorted[j] < sorted[i]) {
                    double t = sorted[i];
                    sorted[i] = sorted[j];
                    sorted[j] = t;
                }
        double med = sorted[m / 2], fac = atof(getenv("PBE_TRIM"));
        for (size_t k = 0; k < m; k++) {
            g_skip[k] = frac[k] > fac * med;
            if (getenv("PBE_VERBOSE"))
                fprintf(stderr, "frame %zu: outside %.4f%s\n", k, frac[k], g_skip[k] ? " (left out)" : "");
        }
    }
    /* frames named in PBE_EXCLUDE (comma separated): left out as trimmed ones */
    if (getenv("PBE_EXCLUDE")) {
        const char *q = getenv("PBE_EXCLUDE");
        while (*q) {
            char *end;
            long f = strtol(q, &end, 10);
            if (end == q)
                break;
            if (f >= 0 && (size_t)f < m)
                g_skip[f] = 1;
            q = *end ? end + 1 : end;
        }
        if (getenv("PBE_VERBOSE"))
            for (size_t k = 0; k < m; k++)
                if (g_skip[k])
                    fprintf(stderr, "frame %zu left out\n", k);
    }
    double at_ref = weight[ref];
    for (size_t k = 0; k < m; k++) {
        weight[k] -= at_ref;
        widest = fmax(widest, fabs(weight[k]));
    }
    if (!(widest > 0))
        return 0;
    for (size_t k = 0; k < m; k++) {
        weight[k] /= widest;
        if (g_skip[k])
            weight[k] = 0.0;
        if (getenv("PBE_VERBOSE"))
            fprintf(stderr, "frame %zu: weight %.3f\n", k, weight[k]);
    }
    return 1;
}

/* Solves the NG x NG system h x = -g with h's eigenvalues held above a
 * floor (a valley's flat or bent directions take no step to infinity). */
static void newton_step(const double *h, const double *g, double *x)
{
    double a[NG * NG], w[NG], v[NG * NG];
    memcpy(a, h, sizeof a);
    pbe_eigen(a, NG, w, v);
    double top = 0.0;
    for (int i = 0; i < NG; i++)
        top = fmax(top, fabs(w[i]));
    for (int i = 0; i < NG; i++)
        x[i] = 0.0;
    for (int j = 0; j < NG; j++) {
        double lam = fmax(fabs(w[j]), 1e-3 * top);
        if (!(lam > 0))
            continue;
        double d = 0.0;
        for (int i = 0; i < NG; i++)
            d += v[i * NG + j] * g[i];
        for (int i = 0; i < NG; i++)
            x[i] -= v[i * NG + j] * d / lam;
    }
}

pb_status pbe_collective(pb_context *ctx, pbe_level *level, const float *frames, size_t count, size_t ref,
                         const double c[3], pb_pose *poses, double *moved_mm)
{
    const size_t n = level->n, m = count;
    collective cv = {.ctx = ctx, .level = level, .frames = frames, .count = count,
                     .rank = pbe_reference_rank(count), .c = c, .poses = poses};
    double *weight = malloc(sizeof(double) * m);
    cv.moved = malloc(sizeof(float) * n * m);
    cv.ref = malloc(sizeof(float) * n);
    cv.gram = malloc(sizeof(double) * m * m);
    cv.a = malloc(sizeof(double) * m * m);
    cv.w = malloc(sizeof(double) * m);
    cv.v = malloc(sizeof(double) * m * m);
    cv.weight = weight;
    *moved_mm = 0.0;
    pb_status st = weight && cv.moved && cv.gram && cv.a && cv.w && cv.v ? PB_OK : PB_ERR_OUT_OF_MEMORY;
    for (int i = 0; i < 3; i++)
        cv.radius = fmax(cv.radius, 0.5 * (double)level->g.dims[i] * level->g.voxel_size[i]);
    double p[NG] = {0}, e0 = 0.0;
    cv.weight = NULL;
    for (size_t k = 0; k < m && weight; k++)
        weight[k] = 0.0;
    if (st == PB_OK) {
        cv.weight = weight;
        st = residual(&cv, p, &e0);
    }
    if (st == PB_OK && contrast_weights(cv.gram, m, ref, cv.a, cv.w, cv.v, weight) &&
        (st = residual(&cv, p, &e0)) == PB_OK) {
        /* a quadratic model of the residual from central differences, a
         * Newton step on it, halved until the residual falls */
        const double h = 0.25 * fmin(level->g.voxel_size[0], fmin(level->g.voxel_size[1], level->g.voxel_size[2]));
        for (int round = 0; round < 3 && st == PB_OK; round++) {
            double plus[NG], minus[NG], hess[NG * NG], grad[NG], q[NG];
            for (int i = 0; i < NG && st == PB_OK; i++) {
                memcpy(q, p, sizeof q);
                q[i] += h;
                st = residual(&cv, q, &plus[i]);
                q[i] -= 2 * h;
                if (st == PB_OK)
                    st = residual(&cv, q, &minus[i]);
                grad[i] = (plus[i] - minus[i]) / (2 * h);
                hess[i * NG + i] = (plus[i] - 2 * e0 + minus[i]) / (h * h);
            }
            for (int i = 0; i < NG && st == PB_OK; i++)
                for (int j = i + 1; j < NG && st == PB_OK; j++) {
                    double both;
                    memcpy(q, p, sizeof q);
                    q[i] += h;
                    q[j] += h;
                    st = residual(&cv, q, &both);
                    hess[i * NG + j] = hess[j * NG + i] = (both - plus[i] - plus[j] + e0) / (h * h);
                }
            if (st != PB_OK)
                break;
            double step[NG], len = 0.0;
            newton_step(hess, grad, step);
            for (int i = 0; i < NG; i++)
                len += step[i] * step[i];
            len = sqrt(len);
            /* no more than two voxels a round: the model is local */
            double most = 8.0 * h;
            for (int i = 0; i < NG && len > most; i++)
                step[i] *= most / len;
            int taken = 0;
            for (int halve = 0; halve < 4 && st == PB_OK && !taken; halve++) {
                double e;
                for (int i = 0; i < NG; i++)
                    q[i] = p[i] + step[i];
                st = residual(&cv, q, &e);
                if (st == PB_OK && e < e0) {
                    memcpy(p, q, sizeof p);
                    e0 = e;
                    taken = 1;
                }
                for (int i = 0; i < NG; i++)
                    step[i] *= 0.5;
            }
            if (!taken)
                break;
        }
        if (st == PB_OK) {
            for (size_t k = 0; k < m; k++) {
                pb_pose out;
                corrected(&cv, k, p, &out);
                poses[k] = out;
            }
            *moved_mm = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2] + p[3] * p[3] + p[4] * p[4] + p[5] * p[5]);
        }
    }
    free(weight);
    free(cv.moved);
    free(cv.ref);
    free(cv.gram);
    free(cv.a);
    free(cv.w);
    free(cv.v);
    return st;
}
