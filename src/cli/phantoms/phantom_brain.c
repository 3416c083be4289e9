/* The analytic head that stands in for the Zubal brain phantom. */
#include <math.h>
#include <string.h>

#include "phantom_shapes.h"

/* ---- brain: an analytic head standing in for the Zubal phantom ----------- */

/* Ellipsoids painted in order: where several hold a point, the last one sets
 * its activity. Sizes are an adult's in mm, x across, y back to front, z up,
 * at the default 281.6 x 281.6 x 179.2 mm field of view: the head is 156 x
 * 192 mm in-plane, framed as in the Zubal grid, and reaches from 5 mm below
 * the top of the field of view down through the cerebellum into the neck.
 * It is the same ~18 cm head in mm on every grid: a smaller field of view
 * crops it.
 *
 * Activities are FDG-like, relative to white matter: grey matter 4, the 4 : 1
 * of the tissue itself (images show 2.5-3 : 1 only after the scanner's blur,
 * which is what a blur of this phantom should reproduce); striatum as cortex,
 * thalamus a little below (3.5); cerebellar cortex about 0.8 of cerebral
 * cortex (3.2) over a white core (1.5, mixed with folia); brainstem, mostly
 * tracts, 2; scalp and muscle 0.3 (SUV ~0.8 against ~2.7 for white matter);
 * bone 0.1; CSF 0, which takes up no glucose. Three hot lesions of 1.5-2 times
 * cortex, like high-grade tumours or metastases: 8 mm at the frontal
 * grey-white junction at +x (8), 10 mm deep in the white matter beside the
 * thalamus at -x (6), 6 mm in the cerebellar hemisphere at +x (7). */
typedef struct ellipsoid {
    double centre[3], semi_axis[3];
    double angle; /* degrees, about z */
    double activity;
    int in_cerebrum; /* counts only inside the cerebrum: keeps the midline's cuts off the skull */
} ellipsoid;

enum { CEREBRUM = 6 }; /* its index in head[]; -Woverride-init flags an entry too many before it */

static const ellipsoid head[] = {
    {{0, 0, 8}, {78, 96, 76}, 0, 0.3, 0},          /* scalp */
    {{0, 6, -58}, {64, 84, 56}, 0, 0.3, 0},        /* face and neck below the skull */
    {{0, 0, 8}, {73, 91, 71}, 0, 0.1, 0},          /* skull */
    {{0, -48, -40}, {58, 42, 31}, 0, 0.1, 0},      /* bone around the posterior fossa */
    {{0, 0, 11}, {67, 85, 61}, 0, 0.0, 0},         /* CSF inside the skull */
    {{0, -48, -40}, {52, 36, 25}, 0, 0.0, 0},      /* posterior fossa */
    [CEREBRUM] = {{0, 0, 18}, {64, 82, 54}, 0, 4.0, 0}, /* cerebral cortex */
    {{0, -1, 19}, {59, 77, 48}, 0, 1.0, 0},        /* white matter */
    {{-40, 8, -22}, {18, 36, 22}, 0, 4.0, 0},      /* temporal lobes, hanging below */
    {{40, 8, -22}, {18, 36, 22}, 0, 4.0, 0},
    {{-40, 6, -22}, {12, 29, 16}, 0, 1.0, 0},
    {{40, 6, -22}, {12, 29, 16}, 0, 1.0, 0},
    {{0, -2, 24}, {16, 36, 5}, 0, 1.0, 0},         /* corpus callosum */
    {{0, 0, 70}, {5, 90, 40}, 0, 4.0, 1},          /* medial cortex over, before and behind it */
    {{0, 65, 10}, {5, 28, 60}, 0, 4.0, 1},
    {{0, -65, 10}, {5, 28, 60}, 0, 4.0, 1},
    {{0, 0, 70}, {1, 90, 40}, 0, 0.0, 1},          /* the interhemispheric fissure in it */
    {{0, 65, 10}, {1, 28, 60}, 0, 0.0, 1},
    {{0, -65, 10}, {1, 28, 60}, 0, 0.0, 1},
    {{0, -50, -42}, {48, 30, 20}, 0, 3.2, 0},      /* cerebellum */
    {{0, -48, -42}, {30, 14, 10}, 0, 1.5, 0},
    {{0, -20, -48}, {11, 13, 30}, 0, 2.0, 0},      /* brainstem */
    {{-15, 14, 14}, {5, 11, 8}, 0, 4.0, 0},        /* caudate nuclei */
    {{15, 14, 14}, {5, 11, 8}, 0, 4.0, 0},
    {{-24, 4, 4}, {6, 15, 10}, 0, 4.0, 0},         /* putamen */
    {{24, 4, 4}, {6, 15, 10}, 0, 4.0, 0},
    {{-9, -14, 6}, {8, 13, 9}, 0, 3.5, 0},         /* thalami */
    {{9, -14, 6}, {8, 13, 9}, 0, 3.5, 0},
    {{-9, 0, 18}, {6, 26, 7}, -10, 0.0, 0},        /* lateral ventricles, apart at the back */
    {{9, 0, 18}, {6, 26, 7}, 10, 0.0, 0},
    {{0, -8, 4}, {1.5, 12, 8}, 0, 0.0, 0},         /* third ventricle */
    {{0, -36, -44}, {5, 4, 6}, 0, 0.0, 0},         /* fourth ventricle */
    {{44, 52, 30}, {4, 4, 4}, 0, 8.0, 0},          /* lesions */
    {{-28, -24, 4}, {5, 5, 5}, 0, 6.0, 0},
    {{22, -56, -40}, {3, 3, 3}, 0, 7.0, 0},
};
enum { HEAD_SHAPES = sizeof head / sizeof head[0], HEAD_SUBSAMPLES = 4 };

/* An ellipsoid placed on the grid. q(p), the point's distance from the centre
 * in semi-axes, changes by at most |dp| * reach, reach being 1 / the shortest
 * semi-axis: that bounds q over a voxel from its value at the centre. */
typedef struct placed {
    double centre[3], inverse_axis[3], cos_a, sin_a, reach, activity;
    int clip; /* index of the shape that bounds this one, or -1 */
} placed;

enum { OUTSIDE, CROSSING, INSIDE }; /* ordered so that min() intersects two */

static void place_head(placed *s)
{
    for (int e = 0; e < HEAD_SHAPES; e++) {
        const ellipsoid *h = &head[e];
        double shortest = fmin(h->semi_axis[0], fmin(h->semi_axis[1], h->semi_axis[2]));
        for (int a = 0; a < 3; a++) {
            s[e].centre[a] = h->centre[a];
            s[e].inverse_axis[a] = 1.0 / (h->semi_axis[a]);
        }
        s[e].cos_a = cos(h->angle * PB_PI / 180.0);
        s[e].sin_a = sin(h->angle * PB_PI / 180.0);
        s[e].reach = 1.0 / (shortest);
        s[e].activity = h->activity;
        s[e].clip = h->in_cerebrum ? CEREBRUM : -1;
    }
}

static double shape_q(const placed *s, const double p[3])
{
    double dx = p[0] - s->centre[0], dy = p[1] - s->centre[1];
    double u = (s->cos_a * dx + s->sin_a * dy) * s->inverse_axis[0];
    double v = (s->cos_a * dy - s->sin_a * dx) * s->inverse_axis[1];
    double w = (p[2] - s->centre[2]) * s->inverse_axis[2];
    return sqrt(u * u + v * v + w * w);
}

static int holds(const placed *s, int e, const double p[3])
{
    return shape_q(&s[e], p) <= 1.0 && (s[e].clip < 0 || holds(s, s[e].clip, p));
}

/* The mean over the voxel whose low corner is lo: the topmost shape that holds
 * all of the voxel gives it its activity, unless a later shape's surface may
 * pass through the voxel; only then are those shapes sub-sampled. */
static double head_voxel(const placed *s, const double lo[3], const double d[3], double half_diagonal)
{
    enum { S = HEAD_SUBSAMPLES };
    double centre[3] = {lo[0] + 0.5 * d[0], lo[1] + 0.5 * d[1], lo[2] + 0.5 * d[2]};
    int state[HEAD_SHAPES], crossing[HEAD_SHAPES], n_crossing = 0, top = -1;
    for (int e = 0; e < HEAD_SHAPES; e++) {
        double q = shape_q(&s[e], centre), t = half_diagonal * s[e].reach;
        state[e] = q + t <= 1.0 ? INSIDE : q - t >= 1.0 ? OUTSIDE : CROSSING;
        if (s[e].clip >= 0 && state[s[e].clip] < state[e])
            state[e] = state[s[e].clip];
        if (state[e] == INSIDE) {
            top = e;
            n_crossing = 0;
        } else if (state[e] == CROSSING) {
            crossing[n_crossing++] = e;
        }
    }
    double base = top < 0 ? 0.0 : s[top].activity, sum = 0.0;
    if (!n_crossing)
        return base;
    for (int sub = 0; sub < S * S * S; sub++) {
        int idx[3] = {sub % S, sub / S % S, sub / (S * S)};
        double p[3], v = base;
        for (int a = 0; a < 3; a++)
            p[a] = lo[a] + (idx[a] + 0.5) * d[a] / S;
        for (int c = n_crossing - 1; c >= 0; c--)
            if (holds(s, crossing[c], p)) {
                v = s[crossing[c]].activity;
                break;
            }
        sum += v;
    }
    return sum / (S * S * S);
}

void pbc_phantom_brain(const size_t n[3], const double d[3], float *out)
{
    placed s[HEAD_SHAPES];
    place_head(s);
    double half_diagonal = 0.5 * sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (size_t k = 0; k < n[2]; k++)
        for (size_t j = 0; j < n[1]; j++)
            for (size_t i = 0; i < n[0]; i++) {
                double lo[3] = {pbc_voxel_edge(i, n[0], d[0]), pbc_voxel_edge(j, n[1], d[1]), pbc_voxel_edge(k, n[2], d[2])};
                out[(k * n[1] + j) * n[0] + i] = (float)head_voxel(s, lo, d, half_diagonal);
            }
}
