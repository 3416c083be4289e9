// How the texture unit rounds a linear filter's weight, measured: a 3-D float
// texture that ramps along x (T[i] = i) is fetched at many coordinates; the
// fetch returns i0 + alpha exactly, alpha being the weight the unit used.
// For each sample the exact fraction f = frac(x - 0.5) is split into its
// 1/256 step k and the remainder r in [0, 1) of a step; the table gives, per
// remainder bin, how often the unit rounded up (alpha = (k + 1) / 256), and
// how far alpha is from each candidate rule. petblur's adjoint reproduces the
// rule for the HARDWARE filter (cl/pb_adjoint.cl, pb_texture_weight).
//
//   nvcc -O3 -arch=sm_90 bench/texture_rounding.cu -o texture_rounding && ./texture_rounding
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include <cuda_runtime.h>

#define CHECK(x)                                                                                                    \
    do {                                                                                                            \
        cudaError_t e_ = (x);                                                                                       \
        if (e_ != cudaSuccess) {                                                                                    \
            fprintf(stderr, "%s: %s\n", #x, cudaGetErrorString(e_));                                                \
            exit(1);                                                                                                \
        }                                                                                                           \
    } while (0)

__global__ void fetch(cudaTextureObject_t tex, const float *x, float *out, int n)
{
    int i = blockIdx.x * blockDim.x + threadIdx.x;
    if (i < n)
        out[i] = tex3D<float>(tex, x[i], 1.5f, 1.5f);
}

__global__ void fetch3(cudaTextureObject_t tex, const float *p, float *out, int n)
{
    int i = blockIdx.x * blockDim.x + threadIdx.x;
    if (i < n)
        out[i] = tex3D<float>(tex, p[3 * i], p[3 * i + 1], p[3 * i + 2]);
}

static cudaTextureObject_t make_tex(const float *data, int nx, int ny, int nz)
{
    cudaArray_t arr;
    cudaChannelFormatDesc fmt = cudaCreateChannelDesc<float>();
    CHECK(cudaMalloc3DArray(&arr, &fmt, make_cudaExtent(nx, ny, nz)));
    cudaMemcpy3DParms cp = {};
    cp.srcPtr = make_cudaPitchedPtr((void *)data, nx * sizeof(float), nx, ny);
    cp.dstArray = arr;
    cp.extent = make_cudaExtent(nx, ny, nz);
    cp.kind = cudaMemcpyHostToDevice;
    CHECK(cudaMemcpy3D(&cp));
    cudaResourceDesc res = {};
    res.resType = cudaResourceTypeArray;
    res.res.array.array = arr;
    cudaTextureDesc td = {};
    td.addressMode[0] = td.addressMode[1] = td.addressMode[2] = cudaAddressModeBorder;
    td.filterMode = cudaFilterModeLinear;
    td.readMode = cudaReadModeElementType;
    cudaTextureObject_t tex;
    CHECK(cudaCreateTextureObject(&tex, &res, &td, nullptr));
    return tex;
}

static double rule(double f)
{
    return std::floor(f * 256.0 + 0.5) / 256.0;
}

// Trilinear fetches of random values at random 3-D points, against the
// weights' products in double with each axis's weight rounded by rule().
static void trilinear_check()
{
    const int nx = 24, ny = 20, nz = 16, n = 1 << 20;
    std::vector<float> v(nx * ny * nz), p(3 * n), got(n);
    unsigned long long s = 1442695040888963407ULL;
    auto uni = [&s]() {
        s ^= s << 13, s ^= s >> 7, s ^= s << 17;
        return (double)(s >> 11) * (1.0 / 9007199254740992.0);
    };
    for (auto &x : v)
        x = (float)uni();
    for (int i = 0; i < n; i++) {
        p[3 * i] = (float)(1.0 + (nx - 2) * uni());
        p[3 * i + 1] = (float)(1.0 + (ny - 2) * uni());
        p[3 * i + 2] = (float)(1.0 + (nz - 2) * uni());
    }
    cudaTextureObject_t tex = make_tex(v.data(), nx, ny, nz);
    float *dp, *dout;
    CHECK(cudaMalloc(&dp, 3 * n * sizeof(float)));
    CHECK(cudaMalloc(&dout, n * sizeof(float)));
    CHECK(cudaMemcpy(dp, p.data(), 3 * n * sizeof(float), cudaMemcpyHostToDevice));
    fetch3<<<(n + 255) / 256, 256>>>(tex, dp, dout, n);
    CHECK(cudaMemcpy(got.data(), dout, n * sizeof(float), cudaMemcpyDeviceToHost));
    double worst_q = 0, sum_q = 0, worst_exact = 0, bias_q = 0;
    for (int i = 0; i < n; i++) {
        double a[3], f[3];
        int i0[3];
        for (int d = 0; d < 3; d++) {
            double c = (double)p[3 * i + d] - 0.5;
            i0[d] = (int)std::floor(c);
            f[d] = c - i0[d];
            a[d] = rule(f[d]);
        }
        double q = 0, e = 0;
        for (int c = 0; c < 8; c++) {
            double wq = 1, we = 1;
            for (int d = 0; d < 3; d++) {
                int up = c >> d & 1;
                wq *= up ? a[d] : 1 - a[d];
                we *= up ? f[d] : 1 - f[d];
            }
            double t = v[(i0[0] + (c & 1)) + nx * ((i0[1] + (c >> 1 & 1)) + ny * (i0[2] + (c >> 2)))];
            q += wq * t;
            e += we * t;
        }
        double dq = (double)got[i] - q;
        worst_q = std::fmax(worst_q, std::fabs(dq));
        sum_q += std::fabs(dq);
        bias_q += dq;
        worst_exact = std::fmax(worst_exact, std::fabs((double)got[i] - e));
    }
    printf("trilinear, %d random points, values in [0, 1): against rounded weights' products: largest %.3g, mean "
           "%.3g, mean signed %.3g; against float weights: largest %.3g\n",
           n, worst_q, sum_q / n, bias_q / n, worst_exact);
}

int main()
{
    const int nx = 64, n = 1 << 22;
    std::vector<float> ramp(nx * 4 * 4), x(n), got(n);
    for (int k = 0; k < 16; k++)
        for (int i = 0; i < nx; i++)
            ramp[k * nx + i] = (float)i;
    cudaTextureObject_t tex = make_tex(ramp.data(), nx, 4, 4);

    // Random float coordinates over the ramp's inside, every exponent from 1 to 62.
    unsigned long long s = 88172645463325252ULL;
    for (int i = 0; i < n; i++) {
        s ^= s << 13, s ^= s >> 7, s ^= s << 17;
        x[i] = 1.0f + 61.0f * (float)((s >> 11) * (1.0 / 9007199254740992.0));
    }
    float *dx, *dout;
    CHECK(cudaMalloc(&dx, n * sizeof(float)));
    CHECK(cudaMalloc(&dout, n * sizeof(float)));
    CHECK(cudaMemcpy(dx, x.data(), n * sizeof(float), cudaMemcpyHostToDevice));
    fetch<<<(n + 255) / 256, 256>>>(tex, dx, dout, n);
    CHECK(cudaMemcpy(got.data(), dout, n * sizeof(float), cudaMemcpyDeviceToHost));

    enum { BINS = 32 };
    long up[BINS] = {0}, all[BINS] = {0}, off_grid = 0;
    long miss_rint_f = 0, miss_rint_x = 0, miss_floor = 0, miss_f32 = 0;
    for (int i = 0; i < n; i++) {
        double xb = (double)x[i] - 0.5, i0 = std::floor(xb), f = xb - i0;
        double alpha = (double)got[i] - i0; // the weight the unit used
        double steps = alpha * 256.0;
        if (steps != std::floor(steps))
            off_grid++;
        double k = std::floor(f * 256.0), r = f * 256.0 - k;
        int b = (int)(r * BINS);
        all[b]++;
        up[b] += steps > k;
        // Candidate rules for alpha.
        float ff = (float)((float)x[i] - 0.5f) - std::floor((float)x[i] - 0.5f);
        miss_f32 += std::floor(ff * 256.0f + 0.5f) / 256.0 != alpha; // petblur: ties up, of the float fraction
        miss_rint_f += std::rint(f * 256.0) / 256.0 != alpha;     // rint of the exact fraction
        miss_floor += std::floor(f * 256.0) / 256.0 != alpha;     // truncation
        double xr = std::rint((double)x[i] * 256.0) / 256.0 - 0.5; // x itself to 8 fractional bits first
        miss_rint_x += xr - std::floor(xr) != alpha && !(xr - std::floor(xr) == 0.0 && alpha == 1.0);
    }
    printf("# texture weight rounding on this GPU: %d random x in [1, 62), T[i] = i along x\n", n);
    printf("weights off the 1/256 grid: %ld\n", off_grid);
    printf("mismatches: floor(float frac * 256 + 0.5) [petblur] %ld, rint(exact frac * 256) %ld, floor %ld, x rounded "
           "to 1/256 first %ld\n", miss_f32, miss_rint_f, miss_floor, miss_rint_x);
    printf("%-24s %10s %10s\n", "remainder r (of a step)", "samples", "rounded up");
    for (int b = 0; b < BINS; b++)
        printf("[%.4f, %.4f)         %10ld %10.6f\n", (double)b / BINS, (double)(b + 1) / BINS, all[b],
               all[b] ? (double)up[b] / all[b] : 0.0);
    trilinear_check();
    return 0;
}
