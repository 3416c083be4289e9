// Measures the texture unit's fetch rates on the GPU at hand, for the physical
// floor of AB's time (fetches over fetch rate) and to test a lead: AB samples on
// slice centres, so a bilinear fetch from a 2-D layered texture could stand in
// for the trilinear 3-D fetch. Each thread of a 256^3 grid makes `steps`
// fetches along z with fractional x and y offsets, the access pattern of AB on
// a diagonal translation. CUDA events, warm-up, median of 20. With a file
// argument it also writes the rates as CSV (kind,steps,ms,rate; rate in G
// fetches/s, or GB/s for the copy), which bench/paper_report.py reads for AB's
// floor.
//   nvcc -O3 -arch=sm_90 -o fetch_rate bench/fetch_rate.cu && ./fetch_rate [rates.csv]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include <cuda_runtime.h>

#define CHECK(call)                                                                                                  \
    do {                                                                                                             \
        cudaError_t e_ = (call);                                                                                     \
        if (e_ != cudaSuccess) {                                                                                     \
            std::fprintf(stderr, "%s:%d: %s: %s\n", __FILE__, __LINE__, #call, cudaGetErrorString(e_));           \
            std::exit(1);                                                                                            \
        }                                                                                                            \
    } while (0)

static const int N = 256;

__global__ void fetch3d(cudaTextureObject_t t, int steps, float gx, float gy, float *out)
{
    int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y,
        z = blockIdx.z * blockDim.z + threadIdx.z;
    float s = 0.0f;
    for (int k = 0; k < steps; k++)
        s += tex3D<float>(t, x + 0.5f + gx * k, y + 0.5f + gy * k, z + 0.5f + k);
    out[x + N * (y + N * z)] = s;
}

__global__ void fetch_layered(cudaTextureObject_t t, int steps, float gx, float gy, float *out)
{
    int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y,
        z = blockIdx.z * blockDim.z + threadIdx.z;
    float s = 0.0f;
    for (int k = 0; k < steps; k++)
        s += tex2DLayered<float>(t, x + 0.5f + gx * k, y + 0.5f + gy * k, min(z + k, N - 1));
    out[x + N * (y + N * z)] = s;
}

static cudaTextureObject_t texture(cudaArray_t a, cudaTextureFilterMode f)
{
    cudaResourceDesc r = {};
    r.resType = cudaResourceTypeArray;
    r.res.array.array = a;
    cudaTextureDesc d = {};
    for (int i = 0; i < 3; i++)
        d.addressMode[i] = cudaAddressModeBorder;
    d.filterMode = f;
    d.readMode = cudaReadModeElementType;
    cudaTextureObject_t t;
    CHECK(cudaCreateTextureObject(&t, &r, &d, nullptr));
    return t;
}

template <class F> static double median_ms(F launch)
{
    cudaEvent_t a, b;
    CHECK(cudaEventCreate(&a));
    CHECK(cudaEventCreate(&b));
    launch();
    std::vector<float> ms(20);
    for (float &m : ms) {
        CHECK(cudaEventRecord(a));
        launch();
        CHECK(cudaEventRecord(b));
        CHECK(cudaEventSynchronize(b));
        CHECK(cudaEventElapsedTime(&m, a, b));
    }
    CHECK(cudaGetLastError());
    std::sort(ms.begin(), ms.end());
    return 0.5 * (ms[9] + ms[10]);
}

int main(int argc, char **argv)
{
    FILE *csv = argc > 1 ? std::fopen(argv[1], "w") : nullptr;
    if (argc > 1 && !csv) {
        std::perror(argv[1]);
        return 1;
    }
    if (csv)
        std::fprintf(csv, "kind,steps,ms,rate\n");
    size_t n = (size_t)N * N * N;
    std::vector<float> h(n);
    for (size_t i = 0; i < n; i++)
        h[i] = (float)(i % 977) / 977.0f;
    cudaChannelFormatDesc fmt = cudaCreateChannelDesc<float>();
    cudaArray_t a3, al;
    CHECK(cudaMalloc3DArray(&a3, &fmt, make_cudaExtent(N, N, N), 0));
    CHECK(cudaMalloc3DArray(&al, &fmt, make_cudaExtent(N, N, N), cudaArrayLayered));
    for (cudaArray_t a : {a3, al}) {
        cudaMemcpy3DParms p = {};
        p.srcPtr = make_cudaPitchedPtr(h.data(), N * sizeof(float), N, N);
        p.dstArray = a;
        p.extent = make_cudaExtent(N, N, N);
        p.kind = cudaMemcpyHostToDevice;
        CHECK(cudaMemcpy3D(&p));
    }
    float *out, *copy;
    CHECK(cudaMalloc(&out, n * sizeof(float)));
    CHECK(cudaMalloc(&copy, n * sizeof(float)));
    cudaTextureObject_t lin3 = texture(a3, cudaFilterModeLinear), pt3 = texture(a3, cudaFilterModePoint),
                        linl = texture(al, cudaFilterModeLinear);
    cudaDeviceProp prop;
    CHECK(cudaGetDeviceProperties(&prop, 0));
    std::printf("# %s, %d SMs, 256^3 float, median of 20 (CUDA events)\n", prop.name, prop.multiProcessorCount);
    std::printf("%-34s %6s %10s %14s\n", "fetch", "steps", "ms", "G fetches/s");
    dim3 block(32, 4, 2), grid(N / 32, N / 4, N / 2);
    const float gx = 10.0f / 11.0f, gy = 0.37f; /* fractional in-slice steps, as on a diagonal path */
    for (int steps : {1, 13, 31}) {
        struct {
            const char *name, *key;
            cudaTextureObject_t t;
            bool layered;
        } kinds[] = {{"3-D trilinear (linear filter)", "trilinear3d", lin3, false},
                     {"3-D nearest (point filter)", "nearest3d", pt3, false},
                     {"2-D layered bilinear", "bilinear_layered", linl, true}};
        for (auto &k : kinds) {
            double ms = median_ms([&] {
                if (k.layered)
                    fetch_layered<<<grid, block>>>(k.t, steps, gx, gy, out);
                else
                    fetch3d<<<grid, block>>>(k.t, steps, gx, gy, out);
            });
            std::printf("%-34s %6d %10.4f %14.1f\n", k.name, steps, ms, (double)n * steps / (ms * 1e6));
            if (csv)
                std::fprintf(csv, "%s,%d,%.5f,%.2f\n", k.key, steps, ms, (double)n * steps / (ms * 1e6));
        }
    }
    double ms = median_ms([&] { CHECK(cudaMemcpyAsync(copy, out, n * sizeof(float), cudaMemcpyDeviceToDevice)); });
    std::printf("device-to-device copy of 64 MiB: %.4f ms, %.0f GB/s (read + write)\n", ms,
                2.0 * n * sizeof(float) / (ms * 1e6));
    if (csv) {
        std::fprintf(csv, "copy,0,%.5f,%.2f\n", ms, 2.0 * n * sizeof(float) / (ms * 1e6));
        std::fclose(csv);
    }
    return 0;
}
