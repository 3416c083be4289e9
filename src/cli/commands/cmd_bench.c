/* petblur bench: the paper's experiment (section 4, Tables 1-3) on the device
 * at hand. Three phantoms, the eight motions of the paper, every method with
 * both filters, each compared with the multi-point reference (REF) by eq. (5)
 * and timed with device events. The reference is drawn twice with different
 * seeds, so that its own noise is known. Writes results.csv and cases.csv (the
 * motions and the S a classical blur needs, for bench/peers.py), and with
 * --keep-volumes the phantoms and references that the peers compare against. */
#define _XOPEN_SOURCE 700 /* realpath */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "atomic_file.h"
#include "scenarios.h"
#include "bench_measure.h"
#include "blur_run.h"
#include "cli.h"
#include "commands.h"
#include "phantom.h"

static const pbc_option options[] = {
    PBC_OPTION_DEVICE,
    {"--phantoms", NULL, "LIST", "some of homogeneity,derenzo,brain (default all three)"},
    {"--scenarios", NULL, "LIST", "some of the paper's motions 1-8, e.g. 2,3,6 (default all)"},
    {"--size", NULL, "N", "in-plane voxels of the phantoms (default 256; the brain 128 x 128 x 64, else N x N x N/2)"},
    {"--brain", NULL, "FILE", "your own head volume (e.g. the Zubal phantom) in place of the analytic brain"},
    {"--dims", NULL, "NX,NY,NZ", "grid of a .raw --brain file"},
    {"--voxel-size", NULL, "VX,VY,VZ", "mm, of a .raw --brain file (default 1,1,1)"},
    {"--points", NULL, "K", "REF's random points per voxel (default 200, the paper's)"},
    {"--runs", NULL, "N", "timed runs per method; the median is reported (default 20)"},
    {"--reference", NULL, "DIR", "read the references from DIR/volumes (an earlier run's --out-dir with "
                                 "--keep-volumes) instead of computing them (ref_points is then 0: unknown here)"},
    {"--out-dir", NULL, "DIR", "where results.csv and cases.csv go (default petblur-bench)"},
    {"--keep-volumes", NULL, NULL, "also write the phantoms and references (float32 .raw) to DIR/volumes"},
    {"--quick", NULL, NULL, "a small version (CI): grids of 48 voxels, 32 points, 3 runs"},
    {"--quiet", "-q", NULL, "no progress lines"},
};

static const pbc_command command = {
    "bench", "[--device DEV] [--phantoms LIST] [--scenarios LIST] [--out-dir DIR] [--quick]",
    "The paper's experiment on this device: the homogeneity (256^3), Derenzo (256^3) and brain (128x128x64)\n"
    "phantoms under the paper's eight motions (translations in voxels, rotations about z through the grid's\n"
    "centre), blurred by every method with both filters. Errors by eq. (5) against REF (K points per voxel,\n"
    "dense time steps), whose own noise is the error between two REFs of different seeds; kernel times from\n"
    "device events (a warm-up, then the median of --runs), end-to-end times with upload and download.\n"
    "bench/paper.sh runs it with the peers (PyTorch, SciPy) and makes the tables and plots.",
    options, (int)(sizeof options / sizeof options[0]), 0, 0,
    "example: petblur bench --device cuda --out-dir run --keep-volumes"};

enum { MAX_PHANTOMS = 3 };

typedef struct bench_config {
    pbc_phantom_kind phantoms[MAX_PHANTOMS];
    int phantom_count;
    int scenario[8]; /* 1 where chosen */
    unsigned long size, points, runs;
    int size_given, keep;
    const char *brain, *reference, *dir;
    pbc_read_hints hints;
    size_t hint_dims[3];
    double hint_vs[3];
} bench_config;

typedef struct bench_files {
    pbc_temp results_tmp, cases_tmp;
    FILE *results, *cases;
} bench_files;

/* The paper's methods as the paper ran them (AB and RM on one segment per
 * tracked interval), then every method petblur adds: AB-E and RM-E are AB and
 * RM with the default bound on the path error (pb_blur_options), AB-C AB
 * with it reading every segment exactly (PB_AB_SAMPLING_CHORD). */
static const struct {
    const char *name;
    pb_method method;
    pb_path_model path;
    pb_ab_sampling sampling;
} methods[] = {{"AB", PB_METHOD_AB, PB_PATH_TRACKED, PB_AB_SAMPLING_DEFAULT},
               {"RM", PB_METHOD_RM, PB_PATH_TRACKED, PB_AB_SAMPLING_DEFAULT},
               {"CL", PB_METHOD_CL, PB_PATH_DEFAULT, PB_AB_SAMPLING_DEFAULT},
               {"AB-E", PB_METHOD_AB, PB_PATH_DEFAULT, PB_AB_SAMPLING_DEFAULT},
               {"RM-E", PB_METHOD_RM, PB_PATH_DEFAULT, PB_AB_SAMPLING_DEFAULT},
               {"AB-C", PB_METHOD_AB, PB_PATH_DEFAULT, PB_AB_SAMPLING_CHORD}};

/* "a,b,c" into tokens of at most 31 characters; calls take(token) for each. */
static int for_each_token(const char *option, const char *list, int (*take)(const char *, void *), void *user)
{
    const char *p = list;
    while (1) {
        const char *e = strchr(p, ',');
        size_t n = e ? (size_t)(e - p) : strlen(p);
        char tok[32];
        if (n == 0 || n >= sizeof tok)
            return pbc_fail(PBC_EXIT_USAGE, "%s %s: expected a comma-separated list without empty items", option,
                            list);
        memcpy(tok, p, n);
        tok[n] = '\0';
        int rc = take(tok, user);
        if (rc)
            return rc;
        if (!e)
            return 0;
        p = e + 1;
    }
}

static int take_phantom(const char *tok, void *user)
{
    bench_config *c = user;
    pbc_phantom_kind k;
    if (pbc_phantom_parse(tok, &k) != 0)
        return pbc_fail(PBC_EXIT_USAGE, "--phantoms: unknown phantom '%s'; choose from homogeneity, derenzo, brain",
                        tok);
    for (int i = 0; i < c->phantom_count; i++)
        if (c->phantoms[i] == k)
            return pbc_fail(PBC_EXIT_USAGE, "--phantoms: '%s' is listed twice", tok);
    c->phantoms[c->phantom_count++] = k;
    return 0;
}

static int take_scenario(const char *tok, void *user)
{
    bench_config *c = user;
    unsigned long s;
    int rc = pbc_parse_count("--scenarios", tok, 1, 8, &s);
    if (!rc && c->scenario[s - 1])
        return pbc_fail(PBC_EXIT_USAGE, "--scenarios: '%s' is listed twice", tok);
    if (!rc)
        c->scenario[s - 1] = 1;
    return rc;
}

static int parse_config(const pbc_args *args, bench_config *c)
{
    const char *v;
    int rc = 0, quick = pbc_arg(&command, args, "--quick") != NULL;
    memset(c, 0, sizeof *c);
    c->points = quick ? 32 : 200;
    c->runs = quick ? 3 : 20;
    c->size = quick ? 48 : 0;
    c->size_given = quick;
    c->brain = pbc_arg(&command, args, "--brain");
    c->reference = pbc_arg(&command, args, "--reference");
    c->keep = pbc_arg(&command, args, "--keep-volumes") != NULL;
    c->dir = (v = pbc_arg(&command, args, "--out-dir")) ? v : "petblur-bench";
    if ((v = pbc_arg(&command, args, "--phantoms")) && (rc = for_each_token("--phantoms", v, take_phantom, c)))
        return rc;
    if (!v) {
        c->phantoms[0] = PBC_PHANTOM_HOMOGENEITY;
        c->phantoms[1] = PBC_PHANTOM_DERENZO;
        c->phantoms[2] = PBC_PHANTOM_BRAIN;
        c->phantom_count = 3;
    }
    if ((v = pbc_arg(&command, args, "--scenarios")) && (rc = for_each_token("--scenarios", v, take_scenario, c)))
        return rc;
    for (int s = 0; s < 8 && !v; s++)
        c->scenario[s] = 1;
    if ((v = pbc_arg(&command, args, "--size"))) {
        if ((rc = pbc_parse_count("--size", v, 8, 1024, &c->size)))
            return rc;
        c->size_given = 1;
    }
    if (((v = pbc_arg(&command, args, "--points")) && (rc = pbc_parse_count("--points", v, 1, 100000, &c->points))) ||
        ((v = pbc_arg(&command, args, "--runs")) && (rc = pbc_parse_count("--runs", v, 1, 10000, &c->runs))))
        return rc;
    if ((rc = pbc_hints_from_args(&command, args, c->hint_dims, c->hint_vs, &c->hints)))
        return rc;
    if ((c->hints.dims || c->hints.voxel_size) && !c->brain)
        return pbc_fail(PBC_EXIT_USAGE, "--dims and --voxel-size describe a .raw --brain file; give --brain FILE or "
                        "drop them");
    if (c->reference && c->keep)
        return pbc_fail(PBC_EXIT_USAGE, "--keep-volumes with --reference would copy the references; the volumes "
                        "are in %s/volumes already", c->reference);
    /* A bad --brain file fails now, not after the other phantoms' minutes. */
    if (c->brain) {
        int brain = 0;
        for (int i = 0; i < c->phantom_count; i++)
            brain |= c->phantoms[i] == PBC_PHANTOM_BRAIN;
        if (!brain)
            return pbc_fail(PBC_EXIT_USAGE, "--brain %s replaces the brain phantom, which --phantoms leaves out; add "
                            "brain to --phantoms or drop --brain", c->brain);
        pbc_image probe;
        if ((rc = pbc_image_read(c->brain, &c->hints, &probe)))
            return rc;
        size_t n = pbc_image_frame_voxels(&probe), nonzero = 0;
        for (size_t i = 0; i < n && !nonzero; i++)
            nonzero = probe.data[i] != 0.0f;
        pbc_image_free(&probe);
        if (!nonzero)
            return pbc_fail(PBC_EXIT_USAGE, "--brain %s is zero everywhere: its blur has no relative error; give a head "
                            "volume with activity", c->brain);
    }
    return 0;
}

/* The phantom on its grid: the analytic one (the same object at any size,
 * sampled finer or coarser), or the user's head volume for the brain. */
static int make_phantom(const bench_config *c, pbc_phantom_kind kind, pbc_image *img)
{
    if (kind == PBC_PHANTOM_BRAIN && c->brain)
        return pbc_image_read(c->brain, &c->hints, img);
    size_t dims[3];
    double vs[3];
    pbc_phantom_default_geometry(kind, dims, vs);
    for (int i = 0; c->size_given && i < 3; i++) {
        size_t m = i < 2 || kind != PBC_PHANTOM_BRAIN ? c->size : c->size / 2;
        vs[i] *= (double)dims[i] / (double)m;
        dims[i] = m;
    }
    int rc = pbc_image_alloc(img, dims, vs);
    return rc ? rc : pbc_phantom_make(kind, dims, vs, img->data);
}

static int volume_path(char *buf, size_t size, const char *dir, const char *phantom, int scenario, int seed)
{
    int n = scenario ? snprintf(buf, size, "%s/volumes/%s_s%d_ref%d.raw", dir, phantom, scenario, seed)
                     : snprintf(buf, size, "%s/volumes/%s.raw", dir, phantom);
    if (n < 0 || (size_t)n >= size)
        return pbc_fail(PBC_EXIT_USAGE, "%s: the path is too long; choose a shorter folder", dir);
    return 0;
}

/* A volume's path as cases.csv gives it (see bench_case); seed 0 is the
 * phantom. */
static int case_path(const bench_config *c, const char *name, int s, int seed, char *buf, size_t size)
{
    if (!c->reference)
        return volume_path(buf, size, ".", name, s, seed);
    char rel[4096];
    int rc = volume_path(rel, sizeof rel, c->reference, name, s, seed);
    if (!rc && (size < 4096 || !realpath(rel, buf))) /* realpath writes up to PATH_MAX (4096) */
        rc = pbc_fail(PBC_EXIT_USAGE, "--reference: %s: %s", rel, strerror(errno));
    return rc;
}

static void progress(const char *phantom, int scenario, const char *what)
{
    if (pbc_show_progress) {
        fprintf(stderr, "\rpetblur: bench %s, motion %d, %-12s", phantom, scenario, what);
        fflush(stderr);
    }
}

static void progress_clear(void)
{
    if (pbc_show_progress)
        fprintf(stderr, "\r%60s\r", "");
}

/* REF twice, with seeds 1 and 2 (or both read from --reference); ref gets the
 * first, the reference of every error. */
static int references(pb_context *ctx, const bench_config *c, const char *name, int s, const pbc_image *ph,
                      pb_volume *in, pb_volume *out, const pb_motion *motion, float *ref[2], double *ms)
{
    *ms = (double)NAN;
    for (int seed = 1; seed <= 2; seed++) {
        char path[4096];
        int rc;
        progress(name, s, seed == 1 ? "REF" : "REF, seed 2");
        if (c->reference) {
            pbc_image r = {0};
            pbc_read_hints h = {ph->dims, ph->voxel_size, 0};
            if ((rc = volume_path(path, sizeof path, c->reference, name, s, seed)))
                return rc;
            if (access(path, R_OK) != 0)
                return pbc_fail(PBC_EXIT_USAGE, "--reference %s: no reference of the %s phantom under motion %d "
                                "(%s: %s); make them first with petblur bench --keep-volumes --out-dir %s and the "
                                "same phantoms, motions and --size", c->reference, name, s, path, strerror(errno),
                                c->reference);
            if ((rc = pbc_image_read(path, &h, &r)))
                return rc;
            memcpy(ref[seed - 1], r.data, ph->dims[0] * ph->dims[1] * ph->dims[2] * sizeof(float));
            pbc_image_free(&r);
            continue;
        }
        pb_blur_options opt = {PB_METHOD_REF, PB_FILTER_EXACT, 0, (unsigned)c->points, 0, (uint32_t)seed, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
        pbc_timing t;
        if ((rc = pbc_bench_time(ctx, in, out, ph->data, motion, &opt, 0, 0, ref[seed - 1], NULL, &t)))
            return rc;
        if (seed == 1)
            *ms = t.kernel_ms;
        if (c->keep) {
            pbc_image r = *ph;
            r.data = ref[seed - 1];
            if ((rc = volume_path(path, sizeof path, c->dir, name, s, seed)) || (rc = pbc_image_write(path, &r)))
                return rc;
        }
    }
    return 0;
}

static int segments_of(const pb_geometry *g, const pb_motion *motion, const pb_blur_options *opt, size_t *n)
{
    *n = 1;
    if (opt->method != PB_METHOD_AB && opt->method != PB_METHOD_RM)
        return 0; /* CL and REF follow the path itself */
    pb_status st = pb_path_segments(g, motion, opt, n);
    return st == PB_OK ? 0 : pbc_fail(pbc_exit_for(st), "path segments: %s", pb_last_error(NULL));
}

static void row_prefix(FILE *f, const char *name, const pbc_image *ph, int s, const pb_scenario *sc)
{
    fprintf(f, "%s,%zu,%zu,%zu,%.6g,%.6g,%.6g,%d,%g,%g,%g,%g", name, ph->dims[0], ph->dims[1], ph->dims[2],
            ph->voxel_size[0], ph->voxel_size[1], ph->voxel_size[2], s, sc->t[0], sc->t[1], sc->t[2], sc->deg);
}

/* One phantom under one motion: the references, then every method and filter. */
static int bench_case(pb_context *ctx, const bench_config *c, bench_files *f, const char *device, const char *name,
                      const pbc_image *ph, pb_volume *in, pb_volume *out, pb_volume *adj, int s, float *ref[2],
                      float *res)
{
    const pb_scenario *sc = &pb_paper_scenarios[s - 1];
    double times[2], ref_ms;
    pb_pose poses[2];
    pb_geometry g = {{ph->dims[0], ph->dims[1], ph->dims[2]}, {ph->voxel_size[0], ph->voxel_size[1], ph->voxel_size[2]}};
    pb_motion motion = pb_scenario_motion(sc, g.voxel_size, times, poses);
    size_t n = ph->dims[0] * ph->dims[1] * ph->dims[2];
    pbc_ab_work work;
    int rc;
    if ((rc = pbc_ab_work_of(&g, &motion, &work)) ||
        (rc = references(ctx, c, name, s, ph, in, out, &motion, ref, &ref_ms)))
        return rc;
    /* REF's own noise: seed 2 against seed 1. */
    pb_comparison noise;
    if (pb_compare(ref[0], ref[1], n, &noise) != PB_OK)
        return pbc_fail(PBC_EXIT_RUNTIME, "the references of %s, scenario %d: %s", name, s, pb_last_error(NULL));
    char motion_text[64];
    snprintf(motion_text, sizeof motion_text, "(%g,%g,%g) %g deg", sc->t[0], sc->t[1], sc->t[2], sc->deg);
    progress_clear();
    if (c->reference)
        printf("%-11s %d %-22s REF %-8s %8.4f %8.4f %9.5f %11s %10s   (noise: seed 2 against seed 1, read from %s)\n",
               name, s, motion_text, "box", noise.rms_percent, noise.max_percent, noise.eq5_percent, "", "",
               c->reference);
    else
        printf("%-11s %d %-22s REF %-8s %8.4f %8.4f %9.5f %11.3f %10s   (noise: seed 2 against seed 1; %lu points)\n",
               name, s, motion_text, "box", noise.rms_percent, noise.max_percent, noise.eq5_percent, ref_ms, "",
               c->points);
    row_prefix(f->results, name, ph, s, sc);
    fprintf(f->results, ",%s,REF,exact,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,,,1,%.0f,%u,%lu,,1,\n", device,
            noise.rms_percent, noise.max_percent, noise.eq5_percent, noise.rms_percent, noise.eq5_percent, ref_ms,
            work.fetches, work.max_slices, c->reference ? 0UL : c->points);
    for (size_t m = 0; m < sizeof methods / sizeof methods[0]; m++)
        for (int filt = 0; filt < 2; filt++) {
            pb_blur_options opt = {methods[m].method, (pb_filter)filt, 0, 0, 0, 0, methods[m].path, 0.0,
                                   methods[m].sampling, 0};
            size_t segments = 1;
            if ((rc = segments_of(&g, &motion, &opt, &segments)))
                return rc;
            pbc_timing t;
            char what[32];
            snprintf(what, sizeof what, "%s %s", methods[m].name, pb_filter_name((pb_filter)filt));
            progress(name, s, what);
            int e2e = c->runs < 5 ? (int)c->runs : 5;
            for (size_t i = 0; i < n; i++)
                res[i] = (double)NAN; /* a blur that wrote nothing cannot pass for one that did */
            if ((rc = pbc_bench_time(ctx, in, out, ph->data, &motion, &opt, (int)c->runs, e2e, res, adj, &t)))
                return rc;
            pb_comparison err;
            if (pb_compare(ref[0], res, n, &err) != PB_OK)
                return pbc_fail(PBC_EXIT_RUNTIME, "%s %s on %s, scenario %d: %s", methods[m].name,
                                pb_filter_name((pb_filter)filt), name, s, pb_last_error(NULL));
            progress_clear();
            printf("%-11s %d %-22s %-4s %-8s %8.4f %8.4f %9.5f %11.3f %10.3f %11.3f\n", name, s, motion_text,
                   methods[m].name, pb_filter_name((pb_filter)filt), err.rms_percent, err.max_percent, err.eq5_percent,
                   t.kernel_ms, t.e2e_ms, t.adjoint_ms);
            fflush(stdout);
            row_prefix(f->results, name, ph, s, sc);
            /* The bound in force: -1 for the paper's one segment, empty for CL. */
            char bound[32] = "";
            if (methods[m].method != PB_METHOD_CL)
                snprintf(bound, sizeof bound, "%g",
                         opt.path == PB_PATH_TRACKED ? -1.0 : PB_DEFAULT_MAX_PATH_ERROR);
            fprintf(f->results, ",%s,%s,%s,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%lu,%.0f,%u,%lu,%s,%zu,%.6g\n",
                    device, methods[m].name, pb_filter_name((pb_filter)filt), err.rms_percent, err.max_percent, err.eq5_percent,
                    noise.rms_percent, noise.eq5_percent, t.kernel_ms, t.kernel_min_ms, t.e2e_ms, c->runs,
                    work.fetches, work.max_slices, c->reference ? 0UL : c->points, bound, segments, t.adjoint_ms);
        }
    /* Paths in cases.csv are relative to its folder: ours in ./volumes, those of
     * --reference (its phantom too: the same one) made absolute. */
    char p0[4096], p1[4096], p2[4096];
    if ((rc = case_path(c, name, 0, 0, p0, sizeof p0)) || (rc = case_path(c, name, s, 1, p1, sizeof p1)) ||
        (rc = case_path(c, name, s, 2, p2, sizeof p2)))
        return rc;
    row_prefix(f->cases, name, ph, s, sc);
    fprintf(f->cases, ",%u,%s,%s,%s,%.6g,%.6g\n", work.max_slices, p0, p1, p2, noise.rms_percent, noise.eq5_percent);
    return 0;
}

static int bench_phantom(pb_context *ctx, const bench_config *c, bench_files *f, const char *device,
                         pbc_phantom_kind kind)
{
    const char *name = pbc_phantom_name(kind);
    pbc_image ph = {0};
    pb_volume *in = NULL, *out = NULL, *adj = NULL;
    float *ref[2] = {NULL, NULL}, *res = NULL;
    char path[4096];
    int rc = make_phantom(c, kind, &ph);
    if (rc)
        goto done;
    size_t n = ph.dims[0] * ph.dims[1] * ph.dims[2];
    pb_geometry g = {{ph.dims[0], ph.dims[1], ph.dims[2]}, {ph.voxel_size[0], ph.voxel_size[1], ph.voxel_size[2]}};
    pb_status st = pb_volume_create(ctx, &g, &in);
    if (st == PB_OK)
        st = pb_volume_create(ctx, &g, &out);
    if (st == PB_OK)
        st = pb_volume_create(ctx, &g, &adj);
    if (st == PB_OK)
        st = pb_volume_upload(in, ph.data);
    if (st != PB_OK) {
        rc = pbc_fail(pbc_exit_for(st), "%s phantom of %zu x %zu x %zu: %s: %s", name, ph.dims[0], ph.dims[1],
                      ph.dims[2], pb_status_string(st), pb_last_error(ctx));
        goto done;
    }
    if (!(ref[0] = malloc(n * sizeof(float))) || !(ref[1] = malloc(n * sizeof(float))) ||
        !(res = malloc(n * sizeof(float)))) {
        rc = pbc_fail(PBC_EXIT_RUNTIME, "out of memory for the %s phantom's volumes; use a smaller --size", name);
        goto done;
    }
    if (c->keep && (rc = volume_path(path, sizeof path, c->dir, name, 0, 0)))
        goto done;
    if (c->keep && (rc = pbc_image_write(path, &ph)))
        goto done;
    for (int s = 1; s <= 8 && !rc; s++)
        if (c->scenario[s - 1])
            rc = bench_case(ctx, c, f, device, name, &ph, in, out, adj, s, ref, res);
done:
    pb_volume_destroy(in);
    pb_volume_destroy(out);
    pb_volume_destroy(adj);
    free(ref[0]);
    free(ref[1]);
    free(res);
    pbc_image_free(&ph);
    return rc;
}

/* The volumes under dir that a run reads (--reference: the references) or
 * writes (--keep-volumes: the phantoms too), as volume_path names them. */
static void list_volumes(pbc_files *f, const bench_config *c, const char *option, const char *dir, int written)
{
    char path[4096];
    for (int p = 0; p < c->phantom_count && !f->status; p++) {
        const char *name = pbc_phantom_name(c->phantoms[p]);
        if (written && !(f->status = volume_path(path, sizeof path, dir, name, 0, 0)))
            pbc_files_write(f, option, path);
        for (int s = 1; s <= 8; s++)
            for (int seed = 1; seed <= 2 && c->scenario[s - 1] && !f->status; seed++) {
                if ((f->status = volume_path(path, sizeof path, dir, name, s, seed)))
                    break;
                if (written)
                    pbc_files_write(f, option, path);
                else
                    pbc_files_read(f, option, path);
            }
    }
}

/* Every file bench reads and writes, for the rule that no output names a file
 * the command reads (pbc_files_check): a --brain inside DIR/volumes is not
 * replaced by its own copy. */
static int check_files(const bench_config *c)
{
    pbc_files f = {0};
    char path[4096];
    pbc_files_read_image(&f, "--brain", c->brain);
    if (c->reference)
        list_volumes(&f, c, "--reference", c->reference, 0);
    for (int i = 0; i < 2 && !f.status; i++)
        if (snprintf(path, sizeof path, "%s/%s", c->dir, i ? "cases.csv" : "results.csv") >= (int)sizeof path)
            f.status = pbc_fail(PBC_EXIT_USAGE, "--out-dir %s: the path is too long", c->dir);
        else
            pbc_files_write(&f, "--out-dir", path);
    if (c->keep)
        list_volumes(&f, c, "--out-dir", c->dir, 1);
    return pbc_files_check(&f);
}

static int open_outputs(const bench_config *c, bench_files *f)
{
    char path[4096];
    int rc;
    if ((rc = pbc_make_dir("--out-dir", c->dir)))
        return rc;
    if (c->keep) {
        snprintf(path, sizeof path, "%s/volumes", c->dir);
        if ((rc = pbc_make_dir("--out-dir", path)))
            return rc;
    }
    if (snprintf(path, sizeof path, "%s/results.csv", c->dir) >= (int)sizeof path)
        return pbc_fail(PBC_EXIT_USAGE, "--out-dir %s: the path is too long", c->dir);
    if ((rc = pbc_temp_open(&f->results_tmp, path, &f->results)))
        return rc;
    snprintf(path, sizeof path, "%s/cases.csv", c->dir);
    if ((rc = pbc_temp_open(&f->cases_tmp, path, &f->cases))) {
        pbc_temp_abort(&f->results_tmp, f->results);
        f->results = NULL;
        return rc;
    }
    static const char prefix[] = "phantom,nx,ny,nz,vx,vy,vz,scenario,tx,ty,tz,rot_deg";
    /* Errors against REF: rms_pct and max_pct (relative L2 and max, percent),
     * eq5_pct the paper's eq. (5) for its tables; REF's noise likewise. */
    fprintf(f->results, "%s,backend,device,method,filter,rms_pct,max_pct,eq5_pct,ref_noise_rms_pct,ref_noise_eq5_pct,"
                        "kernel_ms,kernel_min_ms,e2e_ms,runs,ab_fetches,ab_max_slices,ref_points,max_path_error,"
                        "segments,adjoint_ms\n", prefix);
    fprintf(f->cases, "%s,S,phantom_file,ref_file,ref2_file,ref_noise_rms_pct,ref_noise_eq5_pct\n", prefix);
    return 0;
}

int pbc_cmd_bench(int argc, char **argv)
{
    pbc_args args;
    bench_config c;
    bench_files f = {0};
    pb_context *ctx = NULL;
    int rc = pbc_parse_args(&command, argc, argv, &args);
    if (rc)
        return rc < 0 ? 0 : rc;
    if (pbc_arg(&command, &args, "--quiet"))
        pbc_show_progress = 0;
    if ((rc = parse_config(&args, &c)) || (rc = check_files(&c)) || (rc = pbc_open_device(pbc_arg(&command, &args, "--device"), &ctx)) ||
        (rc = open_outputs(&c, &f)))
        goto done;
    char dev[600], device[300];
    pbc_describe_device(ctx, dev, sizeof dev);
    pb_device_info info;
    pb_context_device_info(ctx, &info);
    /* The CSV's backend and device columns; commas would split them. */
    snprintf(device, sizeof device, "%s,%s", pb_backend_name(pb_context_backend(ctx)), info.name);
    for (char *p = strchr(device, ',') + 1; *p; p++)
        if (*p == ',')
            *p = ';';
    printf("device: %s\n", dev);
    printf("errors against REF (%lu points per voxel, seed 1): relative RMS and max in percent, and the paper's "
           "eq. (5); times: kernel (device events, median of %lu after a warm-up) and end to end (upload + blur + "
           "download)\n\n", c.points, c.runs);
    printf("%-11s %s %-22s %-3s %-8s %8s %8s %9s %11s %10s %11s\n", "phantom", "#", "motion (voxels, z)", "", "filter",
           "rms %", "max %", "eq5 %", "kernel ms", "e2e ms", "adjoint ms");
    for (int p = 0; p < c.phantom_count && !rc; p++)
        rc = bench_phantom(ctx, &c, &f, device, c.phantoms[p]);
    progress_clear();
    if (!rc && !(rc = pbc_temp_commit(&f.results_tmp, f.results))) {
        f.results = NULL;
        rc = pbc_temp_commit(&f.cases_tmp, f.cases);
        f.cases = NULL;
        if (!rc)
            printf("\nwrote %s/results.csv and %s/cases.csv%s\n", c.dir, c.dir,
                   c.keep ? " and the phantoms and references in volumes/" : "");
    }
done:
    if (f.results)
        pbc_temp_abort(&f.results_tmp, f.results);
    if (f.cases)
        pbc_temp_abort(&f.cases_tmp, f.cases);
    pb_context_destroy(ctx);
    return rc;
}
