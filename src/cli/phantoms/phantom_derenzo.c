/* The Derenzo (hot-rod) phantom. */
#include <math.h>
#include <string.h>

#include "phantom_shapes.h"

/* ---- derenzo: hot rods in six sectors between two plates --------------- */

/* The common layout: rods of 11.1 ... 3.2 mm at their true sizes, centres two
 * diameters apart on a triangular lattice, in a cylinder of 217.6 mm diameter
 * (about the standard phantoms' body), which fills 85 % of the default 256 mm
 * field of view; 217.6 mm long (85 % of it). The phantom is the same object in
 * mm on every grid: a finer grid samples it finer, a smaller one crops it. */
#define DZ_RADIUS 108.8      /* mm, of the cylinder: body, plates */
#define DZ_WALL_GAP 2.0      /* mm, least distance from a rod to the cylinder wall */
#define DZ_PLATE 10.0        /* mm, thickness of each end plate */
#define DZ_LENGTH 217.6      /* mm, along z */
#define DZ_SUBSAMPLES 8      /* per in-plane axis; once per (x, y) column, so it can be fine */
#define DZ_SECTORS 6
/* The sectors' edges lie 15 degrees off the axes, so that the central coronal and
 * sagittal slices both cut through rods rather than run between sectors. */
#define DZ_FIRST_EDGE (-PB_PI / 12.0)

#define DZ_ROD_ACTIVITY 1.0
#define DZ_BODY_ACTIVITY 0.05 /* a little, so that the cylinder's outline shows */
#define DZ_PLATE_ACTIVITY 0.5

static const double rod_diameter[DZ_SECTORS] = {11.1, 9.5, 7.9, 6.4, 4.8, 3.2};
static const double sin60 = 0.86602540378443864676;

/* In its own frame a sector's first edge runs along +x and its second at 60 degrees. */
typedef struct rod_sector {
    double radius, pitch;
    double apex;         /* distance from the centre, along the bisector, of the innermost rod */
    int rows;            /* row t of the triangle holds t + 1 rods */
    double cos_a, sin_a; /* direction of the first edge */
} rod_sector;

typedef struct derenzo_layout {
    double radius, half_length, plate;
    rod_sector sector[DZ_SECTORS];
} derenzo_layout;

/* Complete rows inside the wall; a row's two end rods are its farthest out. */
static int sector_rows(const rod_sector *s, double limit)
{
    int rows = 0;
    while (hypot(s->apex * sin60 + rows * s->pitch, 0.5 * s->apex) + s->radius <= limit)
        rows++;
    return rows;
}

static void derenzo_plan(derenzo_layout *plan)
{
    plan->radius = DZ_RADIUS;
    plan->half_length = 0.5 * DZ_LENGTH;
    plan->plate = DZ_PLATE;
    for (int m = 0; m < DZ_SECTORS; m++) {
        rod_sector *s = &plan->sector[m];
        s->radius = 0.5 * rod_diameter[m];
        s->pitch = 4.0 * s->radius;
        /* A diameter between a rod and the sector's edges sets the sectors
         * apart by twice the gap between rods within one; an edge makes 30 degrees
         * with the bisector, so the apex rod, 3 radii from both, sits 6 out. */
        s->apex = 6.0 * s->radius;
        s->rows = sector_rows(s, plan->radius - DZ_WALL_GAP);
        s->cos_a = cos(DZ_FIRST_EDGE + PB_PI / 3.0 * m);
        s->sin_a = sin(DZ_FIRST_EDGE + PB_PI / 3.0 * m);
    }
}

static int in_rod(const derenzo_layout *plan, double x, double y)
{
    double angle = atan2(y, x) - DZ_FIRST_EDGE;
    int m = (int)((angle < 0.0 ? angle + 2.0 * PB_PI : angle) / (PB_PI / 3.0));
    const rod_sector *s = &plan->sector[m < DZ_SECTORS ? m : DZ_SECTORS - 1];
    double u = x * s->cos_a + y * s->sin_a - s->apex * sin60, v = -x * s->sin_a + y * s->cos_a - 0.5 * s->apex;
    /* Lattice coordinates along the two edges: a point within a radius of a
     * rod lies in one of the four lattice cells that meet at its centre. */
    double b = v / (s->pitch * sin60), a = u / s->pitch - 0.5 * b;
    for (int da = 0; da < 2; da++)
        for (int db = 0; db < 2; db++) {
            double ra = floor(a) + da, rb = floor(b) + db;
            if (ra < 0.0 || rb < 0.0 || ra + rb >= s->rows)
                continue;
            double cu = (ra + 0.5 * rb) * s->pitch - u, cv = rb * s->pitch * sin60 - v;
            if (cu * cu + cv * cv <= s->radius * s->radius)
                return 1;
        }
    return 0;
}

/* The parts of the pixel at (x0, y0) of size w x h inside the cylinder and inside rods. */
static void pixel_cover(const derenzo_layout *plan, double x0, double y0, double w, double h, double *body,
                        double *rods)
{
    int in_body = 0, in_rods = 0;
    for (int sy = 0; sy < DZ_SUBSAMPLES; sy++)
        for (int sx = 0; sx < DZ_SUBSAMPLES; sx++) {
            double x = x0 + (sx + 0.5) * w / DZ_SUBSAMPLES, y = y0 + (sy + 0.5) * h / DZ_SUBSAMPLES;
            if (x * x + y * y <= plan->radius * plan->radius) {
                in_body++;
                in_rods += in_rod(plan, x, y);
            }
        }
    *body = (double)in_body / (DZ_SUBSAMPLES * DZ_SUBSAMPLES);
    *rods = (double)in_rods / (DZ_SUBSAMPLES * DZ_SUBSAMPLES);
}

/* One (x, y) column: the rods and body between the plates, the plates at the
 * ends, each weighted by its exact overlap with the voxel along z. */
static void derenzo_column(const derenzo_layout *plan, const size_t n[3], double dz, double body, double rods,
                           float *out)
{
    double between = rods * DZ_ROD_ACTIVITY + (body - rods) * DZ_BODY_ACTIVITY, plate = body * DZ_PLATE_ACTIVITY;
    double end = plan->half_length, inner = plan->half_length - plan->plate;
    for (size_t k = 0; k < n[2]; k++) {
        double lo = pbc_voxel_edge(k, n[2], dz), hi = lo + dz;
        double in_plates = pbc_overlap(lo, hi, -end, -inner) + pbc_overlap(lo, hi, inner, end);
        out[k * n[0] * n[1]] = (float)(pbc_overlap(lo, hi, -inner, inner) * between + in_plates * plate);
    }
}

/* The object is a prism along z, so the in-plane work is done once per column. */
void pbc_phantom_derenzo(const size_t n[3], const double d[3], float *out)
{
    derenzo_layout plan;
    derenzo_plan(&plan);
    double half_diagonal = 0.5 * hypot(d[0], d[1]);
    for (size_t j = 0; j < n[1]; j++)
        for (size_t i = 0; i < n[0]; i++) {
            double x0 = pbc_voxel_edge(i, n[0], d[0]), y0 = pbc_voxel_edge(j, n[1], d[1]), body = 0.0, rods = 0.0;
            if (hypot(x0 + 0.5 * d[0], y0 + 0.5 * d[1]) - half_diagonal < plan.radius)
                pixel_cover(&plan, x0, y0, d[0], d[1], &body, &rods);
            derenzo_column(&plan, n, d[2], body, rods, out + j * n[0] + i);
        }
}
