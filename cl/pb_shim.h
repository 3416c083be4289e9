/* The shim, OpenCL side: the only place that knows the kernels are compiled as
 * OpenCL C. It maps qualifiers, thread ids (x, y and z), the volume types, the
 * three fetches, the adjoint's float atomic add and a fast division; kernel
 * bodies use nothing else. The CUDA side, with the same names, is
 * cuda/pb_shim_cuda.h.
 *
 * Coordinates, on every backend: unnormalized texel coordinates, texel i's
 * centre at i + 0.5, border addressing (zero outside the volume), x fastest.
 * The CUDA backend binds one texture object per filter to the same cudaArray;
 * OpenCL picks the sampler here. */
#ifndef PB_SHIM_H
#define PB_SHIM_H

#if defined(__OPENCL_VERSION__)

#define PB_KERNEL __kernel
#define PB_FN static inline
#define PB_GLOBAL __global
#define PB_GLOBAL_RO __global const
#define PB_GID_X ((int)get_global_id(0))
#define PB_GID_Y ((int)get_global_id(1))
#define PB_GID_Z ((int)get_global_id(2))
/* A macro, not a typedef: PoCL 3.1 reads garbage through a typedef that carries
 * the access qualifier (seen: every fetch returned 123). */
#define pb_image __read_only image3d_t
/* The same volume as a 2-D image array, one layer per slice along an axis:
 * AB's slice samples are bilinear, which the texture unit fetches at twice its
 * trilinear rate (bench/fetch_rate.cu). */
#define pb_layers __read_only image2d_array_t

__constant sampler_t pb_sampler_linear = CLK_NORMALIZED_COORDS_FALSE | CLK_ADDRESS_CLAMP | CLK_FILTER_LINEAR;
__constant sampler_t pb_sampler_nearest = CLK_NORMALIZED_COORDS_FALSE | CLK_ADDRESS_CLAMP | CLK_FILTER_NEAREST;

/* Border colour of a single-channel image is (0, 0, 0, 1): .x is zero outside. */
#define PB_FETCH_LINEAR(img, px, py, pz) read_imagef((img), pb_sampler_linear, (float4)((px), (py), (pz), 0.0f)).x
#define PB_FETCH_NEAREST(img, px, py, pz) read_imagef((img), pb_sampler_nearest, (float4)((px), (py), (pz), 0.0f)).x
/* Bilinear inside layer `layer` (an int in range: an array clamps the layer,
 * it has no border there). */
#define PB_FETCH_LAYER(img, pa, pb, layer)                                                                       \
    read_imagef((img), pb_sampler_linear, (float4)((pa), (pb), (float)(layer), 0.0f)).x

/* Float atomic add, for the adjoint's scatter. OpenCL 1.2 has none. On
 * NVIDIA's platform (the backend defines PB_OPENCL_NVIDIA) PTX's
 * red.global.add.f32 is what CUDA's atomicAdd compiles to; elsewhere a
 * compare-and-swap loop on the float's bits, which on CPUs (PoCL) seldom
 * retries. */
#if defined(PB_OPENCL_NVIDIA)
static inline void pb_atomic_add(volatile __global float *p, float v)
{
    asm volatile("red.global.add.f32 [%0], %1;" : : "l"(p), "f"(v) : "memory");
}
#else
static inline void pb_atomic_add(volatile __global float *p, float v)
{
    volatile __global unsigned int *u = (volatile __global unsigned int *)p;
    unsigned int old = *u, seen;
    while ((seen = atomic_cmpxchg(u, old, as_uint(as_float(old) + v))) != old)
        old = seen;
}
#endif
#define PB_ATOMIC_ADD(p, v) pb_atomic_add((p), (v))
/* A division off the precise path (a few ulp), for the walk's per-segment
 * divisions: under the error bound a path has many short segments, and their
 * precise divisions were measured to cost AB-E 5 % on the H200 (bench/). The
 * forward and the adjoint divide through the same helpers, so they agree. */
#define PB_DIV(a, b) native_divide((a), (b))
/* CL's step: the sine of x, its cosine into *c (one range reduction for both),
 * and a reciprocal square root. */
#define PB_SINCOS(x, c) sincos((x), (c))
#define PB_RSQRT(x) rsqrt(x)

#elif defined(PB_SHIM_CUDA)
/* CUDA: cuda/pb_shim_cuda.h has defined the same names before including the
 * kernels. */
#else
#error "pb_shim.h is for OpenCL C; CUDA includes cuda/pb_shim_cuda.h first"
#endif

#endif
