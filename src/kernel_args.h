/* The plan in the float layout every device kernel reads (cl/pb_kernel_types.h),
 * shared by the OpenCL and CUDA backends. */
#ifndef PB_KERNEL_ARGS_H
#define PB_KERNEL_ARGS_H

#include "motion.h"
#include "../cl/pb_kernel_types.h"

/* NVIDIA's texture unit keeps each linear-filter weight in 9-bit fixed point
 * with 8 fractional bits (CUDA C Programming Guide, "Linear Filtering"); the
 * device test test_hardware_weights checks the rounding to the nearest step. */
#define PB_NVIDIA_WEIGHT_STEPS 256.0f

void pb_kparams_from_plan(const pb_path *plan, const pb_blur_options *opt, pb_kparams *prm);

/* Whether a launch may use the shift-invariant kernels (cl/pb_shift.cl): AB,
 * RM or CL under key poses that all have the identity rotation, exactly (a
 * motion of translations only; any rotation, however small, takes the general
 * kernels). */
int pb_path_shift_invariant(const pb_path *plan, const pb_blur_options *opt);
/* The axis along which every segment of a motion of translations only moves
 * most (ties: the lower axis, as the kernels break them; segments of no
 * length take any), or -1 when two segments differ. */
int pb_path_layer_axis(const pb_path *plan);

/* The forward kernel of a launch (PB_KERNEL_NAMES): for AB HARDWARE under
 * translations along one axis (along x: of at least 8 slices), where the object fits the device's 2-D image
 * arrays laid out along it (layer_limits: largest width, height and layer
 * count; NULL: none), the layered kernel; otherwise the shift-invariant one
 * where pb_path_shift_invariant, the general one elsewhere. */
int pb_forward_kernel(const pb_path *plan, const pb_blur_options *opt, const size_t *layer_limits);

/* Whether kernel `kernel` reads the object as 2-D layers (along
 * prm.layer_axis) instead of as a 3-D image. */
int pb_kernel_layered(int kernel);

/* The work items of a launch of `kernel` over a grid of dims, per launch axis:
 * one per voxel, x first; pb_shift_ab_layers_x has them along y first, then
 * one per run of PB_X_RUN voxels along x. */
void pb_kernel_extent(int kernel, const size_t *dims, size_t *extent);

/* The work-group (CUDA: thread block) shape of kernel `kernel` on a GPU, x
 * first, 256 work items. */
void pb_kernel_group(int kernel, unsigned group[3]);

/* pb_permute's parameters: a volume of dims laid out in layers along axis m. */
void pb_kparams_permute(const size_t *dims, int m, pb_kparams *prm);
/* What a launch of `method` reads besides its parameters, in the kernels'
 * layout: the plan's key poses (pb_kpose), or for REF its time steps
 * (pb_kstep), in one malloc'd block of *bytes for the backend to copy to the
 * device and free. NULL when the host is out of memory. */
void *pb_kernel_plan_pack(const pb_path *plan, pb_method method, size_t *bytes);

#endif
