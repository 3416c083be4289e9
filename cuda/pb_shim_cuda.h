/* The shim, CUDA side: the names cl/pb_shim.h gives the OpenCL C compiler,
 * spelled for nvcc. cuda/pb_kernels.cu includes this, then the very kernel
 * source in cl/. Kernel bodies use nothing else, so both compilers see the same
 * arithmetic.
 *
 * Coordinates, as in OpenCL: unnormalized texel coordinates, texel i's centre at
 * i + 0.5, border addressing (zero outside the volume), x fastest. */
#ifndef PB_SHIM_CUDA_H
#define PB_SHIM_CUDA_H

#ifndef __CUDACC__
#error "cuda/pb_shim_cuda.h is for nvcc"
#endif

#define PB_SHIM_CUDA 1

/* extern "C": unmangled names, the same ones the OpenCL program exports. */
/* No __launch_bounds__: capping AB's registers at 40 (6 blocks of 256 per SM)
 * was measured no faster on an H200; the kernels are bound by texture fetches. */
#define PB_KERNEL extern "C" __global__
#define PB_FN static __device__ __forceinline__
#define PB_GLOBAL
#define PB_GLOBAL_RO const
#define PB_GID_X ((int)(blockIdx.x * blockDim.x + threadIdx.x))
#define PB_GID_Y ((int)(blockIdx.y * blockDim.y + threadIdx.y))
#define PB_GID_Z ((int)(blockIdx.z * blockDim.z + threadIdx.z))
typedef cudaTextureObject_t pb_image;
typedef cudaTextureObject_t pb_layers; /* a layered 2-D texture, linear filter */

/* A CUDA texture object carries its filter mode, where OpenCL passes a sampler
 * per read. The backend binds two texture objects to the volume's cudaArray,
 * one linear and one point, and passes the one the launch's reads need: linear
 * for HARDWARE (every fetch of AB, RM and CL goes through PB_FETCH_LINEAR), point
 * for EXACT and REF (every fetch goes through PB_FETCH_NEAREST). */
#define PB_FETCH_LINEAR(img, px, py, pz) tex3D<float>((img), (px), (py), (pz))
#define PB_FETCH_NEAREST(img, px, py, pz) tex3D<float>((img), (px), (py), (pz))
#define PB_FETCH_LAYER(img, pa, pb, layer) tex2DLayered<float>((img), (pa), (pb), (layer))

/* The adjoint's scatter; with its result unused nvcc emits RED.ADD.F32. */
#define PB_ATOMIC_ADD(p, v) atomicAdd((p), (v))
/* A division off the precise path (2 ulp); why: cl/pb_shim.h. */
#define PB_DIV(a, b) __fdividef((a), (b))
/* As cl/pb_shim.h's: sincosf and rsqrtf, which OpenCL C spells sincos and
 * rsqrt. Left to 1.0f / sqrtf, nvcc emits a correctly rounded square root and
 * division (NVIDIA's OpenCL compiler does not), which made CUDA's CL steps
 * the slower. */
PB_FN float pb_sincos(float x, float *c)
{
    float s;
    sincosf(x, &s, c);
    return s;
}
#define PB_SINCOS(x, c) pb_sincos((x), (c))
#define PB_RSQRT(x) rsqrtf(x)

/* Float maths: for float arguments C++ overloads pick the float versions
 * (floorf, fabsf, fmaxf, sinf, sqrtf), as OpenCL C does. (The only double code
 * in the PTX is sinf's own slow path for huge arguments.) */

#endif
