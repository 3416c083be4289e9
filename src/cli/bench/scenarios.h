/* The paper's eight motions (bench/paper_tables.csv, scenarios 1-8):
 * translations in voxels, rotations in degrees about z through the grid's
 * centre, over one frame: petblur bench's, and bench/'s programs' (header-only). */
#ifndef PB_BENCH_SCENARIOS_H
#define PB_BENCH_SCENARIOS_H

#include "petblur.h"

typedef struct pb_scenario {
    double t[3]; /* voxels */
    double deg;  /* about z */
} pb_scenario;

static const pb_scenario pb_paper_scenarios[8] = {
    {{2, 2, 2}, 0},  {{12, 10, -11}, 0}, {{-20, 30, 15}, 0},     {{-20, 30, 0}, 0},
    {{0, 0, 0}, 10}, {{0, 0, 0}, 60},    {{2.5, -3.2, -0.7}, -5}, {{42, 21, 12}, 20}};

/* The frame [0, 1] from the identity to the scenario's pose, for a grid of
 * voxel size vs (mm); times and poses must outlive the motion. */
static inline pb_motion pb_scenario_motion(const pb_scenario *sc, const double vs[3], double times[2],
                                           pb_pose poses[2])
{
    double z[3] = {0, 0, 1};
    times[0] = 0.0;
    times[1] = 1.0;
    pb_pose id = {{0, 0, 0}, {1, 0, 0, 0}};
    poses[0] = id;
    poses[1] = id;
    for (int d = 0; d < 3; d++)
        poses[1].translation[d] = sc->t[d] * vs[d];
    pb_quaternion_from_axis_angle(z, sc->deg, poses[1].rotation);
    pb_motion m = {times, poses, 2, 0.0, 1.0, 0, {0, 0, 0}};
    return m;
}

#endif
