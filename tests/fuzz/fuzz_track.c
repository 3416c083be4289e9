/* libFuzzer harness: the track readers (csv, matrix-csv, Polaris) on the bytes
 * given, the format told from the content or forced by the first byte, with
 * the time unit and quaternion order it also picks. A track read must keep
 * the API's promises (at least two poses, times finite and strictly
 * increasing, unit quaternions); a refusal must leave no track and a message. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz_files.h"
#include "petblur.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check_track(const pb_track *t)
{
    size_t n = pb_track_count(t);
    const double *times = pb_track_times(t);
    const pb_pose *poses = pb_track_poses(t);
    if (n < 2 || pb_track_get_format(t) == PB_TRACK_AUTO || !pb_track_lines(t) || !pb_track_missing(t))
        abort();
    for (size_t i = 0; i < n; i++) {
        const double *q = poses[i].rotation, *tr = poses[i].translation;
        double norm = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
        if (!isfinite(times[i]) || (i > 0 && !(times[i] > times[i - 1])) || !(fabs(norm - 1.0) <= 1e-3) ||
            !isfinite(tr[0]) || !isfinite(tr[1]) || !isfinite(tr[2]))
            abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1)
        return 0;
    char dir[64], path[128];
    if (pbc_fuzz_dir(dir, sizeof dir))
        return 0;
    snprintf(path, sizeof path, "%s/track.csv", dir);
    pbc_fuzz_write(path, data + 1, size - 1);
    pb_track_read_options o = {(pb_track_format)(data[0] & 3), (data[0] & 4) ? 1000.0 : 1.0, data[0] >> 3 & 1};
    pb_track *t = (pb_track *)&o; /* must come back NULL on a refusal */
    if (pb_track_read(path, &o, &t) == PB_OK)
        check_track(t);
    else if (t || !*pb_last_error(NULL))
        abort();
    pb_track_free(t);
    pbc_fuzz_clean(dir);
    return 0;
}
