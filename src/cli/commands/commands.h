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
/* petblur motion estimate, reached through petblur motion. */
int pbc_cmd_motion_estimate(int argc, char **argv);

/* Shared checks of file arguments. */
/* Refuses an output path whose extension no writer knows, whose folder takes no
 * new file, or that stands for something petblur does not replace (a folder,
 * a link, a write-protected file) (before any work). kind: 0 an image, 1 a
 * picture (.png), 2 a table (.csv: a track). */
int pbc_check_output(const char *option, const char *path, int kind);
/* 0 where path is absent or a file petblur may replace; else the error (a
 * folder, a symbolic link, a write-protected file). */
int pbc_check_replaceable(const char *option, const char *path);

/* Every file a command reads and every file it writes, for the one rule that
 * no output names a file the command reads, nor another output (by path,
 * link, or device and inode). A command lists them all and calls
 * pbc_files_check before any work. */
typedef struct pbc_file_use {
    const char *option; /* "-i", "--motion", "--png", ...; "" for a positional argument */
    char *path;         /* malloc'ed */
    char *header;       /* an Interfile pair's data file: its header (malloc'ed); else NULL */
    int written;
} pbc_file_use;
typedef struct pbc_files {
    pbc_file_use *use; /* grown as files are added: a --fields table names one file a row */
    int count, capacity;
    int status; /* the first failure while the list was made (its message printed), else 0 */
} pbc_files;

/* Add a file the command reads, as it is (a track, a calibration, a sidecar)
 * or as an image, whose Interfile data file comes with it (found by parsing
 * the header, by the rule of where a data file may live; a failure is kept in
 * f->status, its message printed). A NULL path adds nothing. */
void pbc_files_read(pbc_files *f, const char *option, const char *path);
void pbc_files_read_image(pbc_files *f, const char *option, const char *path);
/* Adds a file the command writes (NULL: nothing); OUT.hv brings OUT.v. */
void pbc_files_write(pbc_files *f, const char *option, const char *path);
/* The rule, then frees the list. Returns f->status if set, else 0, or
 * PBC_EXIT_USAGE after a message that names both files and the fix. */
int pbc_files_check(pbc_files *f);

/* The data file of the Interfile header path, as reading it would find it
 * (image_interfile.c), by the rule of where a data file may live. Returns 0 or
 * an exit status after the message. */
int pbc_interfile_data_of(const char *path, char *data, size_t size);

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
