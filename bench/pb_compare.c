/* Runs every method and filter on two devices with the same random volume and
 * the paper's eight motions, and prints how far apart the results are: the
 * largest absolute difference and that difference relative to the largest
 * value of the first device's result. Answers "how close are CUDA and PoCL?"
 * on one machine. REF uses the same random points on every backend. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "petblur.h"
#include "scenarios.h"

static void usage(void)
{
    fputs("usage: pb_compare [--size N] [--ref-points K] DEVICE_A DEVICE_B\n"
          "  DEVICE: host, opencl[:N] or cuda[:N]. Blurs one random volume (default 48^3) with AB, RM, CL\n"
          "  (HARDWARE and EXACT) and REF (K points, default 32) for the paper's eight motions on both\n"
          "  devices and prints their largest differences.\n",
          stderr);
}

static pb_context *open_device(const char *spec)
{
    pb_context_options o = {PB_BACKEND_AUTO, 0, NULL};
    pb_context *ctx = NULL;
    if (pb_device_parse(spec, &o.backend, &o.device_index) != PB_OK || pb_context_create(&o, &ctx) != PB_OK) {
        fprintf(stderr, "pb_compare: %s: %s\n", spec, pb_last_error(NULL));
        return NULL;
    }
    return ctx;
}

static int blur(pb_context *ctx, const pb_geometry *g, const float *in, const pb_motion *m,
                const pb_blur_options *opt, float *out)
{
    pb_volume *a = NULL, *b = NULL;
    pb_status st = pb_volume_create(ctx, g, &a);
    if (st == PB_OK)
        st = pb_volume_create(ctx, g, &b);
    if (st == PB_OK)
        st = pb_volume_upload(a, in);
    if (st == PB_OK)
        st = pb_blur(ctx, a, m, opt, b);
    if (st == PB_OK)
        st = pb_volume_download(b, out);
    if (st != PB_OK)
        fprintf(stderr, "pb_compare: %s\n", pb_last_error(ctx));
    pb_volume_destroy(a);
    pb_volume_destroy(b);
    return st == PB_OK;
}

int main(int argc, char **argv)
{
    size_t size = 48;
    unsigned ref_points = 32;
    const char *dev[2] = {NULL, NULL};
    int ndev = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--size") && i + 1 < argc)
            size = (size_t)atoi(argv[++i]);
        else if (!strcmp(argv[i], "--ref-points") && i + 1 < argc)
            ref_points = (unsigned)atoi(argv[++i]);
        else if (argv[i][0] != '-' && ndev < 2)
            dev[ndev++] = argv[i];
        else {
            usage();
            return 2;
        }
    }
    if (ndev != 2 || size < 4 || ref_points < 1) {
        usage();
        return 2;
    }
    pb_context *ctx[2] = {open_device(dev[0]), open_device(dev[1])};
    if (!ctx[0] || !ctx[1])
        return 3;
    pb_device_info info[2];
    for (int d = 0; d < 2; d++)
        pb_context_device_info(ctx[d], &info[d]);
    printf("# A = %s (%s), B = %s (%s), %zu^3 random volume in [0, 1)\n", dev[0], info[0].name, dev[1], info[1].name,
           size);
    printf("# scenario method filter  max|A-B|  max|A-B|/max|A|\n");

    pb_geometry g = {{size, size, size}, {1, 1, 1}};
    size_t n = size * size * size;
    float *in = malloc(n * sizeof *in), *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b);
    srand(7);
    for (size_t i = 0; i < n; i++)
        in[i] = (float)rand() / (float)RAND_MAX;
    static const char *names[] = {"AB", "RM", "CL", "REF"};
    double worst[4][2] = {{0}};
    int ok = 1;
    for (int s = 0; s < 8 && ok; s++) {
        double times[2];
        pb_pose poses[2];
        pb_motion motion = pb_scenario_motion(&pb_paper_scenarios[s], g.voxel_size, times, poses);
        for (int m = 0; m < 4 && ok; m++)
            for (int f = 0; f < 2 && ok; f++) {
                if (m == PB_METHOD_REF && f == PB_FILTER_HARDWARE)
                    continue; /* REF reads nearest voxels either way */
                pb_blur_options opt = {(pb_method)m, (pb_filter)f, 0, m == PB_METHOD_REF ? ref_points : 0, 0, 5, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
                ok = blur(ctx[0], &g, in, &motion, &opt, a) && blur(ctx[1], &g, in, &motion, &opt, b);
                if (!ok)
                    break;
                double d = 0.0, big = 0.0;
                for (size_t i = 0; i < n; i++) {
                    d = fmax(d, fabs((double)a[i] - (double)b[i]));
                    big = fmax(big, fabs((double)a[i]));
                }
                double rel = big > 0.0 ? d / big : d;
                worst[m][f] = fmax(worst[m][f], rel);
                printf("%-8d %-6s %-8s %9.3g %9.3g\n", s + 1, names[m], f ? "exact" : "hardware", d, rel);
            }
    }
    if (ok) {
        printf("# largest relative difference over the eight motions:\n");
        for (int m = 0; m < 3; m++)
            printf("#   %-3s HARDWARE %.3g, EXACT %.3g\n", names[m], worst[m][0], worst[m][1]);
        printf("#   REF %.3g\n", worst[PB_METHOD_REF][1]);
    }
    free(in);
    free(a);
    free(b);
    pb_context_destroy(ctx[0]);
    pb_context_destroy(ctx[1]);
    return ok ? 0 : 3;
}
