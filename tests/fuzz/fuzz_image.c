/* libFuzzer harness: one image reader on the bytes given. The first byte
 * picks the format (NIfTI, NIfTI gzipped by name only, Interfile with its data
 * file, raw) and, for raw, the grid; the rest is the file. A reader may refuse
 * anything, but must not crash, read out of bounds or run without end. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "fuzz_files.h"
#include "image_io.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1)
        return 0;
    static const char *const names[] = {"in.nii", "in.nii", "in.hv", "in.raw"};
    int kind = data[0] & 3;
    char dir[64], path[128], data_path[128];
    if (pbc_fuzz_dir(dir, sizeof dir))
        return 0;
    snprintf(path, sizeof path, "%s/%s", dir, names[kind]);
    const uint8_t *body = data + 1;
    size_t n = size - 1;
    if (kind == 2) {
        /* An Interfile header, then its data file after the first NUL. */
        const uint8_t *nul = memchr(body, 0, n);
        size_t head = nul ? (size_t)(nul - body) : n;
        snprintf(data_path, sizeof data_path, "%s/in.v", dir);
        pbc_fuzz_write(data_path, nul ? nul + 1 : body + n, nul ? n - head - 1 : 0);
        n = head;
    }
    pbc_fuzz_write(path, body, n);
    size_t dims[3] = {1u + (data[0] >> 2 & 3), 1u + (data[0] >> 4 & 3), 1u + (data[0] >> 6 & 3)};
    pbc_read_hints hints = {kind == 3 ? dims : NULL, NULL, data[0] & 0x10};
    pbc_image img = {0};
    if (pbc_image_read(path, &hints, &img) == 0)
        pbc_image_free(&img);
    pbc_fuzz_clean(dir);
    return 0;
}
