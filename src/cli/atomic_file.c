/* Whole-or-nothing output files: temporary name beside the target, rename when
 * complete. */
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
 * lets the signal end the program as it would have). A write has at most two
 * at once (an .hv pair), and a kept backup. */
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

int pbc_temp_reserve(pbc_temp *t, const char *path)
{
    char ext[32];
    pbc_file_extension(path, ext, sizeof ext);
    const char *slash = strrchr(path, '/');
    int dirlen = slash ? (int)(slash - path + 1) : 0;
    const char *base = path + dirlen;
    if (snprintf(t->path, sizeof t->path, "%s", path) >= (int)sizeof t->path)
        return pbc_fail(PBC_EXIT_USAGE, "%s: the output path is too long; choose a shorter one", path);
    /* A hidden name in the same folder: rename() is then atomic, and a crash
     * leaves at most a dot-file behind, never a half-written OUT. */
    for (unsigned attempt = 0; attempt < 100; attempt++) {
        if (snprintf(t->temp, sizeof t->temp, "%.*s.%s.petblur-%ld-%u%s", dirlen, path, base, (long)getpid(),
                     attempt, ext) >= (int)sizeof t->temp)
            return pbc_fail(PBC_EXIT_USAGE, "%s: the output path is too long; choose a shorter one", path);
        /* Tracked before it exists, so that no signal falls between its
         * creation and its tracking; the name holds our pid, so a failed
         * O_EXCL finds only a stale file of ours. */
        track_temp(t->temp);
        int fd = open(t->temp, O_WRONLY | O_CREAT | O_EXCL, 0666);
        if (fd >= 0) {
            close(fd);
            return 0;
        }
        untrack_temp(t->temp);
        if (errno != EEXIST)
            return pbc_fail(PBC_EXIT_RUNTIME, "%s: cannot create a file in that folder (%s); check that the folder "
                            "exists and is writable", path, strerror(errno));
    }
    return pbc_fail(PBC_EXIT_RUNTIME, "%s: cannot find a free temporary name beside it; remove stale "
                    ".*.petblur-* files from that folder", path);
}

int pbc_temp_open(pbc_temp *t, const char *path, FILE **f)
{
    *f = NULL;
    int rc = pbc_temp_reserve(t, path);
    if (rc)
        return rc;
    *f = fopen(t->temp, "wb");
    if (!*f) {
        int e = errno;
        remove(t->temp);
        untrack_temp(t->temp);
        return pbc_fail(PBC_EXIT_RUNTIME, "%s: cannot write (%s)", path, strerror(e));
    }
    return 0;
}

int pbc_temp_commit(pbc_temp *t, FILE *f)
{
    if (f) {
        /* A full disk often shows only at the last flush or at close. */
        int bad = fflush(f) != 0 || ferror(f) || fsync(fileno(f)) != 0;
        int e = errno;
        if (fclose(f) != 0 && !bad) {
            bad = 1;
            e = errno;
        }
        if (bad) {
            remove(t->temp);
            untrack_temp(t->temp);
            return pbc_fail(PBC_EXIT_RUNTIME, "%s: writing failed (%s); nothing was written; free some space or "
                            "choose another folder", t->path, strerror(e));
        }
    }
    /* A replaced file keeps its permission bits. */
    struct stat old;
    if (stat(t->path, &old) == 0 && S_ISREG(old.st_mode))
        chmod(t->temp, old.st_mode & 07777);
    int moved = rename(t->temp, t->path);
    untrack_temp(t->temp);
    if (moved != 0) {
        int e = errno;
        remove(t->temp);
        return pbc_fail(PBC_EXIT_RUNTIME, "%s: cannot move the finished file into place (%s); nothing was written",
                        t->path, strerror(e));
    }
    return 0;
}

void pbc_temp_keep(pbc_temp *t)
{
    untrack_temp(t->temp);
}

void pbc_temp_abort(pbc_temp *t, FILE *f)
{
    if (f)
        fclose(f);
    remove(t->temp);
    untrack_temp(t->temp);
}

int pbc_same_file(const char *a, const char *b)
{
    if (!strcmp(a, b))
        return 1;
    struct stat sa, sb;
    return stat(a, &sa) == 0 && stat(b, &sb) == 0 && sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}
