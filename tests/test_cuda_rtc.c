/* The CUDA kernels compiled at run time by NVRTC (src/devices/cuda_rtc.c),
 * on a GPU (skipped without one). argv[1]:
 *   cache    NVRTC's kernels against nvcc's on fresh random blurs (every
 *            method, forward and adjoint); the cache written once and read
 *            after; a corrupt and a truncated entry rebuilt; a folder that
 *            cannot be made still served from memory; four processes
 *            compiling into one empty folder at once, each right, leaving one
 *            whole entry and no temporary file; a bad PETBLUR_CUDA_KERNELS.
 *   missing  NVRTC absent (PETBLUR_NVRTC_LIBRARY names no file): nvrtc asked
 *            for fails with the fix, the default still runs nvcc's. */
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "testlib.h"

#define N 24

static pb_context *context(const char *kernels, pb_status *st)
{
    setenv("PETBLUR_CUDA_KERNELS", kernels, 1);
    pb_context *ctx = NULL;
    pb_context_options o = {PB_BACKEND_CUDA, 0, NULL};
    *st = pb_context_create(&o, &ctx);
    return ctx;
}

/* The one entry in dir (its path into path), or how many there are. */
static int entries(const char *dir, char *path, size_t n, int *temporaries)
{
    DIR *d = opendir(dir);
    int count = 0;
    *temporaries = 0;
    if (!d)
        return 0;
    for (struct dirent *e; (e = readdir(d));) {
        if (e->d_name[0] == '.' && strncmp(e->d_name, ".tmp-", 5) != 0)
            continue;
        if (strncmp(e->d_name, ".tmp-", 5) == 0) {
            (*temporaries)++;
            continue;
        }
        count++;
        snprintf(path, n, "%s/%s", dir, e->d_name);
    }
    closedir(d);
    return count;
}

static long file_size(const char *path)
{
    struct stat s;
    return stat(path, &s) == 0 ? (long)s.st_size : -1;
}

/* A fresh random blur and adjoint of every method on ctx against nvcc's. */
static void compare(pb_context *rtc, pb_context *nvcc, const char *what)
{
    pb_geometry g = {{N, N - 3, N - 5}, {2.0, 2.2, 2.5}};
    size_t n = g.dims[0] * g.dims[1] * g.dims[2];
    float *in = malloc(n * sizeof *in), *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b);
    for (size_t i = 0; i < n; i++)
        in[i] = (float)pb_rand_uniform();
    double axis[3] = {pb_rand_range(-1, 1), pb_rand_range(-1, 1), 1.0};
    pb_pose p0 = pb_test_pose(0, 0, 0, axis, 0), p1 = pb_test_pose(pb_rand_range(-8, 8), pb_rand_range(-8, 8),
                                                                   pb_rand_range(-8, 8), axis, pb_rand_range(-20, 20));
    pb_test_motion tm;
    pb_test_motion_init(&tm, &p0, &p1);
    for (int method = PB_METHOD_AB; method <= PB_METHOD_REF; method++) {
        for (int adjoint = 0; adjoint < 2; adjoint++) {
            pb_blur_options o = {(pb_method)method, PB_FILTER_HARDWARE, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
            pb_status s1 = adjoint ? pb_test_adjoint(rtc, &g, in, &tm.motion, &o, a)
                                   : pb_test_blur(rtc, &g, in, &tm.motion, &o, a);
            pb_status s2 = adjoint ? pb_test_adjoint(nvcc, &g, in, &tm.motion, &o, b)
                                   : pb_test_blur(nvcc, &g, in, &tm.motion, &o, b);
            double d = pb_max_abs_diff(a, b, n), m = pb_max_abs(b, n);
            /* The same source and arithmetic: equal but for the adjoint's
             * atomic adds, whose order varies between runs. */
            pb_check(s1 == PB_OK && s2 == PB_OK && m > 0 && d <= (adjoint ? 1e-5 : 1e-6) * m,
                     "%s: method %d %s: NVRTC's against nvcc's kernels, max |diff| %.3g of %.3g (%s)", what, method,
                     adjoint ? "adjoint" : "forward", d, m, pb_last_error(rtc));
        }
    }
    free(in);
    free(a);
    free(b);
}

static void corrupt(const char *path, int cut)
{
    FILE *f = fopen(path, "r+b");
    if (!f)
        return;
    if (cut) {
        fclose(f);
        pb_check(truncate(path, file_size(path) / 2) == 0, "truncated %s", path);
        return;
    }
    fseek(f, file_size(path) / 2, SEEK_SET);
    int c = fgetc(f);
    fseek(f, -1, SEEK_CUR);
    fputc(c ^ 0x5a, f);
    fclose(f);
}

static int cache_case(void)
{
    char dir[] = "/tmp/pb_rtc_cache_XXXXXX";
    pb_check(mkdtemp(dir) != NULL, "mkdtemp");
    setenv("PETBLUR_CACHE_DIR", dir, 1);
    pb_test_seed();

    /* Four processes compiling into the empty folder at once, before this
     * process touches CUDA (a child may not inherit a CUDA context). */
    pid_t kids[4];
    for (int i = 0; i < 4; i++) {
        if ((kids[i] = fork()) == 0) {
            pb_status st;
            pb_context *r = context("nvrtc", &st), *n = st == PB_OK ? context("builtin", &st) : NULL;
            if (st == PB_ERR_NO_DEVICE)
                _exit(PB_TEST_SKIP);
            if (st != PB_OK) {
                fprintf(stderr, "child %d: %s\n", i, pb_last_error(NULL));
                _exit(1);
            }
            compare(r, n, "a concurrent compile");
            pb_context_destroy(r);
            pb_context_destroy(n);
            _exit(pb_test_failed ? 1 : 0);
        }
    }
    int skipped = 0;
    for (int i = 0; i < 4; i++) {
        int status = 0;
        waitpid(kids[i], &status, 0);
        skipped += WIFEXITED(status) && WEXITSTATUS(status) == PB_TEST_SKIP;
        pb_check(WIFEXITED(status) && (WEXITSTATUS(status) == 0 || WEXITSTATUS(status) == PB_TEST_SKIP),
                 "concurrent process %d: exit %d", i, WIFEXITED(status) ? WEXITSTATUS(status) : -1);
    }
    if (skipped == 4) {
        printf("SKIP: no CUDA device\n");
        return PB_TEST_SKIP;
    }
    char entry[4400];
    int tmp = 0, count = entries(dir, entry, sizeof entry, &tmp);
    pb_check(count == 1 && tmp == 0, "after the concurrent compiles: %d entries, %d temporaries (want 1, 0)", count,
             tmp);
    long whole = file_size(entry);

    pb_status st;
    pb_context *nvcc = context("builtin", &st);
    pb_check(st == PB_OK, "nvcc's kernels: %s", pb_last_error(NULL));
    /* From the cache: nothing compiled, so nothing written. */
    struct stat before, after;
    stat(entry, &before);
    pb_context *rtc = context("nvrtc", &st);
    pb_check(st == PB_OK, "NVRTC's kernels from the cache: %s", pb_last_error(NULL));
    stat(entry, &after);
    pb_check(before.st_ino == after.st_ino, "a cached entry was read, not written again");
    compare(rtc, nvcc, "from the cache");
    pb_context_destroy(rtc);

    for (int truncate = 0; truncate < 2; truncate++) {
        corrupt(entry, truncate);
        rtc = context("nvrtc", &st);
        pb_check(st == PB_OK, "%s entry: %s", truncate ? "a truncated" : "a corrupt", pb_last_error(NULL));
        stat(entry, &after);
        pb_check(file_size(entry) == whole && after.st_ino != before.st_ino, "%s entry rebuilt whole (%ld of %ld)",
                 truncate ? "a truncated" : "a corrupt", file_size(entry), whole);
        before = after;
        compare(rtc, nvcc, truncate ? "after a truncated entry" : "after a corrupt entry");
        pb_context_destroy(rtc);
    }

    /* A FIFO at the entry's path: not waited on (opening it to read would
     * block until a writer came), said in the context's note, replaced. */
    unlink(entry);
    pb_check(mkfifo(entry, 0644) == 0, "mkfifo %s", entry);
    pb_test_deadline(120, "a context waited on the FIFO at the cache entry");
    rtc = context("nvrtc", &st);
    pb_test_deadline(0, NULL);
    pb_check(st == PB_OK && strstr(pb_context_notes(rtc), "not a regular file"), "a FIFO at the entry: %s; note: %s",
             pb_last_error(NULL), rtc ? pb_context_notes(rtc) : "");
    stat(entry, &after);
    pb_check(S_ISREG(after.st_mode) && file_size(entry) == whole, "the FIFO replaced by a whole entry");
    if (st == PB_OK) {
        compare(rtc, nvcc, "after a FIFO at the entry");
        pb_context_destroy(rtc);
    }
    rtc = context("nvrtc", &st);
    pb_check(st == PB_OK && !pb_context_notes(rtc)[0], "the replaced entry read with no note: %s",
             rtc ? pb_context_notes(rtc) : pb_last_error(NULL));
    pb_context_destroy(rtc);

    /* A cache folder that cannot be made (under a plain file): served from
     * memory, and the note says why. */
    char blocked[64];
    snprintf(blocked, sizeof blocked, "%s/file", dir);
    FILE *f = fopen(blocked, "w");
    fclose(f);
    char below[96];
    snprintf(below, sizeof below, "%s/sub", blocked);
    setenv("PETBLUR_CACHE_DIR", below, 1);
    rtc = context("nvrtc", &st);
    pb_check(st == PB_OK && strstr(pb_context_notes(rtc), "cannot be used") && strstr(pb_context_notes(rtc), below),
             "an unusable cache folder: %s; note: %s", pb_last_error(NULL), rtc ? pb_context_notes(rtc) : "");
    if (st == PB_OK) {
        compare(rtc, nvcc, "compiled in memory");
        pb_context_destroy(rtc);
    }
    unlink(blocked);

    rtc = context("fastest", &st);
    pb_check(st == PB_ERR_INVALID_ARGUMENT && strstr(pb_last_error(NULL), "PETBLUR_CUDA_KERNELS"),
             "a bad PETBLUR_CUDA_KERNELS: %s: %s", pb_status_string(st), pb_last_error(NULL));
    pb_context_destroy(nvcc);
    unlink(entry);
    rmdir(dir);
    return pb_test_finish();
}

static int missing_case(void)
{
    setenv("PETBLUR_NVRTC_LIBRARY", "/nonexistent/libnvrtc.so.13", 1);
    pb_status st;
    pb_context *ctx = context("builtin", &st);
    if (st == PB_ERR_NO_DEVICE) {
        printf("SKIP: no CUDA device\n");
        return PB_TEST_SKIP;
    }
    pb_check(st == PB_OK, "nvcc's kernels without NVRTC: %s", pb_last_error(NULL));
    pb_context_destroy(ctx);
    ctx = context("nvrtc", &st);
    pb_check(st == PB_ERR_BACKEND_UNAVAILABLE && ctx == NULL && strstr(pb_last_error(NULL), "nvidia-cuda-nvrtc"),
             "NVRTC asked for and missing: %s: %s", pb_status_string(st), pb_last_error(NULL));
    unsetenv("PETBLUR_CUDA_KERNELS");
    ctx = context("", &st);
    pb_check(st == PB_OK, "the default without NVRTC: %s", pb_last_error(NULL));
    pb_context_destroy(ctx);
    return pb_test_finish();
}

int main(int argc, char **argv)
{
    if (!pb_backend_compiled(PB_BACKEND_CUDA)) {
        printf("SKIP: the CUDA backend is not compiled in\n");
        return PB_TEST_SKIP;
    }
    /* No CUDA call here: the cache case forks before its first. */
    return argc > 1 && strcmp(argv[1], "missing") == 0 ? missing_case() : cache_case();
}
