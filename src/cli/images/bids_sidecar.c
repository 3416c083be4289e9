/* Frames from a BIDS-PET sidecar (--frames-from): the library's reader, its
 * message under the option's name. */
#include <stdlib.h>

#include "cli.h"
#include "commands.h"
#include "petblur.h"

int pbc_bids_frames(const char *path, double **bounds, size_t *count)
{
    size_t frames = 0;
    *bounds = NULL;
    pb_status st = pb_frames_read_sidecar(path, NULL, 0, &frames);
    if (st == PB_OK && !(*bounds = malloc((frames + 1) * sizeof **bounds)))
        return pbc_fail(PBC_EXIT_RUNTIME, "out of memory reading %s", path);
    if (st == PB_OK)
        st = pb_frames_read_sidecar(path, *bounds, frames + 1, &frames);
    if (st != PB_OK) {
        free(*bounds);
        *bounds = NULL;
        return pbc_fail(st == PB_ERR_OUT_OF_MEMORY ? PBC_EXIT_RUNTIME : PBC_EXIT_USAGE, "--frames-from %s",
                        pb_last_error(NULL));
    }
    *count = frames + 1;
    return 0;
}
