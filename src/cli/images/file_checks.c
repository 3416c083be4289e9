/* Checks of file arguments, made before any work so that a typo costs nothing:
 * what an output may be, and the one rule that no output names a file the
 * command reads or another output. */
#define _XOPEN_SOURCE 700 /* realpath */
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
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
int pbc_check_replaceable(const char *option, const char *path)
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

int pbc_check_output(const char *option, const char *path, int kind)
{
    char ext[32];
    pbc_file_extension(path, ext, sizeof ext);
    static const char *const kinds[] = {".nii, .nii.gz, .hv or .raw", ".png", ".csv"};
    if (kind == 2 ? strcmp(ext, ".csv") != 0 : kind ? strcmp(ext, ".png") != 0 : !pbc_image_format_known(path))
        return pbc_fail(PBC_EXIT_USAGE, "%s %s: unknown extension '%s'; use %s", option, path, ext, kinds[kind]);
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
    int rc = pbc_check_replaceable(option, path);
    if (!rc && !strcmp(ext, ".hv") && !pbc_interfile_data_name(path, data, sizeof data))
        rc = pbc_check_replaceable(option, data);
    return rc;
}

static void add(pbc_files *f, const char *option, const char *path, const char *header, int written)
{
    if (f->status || !path)
        return;
    if (f->count == f->capacity) {
        int cap = f->capacity ? 2 * f->capacity : 16;
        pbc_file_use *grown = realloc(f->use, (size_t)cap * sizeof *grown);
        if (!grown) {
            f->status = pbc_fail(PBC_EXIT_RUNTIME, "out of memory while checking the files' names");
            return;
        }
        f->use = grown;
        f->capacity = cap;
    }
    pbc_file_use *u = &f->use[f->count];
    u->option = option;
    u->written = written;
    u->path = strdup(path);
    u->header = header ? strdup(header) : NULL;
    f->count++;
    if (!u->path || (header && !u->header))
        f->status = pbc_fail(PBC_EXIT_RUNTIME, "out of memory while checking the files' names");
}

static int is_interfile(const char *path)
{
    char ext[32];
    pbc_file_extension(path, ext, sizeof ext);
    return !strcmp(ext, ".hv");
}

void pbc_files_read(pbc_files *f, const char *option, const char *path)
{
    add(f, option, path, NULL, 0);
}

void pbc_files_read_image(pbc_files *f, const char *option, const char *path)
{
    char data[PATH_MAX];
    add(f, option, path, NULL, 0);
    if (f->status || !path || !is_interfile(path))
        return;
    f->status = pbc_interfile_data_of(path, data, sizeof data);
    add(f, option, data, path, 0);
}

void pbc_files_write(pbc_files *f, const char *option, const char *path)
{
    char data[PATH_MAX];
    add(f, option, path, NULL, 1);
    if (f->status || !path || !is_interfile(path))
        return;
    f->status = pbc_interfile_data_name(path, data, sizeof data);
    add(f, option, data, path, 1);
}

/* Where a name leads: the device and inode of the file it reaches (through
 * links), and the real path: the file's own when it exists, else its folder's
 * and its name (an output not written yet), else the name as given. Hard
 * links differ in real path but share the inode; two names of one file not
 * yet there share the real path. */
typedef struct file_id {
    int exists;
    dev_t dev;
    ino_t ino;
    char where[PATH_MAX];
} file_id;

static void identify(const char *path, file_id *id)
{
    struct stat st;
    id->exists = stat(path, &st) == 0;
    id->dev = id->exists ? st.st_dev : 0;
    id->ino = id->exists ? st.st_ino : 0;
    if (id->exists && realpath(path, id->where))
        return;
    char dir[PATH_MAX], real[PATH_MAX];
    const char *slash = strrchr(path, '/');
    snprintf(dir, sizeof dir, "%.*s", slash ? (int)(slash - path) + 1 : 1, slash ? path : ".");
    int n = realpath(dir, real) ? snprintf(id->where, sizeof id->where, "%s/%s", strcmp(real, "/") ? real : "",
                                           slash ? slash + 1 : path)
                                : -1;
    if (n < 0 || n >= (int)sizeof id->where)
        snprintf(id->where, sizeof id->where, "%s", path);
}

static int same_file(const file_id *a, const file_id *b)
{
    if (a->exists && b->exists)
        return a->dev == b->dev && a->ino == b->ino;
    return !strcmp(a->where, b->where);
}

/* "-o out.hv (its data file out.v)", "--motion t.csv" */
static void describe(const pbc_file_use *u, char *out, size_t size)
{
    if (u->header)
        snprintf(out, size, "%s %s (its data file %s)", u->option, u->header, u->path);
    else
        snprintf(out, size, "%s %s", u->option, u->path);
}

/* The fix: another name for the output, or another folder where the folder
 * is all the user names (demo's and bench's --out-dir). */
static void fix(const pbc_file_use *out, char *text, size_t size)
{
    if (!strcmp(out->option, "--out-dir"))
        snprintf(text, size, "choose another --out-dir");
    else
        snprintf(text, size, "give %s another name", out->option);
}

static int refuse(const pbc_file_use *out, const pbc_file_use *other)
{
    char a[2 * PATH_MAX + 64], b[2 * PATH_MAX + 64], how[64];
    describe(out, a, sizeof a);
    describe(other, b, sizeof b);
    fix(out, how, sizeof how);
    if (other->written)
        return pbc_fail(PBC_EXIT_USAGE, "%s and %s name the same file; each output needs a file of its own: %s", b,
                        a, how);
    return pbc_fail(PBC_EXIT_USAGE, "%s and %s name the same file (by name, link or inode); petblur never writes "
                    "over its inputs: %s", a, b, how);
}

static void files_free(pbc_files *f)
{
    for (int i = 0; i < f->count; i++) {
        free(f->use[i].path);
        free(f->use[i].header);
    }
    free(f->use);
    f->use = NULL;
    f->count = f->capacity = 0;
}

/* Each output against every input and every output listed before it. */
int pbc_files_check(pbc_files *f)
{
    int rc = f->status;
    file_id *ids = rc || !f->count ? NULL : malloc((size_t)f->count * sizeof *ids);
    if (!rc && f->count && !ids)
        rc = pbc_fail(PBC_EXIT_RUNTIME, "out of memory while checking the files' names");
    for (int i = 0; ids && i < f->count; i++)
        identify(f->use[i].path, &ids[i]);
    for (int w = 0; ids && !rc && w < f->count; w++)
        for (int j = 0; f->use[w].written && !rc && j < f->count; j++)
            if (j != w && (!f->use[j].written || j < w) && same_file(&ids[w], &ids[j]))
                rc = refuse(&f->use[w], &f->use[j]);
    free(ids);
    files_free(f);
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
    struct stat st;
    if (!*dir)
        return pbc_fail(PBC_EXIT_USAGE, "%s: the folder's name is empty; give one", option);
    if (mkdir(dir, 0777) == 0 || (errno == EEXIST && stat(dir, &st) == 0 && S_ISDIR(st.st_mode)))
        return 0;
    if (errno == EEXIST)
        return pbc_fail(PBC_EXIT_USAGE, "%s %s: is a file, not a folder; choose a folder with %s", option, dir, option);
    /* a missing parent, no permission, a read-only disk: the name the user gave; anything else: the machine */
    int user = errno == ENOENT || errno == EACCES || errno == ENOTDIR || errno == EROFS || errno == ENAMETOOLONG;
    return pbc_fail(user ? PBC_EXIT_USAGE : PBC_EXIT_RUNTIME, "%s %s: cannot create the folder (%s); choose another "
                    "with %s", option, dir, strerror(errno), option);
}
