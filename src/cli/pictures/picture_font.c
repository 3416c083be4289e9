/* The glyphs of the picture font and the drawing of text with them. */
#include <stdint.h>
#include <string.h>

#include "picture_font.h"

/* One glyph per printable ASCII character from ' ' (0x20) to '~' (0x7e). Font
 * row r (0 at the top, 7 and 8 for descenders) is bits 5r to 5r+4, the
 * leftmost column in the highest of the five. */
static const uint64_t glyphs[95] = {
    0x000000000000, 0x000100421084, 0x00000000014a, 0x000295f57d4a, 0x00013c5751e4, /*   ! " # $ */
    0x0000e6820b38, 0x00036554524c, 0x000000002084, 0x000088842082, 0x000208210888, /* % & ' ( ) */
    0x000009575480, 0x0000084f9080, 0x004118000000, 0x0000000f8000, 0x000318000000, /* * + , - . */
    0x000020820820, 0x0003a39ace2e, 0x000388421184, 0x0007d041062e, 0x0003a211105f, /* / 0 1 2 3 */
    0x000085f928c2, 0x0003a210fa1f, 0x0003a31f4106, 0x00021082083f, 0x0003a317462e, /* 4 5 6 7 8 */
    0x00030417c62e, 0x000018c03180, 0x000208c03180, 0x000088882082, 0x000001f07c00, /* 9 : ; < = */
    0x000208208888, 0x00010041062e, 0x0003ab56862e, 0x0004631fc62e, 0x0007a31f463e, /* > ? @ A B */
    0x0003a308422e, 0x00072518c65c, 0x0007e10f421f, 0x0004210f421f, 0x0003e31bc22e, /* C D E F G */
    0x0004631fc631, 0x00038842108e, 0x000324210847, 0x0004654c5251, 0x0007e1084210, /* H I J K L */
    0x0004631ad771, 0x0004633ae631, 0x0003a318c62e, 0x0004210f463e, 0x00036558c62e, /* M N O P Q */
    0x0004654f463e, 0x00078217420f, 0x00010842109f, 0x0003a318c631, 0x00011518c631, /* R S T U V */
    0x0002ab5ac631, 0x000462a22a31, 0x000108422a31, 0x0007e082083f, 0x00039084210e, /* W X Y Z [ */
    0x000002222200, 0x00038421084e, 0x000000004544, 0x00f800000000, 0x000000000088, /* \ ] ^ _ ` */
    0x0003e2f0b800, 0x0007a31cda10, 0x0003a3083800, 0x0003e319b421, 0x0003a1f8b800, /* a b c d e */
    0x0002108e2126, 0x0e0be318bc00, 0x0004631cda10, 0x000388423004, 0x0c9084211802, /* f g h i j */
    0x0004a98a4a10, 0x00038842108c, 0x00056b5ae800, 0x0004631cd800, 0x0003a318b800, /* k l m n o */
    0x1087a318f800, 0x010be318bc00, 0x0004210cd800, 0x000782e83c00, 0x000192847108, /* p q r s t */
    0x00036718c400, 0x00011518c400, 0x0002ab58c400, 0x000454454400, 0x0e0be318c400, /* u v w x y */
    0x0007d0417c00, 0x000088441082, 0x002108421084, 0x000208411088, 0x0000002aa000, /* z { | } ~ */
};

int pbc_font_text_width(const char *text, int scale)
{
    size_t n = strlen(text);
    return n ? ((int)n * PBC_FONT_ADVANCE - 1) * scale : 0;
}

static void draw_glyph(pbc_canvas *c, int x, int y, unsigned char ch, int scale, pbc_rgb colour)
{
    uint64_t bits = glyphs[(ch >= 0x20 && ch <= 0x7e ? ch : '?') - 0x20];
    for (int row = 0; row < PBC_FONT_HEIGHT; row++)
        for (int col = 0; col < 5; col++)
            if (bits >> (5 * row + 4 - col) & 1)
                pbc_canvas_fill(c, x + col * scale, y + row * scale, scale, scale, colour);
}

void pbc_font_draw(pbc_canvas *c, int x, int y, const char *text, int scale, pbc_rgb colour)
{
    for (; *text; text++, x += PBC_FONT_ADVANCE * scale)
        draw_glyph(c, x, y, (unsigned char)*text, scale, colour);
}
