/* The backend's layout of a volume into layers, CUDA's half of image_layout
 * (src/devices/backend.h): reads coalesced along x, writes each voxel's layer
 * texel. Compiled by nvcc (pb_kernels.cu) and by NVRTC (pb_kernels_rtc.cu). */
extern "C" __global__ void pb_cuda_layout_kernel(const float *in, int nx, int ny, int nz, int m,
                                                 cudaSurfaceObject_t surface)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z;
    if (ix >= nx || iy >= ny || iz >= nz)
        return;
    /* pb_layer_across's axes, selected rather than indexed (no local memory). */
    int a = m == 0 ? iy : ix, b = m == 2 ? iy : iz, layer = m == 0 ? ix : (m == 1 ? iy : iz);
    surf2DLayeredwrite(in[ix + nx * (iy + ny * iz)], surface, a * (int)sizeof(float), b, layer);
}
