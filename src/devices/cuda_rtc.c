/* The CUDA kernels compiled at run time: NVRTC (opened with dlopen, from the
 * nvidia-cuda-nvrtc wheel, a toolkit, or PETBLUR_NVRTC_LIBRARY) compiles the
 * embedded source (cuda/pb_kernels_rtc.cu: the one kernel source, as OpenCL
 * builds it) for the device's architecture; the image is cached on disk and
 * loaded through the runtime's library API (cudaLibraryLoadData), whose
 * kernel handles cudaLaunchKernel takes as it takes nvcc's.
 *
 * The cache (kernel_cache.c) keeps one file per source, options, NVRTC
 * version, driver version and architecture; why it was not used is the
 * context's note (pb_context_notes). */
#include "cuda_impl.h"
#include "dl_resolve.h"
#include "kernel_cache.h"

#include <dlfcn.h>
#include <errno.h>
#include <nvrtc.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

extern const char pb_cuda_rtc_source[];

#define PB_NVRTC_FUNCTIONS(X)                                                                                         \
    X(nvrtcVersion) X(nvrtcGetErrorString) X(nvrtcCreateProgram) X(nvrtcDestroyProgram) X(nvrtcCompileProgram)       \
    X(nvrtcGetProgramLogSize) X(nvrtcGetProgramLog) X(nvrtcGetCUBINSize) X(nvrtcGetCUBIN) X(nvrtcGetPTXSize)          \
    X(nvrtcGetPTX) X(nvrtcGetNumSupportedArchs) X(nvrtcGetSupportedArchs)

static struct {
#define PB_NVRTC_MEMBER(f) __typeof__(f) *f;
    PB_NVRTC_FUNCTIONS(PB_NVRTC_MEMBER)
#undef PB_NVRTC_MEMBER
} nv;

static pthread_once_t nv_once = PTHREAD_ONCE_INIT;
static char nv_error[768];
static int nv_major, nv_minor;

static void nv_load(void)
{
    const char *env = getenv("PETBLUR_NVRTC_LIBRARY");
    /* The sonames NVRTC has had, newest first; a toolkit's folder where the
     * loader's path does not reach it. */
    static const char *const names[] = {"libnvrtc.so.13", "libnvrtc.so.12", "libnvrtc.so.11.2", "libnvrtc.so",
                                        "/usr/local/cuda/lib64/libnvrtc.so"};
    void *lib = NULL;
    const char *name = NULL;
    if (env && *env) {
        name = env;
        lib = dlopen(env, RTLD_NOW | RTLD_LOCAL);
    } else {
        for (size_t i = 0; i < sizeof names / sizeof *names && !lib; i++)
            lib = dlopen(name = names[i], RTLD_NOW | RTLD_LOCAL);
    }
    if (!lib) {
        snprintf(nv_error, sizeof nv_error,
                 "NVRTC, which compiles the CUDA kernels at run time, could not be opened (%s: %s); install it "
                 "(pip install nvidia-cuda-nvrtc, or a CUDA toolkit) or set PETBLUR_NVRTC_LIBRARY to libnvrtc.so's "
                 "path",
                 name, dlerror());
        return;
    }
#define PB_NVRTC_NAME(f) #f,
#define PB_NVRTC_SLOT(f) (void *)&nv.f,
    static const char *const names_of[] = {PB_NVRTC_FUNCTIONS(PB_NVRTC_NAME)};
    void *const slots[] = {PB_NVRTC_FUNCTIONS(PB_NVRTC_SLOT)};
#undef PB_NVRTC_NAME
#undef PB_NVRTC_SLOT
    const char *missing = pb_dl_resolve(lib, names_of, slots, sizeof names_of / sizeof *names_of);
    if (missing) {
        snprintf(nv_error, sizeof nv_error, "%s lacks %s(): point PETBLUR_NVRTC_LIBRARY at NVRTC 11.2 or newer", name,
                 missing);
        dlclose(lib);
        memset(&nv, 0, sizeof nv);
        return;
    }
    if (nv.nvrtcVersion(&nv_major, &nv_minor) != NVRTC_SUCCESS) {
        snprintf(nv_error, sizeof nv_error, "%s does not answer nvrtcVersion(); reinstall NVRTC", name);
        memset(&nv, 0, sizeof nv);
    }
}

int pb_cuda_rtc_available(char *why, size_t n)
{
    pthread_once(&nv_once, nv_load);
    if (nv.nvrtcCompileProgram)
        return 1;
    snprintf(why, n, "%s", nv_error);
    return 0;
}

/* ---- compiling and loading ----------------------------------------------- */

static pb_status compile(pb_device *dev, const char *options[], int n_options, int cubin, void **image,
                         size_t *size)
{
    nvrtcProgram prog;
    nvrtcResult r = nv.nvrtcCreateProgram(&prog, pb_cuda_rtc_source, "pb_kernels_rtc.cu", 0, NULL, NULL);
    if (r != NVRTC_SUCCESS)
        return pb_error(pb_owner(dev), PB_ERR_BUILD, "nvrtcCreateProgram() failed: %s", nv.nvrtcGetErrorString(r));
    r = nv.nvrtcCompileProgram(prog, n_options, options);
    if (r != NVRTC_SUCCESS) {
        size_t len = 0;
        nv.nvrtcGetProgramLogSize(prog, &len);
        char *log = malloc(len + 1);
        if (log) {
            log[0] = '\0';
            nv.nvrtcGetProgramLog(prog, log);
            log[len] = '\0';
        }
        pb_error(pb_owner(dev), PB_ERR_BUILD,
                 "NVRTC %d.%d could not compile the CUDA kernels for %s (%s): %s; set PETBLUR_NVRTC_LIBRARY to "
                 "another NVRTC or PETBLUR_CUDA_KERNELS=builtin. Log:\n",
                 nv_major, nv_minor, options[0], dev->info.name, nv.nvrtcGetErrorString(r));
        pb_error_append(pb_owner(dev), log ? log : "(no memory for the log)");
        free(log);
        nv.nvrtcDestroyProgram(&prog);
        return PB_ERR_BUILD;
    }
    r = cubin ? nv.nvrtcGetCUBINSize(prog, size) : nv.nvrtcGetPTXSize(prog, size);
    *image = r == NVRTC_SUCCESS ? malloc(*size) : NULL;
    if (*image)
        r = cubin ? nv.nvrtcGetCUBIN(prog, *image) : nv.nvrtcGetPTX(prog, *image);
    nv.nvrtcDestroyProgram(&prog);
    if (!*image)
        return pb_error(pb_owner(dev), PB_ERR_OUT_OF_MEMORY, "out of host memory for the compiled CUDA kernels");
    if (r != NVRTC_SUCCESS) {
        free(*image);
        *image = NULL;
        return pb_error(pb_owner(dev), PB_ERR_BUILD, "NVRTC gave no image: %s", nv.nvrtcGetErrorString(r));
    }
    return PB_OK;
}

/* The target: the device's own architecture where this NVRTC knows it
 * (machine code), else the newest it knows below it (PTX, which the driver
 * compiles for the device). */
static pb_status target(pb_device *dev, int device, int *arch, int *cubin)
{
    int major = 0, minor = 0;
    if (cudaDeviceGetAttribute(&major, cudaDevAttrComputeCapabilityMajor, device) != cudaSuccess ||
        cudaDeviceGetAttribute(&minor, cudaDevAttrComputeCapabilityMinor, device) != cudaSuccess)
        return pb_cu_fail(dev, PB_ERR_DEVICE, "cudaDeviceGetAttribute", cudaGetLastError());
    int want = 10 * major + minor, n = 0, best = 0;
    int archs[128];
    if (nv.nvrtcGetNumSupportedArchs(&n) != NVRTC_SUCCESS || n <= 0 || n > 128 ||
        nv.nvrtcGetSupportedArchs(archs) != NVRTC_SUCCESS)
        return pb_error(pb_owner(dev), PB_ERR_BUILD, "NVRTC %d.%d does not list its architectures", nv_major, nv_minor);
    for (int i = 0; i < n; i++)
        if (archs[i] <= want && archs[i] > best)
            best = archs[i];
    if (!best)
        return pb_error(pb_owner(dev), PB_ERR_BUILD,
                        "NVRTC %d.%d does not compile for compute capability %d.%d (%s), nor for any below it; use "
                        "an older NVRTC (PETBLUR_NVRTC_LIBRARY) or PETBLUR_CUDA_KERNELS=builtin",
                        nv_major, nv_minor, major, minor, dev->info.name);
    *arch = best;
    *cubin = best == want;
    return PB_OK;
}

pb_status pb_cuda_rtc_load(pb_device *dev, int device, cu_kernels *k)
{
    char why[768];
    if (!pb_cuda_rtc_available(why, sizeof why))
        return pb_error(pb_owner(dev), PB_ERR_BACKEND_UNAVAILABLE, "%s", why);
    int arch = 0, cubin = 0;
    pb_status st = target(dev, device, &arch, &cubin);
    if (st != PB_OK)
        return st;
    char opt_arch[40];
    snprintf(opt_arch, sizeof opt_arch, "--gpu-architecture=%s_%d", cubin ? "sm" : "compute", arch);
    /* nvcc's -O3 is NVRTC's default; both keep IEEE divisions and FMA
     * contraction as they are, so the two builds compute alike. */
    const char *options[] = {opt_arch, "-std=c++17"};
    int driver = 0;
    cudaDriverGetVersion(&driver);
    uint64_t key = pb_kernel_cache_hash(PB_KERNEL_CACHE_HASH_START, pb_cuda_rtc_source, strlen(pb_cuda_rtc_source));
    for (size_t i = 0; i < sizeof options / sizeof *options; i++)
        key = pb_kernel_cache_hash(key, options[i], strlen(options[i]) + 1);
    int versions[3] = {nv_major, nv_minor, driver};
    key = pb_kernel_cache_hash(key, versions, sizeof versions);

    char name[32];
    snprintf(name, sizeof name, "cuda-%s%d", cubin ? "sm" : "compute", arch);
    pb_kernel_cache cache;
    pb_kernel_cache_open(&cache, name, key);
    cudaError_t e = cudaSuccess;
    /* A cached image the runtime refuses is compiled again, once. */
    for (int attempt = 0; attempt < 2; attempt++) {
        void *image = NULL;
        size_t size = 0;
        int cached = 0;
        if (attempt == 0)
            cached = (image = pb_kernel_cache_load(&cache, &size)) != NULL;
        if (!image) {
            st = compile(dev, options, 2, cubin, &image, &size);
            if (st != PB_OK)
                return st;
            pb_kernel_cache_store(&cache, image, size);
        }
        e = cudaLibraryLoadData(&k->library, image, NULL, NULL, 0, NULL, NULL, 0);
        free(image);
        if (e == cudaSuccess)
            break;
        (void)cudaGetLastError();
        k->library = NULL;
        if (!cached)
            return pb_cu_fail(dev, PB_ERR_BUILD, "cudaLibraryLoadData (NVRTC's kernels)", e);
    }
    for (int i = 0; i < PB_KERNEL_COUNT; i++) {
        cudaKernel_t h;
        if ((e = cudaLibraryGetKernel(&h, k->library, pb_kernel_table[i].name)) != cudaSuccess)
            return pb_cu_fail(dev, PB_ERR_BUILD, pb_kernel_table[i].name, e);
        k->kernel[i] = (const void *)h;
    }
    cudaKernel_t h;
    if ((e = cudaLibraryGetKernel(&h, k->library, "pb_cuda_layout_kernel")) != cudaSuccess)
        return pb_cu_fail(dev, PB_ERR_BUILD, "pb_cuda_layout_kernel", e);
    k->layout = (const void *)h;
    if (cache.note[0])
        snprintf(dev->notes, sizeof dev->notes, "NVRTC: %s", cache.note);
    return PB_OK;
}
