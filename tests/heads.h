/* Fresh PET heads for the estimator's tests: four tissues of their own
 * contrast on a grid, smoothed to a PET resolution, and how far two poses
 * lie apart where the head is. */
#ifndef PB_TEST_HEADS_H
#define PB_TEST_HEADS_H

#include <stddef.h>

#include "petblur.h"

enum { PBT_TISSUES = 4 }; /* cortex, white matter, lesions, a blood vessel */
#define PBT_RADIUS_MM 45.0

/* A grid of nx x ny x nz voxels of v = 2-3 mm along x, 0.9-1.1 v along y,
 * 0.9-1.2 v along z. */
pb_geometry pbt_head_grid(size_t nx, size_t ny, size_t nz);
/* A late frame's contrast: cortex 1, white matter 0.25-0.4, lesions 1.5-2.5,
 * blood washed out to 0.1-0.3. */
void pbt_late_contrast(double c[PBT_TISSUES]);
/* A standard normal draw. */
double pbt_gauss(void);
/* Each tissue's image on g (t[k], n voxels each): an ellipsoid of cortex,
 * white matter inside it, a few lesions and a vessel along z, smoothed by a
 * Gaussian of twice the voxel. tmp holds the grid's longest line. */
void pbt_head_tissues(const pb_geometry *g, float *const t[PBT_TISSUES], float *tmp);
/* A fresh head on g (n voxels) in a late frame's contrast into out:
 * pbt_head_tissues mixed by pbt_late_contrast. PB_ERR_OUT_OF_MEMORY where
 * its tissues find no room. */
pb_status pbt_late_head(const pb_geometry *g, float *out);
/* Pose p moved by a random perturbation of norm mm over its six numbers
 * (pb_pose_perturb's: the shift in mm, the turn in units of the head's
 * displacement, PBT_RADIUS_MM a radian). */
pb_pose pbt_jittered(const pb_pose *p, double mm);
/* A jerk's two poses: *a near the identity (shifts up to 2 mm along each
 * axis, a turn up to 3 degrees), *b a shift of lo-hi mm and a turn of lo-hi
 * degrees from it, each about a fresh axis. */
void pbt_jerk(double lo, double hi, pb_pose *a, pb_pose *b);
/* out = sum of c[k] t[k]. */
void pbt_mix(const float *const t[PBT_TISSUES], const double *c, size_t n, float *out);
/* The RMS displacement between poses a and b of points spread over a ball of
 * PBT_RADIUS_MM about the turns' centre, mm. */
double pbt_pose_distance(const pb_pose *a, const pb_pose *b);

#endif
