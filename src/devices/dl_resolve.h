/* A table of functions from a library opened at run time (dlopen), shared by
 * the OpenCL ICD loader (opencl_loader.c) and NVRTC (cuda_rtc.c). */
#ifndef PB_DL_RESOLVE_H
#define PB_DL_RESOLVE_H

#include <stddef.h>

/* Resolves names[i] in lib into the function pointer that slots[i] points at,
 * for i < count. Returns NULL, or the first name lib lacks; the caller then
 * clears its table, of which some slots may be set. */
const char *pb_dl_resolve(void *lib, const char *const *names, void *const *slots, size_t count);

#endif
