/* What NVRTC compiles at run time (src/devices/cuda_rtc.c): the very source
 * the OpenCL backend embeds and nvcc compiles (cl/pb_blur.cl, with the shim),
 * and the layout kernel. Embedded into the library with its includes inlined,
 * as the OpenCL source is; every kernel has an unmangled name. */
#include "../cl/pb_blur.cl"
#include "pb_layout.cuh"
