/* Output files appear whole or not at all: each is written under a temporary
 * name in its own folder (so that rename is atomic on the same file system)
 * and renamed into place only when complete. A failure removes the temporary. */
#ifndef PBC_ATOMIC_FILE_H
#define PBC_ATOMIC_FILE_H

#include <stddef.h>
#include <stdio.h>

typedef struct pbc_temp {
    char path[4096];  /* the final name */
    char temp[4096];  /* where it is written meanwhile; ends with path's extension */
} pbc_temp;

/* Reserves a fresh temporary name beside path that ends in the same extension
 * as path (".nii.gz", ".png", ...), so that libraries that pick the format by
 * name still do. The file is created empty (O_EXCL). Returns 0 or an exit
 * status after printing the message. */
int pbc_temp_reserve(pbc_temp *t, const char *path);
/* pbc_temp_reserve, then opens the temporary for writing ("wb"). */
int pbc_temp_open(pbc_temp *t, const char *path, FILE **f);
/* Flushes and closes f (when not NULL), then renames the temporary into place.
 * On any failure removes the temporary and returns an exit status. */
int pbc_temp_commit(pbc_temp *t, FILE *f);
/* Takes the temporary off the list that a signal removes: for a name that will
 * hold something to keep (an .hv pair's old data file while the new is
 * written). */
void pbc_temp_keep(pbc_temp *t);
/* Closes f (when not NULL) and removes the temporary. */
void pbc_temp_abort(pbc_temp *t, FILE *f);

/* 1 when the two paths name the same existing file (same device and inode), or
 * are the same string; used to refuse an output that would overwrite an input. */
int pbc_same_file(const char *a, const char *b);

/* The extension that decides a file's format, lower-cased into ext (".nii.gz",
 * ".nii", ".hv", ".raw", ".png", ".csv"), or "" when there is none. */
void pbc_file_extension(const char *path, char *ext, size_t size);

#endif
