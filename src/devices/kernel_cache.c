#include "kernel_cache.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static const char cache_magic[8] = {'P', 'B', 'K', 'C', 'U', 'B', '1', '\n'};

typedef struct cache_header {
    char magic[8];
    uint64_t key, size, sum;
} cache_header;

uint64_t pb_kernel_cache_hash(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; i++)
        h = (h ^ p[i]) * 0x100000001b3ull;
    return h;
}

/* The folder, made where missing: 0, or errno's reason it cannot be used;
 * *var names the variable it came from (NULL: none was set). */
static int make_dir(pb_kernel_cache *c, const char **var, size_t *length)
{
    static const char *const vars[] = {"PETBLUR_CACHE_DIR", "XDG_CACHE_HOME", "HOME"};
    static const char *const below[] = {"", "/petblur", "/.cache/petblur"};
    const char *value = NULL;
    int i = 0;
    for (; i < 3 && !(value && *value); i++)
        value = getenv(vars[i]);
    if (!value || !*value)
        return ENOENT;
    *var = vars[i - 1];
    int w = snprintf(c->dir, sizeof c->dir, "%s%s", value, below[i - 1]);
    *length = w > 0 ? (size_t)w : 0;
    if (w <= 0 || (size_t)w >= sizeof c->dir - 64) /* room for the entry's name */
        return ENAMETOOLONG;
    for (char *p = c->dir + 1; *p; p++) { /* mkdir -p */
        if (*p != '/')
            continue;
        *p = '\0';
        int bad = mkdir(c->dir, 0755) != 0 && errno != EEXIST;
        *p = '/';
        if (bad)
            return errno;
    }
    if (mkdir(c->dir, 0755) != 0 && errno != EEXIST)
        return errno;
    struct stat s;
    return stat(c->dir, &s) == 0 && S_ISDIR(s.st_mode) ? 0 : ENOTDIR;
}

void pb_kernel_cache_open(pb_kernel_cache *c, const char *name, uint64_t key)
{
    memset(c, 0, sizeof *c);
    c->key = key;
    const char *var = NULL;
    size_t length = 0;
    int err = make_dir(c, &var, &length);
    if (!err) {
        snprintf(c->path, sizeof c->path, "%s/%s-%016llx.bin", c->dir, name, (unsigned long long)key);
        return;
    }
    if (!var)
        snprintf(c->note, sizeof c->note, "no cache folder: none of PETBLUR_CACHE_DIR, XDG_CACHE_HOME and HOME is "
                 "set; set PETBLUR_CACHE_DIR to a writable folder");
    else if (err == ENAMETOOLONG)
        snprintf(c->note, sizeof c->note, "no cache folder: the one %s names is %zu characters long, beyond the "
                 "%zu a cache folder's path may have here; set PETBLUR_CACHE_DIR to a shorter one", var, length,
                 sizeof c->dir - 65);
    else
        snprintf(c->note, sizeof c->note, "the cache folder %.900s (from %s) cannot be used (%s); set "
                 "PETBLUR_CACHE_DIR to a writable folder", c->dir, var, strerror(err));
    c->dir[0] = '\0';
}

/* Opens path for reading only if it is a regular file, without waiting on a
 * FIFO or a device and without following a link: the fd, or -1 with why. */
static int open_regular(const char *path, char *why, size_t n)
{
    int fd = open(path, O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        if (errno == ELOOP)
            snprintf(why, n, "it is a symbolic link, which the cache does not follow");
        else if (errno != ENOENT)
            snprintf(why, n, "%s", strerror(errno));
        return -1;
    }
    struct stat s;
    if (fstat(fd, &s) != 0 || !S_ISREG(s.st_mode)) {
        snprintf(why, n, "it is not a regular file (a FIFO, a device or a folder)");
        close(fd);
        return -1;
    }
    return fd;
}

void *pb_kernel_cache_load(pb_kernel_cache *c, size_t *size)
{
    char why[256] = "";
    int fd = c->path[0] ? open_regular(c->path, why, sizeof why) : -1;
    FILE *f = fd >= 0 ? fdopen(fd, "rb") : NULL;
    if (fd >= 0 && !f)
        close(fd);
    if (why[0])
        snprintf(c->note, sizeof c->note, "the cache entry %.900s was not read (%s); the kernels were compiled "
                 "anew, to be written in its place", c->path, why);
    if (!f)
        return NULL;
    cache_header h;
    void *image = NULL;
    if (fread(&h, sizeof h, 1, f) == 1 && memcmp(h.magic, cache_magic, sizeof cache_magic) == 0 &&
        h.key == c->key && h.size > 0 && h.size < ((uint64_t)1 << 30) && (image = malloc((size_t)h.size)) != NULL) {
        if (fread(image, 1, (size_t)h.size, f) != (size_t)h.size || fgetc(f) != EOF ||
            pb_kernel_cache_hash(PB_KERNEL_CACHE_HASH_START, image, (size_t)h.size) != h.sum) {
            free(image);
            image = NULL;
        }
    }
    fclose(f);
    if (image)
        *size = (size_t)h.size;
    return image;
}

/* 0 on success, else errno's reason. */
static int write_entry(const pb_kernel_cache *c, const void *image, size_t size)
{
    char tmp[4200];
    if (snprintf(tmp, sizeof tmp, "%s/.tmp-XXXXXX", c->dir) >= (int)sizeof tmp)
        return ENAMETOOLONG;
    int fd = mkstemp(tmp);
    if (fd < 0)
        return errno;
    cache_header h;
    memcpy(h.magic, cache_magic, sizeof h.magic);
    h.key = c->key;
    h.size = size;
    h.sum = pb_kernel_cache_hash(PB_KERNEL_CACHE_HASH_START, image, size);
    FILE *f = fdopen(fd, "wb");
    int err = 0;
    if (!f) {
        err = errno;
        close(fd);
    } else {
        if (fwrite(&h, sizeof h, 1, f) != 1 || fwrite(image, 1, size, f) != size)
            err = errno ? errno : EIO;
        if (fclose(f) != 0 && !err)
            err = errno ? errno : EIO;
    }
    /* rename replaces whatever non-folder stood at the path, FIFOs and links
     * included, without opening it. */
    if (!err && rename(tmp, c->path) != 0)
        err = errno;
    if (err)
        unlink(tmp);
    return err;
}

void pb_kernel_cache_store(pb_kernel_cache *c, const void *image, size_t size)
{
    if (!c->path[0])
        return;
    int err = write_entry(c, image, size);
    if (err && !c->note[0])
        snprintf(c->note, sizeof c->note, "the compiled kernels stay in memory: the cache folder %.900s cannot be "
                 "written (%s); set PETBLUR_CACHE_DIR to a writable folder to keep them between runs", c->dir,
                 strerror(err));
}
