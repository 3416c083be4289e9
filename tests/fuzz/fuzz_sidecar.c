/* libFuzzer harness: the BIDS-PET sidecar reader (pb_frames_read_sidecar) on
 * the bytes given. Frames read must keep the API's promises (at least one,
 * bounds finite and increasing, the same count asked twice, a capacity too
 * small refused); a refusal must name the file and report no frames. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz_files.h"
#include "petblur.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check_frames(const char *path, size_t frames)
{
    double *bounds = malloc((frames + 1) * sizeof *bounds);
    size_t again = 0;
    if (!bounds || pb_frames_read_sidecar(path, bounds, frames + 1, &again) != PB_OK || again != frames)
        abort();
    for (size_t i = 0; i <= frames; i++)
        if (!isfinite(bounds[i]) || (i > 0 && !(bounds[i] > bounds[i - 1])))
            abort();
    if (pb_frames_read_sidecar(path, bounds, frames, &again) != PB_ERR_INVALID_ARGUMENT)
        abort();
    free(bounds);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char dir[64], path[128];
    if (pbc_fuzz_dir(dir, sizeof dir))
        return 0;
    snprintf(path, sizeof path, "%s/sub-01_pet.json", dir);
    pbc_fuzz_write(path, data, size);
    size_t frames = 12345;
    if (pb_frames_read_sidecar(path, NULL, 0, &frames) == PB_OK) {
        if (frames == 0)
            abort();
        check_frames(path, frames);
    } else if (frames != 0 || strncmp(pb_last_error(NULL), path, strlen(path))) {
        abort();
    }
    pbc_fuzz_clean(dir);
    return 0;
}
