/* libFuzzer harness: the track readers (csv, matrix-csv, Polaris) on the bytes
 * given, the format told from the content or forced by the first byte, with
 * the time unit and quaternion order it also picks. */
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "fuzz_files.h"
#include "track.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1)
        return 0;
    char dir[64], path[128];
    if (pbc_fuzz_dir(dir, sizeof dir))
        return 0;
    snprintf(path, sizeof path, "%s/track.csv", dir);
    pbc_fuzz_write(path, data + 1, size - 1);
    pbc_track_read_options o = {(pbc_track_format)((data[0] & 3) - 1), (data[0] & 4) ? 1000.0 : 1.0, data[0] >> 3 & 1};
    pbc_track t;
    if (pbc_track_read(path, &o, &t) == 0)
        pbc_track_free(&t);
    pbc_fuzz_clean(dir);
    return 0;
}
