/* The subcommands; each takes the arguments after its name and returns the
 * program's exit status. */
#ifndef PBC_COMMANDS_H
#define PBC_COMMANDS_H

#include "image_io.h"
#include "options.h"

int pbc_cmd_blur(int argc, char **argv);
int pbc_cmd_phantom(int argc, char **argv);
int pbc_cmd_compare(int argc, char **argv);
int pbc_cmd_render(int argc, char **argv);
int pbc_cmd_devices(int argc, char **argv);
int pbc_cmd_demo(int argc, char **argv);
int pbc_cmd_bench(int argc, char **argv);
int pbc_cmd_motion(int argc, char **argv);

/* Shared checks of file arguments. */
/* Refuses an output path whose extension no writer knows (before any work). */
int pbc_check_output(const char *option, const char *path, int picture);

/* Creates the folder dir (named by option, e.g. "--out-dir") unless it exists. */
int pbc_make_dir(const char *option, const char *dir);

/* The read hints of a command's --dims and --voxel-size (either may be absent);
 * dims and voxel_size hold the parsed values that hints points to. */
int pbc_hints_from_args(const pbc_command *cmd, const pbc_args *args, size_t dims[3], double voxel_size[3],
                        pbc_read_hints *hints);

/* --frames-from: the frames' boundaries (count = frames + 1, malloc'ed) from a
 * BIDS-PET sidecar's FrameTimesStart and FrameDuration, which must follow each
 * other without gaps. Returns 0 or an exit status after the message. */
int pbc_bids_frames(const char *path, double **bounds, size_t *count);

#endif
