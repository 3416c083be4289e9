/* The RGB raster that a picture is drawn into before it becomes a PNG. */
#ifndef PBC_PICTURE_CANVAS_H
#define PBC_PICTURE_CANVAS_H

#include <stddef.h>

typedef struct pbc_rgb {
    unsigned char r, g, b;
} pbc_rgb;

typedef struct pbc_canvas {
    unsigned char *rgb;  /* width*height pixels, 3 bytes each, rows top to bottom */
    int width, height;
} pbc_canvas;

static inline void pbc_canvas_put(pbc_canvas *c, int x, int y, pbc_rgb colour)
{
    if (x < 0 || y < 0 || x >= c->width || y >= c->height)
        return;
    unsigned char *p = c->rgb + 3 * ((size_t)y * (size_t)c->width + (size_t)x);
    p[0] = colour.r;
    p[1] = colour.g;
    p[2] = colour.b;
}

/* Clipped to the canvas, so that callers need not check their arithmetic
 * against its edges. */
static inline void pbc_canvas_fill(pbc_canvas *c, int x, int y, int w, int h, pbc_rgb colour)
{
    for (int j = y; j < y + h; j++)
        for (int i = x; i < x + w; i++)
            pbc_canvas_put(c, i, j, colour);
}

/* Writes the canvas to path as an 8-bit RGB PNG, atomically. Returns 0 or an
 * exit status after printing the message. */
int pbc_canvas_write_png(const char *path, const pbc_canvas *c);

#endif
