/* Compiled kernels kept on disk between runs (NVRTC's, cuda_rtc.c): one file
 * per key under PETBLUR_CACHE_DIR, else $XDG_CACHE_HOME/petblur, else
 * ~/.cache/petblur. A file holds a header (magic, key, size, checksum) and the
 * image; one that does not match is a miss, compiled again and replaced.
 * Files are written to a temporary name and renamed, so processes compiling
 * at once each leave a whole file and readers never see a partial one. An
 * entry is opened without blocking and only as a regular file: a FIFO, a
 * device or a link at its path is not read. Nothing here prints: why the
 * cache was not used is the note, for the context to hand on. */
#ifndef PB_KERNEL_CACHE_H
#define PB_KERNEL_CACHE_H

#include <stddef.h>
#include <stdint.h>

typedef struct pb_kernel_cache {
    char dir[4096], path[4200]; /* path "" where no entry can be named */
    uint64_t key;
    char note[1536];            /* why the cache was not used; "" when it was */
} pb_kernel_cache;

/* FNV-1a, for keys: start from PB_KERNEL_CACHE_HASH_START. */
#define PB_KERNEL_CACHE_HASH_START 0xcbf29ce484222325ull
uint64_t pb_kernel_cache_hash(uint64_t h, const void *data, size_t n);

/* Names the entry NAME-KEY.bin in the cache folder, made where missing. */
void pb_kernel_cache_open(pb_kernel_cache *c, const char *name, uint64_t key);
/* The entry's image (malloc'ed, *size bytes), or NULL on a miss; where an
 * entry was there but could not be used, the note says why. */
void *pb_kernel_cache_load(pb_kernel_cache *c, size_t *size);
/* Keeps image as the entry; the note says why where it cannot. */
void pb_kernel_cache_store(pb_kernel_cache *c, const void *image, size_t size);

#endif
