/* A built-in bitmap font for the labels of pictures, so that writing a PNG
 * needs no font library: printable ASCII, 5x7 capitals with 2-row descenders
 * in a 6-pixel advance, each font pixel drawn as scale x scale. */
#ifndef PBC_PICTURE_FONT_H
#define PBC_PICTURE_FONT_H

#include "picture_canvas.h"

enum {
    PBC_FONT_ADVANCE = 6,   /* font pixels from one character to the next */
    PBC_FONT_CAP_HEIGHT = 7,
    PBC_FONT_HEIGHT = 9     /* capitals and descenders */
};

/* Width in canvas pixels of text drawn at scale, without trailing spacing. */
int pbc_font_text_width(const char *text, int scale);

/* Draws text with the top of its capitals at y. Characters outside printable
 * ASCII (UTF-8 bytes included) are drawn as '?'. */
void pbc_font_draw(pbc_canvas *c, int x, int y, const char *text, int scale, pbc_rgb colour);

#endif
