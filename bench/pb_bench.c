/* Times every method on one device with device events (OpenCL profiling events,
 * CUDA events; the host clock for the host backend): warm-up, then the median
 * of --runs kernel times. The motions default to the paper's eight scenarios
 * (translations in voxels; rotations in degrees about z through the centre). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "petblur.h"
#include "bench_stats.h"
#include "scenarios.h"

static void usage(void)
{
    fputs("usage: pb_bench [--device auto|host|opencl[:N]|cuda[:N]] [--size N | --dims X,Y,Z] [--runs N]\n"
          "                [--ref-runs N] [--scenario 1-8 | --translate TX,TY,TZ --rotate DEG] [--csv FILE]\n"
          "                [--label TEXT]\n"
          "Times AB, RM and CL (HARDWARE and EXACT) and REF (200 points, default time steps) with device\n"
          "events: one warm-up, median of --runs (REF: --ref-runs, default 3, 0 to leave it out).\n"
          "Translations in voxels, rotations in degrees about z through the grid's centre.\n",
          stderr);
}

static int parse3(const char *s, double v[3])
{
    char tail;
    return sscanf(s, "%lf,%lf,%lf%c", &v[0], &v[1], &v[2], &tail) == 3;
}

int main(int argc, char **argv)
{
    pb_context_options copt = {PB_BACKEND_AUTO, 0, NULL};
    double dims[3] = {128, 128, 128};
    int runs = 20, ref_runs = 3, only = 0;
    pb_scenario custom = {{0, 0, 0}, 0};
    int have_custom = 0;
    const char *csv = NULL, *label = "";
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!v) {
            usage();
            return 2;
        }
        i++;
        if (!strcmp(a, "--device")) {
            if (pb_device_parse(v, &copt.backend, &copt.device_index) != PB_OK) {
                fprintf(stderr, "pb_bench: --device: %s\n", pb_last_error(NULL));
                return 2;
            }
        } else if (!strcmp(a, "--size")) {
            dims[0] = dims[1] = dims[2] = atof(v);
        } else if (!strcmp(a, "--dims")) {
            if (!parse3(v, dims)) {
                usage();
                return 2;
            }
        } else if (!strcmp(a, "--runs")) {
            runs = atoi(v);
        } else if (!strcmp(a, "--ref-runs")) {
            ref_runs = atoi(v);
        } else if (!strcmp(a, "--scenario")) {
            only = atoi(v);
        } else if (!strcmp(a, "--translate")) {
            have_custom = parse3(v, custom.t);
        } else if (!strcmp(a, "--rotate")) {
            custom.deg = atof(v);
            have_custom = 1;
        } else if (!strcmp(a, "--csv")) {
            csv = v;
        } else if (!strcmp(a, "--label")) {
            label = v;
        } else {
            usage();
            return 2;
        }
    }
    if (runs < 1 || ref_runs < 0 || only < 0 || only > 8 || dims[0] < 1 || dims[1] < 1 || dims[2] < 1) {
        usage();
        return 2;
    }

    pb_context *ctx = NULL;
    pb_status st = pb_context_create(&copt, &ctx);
    if (st != PB_OK) {
        fprintf(stderr, "pb_bench: %s: %s\n", pb_status_string(st), pb_last_error(NULL));
        return 3;
    }
    pb_device_info info;
    pb_context_device_info(ctx, &info);
    pb_geometry g = {{(size_t)dims[0], (size_t)dims[1], (size_t)dims[2]}, {1, 1, 1}};
    size_t count = g.dims[0] * g.dims[1] * g.dims[2];
    float *data = malloc(count * sizeof *data);
    pb_volume *in = NULL, *out = NULL;
    if (!data || pb_volume_create(ctx, &g, &in) != PB_OK || pb_volume_create(ctx, &g, &out) != PB_OK) {
        fprintf(stderr, "pb_bench: cannot allocate %zu voxels: %s\n", count, pb_last_error(ctx));
        return 3;
    }
    srand(1);
    for (size_t i = 0; i < count; i++)
        data[i] = (float)rand() / (float)RAND_MAX;
    pb_volume_upload(in, data);

    FILE *fcsv = csv ? fopen(csv, "w") : NULL;
    if (csv && !fcsv) {
        fprintf(stderr, "pb_bench: cannot write %s: %s; pick a writable path for --csv\n", csv, strerror(errno));
        return 2;
    }
    if (fcsv)
        fprintf(fcsv, "label,backend,device,nx,ny,nz,scenario,tx,ty,tz,rot_deg,method,filter,runs,median_ms,min_ms,"
                      "gvoxels_per_s,device_ms,device_copy_ms\n");
    printf("# %s:%d %s [%s], %zu x %zu x %zu float, median of %d runs (REF: %d) after one warm-up (device "
           "events)\n",
           pb_backend_name(pb_context_backend(ctx)), copt.device_index, info.name, info.platform, g.dims[0],
           g.dims[1], g.dims[2], runs, ref_runs);
    printf("%-3s %-22s %-3s %-8s %10s %10s %10s %10s\n", "#", "translation (voxels)", "deg", "method", "median ms",
           "min ms", "device ms", "copy ms");
    /* The device-memory path: a plan made once, applied from one device
     * buffer to another (the volumes' own memory, handed in as a caller's
     * would be); its time spans the copy into the texture and the kernel. */
    void *dev_in = NULL, *dev_out = NULL;
    pb_volume_memory(in, &dev_in);
    pb_volume_memory(out, &dev_out);

    static const struct {
        const char *name;
        pb_method method;
        pb_filter filter;
    } methods[] = {{"AB-hw", PB_METHOD_AB, PB_FILTER_HARDWARE}, {"AB-ex", PB_METHOD_AB, PB_FILTER_EXACT},
                   {"RM-hw", PB_METHOD_RM, PB_FILTER_HARDWARE}, {"RM-ex", PB_METHOD_RM, PB_FILTER_EXACT},
                   {"CL-hw", PB_METHOD_CL, PB_FILTER_HARDWARE}, {"CL-ex", PB_METHOD_CL, PB_FILTER_EXACT},
                   {"REF", PB_METHOD_REF, PB_FILTER_EXACT}};
    static const char *method_names[] = {"AB", "RM", "CL", "REF"};
    int tty = isatty(STDERR_FILENO);
    double *ms = malloc((size_t)(runs > ref_runs ? runs : ref_runs) * sizeof *ms);
    double *copy_ms = malloc((size_t)(runs > ref_runs ? runs : ref_runs) * sizeof *copy_ms);
    for (int s = have_custom ? 0 : 1; s <= (have_custom ? 0 : 8); s++) {
        if (only && s != only)
            continue;
        pb_scenario sc = have_custom ? custom : pb_paper_scenarios[s - 1];
        double times[2];
        pb_pose poses[2];
        pb_motion motion = pb_scenario_motion(&sc, g.voxel_size, times, poses);
        for (size_t m = 0; m < sizeof methods / sizeof methods[0]; m++) {
            int n_runs = methods[m].method == PB_METHOD_REF ? ref_runs : runs;
            if (n_runs == 0)
                continue;
            /* The paper's polyline (one segment), as in the earlier runs. */
            pb_blur_options opt = {methods[m].method, methods[m].filter, 0, 0, 0, 0, PB_PATH_TRACKED, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
            /* Progress on a terminal only, outside the timed calls (a library
             * progress callback would split the launches and change the times). */
            if (tty)
                fprintf(stderr, "\rpb_bench: scenario %d, %-6s %d runs ...", s, methods[m].name, n_runs + 1);
            st = pb_blur(ctx, in, &motion, &opt, out); /* warm-up */
            for (int r = 0; r < n_runs && st == PB_OK; r++) {
                st = pb_blur(ctx, in, &motion, &opt, out);
                pb_context_last_kernel_ms(ctx, &ms[r]);
            }
            if (st != PB_OK) {
                fprintf(stderr, "pb_bench: %s: %s: %s\n", methods[m].name, pb_status_string(st), pb_last_error(ctx));
                return 3;
            }
            double med = pbc_median(ms, n_runs), min_ms = ms[0]; /* sorted by the median */
            pb_plan *plan = NULL;
            st = pb_plan_create(ctx, &g, &motion, &opt, &plan);
            if (st == PB_OK)
                st = pb_plan_forward_device(plan, 0, dev_in, dev_out); /* warm-up */
            for (int r = 0; r < n_runs && st == PB_OK; r++) {
                st = pb_plan_forward_device(plan, 0, dev_in, dev_out);
                pb_context_last_kernel_ms(ctx, &ms[r]);
                pb_context_last_input_ms(ctx, &copy_ms[r]);
            }
            pb_plan_destroy(plan);
            if (st != PB_OK) {
                fprintf(stderr, "pb_bench: %s (device memory): %s: %s\n", methods[m].name, pb_status_string(st),
                        pb_last_error(ctx));
                return 3;
            }
            if (tty)
                fprintf(stderr, "\r%50s\r", "");
            double dev_med = pbc_median(ms, n_runs), copy_med = pbc_median(copy_ms, n_runs);
            printf("%-3d (%6.1f, %6.1f, %6.1f)   %-3.0f %-8s %10.3f %10.3f %10.3f %10.3f\n", s, sc.t[0], sc.t[1],
                   sc.t[2], sc.deg, methods[m].name, med, min_ms, dev_med, copy_med);
            if (fcsv)
                fprintf(fcsv, "%s,%s,%s,%zu,%zu,%zu,%d,%g,%g,%g,%g,%s,%s,%d,%.4f,%.4f,%.3f,%.4f,%.4f\n", label,
                        pb_backend_name(pb_context_backend(ctx)), info.name, g.dims[0], g.dims[1], g.dims[2], s,
                        sc.t[0], sc.t[1], sc.t[2], sc.deg, method_names[methods[m].method],
                        methods[m].filter == PB_FILTER_EXACT ? "exact" : "hardware", n_runs, med, min_ms,
                        (double)count / (med * 1e6), dev_med, copy_med);
            fflush(stdout);
        }
    }
    free(ms);
    free(copy_ms);
    free(data);
    if (fcsv)
        fclose(fcsv);
    pb_volume_destroy(in);
    pb_volume_destroy(out);
    pb_context_destroy(ctx);
    return 0;
}
