/* petblur devices: what this build can run on, with the limits that matter. */
#include <stdio.h>

#include "cli.h"
#include "commands.h"
#include "options.h"
#include "petblur.h"

static const pbc_command command = {
    "devices", "",
    "Lists the backends compiled into this build and the devices each finds, with their 3-D image limits;\n"
    "the names in the first column are what --device takes.",
    NULL, 0, 0, 0, NULL};

static void print_device(pb_backend b, int i, const pb_device_info *d)
{
    printf("%s:%d  %s [%s]%s\n", pb_backend_name(b), i, d->name, d->platform, d->is_gpu ? " GPU" : "");
    if (b != PB_BACKEND_HOST)
        printf("          images %s, 3-D image max %zu x %zu x %zu, largest allocation %.0f MiB, memory %.0f MiB, "
               "%u compute units\n",
               d->image_support ? "yes" : "NO", d->image3d_max[0], d->image3d_max[1], d->image3d_max[2],
               (double)d->max_alloc_bytes / 1048576.0, (double)d->global_mem_bytes / 1048576.0, d->compute_units);
}

int pbc_cmd_devices(int argc, char **argv)
{
    pbc_args args;
    int rc = pbc_parse_args(&command, argc, argv, &args);
    if (rc)
        return rc < 0 ? 0 : rc;
    for (int b = PB_BACKEND_HOST; b <= PB_BACKEND_CUDA; b++) {
        pb_backend backend = (pb_backend)b;
        int n = 0;
        if (!pb_backend_compiled(backend)) {
            printf("%-7s not compiled into this build\n", pb_backend_name(backend));
            continue;
        }
        pb_status st = pb_device_count(backend, &n);
        if (st != PB_OK) {
            printf("%-7s %s: %s\n", pb_backend_name(backend),
                   st == PB_ERR_BACKEND_UNAVAILABLE ? "unavailable" : "error", pb_last_error(NULL));
            continue;
        }
        if (n == 0)
            printf("%-7s no device found\n", pb_backend_name(backend));
        for (int i = 0; i < n; i++) {
            pb_device_info d;
            if (pb_device_get_info(backend, i, &d) == PB_OK)
                print_device(backend, i, &d);
        }
    }
    return 0;
}
