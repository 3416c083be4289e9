/* A picture of a pose track: how far the grid's centre moves and how far the
 * grid turns against time, with the frames' boundaries. */
#ifndef PBC_MOTION_PLOT_H
#define PBC_MOTION_PLOT_H

#include "motion_args.h"

/* Writes path (PNG) for a placed motion; bounds: count frame boundaries
 * (seconds) to mark. Returns 0 or an exit status after the message. */
int pbc_motion_plot(const char *path, const pbc_motion *m, const double *bounds, size_t count);

#endif
