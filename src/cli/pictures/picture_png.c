/* The canvas as a PNG through libpng, whole or not at all. */
#include <png.h>
#include <setjmp.h>
#include <stdio.h>

#include "atomic_file.h"
#include "cli.h"
#include "picture_canvas.h"

enum { PNG_MESSAGE_SIZE = 200 };

/* libpng would print its own message and abort the process if this returned;
 * keeping the text lets the caller say it the program's way. */
static void on_png_error(png_structp png, png_const_charp message)
{
    snprintf(png_get_error_ptr(png), PNG_MESSAGE_SIZE, "%s", message);
    png_longjmp(png, 1);
}

/* Warnings concern ancillary details that do not spoil the file; stderr stays
 * for the program's own messages. */
static void on_png_warning(png_structp png, png_const_charp message)
{
    (void)png;
    (void)message;
}

/* Returns 0, or -1 with libpng's reason in message. */
static int encode(FILE *f, const pbc_canvas *c, char message[PNG_MESSAGE_SIZE])
{
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, message, on_png_error, on_png_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!info) {
        png_destroy_write_struct(&png, NULL);
        snprintf(message, PNG_MESSAGE_SIZE, "out of memory");
        return -1;
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        return -1;
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, (png_uint_32)c->width, (png_uint_32)c->height, 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    for (int y = 0; y < c->height; y++)
        png_write_row(png, c->rgb + 3 * (size_t)y * (size_t)c->width);
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    return 0;
}

int pbc_canvas_write_png(const char *path, const pbc_canvas *c)
{
    pbc_temp temp;
    FILE *f;
    int rc = pbc_temp_open(&temp, path, &f);
    if (rc)
        return rc;
    char message[PNG_MESSAGE_SIZE] = "";
    if (encode(f, c, message) != 0) {
        pbc_temp_abort(&temp, f);
        return pbc_fail(PBC_EXIT_RUNTIME, "%s: cannot write the PNG (%s); nothing was written; check the free space "
                        "and the folder", path, message);
    }
    return pbc_temp_commit(&temp, f);
}
