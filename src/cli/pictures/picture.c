/* Pictures of volumes: the layout of rows, panels, titles and colour bars, and
 * the drawing of the central slices into it. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "picture.h"
#include "picture_canvas.h"
#include "picture_colormap.h"
#include "picture_font.h"

enum {
    TEXT_SCALE = 2,
    TEXT_HEIGHT = PBC_FONT_HEIGHT * TEXT_SCALE,
    CAP_HEIGHT = PBC_FONT_CAP_HEIGHT * TEXT_SCALE,
    MARGIN = 20,
    PANEL_GAP = 12,           /* between the panels of a row, and between rows */
    TITLE_GAP = 20,           /* between a row's title and its first panel */
    LABEL_GAP = 6,            /* between a panel's label and the panel */
    BAR_GAP = 28,             /* between the panels and a colour bar, and between two bars */
    BAR_WIDTH = 20,
    TICK_LENGTH = 5,
    TICK_GAP = 5,             /* between a tick and its label */
    BAR_INSET = CAP_HEIGHT / 2 + 3, /* keeps a bar's end labels inside its rows */
    MIN_ROW_HEIGHT = 100,     /* room for a colour bar's three labels */
    TITLE_CHARS = 24,         /* longer row titles are shortened */
    LABEL_CHARS = 32,
    MIN_FIELD_PIXELS = 256,   /* the largest extent of the field of view; small volumes are enlarged to it */
    MAX_FIELD_PIXELS = 512    /* ... and large ones shown at one voxel per pixel up to this */
};

static const pbc_rgb background = {255, 255, 255};
static const pbc_rgb ink = {34, 34, 34};
static const pbc_rgb frame_grey = {150, 150, 150};
/* In neither colour map, so that a NaN or infinite voxel cannot pass for a value. */
static const pbc_rgb not_finite = {0, 200, 0};

/* Which axes a view shows (0 x, 1 y, 2 z): u runs to the right, v downwards,
 * or upwards when v_up; the slice is the central one, index n/2 from 0, of the
 * third axis. Axial shows x right and y down, which is how a volume stored in
 * DICOM's LPS order appears in a radiological viewer (the patient's left on
 * the right, anterior at the top); coronal and sagittal put z up, and sagittal
 * puts y right (LPS: anterior on the left). Volumes stored in other orders are
 * drawn the same way in voxel terms. */
typedef struct view {
    const char *name;
    int u, v, fixed, v_up;
} view;

static const view views[3] = {
    {"axial", 0, 1, 2, 0},
    {"coronal", 0, 2, 1, 1},
    {"sagittal", 1, 2, 0, 1},
};

typedef struct colour_bar {
    pbc_colormap map;
    double lo, hi;                 /* the values at the bottom and the top */
    int first_row, last_row;       /* the rows drawn on its scale; first_row -1 when none */
    char labels[3][LABEL_CHARS];   /* top, middle, bottom */
    int x, top, height;
} colour_bar;

typedef struct box {
    int x, y, w, h;
} box;

typedef struct layout {
    int panel_w[3], panel_h[3];
    int column_x[3], column_w[3];  /* a column is as wide as its panel or its label, whichever is wider */
    char panel_labels[3][LABEL_CHARS];
    int rows_top, row_h;
    int width, height;
    int legend_y;                  /* the line that explains the not-finite colour; -1 when not needed */
} layout;

static int max_int(int a, int b)
{
    return a > b ? a : b;
}

static int validate(const char *path, const pbc_picture *p)
{
    if (!p->rows || p->row_count < 1 || p->row_count > 12)
        return pbc_fail(PBC_EXIT_USAGE, "%s: a picture shows 1 to 12 volumes, not %d", path, p->row_count);
    const size_t *d = p->dims;
    if (!d[0] || !d[1] || !d[2] || d[1] > SIZE_MAX / d[0] || d[2] > SIZE_MAX / (d[0] * d[1]))
        return pbc_fail(PBC_EXIT_USAGE, "%s: cannot draw a volume of %zu x %zu x %zu voxels; check its dimensions",
                        path, d[0], d[1], d[2]);
    for (int a = 0; a < 3; a++)
        if (!(p->voxel_size[a] > 0.0) || !isfinite(p->voxel_size[a] * (double)d[a]))
            return pbc_fail(PBC_EXIT_USAGE, "%s: voxel sizes must be positive and finite, not %g x %g x %g mm; "
                            "check the header or --voxel-size", path, p->voxel_size[0], p->voxel_size[1],
                            p->voxel_size[2]);
    for (int r = 0; r < p->row_count; r++)
        if (!p->rows[r].data)
            return pbc_fail(PBC_EXIT_USAGE, "%s: row %d of the picture has no volume", path, r + 1);
    return 0;
}

static void format_value(char out[LABEL_CHARS], double v, int with_plus)
{
    /* v == 0 turns -0 into 0, which would print as "-0". */
    snprintf(out, LABEL_CHARS, "%s%.3g", with_plus && v > 0 ? "+" : "", v == 0 ? 0.0 : v);
}

/* Widens [lo, hi] to the volume's finite values; returns 1 when it has others. */
static int widen_range(const float *data, size_t n, double *lo, double *hi)
{
    int odd = 0;
    for (size_t i = 0; i < n; i++) {
        if (!isfinite(data[i])) {
            odd = 1;
            continue;
        }
        *lo = fmin(*lo, (double)data[i]);
        *hi = fmax(*hi, (double)data[i]);
    }
    return odd;
}

/* Activity rows share one scale from min(0, smallest) to max(0, largest), so
 * that they compare at a glance; signed rows share one symmetric about zero.
 * Returns 1 when some voxel is NaN or infinite. */
static int set_scales(const pbc_picture *p, colour_bar bars[2])
{
    size_t n = p->dims[0] * p->dims[1] * p->dims[2];
    int odd = 0;
    for (int b = 0; b < 2; b++)
        bars[b] = (colour_bar){.map = b ? PBC_COLORMAP_SIGNED : PBC_COLORMAP_ACTIVITY, .first_row = -1};
    for (int r = 0; r < p->row_count; r++) {
        colour_bar *bar = &bars[p->rows[r].signed_map ? 1 : 0];
        odd |= widen_range(p->rows[r].data, n, &bar->lo, &bar->hi);
        if (bar->first_row < 0)
            bar->first_row = r;
        bar->last_row = r;
    }
    double extreme = fmax(-bars[1].lo, bars[1].hi);
    bars[1].lo = -extreme;
    bars[1].hi = extreme;
    for (int b = 0; b < 2; b++) {
        int with_plus = bars[b].map == PBC_COLORMAP_SIGNED;
        format_value(bars[b].labels[0], bars[b].hi, with_plus);
        format_value(bars[b].labels[1], (bars[b].lo + bars[b].hi) / 2, with_plus);
        format_value(bars[b].labels[2], bars[b].lo, with_plus);
    }
    return odd;
}

static int to_pixels(double x)
{
    return x < 1.0 ? 1 : (int)(x + 0.5);
}

/* One pixel scale for all panels, so that every slice keeps its true aspect
 * ratio and the three views match in size. */
static void size_panels(const pbc_picture *p, layout *l)
{
    double field[3], largest = 0.0, most = 0.0;
    for (int a = 0; a < 3; a++) {
        field[a] = (double)p->dims[a] * p->voxel_size[a];
        largest = fmax(largest, field[a]);
        most = fmax(most, (double)p->dims[a]);
    }
    double pixels = fmin(fmax(most, MIN_FIELD_PIXELS), MAX_FIELD_PIXELS);
    for (int k = 0; k < 3; k++) {
        l->panel_w[k] = to_pixels(field[views[k].u] / largest * pixels);
        l->panel_h[k] = to_pixels(field[views[k].v] / largest * pixels);
        snprintf(l->panel_labels[k], LABEL_CHARS, "%s %c=%zu", views[k].name, "xyz"[views[k].fixed],
                 p->dims[views[k].fixed] / 2);
    }
}

static void shorten_title(char out[TITLE_CHARS + 1], const char *title)
{
    snprintf(out, TITLE_CHARS + 1, "%s", title ? title : "");
    if (title && strlen(title) > TITLE_CHARS)
        memcpy(out + TITLE_CHARS - 2, "..", 2);
}

static int bar_column_width(const colour_bar *bar)
{
    int w = 0;
    for (int i = 0; i < 3; i++)
        w = max_int(w, pbc_font_text_width(bar->labels[i], TEXT_SCALE));
    return BAR_WIDTH + TICK_LENGTH + TICK_GAP + w;
}

static int row_top(const layout *l, int r)
{
    return l->rows_top + r * (l->row_h + PANEL_GAP);
}

/* Each bar spans the rows drawn on its scale; when those of the two bars
 * interleave, the second bar moves beside the first instead of over it. */
static int place_bars(const layout *l, colour_bar bars[2], int x)
{
    int right = x;
    for (int b = 0; b < 2; b++) {
        colour_bar *bar = &bars[b];
        if (bar->first_row < 0)
            continue;
        int beside = b == 1 && bars[0].first_row >= 0 && bars[0].first_row <= bar->last_row &&
                     bar->first_row <= bars[0].last_row;
        bar->x = beside ? right + BAR_GAP : x;
        bar->top = row_top(l, bar->first_row) + BAR_INSET;
        bar->height = row_top(l, bar->last_row) + l->row_h - BAR_INSET - bar->top;
        right = max_int(right, bar->x + bar_column_width(bar));
    }
    return right;
}

static void plan_layout(const pbc_picture *p, colour_bar bars[2], int odd, layout *l)
{
    size_panels(p, l);
    int title_w = 0;
    for (int r = 0; r < p->row_count; r++) {
        char title[TITLE_CHARS + 1];
        shorten_title(title, p->rows[r].title);
        title_w = max_int(title_w, pbc_font_text_width(title, TEXT_SCALE));
    }
    int x = MARGIN + (title_w ? title_w + TITLE_GAP : 0);
    l->row_h = MIN_ROW_HEIGHT;
    for (int k = 0; k < 3; k++) {
        l->column_x[k] = x;
        l->column_w[k] = max_int(l->panel_w[k], pbc_font_text_width(l->panel_labels[k], TEXT_SCALE));
        x += l->column_w[k] + PANEL_GAP;
        l->row_h = max_int(l->row_h, l->panel_h[k]);
    }
    l->rows_top = MARGIN + TEXT_HEIGHT + LABEL_GAP;
    l->width = place_bars(l, bars, x - PANEL_GAP + BAR_GAP) + MARGIN;
    int bottom = row_top(l, p->row_count - 1) + l->row_h;
    l->legend_y = odd ? bottom + PANEL_GAP : -1;
    l->height = (odd ? l->legend_y + TEXT_HEIGHT : bottom) + MARGIN;
}

static box panel_box(const layout *l, int r, int k)
{
    return (box){l->column_x[k] + (l->column_w[k] - l->panel_w[k]) / 2,
                 row_top(l, r) + (l->row_h - l->panel_h[k]) / 2, l->panel_w[k], l->panel_h[k]};
}

/* A one-pixel line just outside b: it keeps dark panels apart from each other
 * and a white difference panel apart from the background. */
static void draw_frame(pbc_canvas *c, box b)
{
    pbc_canvas_fill(c, b.x - 1, b.y - 1, b.w + 2, 1, frame_grey);
    pbc_canvas_fill(c, b.x - 1, b.y + b.h, b.w + 2, 1, frame_grey);
    pbc_canvas_fill(c, b.x - 1, b.y, 1, b.h, frame_grey);
    pbc_canvas_fill(c, b.x + b.w, b.y, 1, b.h, frame_grey);
}

/* A central slice in the view's own axes: voxel (u, v) is origin[u * stride_u + v * stride_v]. */
typedef struct slice {
    const float *origin;
    size_t stride_u, stride_v, n_u, n_v;
} slice;

static double voxel(const slice *s, size_t u, size_t v)
{
    return (double)s->origin[u * s->stride_u + v * s->stride_v];
}

/* Bilinear between voxel centres, clamped at the edges; next to a NaN or an
 * infinity it falls back to the nearest voxel, so that one bad voxel stays one
 * voxel wide instead of spreading to its neighbours. */
static double sample(const slice *s, double u, double v)
{
    u = fmin(fmax(u, 0.0), (double)(s->n_u - 1));
    v = fmin(fmax(v, 0.0), (double)(s->n_v - 1));
    size_t u0 = (size_t)u, v0 = (size_t)v;
    size_t u1 = u0 + 1 < s->n_u ? u0 + 1 : u0, v1 = v0 + 1 < s->n_v ? v0 + 1 : v0;
    double fu = u - (double)u0, fv = v - (double)v0;
    double a = voxel(s, u0, v0), b = voxel(s, u1, v0), c = voxel(s, u0, v1), d = voxel(s, u1, v1);
    if (!isfinite(a + b + c + d))
        return voxel(s, fu < 0.5 ? u0 : u1, fv < 0.5 ? v0 : v1);
    return (a * (1.0 - fu) + b * fu) * (1.0 - fv) + (c * (1.0 - fu) + d * fu) * fv;
}

static pbc_rgb value_colour(const colour_bar *bar, double value)
{
    if (!isfinite(value))
        return not_finite;
    double span = bar->hi - bar->lo;
    double flat = bar->map == PBC_COLORMAP_SIGNED ? 0.5 : 0.0;
    return pbc_colormap_lookup(bar->map, span > 0.0 ? (value - bar->lo) / span : flat);
}

static void draw_panel(pbc_canvas *c, const pbc_picture *p, const float *data, const colour_bar *bar, int k,
                       box b)
{
    const view *w = &views[k];
    const size_t stride[3] = {1, p->dims[0], p->dims[0] * p->dims[1]};
    slice s = {data + p->dims[w->fixed] / 2 * stride[w->fixed], stride[w->u], stride[w->v], p->dims[w->u],
               p->dims[w->v]};
    for (int j = 0; j < b.h; j++) {
        double v = (j + 0.5) * (double)s.n_v / b.h - 0.5;
        if (w->v_up)
            v = (double)(s.n_v - 1) - v;
        for (int i = 0; i < b.w; i++) {
            double u = (i + 0.5) * (double)s.n_u / b.w - 0.5;
            pbc_canvas_put(c, b.x + i, b.y + j, value_colour(bar, sample(&s, u, v)));
        }
    }
    draw_frame(c, b);
}

static void draw_row(pbc_canvas *c, const layout *l, const pbc_picture *p, int r, const colour_bar *bar)
{
    char title[TITLE_CHARS + 1];
    shorten_title(title, p->rows[r].title);
    pbc_font_draw(c, MARGIN, row_top(l, r) + (l->row_h - CAP_HEIGHT) / 2, title, TEXT_SCALE, ink);
    for (int k = 0; k < 3; k++) {
        box b = panel_box(l, r, k);
        draw_panel(c, p, p->rows[r].data, bar, k, b);
        if (r == 0) {
            int label_w = pbc_font_text_width(l->panel_labels[k], TEXT_SCALE);
            pbc_font_draw(c, l->column_x[k] + (l->column_w[k] - label_w) / 2, b.y - LABEL_GAP - TEXT_HEIGHT,
                          l->panel_labels[k], TEXT_SCALE, ink);
        }
    }
}

/* Highest value at the top, with ticks and labels at the top, middle and bottom. */
static void draw_colour_bar(pbc_canvas *c, const colour_bar *bar)
{
    for (int j = 0; j < bar->height; j++) {
        double t = bar->height > 1 ? 1.0 - (double)j / (bar->height - 1) : 1.0;
        pbc_canvas_fill(c, bar->x, bar->top + j, BAR_WIDTH, 1, pbc_colormap_lookup(bar->map, t));
    }
    draw_frame(c, (box){bar->x, bar->top, BAR_WIDTH, bar->height});
    for (int i = 0; i < 3; i++) {
        int y = bar->top + (bar->height - 1) * i / 2;
        pbc_canvas_fill(c, bar->x + BAR_WIDTH, y, TICK_LENGTH, 1, ink);
        pbc_font_draw(c, bar->x + BAR_WIDTH + TICK_LENGTH + TICK_GAP, y - CAP_HEIGHT / 2, bar->labels[i],
                      TEXT_SCALE, ink);
    }
}

static void draw_not_finite_legend(pbc_canvas *c, const layout *l)
{
    box swatch = {l->column_x[0] + 1, l->legend_y, CAP_HEIGHT, CAP_HEIGHT};
    pbc_canvas_fill(c, swatch.x, swatch.y, swatch.w, swatch.h, not_finite);
    draw_frame(c, swatch);
    pbc_font_draw(c, swatch.x + swatch.w + 8, swatch.y, "NaN or infinite", TEXT_SCALE, ink);
}

int pbc_picture_write(const char *path, const pbc_picture *picture)
{
    int rc = validate(path, picture);
    if (rc)
        return rc;
    colour_bar bars[2];
    int odd = set_scales(picture, bars);
    layout l;
    plan_layout(picture, bars, odd, &l);
    pbc_canvas c = {malloc(3 * (size_t)l.width * (size_t)l.height), l.width, l.height};
    if (!c.rgb)
        return pbc_fail(PBC_EXIT_RUNTIME, "%s: out of memory for a %d x %d picture", path, l.width, l.height);
    pbc_canvas_fill(&c, 0, 0, c.width, c.height, background);
    for (int r = 0; r < picture->row_count; r++)
        draw_row(&c, &l, picture, r, &bars[picture->rows[r].signed_map ? 1 : 0]);
    for (int b = 0; b < 2; b++)
        if (bars[b].first_row >= 0)
            draw_colour_bar(&c, &bars[b]);
    if (odd)
        draw_not_finite_legend(&c, &l);
    rc = pbc_canvas_write_png(path, &c);
    free(c.rgb);
    return rc;
}
