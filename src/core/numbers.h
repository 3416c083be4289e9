/* The one grammar of numbers in petblur's text files, tracks (csv,
 * matrix-csv, Polaris .mt and Toolviewer CSV) and calibrations: every reader
 * in src/motion reads its numbers here, so that a file means one thing
 * wherever it is read (docs/motion.md, "Numbers in tracks and calibrations").
 *
 *   number   = [sign] (digits ["." [digits]] | "." digits) [("e" | "E") [sign] digits]
 *   whole    = [sign] digits, or digits alone where no sign is allowed
 *   sign     = "+" | "-"
 *
 * The whole token, nothing around it (the readers trim and split first), in
 * ASCII: no hex, inf, nan, blanks or thousands separators, and "." the
 * decimal point in every locale. A number that rounds beyond the largest
 * double is refused; one below the smallest is the nearest double (0 or a
 * subnormal), as every decimal reader takes it. */
#ifndef PB_NUMBERS_H
#define PB_NUMBERS_H

#include <stddef.h>

#include "petblur.h"

typedef enum {
    PB_NUMBER_OK = 0,
    PB_NUMBER_MALFORMED = 1, /* not a number of the grammar */
    PB_NUMBER_BEYOND = 2     /* a number beyond the largest double, or a whole one beyond its bound */
} pb_number_kind;

/* token as a number, correctly rounded (*v is set only when it is one). */
pb_number_kind pb_number_scan(const char *token, double *v);

/* The same, refused with "PATH:LINE: WHAT is 'TOKEN', not a number; ..." and
 * how to write it: PB_ERR_BAD_FILE, or PB_ERR_NOT_FINITE beyond double's
 * range. */
pb_status pb_number_read(const char *path, size_t line, const char *what, const char *token, double *v);

/* token as a whole number of magnitude at most max, signed or not; refused
 * as pb_number_read refuses (PB_ERR_BAD_FILE). */
pb_status pb_whole_read(const char *path, size_t line, const char *what, const char *token, int sign, long long max,
                        long long *v);

/* pb_number_text as a value: PB_NUM(v) is the text, alive until the end of
 * the full expression that holds it (a message's arguments). */
typedef struct pb_number_text_buf { char text[PB_NUMBER_TEXT_SIZE]; } pb_number_text_buf;
pb_number_text_buf pb_number_text_of(double v);
#define PB_NUM(v) (pb_number_text_of(v).text)

#endif
