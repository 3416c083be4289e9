/* Files for the harnesses: a private folder per process, each input written
 * into it and the folder emptied after. */
#ifndef PBC_FUZZ_FILES_H
#define PBC_FUZZ_FILES_H

#include <stddef.h>
#include <stdint.h>

int pbc_fuzz_dir(char *dir, size_t size);
void pbc_fuzz_write(const char *path, const uint8_t *data, size_t size);
void pbc_fuzz_clean(const char *dir);

#endif
