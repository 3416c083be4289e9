/* The compiled-kernel cache (src/devices/kernel_cache.c), on fresh images and
 * keys each run, without a GPU: entries read back whole; a FIFO, a link or a
 * folder at an entry's path is neither waited on nor followed, and is
 * replaced; a damaged entry is a miss; a folder that cannot be used, or a
 * path too long, is said in the note (nothing is printed: stderr is closed
 * while the cache works). */
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "kernel_cache.h"
#include "testlib.h"

static char root[] = "/tmp/pb-cache-test-XXXXXX";

static void *random_image(size_t *size)
{
    *size = 1 + (size_t)pb_rand_range(0, 5000);
    unsigned char *p = malloc(*size);
    for (size_t i = 0; i < *size; i++)
        p[i] = (unsigned char)pb_rand_range(0, 256);
    return p;
}

static uint64_t random_key(void)
{
    uint64_t k = 0;
    for (int i = 0; i < 4; i++)
        k = k << 16 | (uint64_t)pb_rand_range(0, 65536);
    return k;
}

static void test_round_trip(void)
{
    setenv("PETBLUR_CACHE_DIR", root, 1);
    size_t size, got = 0;
    void *image = random_image(&size);
    pb_kernel_cache c;
    pb_kernel_cache_open(&c, "cuda-sm90", random_key());
    pb_check(c.path[0] && !c.note[0], "an entry named in %s: %s", root, c.note);
    pb_check(pb_kernel_cache_load(&c, &got) == NULL && !c.note[0], "no entry yet: a miss with no note (%s)", c.note);
    pb_kernel_cache_store(&c, image, size);
    void *back = pb_kernel_cache_load(&c, &got);
    pb_check(back && got == size && !memcmp(back, image, size), "the entry reads back whole (%zu bytes)", size);
    free(back);
    /* One byte changed anywhere: a miss, compiled again. */
    int fd = open(c.path, O_RDWR);
    off_t at = (off_t)pb_rand_range(0, (double)size + 32);
    unsigned char b;
    pb_check(pread(fd, &b, 1, at) == 1, "read byte %lld", (long long)at);
    b ^= 0x5a;
    pb_check(pwrite(fd, &b, 1, at) == 1, "damage byte %lld", (long long)at);
    close(fd);
    pb_check(pb_kernel_cache_load(&c, &got) == NULL, "an entry damaged at byte %lld is a miss", (long long)at);
    free(image);
}

/* What stands at the entry's path: a FIFO (open() would wait for a writer),
 * a link to a real entry, a folder. */
static void test_odd_entries(void)
{
    setenv("PETBLUR_CACHE_DIR", root, 1);
    size_t size, got = 0;
    void *image = random_image(&size);
    pb_kernel_cache real;
    pb_kernel_cache_open(&real, "real", random_key());
    pb_kernel_cache_store(&real, image, size);
    for (int kind = 0; kind < 3; kind++) {
        pb_kernel_cache c;
        pb_kernel_cache_open(&c, "odd", real.key);
        int made = kind == 0 ? mkfifo(c.path, 0644) : kind == 1 ? symlink(real.path, c.path) : mkdir(c.path, 0755);
        pb_check(made == 0, "made the odd entry %d: %s", kind, strerror(errno));
        pb_test_deadline(10, "the cache blocked on an entry");
        void *back = pb_kernel_cache_load(&c, &got);
        pb_test_deadline(0, NULL);
        const char *words[] = {"not a regular file", "symbolic link", "not a regular file"};
        pb_check(back == NULL && strstr(c.note, words[kind]) && strstr(c.note, c.path), "entry kind %d not read, "
                 "said: %s", kind, c.note);
        free(back);
        c.note[0] = '\0';
        pb_kernel_cache_store(&c, image, size);
        struct stat s;
        if (kind < 2) {
            pb_check(lstat(c.path, &s) == 0 && S_ISREG(s.st_mode), "entry kind %d replaced by a regular file", kind);
            back = pb_kernel_cache_load(&c, &got);
            pb_check(back && got == size && !memcmp(back, image, size), "entry kind %d reads back once replaced",
                     kind);
            free(back);
        } else {
            pb_check(strstr(c.note, "cannot be written") != NULL, "a folder at the entry: said (%s)", c.note);
            rmdir(c.path);
        }
        unlink(c.path);
    }
    unlink(real.path);
    free(image);
}

static void test_unusable_folders(void)
{
    pb_kernel_cache c;
    /* A path longer than a cache folder's may be (5000 characters). */
    char *longer = malloc(5001);
    memset(longer, 'a', 5000);
    longer[0] = '/';
    longer[5000] = '\0';
    setenv("PETBLUR_CACHE_DIR", longer, 1);
    pb_kernel_cache_open(&c, "x", 1);
    pb_check(!c.path[0] && strstr(c.note, "the one PETBLUR_CACHE_DIR names is 5000 characters") && strstr(c.note, "shorter"),
             "a 5000-character PETBLUR_CACHE_DIR: %s", c.note);
    free(longer);
    /* A file where the folder should be. */
    char file[4200];
    snprintf(file, sizeof file, "%s/plain-file", root);
    FILE *f = fopen(file, "w");
    fclose(f);
    setenv("PETBLUR_CACHE_DIR", file, 1);
    pb_kernel_cache_open(&c, "x", 1);
    pb_check(!c.path[0] && strstr(c.note, file) && strstr(c.note, "PETBLUR_CACHE_DIR"), "a file as the folder: %s",
             c.note);
    unlink(file);
    /* None set at all. */
    unsetenv("PETBLUR_CACHE_DIR");
    unsetenv("XDG_CACHE_HOME");
    unsetenv("HOME");
    pb_kernel_cache_open(&c, "x", 1);
    pb_check(!c.path[0] && strstr(c.note, "none of PETBLUR_CACHE_DIR, XDG_CACHE_HOME and HOME"), "none set: %s",
             c.note);
}

int main(void)
{
    pb_test_seed();
    if (!mkdtemp(root))
        return 99;
    /* The library never prints: anything written to stderr would vanish
     * here, and stdout carries the results. */
    int saved = dup(STDERR_FILENO);
    close(STDERR_FILENO);
    test_round_trip();
    test_odd_entries();
    test_unusable_folders();
    dup2(saved, STDERR_FILENO);
    char cmd[256];
    snprintf(cmd, sizeof cmd, "rm -rf %s", root);
    if (system(cmd) != 0)
        return 99;
    return pb_test_finish();
}
