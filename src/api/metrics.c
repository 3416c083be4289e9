/* How far a volume is from a reference: relative RMS and max in percent (what
 * users measure), and the paper's eq. (5). */
#include <math.h>

#include "error.h"
#include "petblur.h"

pb_status pb_compare(const float *reference, const float *x, size_t n, pb_comparison *out)
{
    if (!reference || !x || !out || n == 0)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "pb_compare needs a reference, a volume, n > 0 and out");
    double num = 0.0, den = 0.0, maxdiff = 0.0, maxref = 0.0;
    size_t worst = 0;
    for (size_t i = 0; i < n; i++) {
        double r = (double)reference[i], v = (double)x[i], d = fabs(v - r);
        if (!isfinite(r) || !isfinite(v))
            return pb_error(NULL, PB_ERR_NOT_FINITE, "value %zu is %g in the reference and %g in the volume; compare "
                            "finite volumes", i, r, v);
        num += d * d;
        den += r * r;
        if (d > maxdiff) {
            maxdiff = d;
            worst = i;
        }
        maxref = fmax(maxref, fabs(r));
    }
    if (!(den > 0.0))
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "the reference is zero everywhere, so no relative error exists; "
                        "give a non-zero reference");
    out->rms_percent = 100.0 * sqrt(num / den);
    out->max_percent = 100.0 * maxdiff / maxref;
    out->max_difference = maxdiff;
    out->worst = worst;
    out->eq5_percent = 100.0 * num / den;
    return PB_OK;
}

double pb_error_percent(const float *reference, const float *x, size_t n)
{
    double num = 0.0, den = 0.0;
    if (!reference || !x)
        return (double)NAN;
    for (size_t i = 0; i < n; i++) {
        double d = (double)x[i] - (double)reference[i];
        num += d * d;
        den += (double)reference[i] * (double)reference[i];
    }
    return den > 0.0 ? 100.0 * num / den : (double)NAN;
}
