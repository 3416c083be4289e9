/* petblur: the command-line program. This first version runs the main job
 * (demo) and lists devices; the file-format subcommands come with the CLI issue. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "petblur.h"

enum { EXIT_USAGE = 2, EXIT_RUNTIME = 3 };

static void usage(FILE *f)
{
    fputs("usage: petblur COMMAND [options]\n"
          "\n"
          "commands:\n"
          "  demo      blur a phantom with AB, RM and CL on the default device and compare each with the\n"
          "            paper's multi-point reference (REF); prints method, error % (eq. 5) and kernel time\n"
          "  devices   list the backends and devices found, with their limits\n"
          "\n"
          "demo options:\n"
          "  --device auto|host|opencl[:N]|cuda[:N]   where to run (default auto: CUDA, else an OpenCL GPU,\n"
          "                                           else OpenCL on the CPU)\n"
          "  --size N        phantom of N^3 voxels, 1 mm (default 64)\n"
          "  --points K      REF's random points per voxel (default 200, the paper's)\n"
          "  --help          this text\n",
          f);
}

static int cmd_devices(void)
{
    for (int b = PB_BACKEND_HOST; b <= PB_BACKEND_CUDA; b++) {
        int n = 0;
        if (!pb_backend_compiled((pb_backend)b)) {
            printf("%-7s not compiled into this build\n", pb_backend_name((pb_backend)b));
            continue;
        }
        if (pb_device_count((pb_backend)b, &n) != PB_OK) {
            printf("%-7s error: %s\n", pb_backend_name((pb_backend)b), pb_last_error(NULL));
            continue;
        }
        if (n == 0)
            printf("%-7s no device found\n", pb_backend_name((pb_backend)b));
        for (int i = 0; i < n; i++) {
            pb_device_info d;
            if (pb_device_get_info((pb_backend)b, i, &d) != PB_OK)
                continue;
            printf("%s:%d  %s [%s]%s\n", pb_backend_name((pb_backend)b), i, d.name, d.platform,
                   d.is_gpu ? " GPU" : "");
            if (b != PB_BACKEND_HOST)
                printf("          images %s, 3-D image max %zu x %zu x %zu, largest allocation %.0f MiB, "
                       "memory %.0f MiB, %u compute units\n",
                       d.image_support ? "yes" : "NO", d.image3d_max[0], d.image3d_max[1], d.image3d_max[2],
                       d.max_alloc_bytes / 1048576.0, d.global_mem_bytes / 1048576.0, d.compute_units);
        }
    }
    return 0;
}

/* The paper's homogeneity phantom in miniature: eight cubes of different,
 * constant activities, one per octant. */
static void make_cubes(size_t n, float *v)
{
    static const float activity[8] = {1.0f, 0.5f, 2.0f, 0.25f, 1.5f, 0.75f, 3.0f, 0.1f};
    size_t half = n / 2, inset = n / 12;
    for (size_t k = 0; k < n; k++)
        for (size_t j = 0; j < n; j++)
            for (size_t i = 0; i < n; i++) {
                size_t oi = i / half, oj = j / half, ok = k / half;
                size_t li = i % half, lj = j % half, lk = k % half;
                int inside = oi < 2 && oj < 2 && ok < 2 && li >= inset && lj >= inset && lk >= inset &&
                             li < half - inset && lj < half - inset && lk < half - inset;
                v[i + n * (j + n * k)] = inside ? activity[oi + 2 * oj + 4 * ok] : 0.0f;
            }
}

static int fail(pb_context *ctx, pb_status st, const char *what)
{
    fprintf(stderr, "petblur: %s failed: %s: %s\n", what, pb_status_string(st), pb_last_error(ctx));
    /* -1 .. -99 are bad inputs; the rest are device or runtime failures. */
    return st > -100 ? EXIT_USAGE : EXIT_RUNTIME;
}

static int cmd_demo(int argc, char **argv)
{
    pb_context_options copt = {PB_BACKEND_AUTO, 0, NULL};
    long size = 64, points = 200;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        const char *val = i + 1 < argc ? argv[i + 1] : NULL;
        char *end = NULL;
        if (!strcmp(a, "--help")) {
            usage(stdout);
            return 0;
        } else if (!strcmp(a, "--device") && val) {
            if (pb_device_parse(val, &copt.backend, &copt.device_index) != PB_OK) {
                fprintf(stderr, "petblur: --device: %s\n", pb_last_error(NULL));
                return EXIT_USAGE;
            }
            i++;
        } else if (!strcmp(a, "--size") && val) {
            size = strtol(val, &end, 10);
            if (*end || size < 8 || size > 1024) {
                fprintf(stderr, "petblur: --size %s: give a whole number from 8 to 1024\n", val);
                return EXIT_USAGE;
            }
            i++;
        } else if (!strcmp(a, "--points") && val) {
            points = strtol(val, &end, 10);
            if (*end || points < 1 || points > 100000) {
                fprintf(stderr, "petblur: --points %s: give a whole number from 1 to 100000\n", val);
                return EXIT_USAGE;
            }
            i++;
        } else {
            fprintf(stderr, "petblur: demo: unknown or incomplete option '%s'; see petblur demo --help\n", a);
            return EXIT_USAGE;
        }
    }

    pb_context *ctx = NULL;
    pb_status st = pb_context_create(&copt, &ctx);
    if (st != PB_OK) {
        fprintf(stderr, "petblur: cannot open the device: %s: %s\n", pb_status_string(st), pb_last_error(NULL));
        return EXIT_RUNTIME;
    }
    pb_device_info info;
    pb_context_device_info(ctx, &info);
    size_t n = (size_t)size, count = n * n * n;
    printf("device: %s:%d  %s [%s]\n", pb_backend_name(pb_context_backend(ctx)), copt.device_index, info.name,
           info.platform);

    /* A frame that starts at rest and ends moved by (6, 4, -3) voxels and turned
     * 10 degrees about z through the grid's centre. */
    double z[3] = {0, 0, 1};
    pb_pose poses[2] = {{{0, 0, 0}, {1, 0, 0, 0}}, {{6 * size / 64.0, 4 * size / 64.0, -3 * size / 64.0}, {0}}};
    pb_quaternion_from_axis_angle(z, 10.0, poses[1].rotation);
    double times[2] = {0.0, 1.0};
    pb_motion motion = {times, poses, 2, 0.0, 1.0, 0, {0, 0, 0}};
    printf("phantom: %zu^3 cubes, 1 mm voxels; motion: translation (%.2f, %.2f, %.2f) mm, 10 deg about z\n", n,
           poses[1].translation[0], poses[1].translation[1], poses[1].translation[2]);

    float *phantom = malloc(count * sizeof *phantom), *ref = malloc(count * sizeof *ref),
          *out = malloc(count * sizeof *out);
    if (!phantom || !ref || !out) {
        fprintf(stderr, "petblur: out of host memory for %zu^3 volumes; use a smaller --size\n", n);
        return EXIT_RUNTIME;
    }
    make_cubes(n, phantom);
    pb_geometry g = {{n, n, n}, {1, 1, 1}};
    pb_volume *in = NULL, *res = NULL;
    if ((st = pb_volume_create(ctx, &g, &in)) != PB_OK || (st = pb_volume_create(ctx, &g, &res)) != PB_OK ||
        (st = pb_volume_upload(in, phantom)) != PB_OK)
        return fail(ctx, st, "volume upload");

    static const struct {
        const char *name;
        pb_method method;
        pb_filter filter;
    } runs[] = {{"REF", PB_METHOD_REF, PB_FILTER_EXACT}, {"AB", PB_METHOD_AB, PB_FILTER_HARDWARE},
                {"AB", PB_METHOD_AB, PB_FILTER_EXACT},   {"RM", PB_METHOD_RM, PB_FILTER_HARDWARE},
                {"CL", PB_METHOD_CL, PB_FILTER_HARDWARE}};
    printf("\n%-4s %-9s %12s %12s\n", "", "filter", "error %", "kernel ms");
    for (size_t r = 0; r < sizeof runs / sizeof runs[0]; r++) {
        pb_blur_options opt = {runs[r].method, runs[r].filter, 0, (unsigned)points, 0, 1};
        if ((st = pb_blur(ctx, in, &motion, &opt, res)) != PB_OK)
            return fail(ctx, st, runs[r].name);
        if ((st = pb_volume_download(res, r == 0 ? ref : out)) != PB_OK)
            return fail(ctx, st, "download");
        double ms = 0.0;
        pb_context_last_kernel_ms(ctx, &ms);
        if (r == 0)
            printf("%-4s %-9s %12s %12.2f   (%ld points per voxel)\n", runs[r].name, "box", "reference", ms, points);
        else
            printf("%-4s %-9s %12.4f %12.2f\n", runs[r].name,
                   runs[r].filter == PB_FILTER_EXACT ? "exact" : "hardware", pb_error_percent(ref, out, count), ms);
    }
    pb_volume_destroy(in);
    pb_volume_destroy(res);
    pb_context_destroy(ctx);
    free(phantom);
    free(ref);
    free(out);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc < 2 || !strcmp(argv[1], "--help") || !strcmp(argv[1], "-h") || !strcmp(argv[1], "help")) {
        usage(argc < 2 ? stderr : stdout);
        return argc < 2 ? EXIT_USAGE : 0;
    }
    if (!strcmp(argv[1], "demo"))
        return cmd_demo(argc - 2, argv + 2);
    if (!strcmp(argv[1], "devices"))
        return cmd_devices();
    fprintf(stderr, "petblur: unknown command '%s'; see petblur --help\n", argv[1]);
    return EXIT_USAGE;
}
