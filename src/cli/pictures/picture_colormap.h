/* The colour maps of pictures: a perceptual sequential map for activity and a
 * diverging one for differences, both by interpolation between control points. */
#ifndef PBC_PICTURE_COLORMAP_H
#define PBC_PICTURE_COLORMAP_H

#include "picture_canvas.h"

typedef enum pbc_colormap {
    PBC_COLORMAP_ACTIVITY,  /* matplotlib's "magma": black, purple, orange, pale yellow */
    PBC_COLORMAP_SIGNED     /* ColorBrewer's RdBu reversed: blue below, white at 0.5, red above */
} pbc_colormap;

/* The colour at t in [0, 1] (clamped; NaN reads as 0). */
pbc_rgb pbc_colormap_lookup(pbc_colormap map, double t);

#endif
