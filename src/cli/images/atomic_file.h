/* Output files appear whole or not at all, and never through a link: each is
 * written under a temporary name in its own folder (so that rename is atomic
 * on the same file system), created exclusively (O_EXCL | O_NOFOLLOW) and
 * written only through the descriptor that creation returned, never reopened
 * by name. It is renamed into place when complete, after checking that the
 * name still is the file we wrote; a failure removes the temporary. */
#ifndef PBC_ATOMIC_FILE_H
#define PBC_ATOMIC_FILE_H

#include <stddef.h>
#include <stdio.h>
#include <sys/types.h>

typedef struct pbc_temp {
    char path[4096]; /* the final name, as given */
    char temp[4096]; /* the temporary's path (messages, the signal handler); ends with path's extension */
    int dir;         /* the folder of both, open: every later step happens in this folder, whatever its path
                      * comes to name meanwhile */
    int fd;          /* the temporary, open from its creation until commit or abort; -1 for a backup */
    dev_t dev;       /* what fd is (or what a backup kept): a name must still be this file to be renamed */
    ino_t ino;
} pbc_temp;

/* Creates a fresh temporary beside path, ending in the same extension as path
 * (".nii.gz", ".png", ...), with O_CREAT | O_EXCL | O_NOFOLLOW, and keeps it
 * open in t->fd. A writer that needs its own descriptor (zlib's gzdopen) takes
 * a dup() of t->fd. Returns 0 or an exit status after printing the message. */
int pbc_temp_create(pbc_temp *t, const char *path);
/* pbc_temp_create, then *f = a stdio stream on a dup() of the descriptor. */
int pbc_temp_open(pbc_temp *t, const char *path, FILE **f);
/* Flushes and closes f (when not NULL), syncs the temporary, gives it the
 * permission bits of the file it replaces, and renames it into place if the
 * temporary's name still is the file that was written (and checks the final
 * name afterwards). On any failure removes what it can and returns an exit
 * status after the message; the output is then never a link. */
int pbc_temp_commit(pbc_temp *t, FILE *f);
/* Closes f (when not NULL) and the temporary, and removes it. */
void pbc_temp_abort(pbc_temp *t, FILE *f);

/* Backups, for an output that comes in two files (an Interfile pair): the
 * existing regular file at path is kept under a fresh hidden name beside it
 * (a hard link) until the new pair is in place. *kept is 0 when path does not
 * exist. Returns 0 or an exit status after the message. */
int pbc_backup_make(pbc_temp *b, const char *path, int *kept);
/* Puts the backup back at its path, if its name still is the file it kept;
 * returns 0, or -1 when it could not (the backup is then removed). */
int pbc_backup_restore(pbc_temp *b);
/* Removes the backup. */
void pbc_backup_drop(pbc_temp *b);


/* The extension that decides a file's format, lower-cased into ext (".nii.gz",
 * ".nii", ".hv", ".raw", ".png", ".csv"), or "" when there is none. */
void pbc_file_extension(const char *path, char *ext, size_t size);

#endif
