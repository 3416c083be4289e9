/* Bare float32 volumes: little-endian, x fastest, no header; the geometry
 * comes from --dims and --voxel-size. */
#include <errno.h>
#include <string.h>
#include <sys/stat.h>

#include "atomic_file.h"
#include "cli.h"
#include "image_formats.h"

static int check_size(const char *path, FILE *f, const pbc_image *img)
{
    struct stat st;
    if (fstat(fileno(f), &st) != 0)
        return pbc_fail(PBC_EXIT_USAGE, "%s: cannot read it (%s); check the file", path, strerror(errno));
    size_t n = pbc_image_voxels(img);
    long long need = (long long)(n * sizeof(float));
    if (st.st_size != need)
        return pbc_fail(PBC_EXIT_USAGE, "%s: is %lld bytes, but --dims %zu,%zu,%zu means %zu float32 voxels = %lld "
                        "bytes; fix --dims (or check that the file is bare little-endian float32)", path,
                        (long long)st.st_size, img->dims[0], img->dims[1], img->dims[2], n, need);
    return 0;
}

int pbc_raw_read(const char *path, const pbc_read_hints *hints, pbc_image *img)
{
    static const double default_voxel_size[3] = {1, 1, 1};
    if (!hints || !hints->dims)
        return pbc_fail(PBC_EXIT_USAGE, "%s: a .raw file has no header; give --dims NX,NY,NZ (and --voxel-size, "
                        "default 1 mm)", path);
    memcpy(img->dims, hints->dims, sizeof img->dims);
    memcpy(img->voxel_size, hints->voxel_size ? hints->voxel_size : default_voxel_size, sizeof img->voxel_size);
    FILE *f = fopen(path, "rb");
    if (!f)
        return pbc_fail(PBC_EXIT_USAGE, "%s: cannot read it (%s); check the path", path, strerror(errno));
    const pbc_sample_format format = {PBC_SAMPLE_F32, pbc_host_is_big_endian(), 1, 0};
    /* The size is checked before the memory is taken: a wrong --dims should
     * be told as such, not as a lack of memory. */
    int rc = pbc_image_check_grid(path, img->dims);
    if (!rc)
        rc = check_size(path, f, img);
    if (!rc)
        rc = pbc_image_prepare(path, hints, img);
    if (!rc)
        rc = pbc_samples_read(path, pbc_read_stdio, f, &format, img);
    fclose(f);
    return rc;
}

int pbc_raw_write_temp(const char *path, const pbc_image *img, pbc_temp *t, FILE **f)
{
    int rc = pbc_temp_open(t, path, f);
    if (rc)
        return rc;
    if (pbc_write_f32le(*f, img->data, pbc_image_voxels(img)) != 0) {
        int e = errno;
        pbc_temp_abort(t, *f);
        return pbc_fail(PBC_EXIT_RUNTIME, "%s: writing failed (%s); nothing was written; free some space or choose "
                        "another folder", path, strerror(e));
    }
    return 0;
}

int pbc_raw_write(const char *path, const pbc_image *img)
{
    pbc_temp t;
    FILE *f;
    int rc = pbc_raw_write_temp(path, img, &t, &f);
    return rc ? rc : pbc_temp_commit(&t, f);
}
