/* Whole-or-nothing output files, never written through a link: a temporary
 * created exclusively beside the target, written through its descriptor, and
 * renamed into place when complete if its name still is that file. */
#include <ctype.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "atomic_file.h"
#include "cli.h"

/* Temporaries alive now, removed by a handler when SIGINT, SIGTERM or SIGHUP
 * ends the program mid-write (unlink is async-signal-safe; the handler then
 * lets the signal end the program as it would have). A command has at most
 * three at once (an .hv pair; bench's two tables and a volume). */
enum { LIVE_TEMPS = 8 };
static char live_temp[LIVE_TEMPS][4096];
static volatile sig_atomic_t live_used[LIVE_TEMPS];

static void remove_live_temps(int sig)
{
    for (int i = 0; i < LIVE_TEMPS; i++)
        if (live_used[i])
            unlink(live_temp[i]);
    signal(sig, SIG_DFL);
    raise(sig);
}

static void track_temp(const char *temp)
{
    static int installed;
    if (!installed) {
        static const int sigs[] = {SIGINT, SIGTERM, SIGHUP};
        for (size_t i = 0; i < sizeof sigs / sizeof sigs[0]; i++) {
            struct sigaction sa;
            /* A signal the caller ignores (nohup, a background job) stays ignored. */
            if (sigaction(sigs[i], NULL, &sa) == 0 && sa.sa_handler == SIG_IGN)
                continue;
            memset(&sa, 0, sizeof sa);
            sa.sa_handler = remove_live_temps;
            sigemptyset(&sa.sa_mask);
            sigaction(sigs[i], &sa, NULL);
        }
        installed = 1;
    }
    for (int i = 0; i < LIVE_TEMPS; i++)
        if (!live_used[i]) {
            snprintf(live_temp[i], sizeof live_temp[i], "%s", temp);
            live_used[i] = 1;
            return;
        }
}

static void untrack_temp(const char *temp)
{
    for (int i = 0; i < LIVE_TEMPS; i++)
        if (live_used[i] && !strcmp(live_temp[i], temp))
            live_used[i] = 0;
}

void pbc_file_extension(const char *path, char *ext, size_t size)
{
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    /* ".nii.gz" is one extension; any other ".gz" is not one of ours. */
    const char *dot = strrchr(base, '.');
    if (dot && dot != base && !strcasecmp(dot, ".gz")) {
        const char *prev = dot;
        while (prev > base && prev[-1] != '.')
            prev--;
        if (prev > base + 1)
            dot = prev - 1;
    }
    if (!dot || dot == base) {
        if (size)
            ext[0] = '\0';
        return;
    }
    size_t i = 0;
    for (; dot[i] && i + 1 < size; i++)
        ext[i] = (char)tolower((unsigned char)dot[i]);
    if (size)
        ext[i] = '\0';
}

static const char *base_name(const char *path)
{
    const char *slash = strrchr(path, '/');
    return slash ? slash + 1 : path;
}

/* The folder that path's name lies in, open for the *at() calls. */
static int open_folder(const char *path)
{
    const char *slash = strrchr(path, '/');
    char dir[4096];
    snprintf(dir, sizeof dir, "%.*s", slash ? (int)(slash - path) + 1 : 1, slash ? path : ".");
    return open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
}

/* 1 when name, in t's folder and not followed if a link, is the regular file
 * that t holds (the descriptor's device and inode, taken by fstat when it was
 * created). Anyone who can write the folder can swap a name for a link at any
 * moment; this is how the swap is seen. */
static int is_ours(const pbc_temp *t, const char *name)
{
    struct stat st;
    return fstatat(t->dir, name, &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISREG(st.st_mode) && st.st_dev == t->dev &&
           st.st_ino == t->ino;
}

/* After a rename into place: 0 when name is t's file. Otherwise someone swapped
 * the temporary between the check and the rename, and what now stands at the
 * output's name came from our temporary's name: it is removed unless it is a
 * lone regular file (another writer's output, which is not ours to delete), so
 * that no link is ever left as an output. Returns -1 then. */
static int settle(const pbc_temp *t, const char *name)
{
    struct stat st;
    if (is_ours(t, name))
        return 0;
    if (fstatat(t->dir, name, &st, AT_SYMLINK_NOFOLLOW) == 0 && (!S_ISREG(st.st_mode) || st.st_nlink > 1))
        unlinkat(t->dir, name, 0);
    return -1;
}

static int replaced(const pbc_temp *t)
{
    return pbc_fail(PBC_EXIT_RUNTIME, "%s: its temporary %s was replaced while petblur wrote it (another user or "
                    "program writes in that folder); nothing was written; write into a folder that only you can "
                    "write to", t->path, t->temp);
}

static void close_all(pbc_temp *t)
{
    if (t->fd >= 0)
        close(t->fd);
    if (t->dir >= 0)
        close(t->dir);
    t->fd = t->dir = -1;
}

/* t->temp is a fresh name beside path: a hidden one in the same folder, so
 * that rename() is atomic and a crash leaves at most a dot-file behind, never a
 * half-written OUT. It holds our pid, so a taken name is a stale file of ours
 * (or someone's trap): the next one is tried. */
static int temp_name(pbc_temp *t, const char *path, unsigned attempt, const char *suffix)
{
    char ext[32];
    pbc_file_extension(path, ext, sizeof ext);
    const char *base = base_name(path);
    int n = snprintf(t->temp, sizeof t->temp, "%.*s.%s.petblur-%ld-%u%s%s", (int)(base - path), path, base,
                     (long)getpid(), attempt, suffix, ext);
    if (n < 0 || n >= (int)sizeof t->temp)
        return pbc_fail(PBC_EXIT_USAGE, "%s: the output path is too long; choose a shorter one", path);
    return 0;
}

static int start(pbc_temp *t, const char *path)
{
    t->fd = t->dir = -1;
    t->temp[0] = '\0';
    if (snprintf(t->path, sizeof t->path, "%s", path) >= (int)sizeof t->path)
        return pbc_fail(PBC_EXIT_USAGE, "%s: the output path is too long; choose a shorter one", path);
    t->dir = open_folder(path);
    if (t->dir < 0)
        return pbc_fail(PBC_EXIT_RUNTIME, "%s: cannot open its folder (%s); check that the folder exists and is "
                        "writable", path, strerror(errno));
    return 0;
}

int pbc_temp_create(pbc_temp *t, const char *path)
{
    int rc = start(t, path);
    for (unsigned attempt = 0; !rc && attempt < 100; attempt++) {
        if ((rc = temp_name(t, path, attempt, "")))
            break;
        /* Tracked before it exists, so that no signal falls between its
         * creation and its tracking. O_EXCL creates a new file or fails, even
         * where a link stands (O_NOFOLLOW says so twice). */
        track_temp(t->temp);
        t->fd = openat(t->dir, base_name(t->temp), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
        struct stat st;
        if (t->fd >= 0 && fstat(t->fd, &st) == 0) {
            t->dev = st.st_dev;
            t->ino = st.st_ino;
            return 0;
        }
        int e = errno;
        if (t->fd >= 0) {
            pbc_temp_abort(t, NULL);
            return pbc_fail(PBC_EXIT_RUNTIME, "%s: cannot create a file in that folder (%s)", path, strerror(e));
        }
        untrack_temp(t->temp);
        if (e != EEXIST)
            rc = pbc_fail(PBC_EXIT_RUNTIME, "%s: cannot create a file in that folder (%s); check that the folder "
                          "exists and is writable", path, strerror(e));
        else if (attempt == 99)
            rc = pbc_fail(PBC_EXIT_RUNTIME, "%s: cannot find a free temporary name beside it; remove stale "
                          ".*.petblur-* files from that folder", path);
    }
    close_all(t);
    return rc;
}

int pbc_temp_open(pbc_temp *t, const char *path, FILE **f)
{
    *f = NULL;
    int rc = pbc_temp_create(t, path);
    if (rc)
        return rc;
    /* The stream gets a copy of the descriptor: closing it leaves ours open
     * for the checks at commit. */
    int copy = fcntl(t->fd, F_DUPFD_CLOEXEC, 0);
    *f = copy >= 0 ? fdopen(copy, "wb") : NULL;
    if (!*f) {
        int e = errno;
        if (copy >= 0)
            close(copy);
        pbc_temp_abort(t, NULL);
        return pbc_fail(PBC_EXIT_RUNTIME, "%s: cannot write (%s)", path, strerror(e));
    }
    return 0;
}

/* Flushes and closes f; returns 0 or the errno of the first failure. A full
 * disk often shows only at the last flush or at close. */
static int close_stream(FILE *f)
{
    if (!f)
        return 0;
    int e = fflush(f) != 0 || ferror(f) ? (errno ? errno : EIO) : 0;
    if (fclose(f) != 0 && !e)
        e = errno ? errno : EIO;
    return e;
}

int pbc_temp_commit(pbc_temp *t, FILE *f)
{
    errno = 0;
    int e = close_stream(f);
    if (!e && fsync(t->fd) != 0)
        e = errno;
    if (e) {
        pbc_temp_abort(t, NULL);
        return pbc_fail(PBC_EXIT_RUNTIME, "%s: writing failed (%s); nothing was written; free some space or "
                        "choose another folder", t->path, strerror(e));
    }
    /* A replaced file keeps its permission bits (not set-id bits: an image is
     * not a program), set through the descriptor, never by name. */
    struct stat old;
    const char *name = base_name(t->path), *temp = base_name(t->temp);
    if (fstatat(t->dir, name, &old, AT_SYMLINK_NOFOLLOW) == 0 && S_ISREG(old.st_mode))
        (void)fchmod(t->fd, old.st_mode & 0777);
    if (!is_ours(t, temp)) {
        pbc_temp_abort(t, NULL);
        return replaced(t);
    }
    int moved = renameat(t->dir, temp, t->dir, name);
    e = errno;
    untrack_temp(t->temp);
    if (moved != 0) {
        pbc_temp_abort(t, NULL);
        if (e == ENOENT) /* taken away between the check and the rename */
            return replaced(t);
        return pbc_fail(PBC_EXIT_RUNTIME, "%s: cannot move the finished file into place (%s); nothing was written",
                        t->path, strerror(e));
    }
    int swapped = settle(t, name) != 0;
    close_all(t);
    return swapped ? replaced(t) : 0;
}

void pbc_temp_abort(pbc_temp *t, FILE *f)
{
    if (f)
        fclose(f);
    /* Whatever stands at our temporary's name goes: our file, or a link that
     * someone put there (unlink removes the link, not what it names). */
    if (t->dir >= 0 && t->temp[0])
        unlinkat(t->dir, base_name(t->temp), 0);
    untrack_temp(t->temp);
    close_all(t);
}

/* b's path is a regular file (not a link: it may have been swapped since the
 * output's checks); its device and inode are what the backup must keep. */
static int backup_source(pbc_temp *b, int *exists)
{
    struct stat st;
    *exists = 0;
    if (fstatat(b->dir, base_name(b->path), &st, AT_SYMLINK_NOFOLLOW) != 0)
        return errno == ENOENT ? 0 : pbc_fail(PBC_EXIT_RUNTIME, "%s: cannot look at it (%s); nothing was written",
                                              b->path, strerror(errno));
    if (!S_ISREG(st.st_mode))
        return pbc_fail(PBC_EXIT_USAGE, "%s: is not a regular file (a link or a folder appeared there); petblur "
                        "replaces only files; remove it or name another output", b->path);
    b->dev = st.st_dev;
    b->ino = st.st_ino;
    *exists = 1;
    return 0;
}

int pbc_backup_make(pbc_temp *b, const char *path, int *kept)
{
    int exists = 0;
    int rc = start(b, path);
    if (!rc)
        rc = backup_source(b, &exists);
    /* Not tracked for the signal handler: once the new data file replaces the
     * old, the backup may be the old data's last copy. */
    for (unsigned attempt = 0; !rc && exists && attempt < 100; attempt++) {
        if ((rc = temp_name(b, path, attempt, ".keep")))
            break;
        /* linkat does not follow a link at path, and what it linked is checked. */
        if (linkat(b->dir, base_name(path), b->dir, base_name(b->temp), 0) == 0) {
            if (is_ours(b, base_name(b->temp))) {
                *kept = 1;
                return 0;
            }
            unlinkat(b->dir, base_name(b->temp), 0);
            rc = pbc_fail(PBC_EXIT_RUNTIME, "%s: was replaced while petblur kept a copy of it (another user or "
                          "program writes in that folder); nothing was written", path);
        } else if (errno != EEXIST || attempt == 99) {
            rc = pbc_fail(PBC_EXIT_RUNTIME, "%s: cannot keep the existing file while the new one is written (%s); "
                          "nothing was written", path, strerror(errno));
        }
    }
    *kept = 0;
    close_all(b);
    return rc;
}

int pbc_backup_restore(pbc_temp *b)
{
    const char *temp = base_name(b->temp), *name = base_name(b->path);
    int rc = is_ours(b, temp) && renameat(b->dir, temp, b->dir, name) == 0 ? settle(b, name) : -1;
    /* Gone when it moved; still there when the kept file never left its name
     * (rename between two links of one file does nothing), or not ours. */
    unlinkat(b->dir, temp, 0);
    close_all(b);
    return rc;
}

void pbc_backup_drop(pbc_temp *b)
{
    unlinkat(b->dir, base_name(b->temp), 0);
    close_all(b);
}
