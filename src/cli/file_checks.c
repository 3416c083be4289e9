/* Checks of output paths, made before any work so that a typo costs nothing. */
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "atomic_file.h"
#include "cli.h"
#include "commands.h"
#include "image_formats.h"

/* An output that exists is replaced by a new file that keeps its mode; a
 * folder, a symbolic link, or a file its owner made read-only is not
 * petblur's to replace. */
static int replaceable(const char *option, const char *path)
{
    struct stat st;
    if (lstat(path, &st) != 0)
        return 0;
    if (S_ISDIR(st.st_mode))
        return pbc_fail(PBC_EXIT_USAGE, "%s %s: is a folder; name a file", option, path);
    if (S_ISLNK(st.st_mode))
        return pbc_fail(PBC_EXIT_USAGE, "%s %s: is a symbolic link, which petblur does not replace or write "
                        "through; remove it or name another output", option, path);
    /* The mode bits, not access(): root may write anything, and still should not
     * replace a file made read-only. */
    if (!(st.st_mode & (S_IWUSR | S_IWGRP | S_IWOTH)) || access(path, W_OK) != 0)
        return pbc_fail(PBC_EXIT_USAGE, "%s %s: exists and is write-protected; remove it or name another output",
                        option, path);
    return 0;
}

int pbc_check_output(const char *option, const char *path, int picture)
{
    char ext[32];
    pbc_file_extension(path, ext, sizeof ext);
    if (picture ? strcmp(ext, ".png") != 0 : !pbc_image_format_known(path))
        return pbc_fail(PBC_EXIT_USAGE, "%s %s: unknown extension '%s'; use %s", option, path, ext,
                        picture ? ".png" : ".nii, .nii.gz, .hv or .raw");
    /* The folder must take a new file now, not after minutes of blurring. */
    char dir[4096];
    const char *slash = strrchr(path, '/');
    snprintf(dir, sizeof dir, "%.*s", slash ? (int)(slash - path) + 1 : 1, slash ? path : ".");
    if (access(dir, W_OK | X_OK) != 0)
        return pbc_fail(PBC_EXIT_USAGE, "%s %s: cannot write into the folder %s (%s); create it or choose another",
                        option, path, dir, strerror(errno));
    /* The temporary beside it adds ".", ".petblur-PID-N" and the extension. */
    const char *base = slash ? slash + 1 : path;
    if (strlen(base) + strlen(ext) + 32 > NAME_MAX)
        return pbc_fail(PBC_EXIT_USAGE, "%s %s: the file name is too long to write beside a temporary of it (at most "
                        "%d characters); choose a shorter one", option, path, (int)(NAME_MAX - strlen(ext) - 32));
    char data[4096];
    int rc = replaceable(option, path);
    if (!rc && !strcmp(ext, ".hv") && !pbc_interfile_data_name(path, data, sizeof data))
        rc = replaceable(option, data);
    return rc;
}

int pbc_hints_from_args(const pbc_command *cmd, const pbc_args *args, size_t dims[3], double voxel_size[3],
                        pbc_read_hints *hints)
{
    const char *d = pbc_arg(cmd, args, "--dims"), *v = pbc_arg(cmd, args, "--voxel-size");
    int rc = 0;
    if ((d && (rc = pbc_parse_dims("--dims", d, dims))) ||
        (v && (rc = pbc_parse_vec3("--voxel-size", v, 1, voxel_size))))
        return rc;
    hints->dims = d ? dims : NULL;
    hints->voxel_size = v ? voxel_size : NULL;
    hints->allow_frames = 0;
    return 0;
}

int pbc_make_dir(const char *option, const char *dir)
{
    if (mkdir(dir, 0777) != 0 && errno != EEXIST)
        return pbc_fail(PBC_EXIT_RUNTIME, "%s %s: cannot create the folder (%s); choose another with %s", option, dir,
                        strerror(errno), option);
    return 0;
}
