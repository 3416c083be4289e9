/* libFuzzer harness: the calibration reader (pb_calibration_read) on the
 * bytes given. A calibration read must be a rigid 4x4 of finite numbers
 * (pb_pose_from_matrix takes it, its last row 0 0 0 1); a refusal must name
 * the file. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz_files.h"
#include "petblur.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char dir[64], path[128];
    if (pbc_fuzz_dir(dir, sizeof dir))
        return 0;
    snprintf(path, sizeof path, "%s/cal.txt", dir);
    pbc_fuzz_write(path, data, size);
    double m[16];
    if (pb_calibration_read(path, m) == PB_OK) {
        pb_pose pose;
        for (int i = 0; i < 16; i++)
            if (!isfinite(m[i]))
                abort();
        if (pb_pose_from_matrix(m, &pose) != PB_OK || fabs(m[15] - 1.0) > 1e-4)
            abort();
    } else if (strncmp(pb_last_error(NULL), path, strlen(path))) {
        abort();
    }
    pbc_fuzz_clean(dir);
    return 0;
}
