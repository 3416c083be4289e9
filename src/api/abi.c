/* pb_abi_layout: the header's structs and enums as this library was built,
 * so that a binding holding copies of them (Python's ctypes) finds out at
 * load time, not by corrupting memory, when the header moved under it. */
#include <stddef.h>
#include <stdio.h>

#include "petblur.h"

/* Built once at first call from sizeof and offsetof; the text is static. */
static char layout[8192];

#define S(T) n += (size_t)snprintf(layout + n, sizeof layout - n, "struct %s %zu\n", #T, sizeof(T))
#define F(T, f) n += (size_t)snprintf(layout + n, sizeof layout - n, "field %s.%s %zu %zu\n", #T, #f, \
                                      offsetof(T, f), sizeof(((T *)0)->f))
#define E(v) n += (size_t)snprintf(layout + n, sizeof layout - n, "enum %s %d\n", #v, (int)(v))

const char *pb_abi_layout(void)
{
    if (layout[0])
        return layout;
    size_t n = 0;
    S(pb_geometry); F(pb_geometry, dims); F(pb_geometry, voxel_size);
    S(pb_pose); F(pb_pose, translation); F(pb_pose, rotation);
    S(pb_motion); F(pb_motion, times); F(pb_motion, poses); F(pb_motion, count); F(pb_motion, frame_start);
    F(pb_motion, frame_end); F(pb_motion, has_center); F(pb_motion, center);
    S(pb_blur_options); F(pb_blur_options, method); F(pb_blur_options, filter); F(pb_blur_options, steps);
    F(pb_blur_options, ref_points); F(pb_blur_options, ref_time_steps); F(pb_blur_options, seed);
    F(pb_blur_options, path); F(pb_blur_options, max_path_error); F(pb_blur_options, ab_sampling);
    F(pb_blur_options, jacobian);
    S(pb_context_options); F(pb_context_options, backend); F(pb_context_options, device_index);
    F(pb_context_options, build_options);
    S(pb_device_info); F(pb_device_info, name); F(pb_device_info, platform); F(pb_device_info, is_gpu);
    F(pb_device_info, image_support); F(pb_device_info, image3d_max); F(pb_device_info, max_alloc_bytes);
    F(pb_device_info, global_mem_bytes); F(pb_device_info, compute_units);
    S(pb_native); F(pb_native, context); F(pb_native, queue); F(pb_native, device); F(pb_native, device_index);
    S(pb_track_read_options); F(pb_track_read_options, format); F(pb_track_read_options, time_divisor);
    F(pb_track_read_options, xyzw);
    S(pb_track_conventions); F(pb_track_conventions, inverse); F(pb_track_conventions, has_reference_time);
    F(pb_track_conventions, reference_time); F(pb_track_conventions, has_calibration);
    F(pb_track_conventions, calibration); F(pb_track_conventions, has_center); F(pb_track_conventions, center);
    S(pb_warnings); F(pb_warnings, flags); F(pb_warnings, text);
    S(pb_estimate_options); F(pb_estimate_options, reference); F(pb_estimate_options, levels);
    F(pb_estimate_options, iterations); F(pb_estimate_options, frame_poses_only); F(pb_estimate_options, fwhm_mm);
    F(pb_estimate_options, frames);
    S(pb_estimate_report); F(pb_estimate_report, seconds); F(pb_estimate_report, moving_frames);
    F(pb_estimate_report, warnings);
    S(pb_estimate_frame); F(pb_estimate_frame, explained); F(pb_estimate_frame, motion_from);
    F(pb_estimate_frame, motion_to); F(pb_estimate_frame, structure); F(pb_estimate_frame, moving);
    F(pb_estimate_frame, jumped_at_start); F(pb_estimate_frame, unfollowed);
    S(pb_comparison); F(pb_comparison, rms_percent); F(pb_comparison, max_percent);
    F(pb_comparison, max_difference); F(pb_comparison, worst); F(pb_comparison, eq5_percent);
    S(pb_frame_summary); F(pb_frame_summary, samples); F(pb_frame_summary, max_turn_deg);
    F(pb_frame_summary, max_corner_mm);
    S(pb_track_summary); F(pb_track_summary, samples); F(pb_track_summary, first); F(pb_track_summary, last);
    F(pb_track_summary, median_step); F(pb_track_summary, missing); F(pb_track_summary, gaps);
    F(pb_track_summary, longest_gap);
    S(pb_field_motion); F(pb_field_motion, times); F(pb_field_motion, displacements); F(pb_field_motion, count);
    F(pb_field_motion, dims); F(pb_field_motion, has_map); F(pb_field_motion, field_from_grid);
    F(pb_field_motion, frame_start); F(pb_field_motion, frame_end); F(pb_field_motion, signal_times);
    F(pb_field_motion, signal); F(pb_field_motion, signal_count);
    S(pb_field_folds); F(pb_field_folds, voxels); F(pb_field_folds, field); F(pb_field_folds, voxel);
    F(pb_field_folds, worst_determinant);
    E(PB_BACKEND_AUTO); E(PB_BACKEND_HOST); E(PB_BACKEND_OPENCL); E(PB_BACKEND_CUDA);
    E(PB_TRACK_AUTO); E(PB_TRACK_CSV); E(PB_TRACK_MATRIX_CSV); E(PB_TRACK_POLARIS);
    E(PB_METHOD_AB); E(PB_METHOD_RM); E(PB_METHOD_CL); E(PB_METHOD_REF);
    E(PB_FILTER_HARDWARE); E(PB_FILTER_EXACT);
    E(PB_PATH_DEFAULT); E(PB_PATH_BOUNDED); E(PB_PATH_TRACKED);
    E(PB_AB_SAMPLING_DEFAULT); E(PB_AB_SAMPLING_SLICE); E(PB_AB_SAMPLING_SWEEP); E(PB_AB_SAMPLING_CHORD);
    E(PB_ERR_OUT_OF_VIEW);
    (void)n;
    return layout;
}
