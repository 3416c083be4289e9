/* The paper's error measure, eq. (5). */
#include <math.h>

#include "petblur.h"

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
