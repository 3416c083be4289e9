/* Numbers in petblur's text files, by the one grammar of numbers.h. The
 * grammar is checked here, byte by byte; strtod only rounds what passed,
 * under the C locale of the calling thread (uselocale), so that a program
 * that set LC_NUMERIC to a locale with a decimal comma reads "1.5" as 1.5. */
#include <locale.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"
#include "numbers.h"

/* A token in a message: at most 40 bytes, other than printable ASCII as \xNN. */
#define SHOWN 40

static locale_t c_numeric;
static pthread_once_t c_numeric_once = PTHREAD_ONCE_INIT;

static void make_c_numeric(void)
{
    c_numeric = newlocale(LC_NUMERIC_MASK, "C", (locale_t)0);
}

static int digit(char c)
{
    return c >= '0' && c <= '9';
}

/* The number of digits at s. */
static size_t digits(const char *s)
{
    size_t n = 0;
    while (digit(s[n]))
        n++;
    return n;
}

/* Whether the whole token follows the grammar of a number. */
static int is_number(const char *s)
{
    s += *s == '+' || *s == '-';
    size_t whole = digits(s);
    s += whole;
    size_t fraction = 0;
    if (*s == '.') {
        fraction = digits(s + 1);
        s += 1 + fraction;
    }
    if (whole + fraction == 0)
        return 0;
    if (*s == 'e' || *s == 'E') {
        s++;
        s += *s == '+' || *s == '-';
        size_t exponent = digits(s);
        if (exponent == 0)
            return 0;
        s += exponent;
    }
    return *s == '\0';
}

pb_number_kind pb_number_scan(const char *token, double *v)
{
    if (!is_number(token))
        return PB_NUMBER_MALFORMED;
    pthread_once(&c_numeric_once, make_c_numeric);
    /* Without the C locale object (no memory for it) the thread's own is
     * used: right wherever LC_NUMERIC is "C", as it is unless a program set it. */
    locale_t previous = c_numeric ? uselocale(c_numeric) : (locale_t)0;
    char *end;
    double x = strtod(token, &end);
    if (previous)
        uselocale(previous);
    if (*end) /* a decimal comma's locale stopped strtod at the point */
        return PB_NUMBER_MALFORMED;
    if (isinf(x))
        return PB_NUMBER_BEYOND;
    *v = x;
    return PB_NUMBER_OK;
}

const char *pb_number_text(double v, char *out)
{
    pthread_once(&c_numeric_once, make_c_numeric);
    locale_t previous = c_numeric ? uselocale(c_numeric) : (locale_t)0;
    /* Whole parts up to 17 digits in full: "10000", not "1e+04". */
    int first = isfinite(v) && fabs(v) >= 1.0 && fabs(v) < 1e17 ? (int)floor(log10(fabs(v))) + 1 : 1;
    if (first > 17) /* log10 rounds up to 17 just below 1e17 */
        first = 17;
    for (int digits = first; digits <= 17; digits++) {
        snprintf(out, PB_NUMBER_TEXT_SIZE, "%.*g", digits, v);
        if (!isfinite(v) || strtod(out, NULL) == v)
            break;
    }
    if (previous)
        uselocale(previous);
    return out;
}

pb_number_text_buf pb_number_text_of(double v)
{
    pb_number_text_buf t;
    pb_number_text(v, t.text);
    return t;
}

/* token as a message shows it (see SHOWN). */
static const char *shown(const char *token, char *out, size_t size)
{
    size_t n = 0, i = 0;
    for (; token[i] && i < SHOWN && n + 5 < size; i++) {
        unsigned char c = (unsigned char)token[i];
        if (c >= 0x20 && c < 0x7f)
            out[n++] = (char)c;
        else
            n += (size_t)snprintf(out + n, size - n, "\\x%02X", c);
    }
    out[n] = '\0';
    if (token[i] && n + 4 < size)
        strcpy(out + n, "...");
    return out;
}

pb_status pb_number_read(const char *path, size_t line, const char *what, const char *token, double *v)
{
    char text[4 * SHOWN + 8];
    switch (pb_number_scan(token, v)) {
    case PB_NUMBER_OK:
        return PB_OK;
    case PB_NUMBER_BEYOND:
        return pb_error(NULL, PB_ERR_NOT_FINITE, "%s:%zu: %s is '%s', beyond the largest double (about 1.8e308), "
                        "larger than any time, translation or rotation; fix it", path, line, what,
                        shown(token, text, sizeof text));
    default:
        if (!*token)
            return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: %s is empty; write its number there", path, line, what);
        return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: %s is '%s', not a number; write it as a plain decimal such "
                        "as -1.5e-3 (no hex, inf, nan, blanks or thousands separators; '.' the decimal point)", path,
                        line, what, shown(token, text, sizeof text));
    }
}

pb_status pb_whole_read(const char *path, size_t line, const char *what, const char *token, int sign, long long max,
                        long long *v)
{
    char text[4 * SHOWN + 8];
    const char *s = token + (sign && (*token == '+' || *token == '-'));
    size_t n = digits(s);
    if (n == 0 || s[n])
        return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: %s is '%s', not a whole number; write digits%s, such as 42",
                        path, line, what, shown(token, text, sizeof text), sign ? " with an optional sign" : " alone");
    long long x = 0; /* at most max: 10 x + d cannot overflow */
    for (size_t i = 0; i < n; i++) {
        if (10 * x > max - (s[i] - '0'))
            return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: %s is '%s', beyond %lld; fix it", path, line, what,
                            shown(token, text, sizeof text), max);
        x = 10 * x + (s[i] - '0');
    }
    *v = *token == '-' ? -x : x;
    return PB_OK;
}
