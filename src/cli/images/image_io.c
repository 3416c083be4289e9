/* Volumes in files: the choice of format by extension, the checks every format
 * shares (hints, grid size, finite voxels) and the sample conversions. */
#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "atomic_file.h"
#include "cli.h"
#include "image_formats.h"

/* The library's kernels index voxels with 32-bit ints and refuse bigger
 * volumes; saying so here comes before the memory and the reading are spent. */
#define MAX_VOXELS ((size_t)INT32_MAX)

typedef struct image_format {
    const char *ext;
    int (*read)(const char *path, const pbc_read_hints *hints, pbc_image *img);
    int (*write)(const char *path, const pbc_image *img);
} image_format;

static const image_format formats[] = {
    {".nii", pbc_nifti_read, pbc_nifti_write},
    {".nii.gz", pbc_nifti_read, pbc_nifti_write},
    {".hv", pbc_interfile_read, pbc_interfile_write},
    {".raw", pbc_raw_read, pbc_raw_write},
};

static const image_format *find_format(const char *path)
{
    char ext[32];
    pbc_file_extension(path, ext, sizeof ext);
    for (size_t i = 0; i < sizeof formats / sizeof formats[0]; i++)
        if (!strcmp(ext, formats[i].ext))
            return &formats[i];
    return NULL;
}

static int unknown_extension(const char *path)
{
    char ext[32];
    pbc_file_extension(path, ext, sizeof ext);
    if (!ext[0])
        return pbc_fail(PBC_EXIT_USAGE, "%s: no extension to tell the format by; use .nii, .nii.gz, .hv or .raw",
                        path);
    return pbc_fail(PBC_EXIT_USAGE, "%s: unknown extension '%s'; use .nii, .nii.gz, .hv or .raw", path, ext);
}

int pbc_image_format_known(const char *path)
{
    return find_format(path) != NULL;
}

int pbc_image_check_grid(const char *path, const size_t dims[3])
{
    const char *sep = path ? ": " : "";
    path = path ? path : "";
    if (!dims[0] || !dims[1] || !dims[2])
        return pbc_fail(PBC_EXIT_USAGE, "%s%sthe grid %zux%zux%zu has no voxels; check the header or --dims", path,
                        sep, dims[0], dims[1], dims[2]);
    /* Dividing instead of multiplying keeps the test itself from overflowing. */
    if (dims[0] > MAX_VOXELS / dims[1] || dims[0] * dims[1] > MAX_VOXELS / dims[2])
        return pbc_fail(PBC_EXIT_USAGE, "%s%sthe grid %zux%zux%zu has more than 2^31 - 1 voxels, more than "
                        "petblur handles; crop or downsample the volume first", path, sep, dims[0], dims[1], dims[2]);
    return 0;
}

size_t pbc_image_frame_voxels(const pbc_image *img)
{
    return img->dims[0] * img->dims[1] * img->dims[2];
}

size_t pbc_image_frame_count(const pbc_image *img)
{
    return img->frames > 1 ? img->frames : 1;
}

size_t pbc_image_voxels(const pbc_image *img)
{
    return pbc_image_frame_voxels(img) * pbc_image_frame_count(img);
}

static int allocate(const char *path, pbc_image *img)
{
    img->data = calloc(pbc_image_voxels(img), sizeof *img->data);
    if (img->data)
        return 0;
    return pbc_fail(PBC_EXIT_RUNTIME, "%s%snot enough memory for %zu frame%s of %zux%zux%zu (%.1f GiB); free some "
                    "memory or use a smaller volume", path ? path : "", path ? ": " : "", pbc_image_frame_count(img),
                    pbc_image_frame_count(img) == 1 ? "" : "s", img->dims[0], img->dims[1], img->dims[2],
                    (double)pbc_image_voxels(img) * sizeof(float) / (1u << 30));
}

int pbc_image_alloc_frames(pbc_image *img, const size_t dims[3], const double voxel_size[3], size_t frames)
{
    memset(img, 0, sizeof *img);
    int rc = pbc_image_check_grid(NULL, dims);
    if (rc)
        return rc;
    memcpy(img->dims, dims, sizeof img->dims);
    memcpy(img->voxel_size, voxel_size, sizeof img->voxel_size);
    img->frames = frames;
    return allocate(NULL, img);
}

int pbc_image_alloc(pbc_image *img, const size_t dims[3], const double voxel_size[3])
{
    return pbc_image_alloc_frames(img, dims, voxel_size, 1);
}

void pbc_image_free(pbc_image *img)
{
    free(img->data);
    img->data = NULL;
}

static int settle_dims(const char *path, const pbc_read_hints *hints, const pbc_image *img)
{
    const size_t *hint = hints ? hints->dims : NULL;
    const size_t *d = img->dims;
    if (hint && (hint[0] != d[0] || hint[1] != d[1] || hint[2] != d[2]))
        return pbc_fail(PBC_EXIT_USAGE, "%s: --dims %zu,%zu,%zu does not match the header's %zu,%zu,%zu; leave "
                        "--dims out or give --dims %zu,%zu,%zu", path, hint[0], hint[1], hint[2], d[0], d[1], d[2],
                        d[0], d[1], d[2]);
    return pbc_image_check_grid(path, d);
}

/* Headers keep sizes in float32 or in a few decimals, so equal sizes may
 * differ in the last digits. */
static int same_size(double a, double b)
{
    return fabs(a - b) <= 1e-5 * fmax(fabs(a), fabs(b));
}

static int usable_size(double v)
{
    return v > 0 && isfinite(v);
}

/* A header without voxel sizes (0 here) takes them from --voxel-size. */
static int settle_voxel_size(const char *path, const pbc_read_hints *hints, pbc_image *img)
{
    const double *hint = hints ? hints->voxel_size : NULL;
    double *v = img->voxel_size;
    if (hint) {
        if (!usable_size(hint[0]) || !usable_size(hint[1]) || !usable_size(hint[2]))
            return pbc_fail(PBC_EXIT_USAGE, "%s: --voxel-size %g,%g,%g is not three positive sizes in mm; fix "
                            "--voxel-size", path, hint[0], hint[1], hint[2]);
        for (int i = 0; i < 3; i++)
            if (v[i] != 0 && !same_size(v[i], hint[i]))
                return pbc_fail(PBC_EXIT_USAGE, "%s: --voxel-size %g,%g,%g does not match the header's %g,%g,%g "
                                "mm; leave --voxel-size out or give --voxel-size %g,%g,%g", path, hint[0], hint[1],
                                hint[2], v[0], v[1], v[2], v[0], v[1], v[2]);
        for (int i = 0; i < 3; i++)
            v[i] = v[i] != 0 ? v[i] : hint[i];
    }
    if (!usable_size(v[0]) || !usable_size(v[1]) || !usable_size(v[2]))
        return pbc_fail(PBC_EXIT_USAGE, "%s: the header gives no usable voxel size (%g,%g,%g); add it to the "
                        "header or give --voxel-size X,Y,Z in mm", path, v[0], v[1], v[2]);
    return 0;
}

int pbc_image_prepare(const char *path, const pbc_read_hints *hints, pbc_image *img)
{
    int rc = settle_dims(path, hints, img);
    if (!rc)
        rc = settle_voxel_size(path, hints, img);
    return rc ? rc : allocate(path, img);
}

/* Voxel index of img as a message names it: "x,y,z = 1,2,3" and, in a 4-D
 * image, " of frame 4". */
static void voxel_place(const pbc_image *img, size_t index, char *out, size_t size)
{
    size_t nx = img->dims[0], ny = img->dims[1], fv = pbc_image_frame_voxels(img), at = index % fv;
    int n = snprintf(out, size, "x,y,z = %zu,%zu,%zu", at % nx, at / nx % ny, at / nx / ny);
    if (img->frames > 1 && n > 0 && (size_t)n < size)
        snprintf(out + n, size - (size_t)n, " of frame %zu", index / fv);
}

/* The blur would smear a NaN or an infinity over its neighbours. */
static int check_finite(const char *path, const pbc_image *img)
{
    size_t n = pbc_image_voxels(img), bad = 0, first = 0;
    for (size_t i = 0; i < n; i++) {
        if (isfinite(img->data[i]))
            continue;
        if (!bad)
            first = i;
        bad++;
    }
    if (!bad)
        return 0;
    char where[96];
    voxel_place(img, first, where, sizeof where);
    return pbc_fail(PBC_EXIT_USAGE, "%s: %zu voxel%s not finite (NaN or infinite), the first at %s; petblur reads "
                    "finite volumes only (a blur would spread them); replace them (e.g. by 0) first", path, bad,
                    bad == 1 ? " is" : "s are", where);
}

static int check_input_file(const char *path)
{
    struct stat st;
    if (stat(path, &st) != 0)
        return pbc_fail(PBC_EXIT_USAGE, "%s: cannot read it (%s); check the path", path, strerror(errno));
    if (S_ISDIR(st.st_mode))
        return pbc_fail(PBC_EXIT_USAGE, "%s: is a folder, not an image; give the image file's path", path);
    return 0;
}

int pbc_image_read(const char *path, const pbc_read_hints *hints, pbc_image *img)
{
    memset(img, 0, sizeof *img);
    const image_format *format = find_format(path);
    if (!format)
        return unknown_extension(path);
    int rc = check_input_file(path);
    if (!rc)
        rc = format->read(path, hints, img);
    if (!rc)
        rc = check_finite(path, img);
    if (!rc && !img->source[0])
        snprintf(img->source, sizeof img->source, "%s", path);
    if (rc)
        pbc_image_free(img);
    return rc;
}

int pbc_image_check_output(const char *path, const size_t dims[3], size_t frames)
{
    const image_format *format = find_format(path);
    if (!format)
        return unknown_extension(path);
    int rc = pbc_image_check_grid(path, dims);
    if (!rc && frames > 1 && format->write != pbc_nifti_write)
        rc = pbc_fail(PBC_EXIT_USAGE, "%s: %zu frames make a 4-D image, which only NIfTI holds; name the output "
                      ".nii or .nii.gz", path, frames);
    if (!rc && format->write == pbc_nifti_write)
        rc = pbc_nifti_check_output(path, dims, frames);
    return rc;
}

int pbc_image_write(const char *path, const pbc_image *img)
{
    int rc = pbc_image_check_output(path, img->dims, pbc_image_frame_count(img));
    return rc ? rc : find_format(path)->write(path, img);
}

size_t pbc_sample_size(pbc_sample_type type)
{
    static const size_t sizes[] = {1, 1, 2, 2, 4, 4, 4, 8};
    return sizes[type];
}

int pbc_host_is_big_endian(void)
{
    const uint16_t one = 1;
    return *(const unsigned char *)&one == 0;
}

static void swap_bytes(unsigned char *p, size_t count, size_t size)
{
    for (size_t i = 0; i < count; i++, p += size)
        for (size_t a = 0, b = size - 1; a < b; a++, b--) {
            unsigned char c = p[a];
            p[a] = p[b];
            p[b] = c;
        }
}

static double sample_value(pbc_sample_type type, const unsigned char *p)
{
    union { uint16_t u16; int16_t i16; uint32_t u32; int32_t i32; float f32; double f64; } v;
    memcpy(&v, p, pbc_sample_size(type));
    switch (type) {
    case PBC_SAMPLE_U8: return p[0];
    case PBC_SAMPLE_I8: return (signed char)p[0];
    case PBC_SAMPLE_U16: return v.u16;
    case PBC_SAMPLE_I16: return v.i16;
    case PBC_SAMPLE_U32: return v.u32;
    case PBC_SAMPLE_I32: return v.i32;
    case PBC_SAMPLE_F32: return (double)v.f32;
    case PBC_SAMPLE_F64: return v.f64;
    }
    return 0;
}

/* Converting an out-of-range double to float is undefined in C; an infinity
 * is what check_finite then reports for a value that was one. */
static float to_float(double v)
{
    if (fabs(v) <= (double)FLT_MAX)
        return (float)v;
    return v > 0 ? INFINITY : -INFINITY;
}

/* Converts count samples at buf into out; returns the index of the first
 * value that is finite but beyond float32's range (its value in *beyond), or
 * count when there is none. */
static size_t convert(const pbc_sample_format *format, unsigned char *buf, size_t count, float *out, double *beyond)
{
    size_t size = pbc_sample_size(format->type);
    if (format->swap)
        swap_bytes(buf, count, size);
    int unscaled = format->slope == 1 && format->inter == 0;
    /* Copied, not computed: 1 * -0.0 + 0 would turn -0.0 into +0.0. */
    if (format->type == PBC_SAMPLE_F32 && unscaled) {
        memcpy(out, buf, count * size);
        return count;
    }
    for (size_t i = 0; i < count; i++) {
        double stored = sample_value(format->type, buf + i * size);
        double v = unscaled ? stored : format->slope * stored + format->inter;
        /* finite in the file: beyond float32 even where the scaling overflows a double */
        if (isfinite(stored) && fabs(v) > (double)FLT_MAX) {
            *beyond = v;
            return i;
        }
        out[i] = to_float(v);
    }
    return count;
}

/* petblur blurs in float32: a value beyond its range would become an
 * infinity, which is not what the file holds. */
static int beyond_float32(const char *data_path, const pbc_image *img, size_t index, double v)
{
    char where[96];
    voxel_place(img, index, where, sizeof where);
    return pbc_fail(PBC_EXIT_USAGE, "%s: the value %s at %s is beyond float32's range (magnitude at most 3.4e38), in "
                    "which petblur blurs; rescale the image first (its scl_slope or rescale slope, or the data's "
                    "unit)", data_path, PBC_NUM(v), where);
}

int pbc_samples_read(const char *data_path, pbc_read_fn read, void *source, const pbc_sample_format *format,
                     pbc_image *img)
{
    unsigned char buf[1 << 16];
    size_t size = pbc_sample_size(format->type), total = pbc_image_voxels(img);
    for (size_t done = 0; done < total;) {
        size_t want = total - done < sizeof buf / size ? total - done : sizeof buf / size;
        size_t got = read(source, buf, want * size);
        if (got != want * size)
            return pbc_fail(PBC_EXIT_USAGE, "%s: the data ends after %zu of its %zu bytes; the file is truncated or "
                            "damaged; copy or write it again", data_path, done * size + got, total * size);
        double v = 0.0;
        size_t bad = convert(format, buf, want, img->data + done, &v);
        if (bad < want)
            return beyond_float32(data_path, img, done + bad, v);
        done += want;
    }
    return 0;
}

size_t pbc_read_stdio(void *file, void *buf, size_t bytes)
{
    return fread(buf, 1, bytes, file);
}

int pbc_write_f32le(FILE *f, const float *data, size_t n)
{
    if (!pbc_host_is_big_endian())
        return fwrite(data, sizeof *data, n, f) == n ? 0 : -1;
    unsigned char buf[1 << 16];
    for (size_t done = 0; done < n;) {
        size_t k = n - done < sizeof buf / 4 ? n - done : sizeof buf / 4;
        memcpy(buf, data + done, k * 4);
        swap_bytes(buf, k, 4);
        if (fwrite(buf, 4, k, f) != k)
            return -1;
        done += k;
    }
    return 0;
}
