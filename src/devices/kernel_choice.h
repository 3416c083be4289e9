/* What a device launch is made of, from a frame's key poses (pb_path): the
 * kernel of each direction, chosen from cl/pb_kernel_table.h by what it
 * computes, its parameters, and the key poses in the float layout every
 * kernel reads (cl/pb_kernel_types.h). */
#ifndef PB_KERNEL_ARGS_H
#define PB_KERNEL_ARGS_H

#include "pb_kernel_table.h"
#include "path.h"
#include "pb_kernel_types.h"

void pb_kparams_from_path(const pb_path *path, const pb_blur_options *opt, pb_kparams *prm);

/* Whether a launch may use the shift-invariant kernels (cl/pb_shift.cl): AB,
 * RM or CL under key poses that all have the identity rotation, exactly (a
 * motion of translations only; any rotation, however small, takes the general
 * kernels). */
int pb_path_shift_invariant(const pb_path *path, const pb_blur_options *opt);
/* The axis along which every segment of a motion of translations only moves
 * most (ties: the lower axis, as the kernels break them; segments of no
 * length take any), or -1 when two segments differ. */
int pb_path_layer_axis(const pb_path *path);
/* How far segment j of a motion of translations moves every voxel along its
 * major axis, in voxels. */
double pb_path_segment_along(const pb_path *path, size_t j);

/* The forward kernel: for AB HARDWARE under translations along one axis
 * (along x: of at least PB_X_LAYERS_MIN_SLICES slices a walk, and an input
 * laid out once and read many times, not fresh_input: the caller's device
 * memory and the adjoint's tomograph are laid out anew every call), where the
 * object fits the device's layered images along it (layer_limits: largest
 * width, height and layer count; NULL: none), the layered kernel; otherwise
 * the shift-invariant one where pb_path_shift_invariant, the general one
 * elsewhere. */
pb_kernel_id pb_forward_kernel(const pb_path *path, const pb_blur_options *opt, const size_t *layer_limits,
                               int fresh_input);
/* The adjoint's: under translations only the forward kernel for a fresh
 * input, mirrored (a gather, prm.mirror); otherwise the method's scatter. */
pb_kernel_id pb_adjoint_kernel(const pb_path *path, const pb_blur_options *opt, const size_t *layer_limits);

/* The work items of a launch over a grid of dims, per launch axis: one per
 * voxel, x first; the LAYERS_X family has them along y first, then one per
 * run of PB_X_RUN voxels along x; the TAPS family one per run of PB_TAP_RUN
 * along z. */
void pb_kernel_extent(pb_kernel_id kernel, const size_t *dims, size_t *extent);
/* The z-slices one work item makes: PB_TAP_RUN for the TAPS family, else 1. */
unsigned pb_kernel_run_z(pb_kernel_id kernel);

/* Whether kernel scatters (adds into its output, which must hold zeros or
 * what to add to): the adjoints of general paths and of fields. */
int pb_kernel_scatters(pb_kernel_id kernel);

/* pb_permute's parameters: a volume of dims laid out in layers along axis m. */
void pb_kparams_permute(const size_t *dims, int m, pb_kparams *prm);
/* What a launch of `method` reads besides its parameters, in the kernels'
 * layout: the key poses (pb_kpose), or for REF its time steps (pb_kstep);
 * for a field frame its knots (pb_kknot) and then its fields. In one
 * malloc'd block of *bytes. NULL when the host is out of memory. */
void *pb_kernel_path_pack(const pb_path *path, pb_method method, size_t *bytes);

#endif
