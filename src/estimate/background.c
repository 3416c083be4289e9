/* What the frames hold besides the moving object: a uniform background that
 * reaches the grid's faces, and frames of noise alone.
 *
 * The blur takes the object as zero outside the grid, so a reference on a
 * background moved by a pose shows an edge at the faces where the
 * background is cut off, and that edge, which the frames do not move with
 * the head, holds every pose near the grid's: a 4 mm shift came back as
 * 0.5 mm at half the peak. The background's level is the median of the
 * faces' voxels: a head that leaves the axial field of view touches two of
 * six faces, and its noise alone leaves a median of 0. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "estimate.h"

static int compare_floats(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

/* The voxels of the grid's six faces, one voxel deep: whole rows on the y
 * and z faces, the two ends of every other row. */
static size_t face_voxels(const pb_geometry *g, const float *f, float *out)
{
    const size_t nx = g->dims[0], ny = g->dims[1], nz = g->dims[2];
    size_t m = 0;
    for (size_t k = 0; k < nz; k++)
        for (size_t j = 0; j < ny; j++) {
            const float *row = f + nx * (j + ny * k);
            if (k == 0 || k + 1 == nz || j == 0 || j + 1 == ny) {
                memcpy(out + m, row, sizeof(float) * nx);
                m += nx;
            } else {
                out[m++] = row[0];
                out[m++] = row[nx - 1];
            }
        }
    return m;
}

pb_status pbe_backgrounds(const pb_geometry *g, const float *frames, size_t count, double *level, double *peak)
{
    const size_t n = g->dims[0] * g->dims[1] * g->dims[2];
    float *faces = malloc(sizeof(float) * n);
    if (!faces)
        return PB_ERR_OUT_OF_MEMORY;
    for (size_t k = 0; k < count; k++) {
        const float *f = frames + k * n;
        size_t m = face_voxels(g, f, faces);
        qsort(faces, m, sizeof *faces, compare_floats);
        level[k] = 0.5 * ((double)faces[(m - 1) / 2] + (double)faces[m / 2]);
        float top = f[0];
        for (size_t i = 1; i < n; i++)
            top = fmaxf(top, f[i]);
        peak[k] = (double)top;
    }
    free(faces);
    return PB_OK;
}

double pbe_explained(const float *frame, size_t n, double sse)
{
    double mean = 0.0, spread = 0.0;
    for (size_t i = 0; i < n; i++)
        mean += (double)frame[i];
    mean /= (double)n;
    for (size_t i = 0; i < n; i++)
        spread += ((double)frame[i] - mean) * ((double)frame[i] - mean);
    return spread > 0 ? 1.0 - sse / spread : 0.0;
}
