/* Two panels over one time axis: the displacement of the grid's centre along
 * the world's axes (mm) and the grid's rotation from its first pose (degrees). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "cli.h"
#include "image_io.h"
#include "motion_plot.h"
#include "picture_canvas.h"
#include "picture_font.h"

enum { WIDTH = 960, PANEL = 240, LEFT = 90, RIGHT = 20, TOP = 34, GAP = 56, SCALE = 2 };

static const pbc_rgb white = {255, 255, 255}, black = {0, 0, 0}, grey = {170, 170, 170},
                     axis_colour[3] = {{214, 39, 40}, {44, 160, 44}, {31, 119, 180}};

typedef struct panel {
    int top;
    double lo, hi;
} panel;

static void line(pbc_canvas *c, int x0, int y0, int x1, int y1, pbc_rgb colour)
{
    int dx = abs(x1 - x0), dy = -abs(y1 - y0), sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1, err = dx + dy;
    for (;;) {
        pbc_canvas_fill(c, x0, y0, 2, 2, colour);
        if (x0 == x1 && y0 == y1)
            return;
        int e2 = 2 * err;
        if (e2 >= dy) {
            err += dy;
            x0 += sx;
        }
        if (e2 <= dx) {
            err += dx;
            y0 += sy;
        }
    }
}

static int to_y(const panel *p, double v)
{
    return p->top + PANEL - (int)lround((v - p->lo) / (p->hi - p->lo) * PANEL);
}

static void label(pbc_canvas *c, int x, int y, double v, const char *unit)
{
    char text[48];
    snprintf(text, sizeof text, "%.6g%s", v, unit);
    pbc_font_draw(c, x, y, text, SCALE, black);
}

static void frame_panel(pbc_canvas *c, const panel *p, const char *title, double t0, double t1, const double *bounds,
                        size_t count)
{
    int x0 = LEFT, x1 = WIDTH - RIGHT;
    for (size_t i = 0; i < count; i++) {
        int x = x0 + (int)lround((bounds[i] - t0) / (t1 - t0) * (x1 - x0));
        pbc_canvas_fill(c, x, p->top, 1, PANEL, grey);
    }
    pbc_canvas_fill(c, x0, p->top, x1 - x0, 1, black);
    pbc_canvas_fill(c, x0, p->top + PANEL, x1 - x0, 1, black);
    pbc_canvas_fill(c, x0, p->top, 1, PANEL, black);
    pbc_canvas_fill(c, x1, p->top, 1, PANEL, black);
    if (p->lo < 0 && p->hi > 0)
        pbc_canvas_fill(c, x0, to_y(p, 0.0), x1 - x0, 1, grey);
    pbc_font_draw(c, x0, p->top - 24, title, SCALE, black);
    label(c, 4, p->top, p->hi, "");
    label(c, 4, p->top + PANEL - 14, p->lo, "");
}

int pbc_motion_plot(const char *path, const pbc_motion *m, const double *bounds, size_t count)
{
    const pb_motion *mo = &m->motion;
    size_t n = mo->count;
    double *v = malloc(4 * n * sizeof *v);
    pb_pose *world = malloc(n * sizeof *world);
    pb_motion wm;
    if (!v || !world) {
        free(v);
        free(world);
        return pbc_fail(PBC_EXIT_RUNTIME, "out of memory for the picture of %zu poses", n);
    }
    /* The poses in the world, about wm.center, as placing made them. */
    pb_track_world(m->track, &m->conventions, &m->geometry, m->affine, world, &wm, NULL);
    double c[3]; /* the grid's centre, world mm */
    pbc_grid_center(m->affine, m->geometry.dims, c);
    panel pt = {TOP + 20, (double)INFINITY, -(double)INFINITY}, pr = {TOP + 20 + PANEL + GAP, 0.0, -(double)INFINITY};
    for (size_t k = 0; k < n; k++) {
        double moved[3];
        pb_pose_apply(&world[k], wm.center, c, moved); /* where the grid's centre goes */
        for (int i = 0; i < 3; i++) {
            v[4 * k + i] = moved[i] - c[i];
            pt.lo = fmin(pt.lo, v[4 * k + i]);
            pt.hi = fmax(pt.hi, v[4 * k + i]);
        }
        v[4 * k + 3] = pb_pose_turn_deg(&world[0], &world[k]);
        pr.hi = fmax(pr.hi, v[4 * k + 3]);
    }
    free(world);
    /* Flat curves still get a visible range. */
    if (pt.hi - pt.lo < 1e-3) {
        pt.lo -= 0.5;
        pt.hi += 0.5;
    }
    pr.hi = fmax(pr.hi, 1e-3) * 1.05;
    double span = 0.05 * (pt.hi - pt.lo);
    pt.lo -= span;
    pt.hi += span;
    pbc_canvas canvas = {NULL, WIDTH, pr.top + PANEL + 40};
    canvas.rgb = malloc((size_t)canvas.width * (size_t)canvas.height * 3);
    if (!canvas.rgb) {
        free(v);
        return pbc_fail(PBC_EXIT_RUNTIME, "out of memory for the picture");
    }
    pbc_canvas_fill(&canvas, 0, 0, canvas.width, canvas.height, white);
    double t0 = mo->times[0], t1 = mo->times[n - 1];
    frame_panel(&canvas, &pt, "grid centre's displacement, world mm: x red, y green, z blue", t0, t1, bounds,
                count);
    frame_panel(&canvas, &pr, "rotation from the first pose, degrees; grey: frame boundaries", t0, t1, bounds, count);
    label(&canvas, LEFT, pr.top + PANEL + 8, t0, " s");
    label(&canvas, WIDTH - RIGHT - 160, pr.top + PANEL + 8, t1, " s");
    int x0 = LEFT, x1 = WIDTH - RIGHT;
    for (size_t k = 1; k < n; k++) {
        int xa = x0 + (int)lround((mo->times[k - 1] - t0) / (t1 - t0) * (x1 - x0));
        int xb = x0 + (int)lround((mo->times[k] - t0) / (t1 - t0) * (x1 - x0));
        for (int i = 0; i < 3; i++)
            line(&canvas, xa, to_y(&pt, v[4 * (k - 1) + i]), xb, to_y(&pt, v[4 * k + i]), axis_colour[i]);
        line(&canvas, xa, to_y(&pr, v[4 * (k - 1) + 3]), xb, to_y(&pr, v[4 * k + 3]), black);
    }
    int rc = pbc_canvas_write_png(path, &canvas);
    free(canvas.rgb);
    free(v);
    return rc;
}
