/* The plan in the float layout every device kernel reads (cl/pb_kernel_types.h),
 * shared by the OpenCL and CUDA backends. */
#ifndef PB_KERNEL_ARGS_H
#define PB_KERNEL_ARGS_H

#include "motion.h"
#include "../cl/pb_kernel_types.h"

void pb_kparams_from_plan(const pb_plan *plan, const pb_blur_options *opt, pb_kparams *prm);
void pb_kpose_from_plan(const pb_plan *plan, size_t index, pb_kpose *out);
void pb_kstep_from_plan(const pb_plan *plan, size_t index, pb_kstep *out);

#endif
