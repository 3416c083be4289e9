/* The harnesses' numbers, taken from the input's bytes in order: what is
 * left too short for one reads as 0, so every input is some case. */
#ifndef PBC_FUZZ_BYTES_H
#define PBC_FUZZ_BYTES_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

/* The next double's bytes as they lie (NaN, infinities and subnormals
 * included). */
static inline double pbc_fuzz_take(const uint8_t **p, size_t *n)
{
    double v = 0.0;
    if (*n >= sizeof v) {
        memcpy(&v, *p, sizeof v);
        *p += sizeof v;
        *n -= sizeof v;
    }
    return v;
}

#endif
