#define _XOPEN_SOURCE 700

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "fuzz_files.h"

int pbc_fuzz_dir(char *dir, size_t size)
{
    static char made[64];
    if (!made[0]) {
        snprintf(made, sizeof made, "/tmp/petblur-fuzz-XXXXXX");
        if (!mkdtemp(made))
            return -1;
    }
    snprintf(dir, size, "%s", made);
    return 0;
}

void pbc_fuzz_write(const char *path, const uint8_t *data, size_t size)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        abort();
    if (size && fwrite(data, 1, size, f) != size)
        abort();
    fclose(f);
}

void pbc_fuzz_clean(const char *dir)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    char path[512];
    while (d && (e = readdir(d)))
        if (e->d_name[0] != '.' || (e->d_name[1] && strcmp(e->d_name, "..")))
            if (snprintf(path, sizeof path, "%s/%s", dir, e->d_name) < (int)sizeof path)
                remove(path);
    if (d)
        closedir(d);
}
