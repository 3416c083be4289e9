/* Control points of the colour maps and the interpolation between them. */
#include "picture_colormap.h"

/* magma sampled at 17 evenly spaced points: its lightness rises steadily, so
 * that equal steps of activity look like equal steps, in colour and in grey. */
static const pbc_rgb activity_points[] = {
    {0, 0, 4},       {10, 8, 34},     {29, 17, 70},    {54, 16, 106},   {80, 18, 124},   {105, 28, 129},
    {130, 38, 129},  {156, 46, 127},  {182, 55, 121},  {207, 65, 112},  {230, 81, 99},   {245, 105, 92},
    {251, 135, 97},  {254, 165, 113}, {254, 195, 135}, {253, 224, 162}, {252, 253, 191},
};

/* RdBu (11 classes) from dark blue to dark red: zero is the light middle, so
 * that only real differences catch the eye, and the two signs differ in hue. */
static const pbc_rgb signed_points[] = {
    {5, 48, 97},     {33, 102, 172},  {67, 147, 195},  {146, 197, 222}, {209, 229, 240}, {247, 247, 247},
    {253, 219, 199}, {244, 165, 130}, {214, 96, 77},   {178, 24, 43},   {103, 0, 31},
};

static unsigned char mix(unsigned char a, unsigned char b, double f)
{
    return (unsigned char)((1.0 - f) * a + f * b + 0.5);
}

pbc_rgb pbc_colormap_lookup(pbc_colormap map, double t)
{
    const pbc_rgb *points = map == PBC_COLORMAP_SIGNED ? signed_points : activity_points;
    int n = map == PBC_COLORMAP_SIGNED ? (int)(sizeof signed_points / sizeof *signed_points)
                                       : (int)(sizeof activity_points / sizeof *activity_points);
    if (!(t > 0.0))
        t = 0.0;
    if (t > 1.0)
        t = 1.0;
    double x = t * (n - 1);
    int i = (int)x < n - 1 ? (int)x : n - 2;
    double f = x - i;
    pbc_rgb a = points[i], b = points[i + 1];
    return (pbc_rgb){mix(a.r, b.r, f), mix(a.g, b.g, f), mix(a.b, b.b, f)};
}
