/* Whether a volume fits a device: a pure function of what the device reports,
 * so that every refusal can be tested without such a device. */
#include <stdint.h>

#include "backend.h"

pb_status pb_device_check_volume(pb_device *dev, const pb_device_info *info, const pb_geometry *g)
{
    if (!info->image_support)
        return pb_error(pb_owner(dev), PB_ERR_NO_IMAGE_SUPPORT,
                        "device '%s' cannot hold 3-D float images with linear filtering, which every method "
                        "samples; choose another device or the host backend",
                        info->name);
    for (int i = 0; i < 3; i++) {
        if (info->image3d_max[i] && g->dims[i] > info->image3d_max[i])
            return pb_error(pb_owner(dev), PB_ERR_VOLUME_TOO_LARGE,
                            "volume %zu x %zu x %zu exceeds the largest 3-D image of device '%s' (%zu x %zu x %zu); "
                            "crop or resample the volume, or use a device with larger images",
                            g->dims[0], g->dims[1], g->dims[2], info->name, info->image3d_max[0],
                            info->image3d_max[1], info->image3d_max[2]);
    }
    uint64_t bytes = (uint64_t)g->dims[0] * g->dims[1] * g->dims[2] * sizeof(float);
    if (info->max_alloc_bytes && bytes > info->max_alloc_bytes)
        return pb_error(pb_owner(dev), PB_ERR_OUT_OF_MEMORY,
                        "volume %zu x %zu x %zu needs %.1f MiB in one allocation, more than device '%s' allows "
                        "(%.1f MiB); use a smaller volume or a device with more memory",
                        g->dims[0], g->dims[1], g->dims[2], bytes / 1048576.0, info->name,
                        info->max_alloc_bytes / 1048576.0);
    return PB_OK;
}
