/* petblur: the command-line program. Dispatches to the subcommands; each
 * returns 0, 2 (bad usage or input) or 3 (device or runtime failure). */
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
#include "commands.h"
#include "petblur.h"

static const struct {
    const char *name;
    int (*run)(int argc, char **argv);
    const char *summary;
} commands[] = {
    {"blur", pbc_cmd_blur, "blur a volume along the motion inside a frame (NIfTI, Interfile, raw)"},
    {"motion", pbc_cmd_motion, "a pose track's summary per frame, and a picture of it, before a blur trusts it"},
    {"phantom", pbc_cmd_phantom, "make the paper's homogeneity, Derenzo or brain phantom"},
    {"compare", pbc_cmd_compare, "relative RMS and max error (%) of a volume against a reference"},
    {"render", pbc_cmd_render, "a picture (PNG) of a volume's central slices"},
    {"devices", pbc_cmd_devices, "the backends and devices found, with their limits"},
    {"demo", pbc_cmd_demo, "the main job: a phantom blurred by AB, RM and CL, each compared with REF"},
    {"bench", pbc_cmd_bench, "the paper's experiment: three phantoms, eight motions, every method timed"},
};
enum { COMMANDS = sizeof commands / sizeof commands[0] };

static void usage(FILE *f)
{
    fprintf(f, "usage: petblur COMMAND [options]      (petblur COMMAND --help for its options)\n\n"
               "3-D motion blur of PET activity volumes on GPUs and CPUs (petblur %s).\n\ncommands:\n",
            PB_VERSION);
    for (int i = 0; i < COMMANDS; i++)
        fprintf(f, "  %-9s %s\n", commands[i].name, commands[i].summary);
    fputs("\nexit status: 0 success, 2 bad usage or input, 3 device or runtime failure\n", f);
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        usage(stderr);
        return PBC_EXIT_USAGE;
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h") || !strcmp(argv[1], "help")) {
        usage(stdout);
        return 0;
    }
    if (!strcmp(argv[1], "--version")) {
        printf("petblur %s\n", PB_VERSION);
        return 0;
    }
    pbc_show_progress = isatty(STDERR_FILENO);
    for (int i = 0; i < COMMANDS; i++)
        if (!strcmp(argv[1], commands[i].name))
            return commands[i].run(argc - 2, argv + 2);
    return pbc_fail(PBC_EXIT_USAGE, "unknown command '%s'; see petblur --help", argv[1]);
}
