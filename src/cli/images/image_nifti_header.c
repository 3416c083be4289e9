/* A NIfTI header checked byte by byte before nifti_clib parses it.
 *
 * nifti_clib trusts what it reads: a NIfTI-2 dim[0] above 7 overflows a stack
 * array in nifti_convert_n2hdr2nim, a dim[0] or dim[i] of 0 is "repaired" into
 * another volume, and a header may promise far more data than the file holds.
 * So the facts petblur relies on are read and checked here first, each with
 * its own message, and nifti_clib is called only on a header that passed. */
#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>

#include <nifti2_io.h>

#include "cli.h"
#include "image_formats.h"

/* Beyond this the offset is no header plus extensions, whatever the file. */
#define MAX_VOX_OFFSET ((int64_t)1 << 30)

static size_t read_some(const char *path, unsigned char *b, size_t size)
{
    znzFile fp = znzopen(path, "rb", nifti_is_gzfile(path));
    if (znz_isnull(fp))
        return 0;
    size_t n = znzread(b, 1, size, fp);
    znzclose(fp);
    return n > size ? 0 : n;
}

/* The uncompressed size modulo 2^32 of a gzip file (its trailer's ISIZE), or -1. */
static int64_t gzip_size(const char *path)
{
    FILE *f = fopen(path, "rb");
    unsigned char t[4];
    int64_t size = -1;
    if (f && fseeko(f, -4, SEEK_END) == 0 && fread(t, 1, 4, f) == 4)
        size = (int64_t)t[0] | (int64_t)t[1] << 8 | (int64_t)t[2] << 16 | (int64_t)t[3] << 24;
    if (f)
        fclose(f);
    return size;
}

/* Whether a .nii.gz decompresses to at least need bytes, counted: the trailer
 * gives only the last member's size, and multi-member files (bgzip's among
 * them) are valid. Read only when the trailer says too few. */
static int gzip_holds(const char *path, uint64_t need)
{
    znzFile fp = znzopen(path, "rb", 1);
    if (znz_isnull(fp))
        return 0;
    static unsigned char buf[1 << 16];
    uint64_t got = 0;
    size_t n;
    while (got < need && (n = znzread(buf, 1, sizeof buf, fp)) > 0 && n <= sizeof buf)
        got += n;
    znzclose(fp);
    return got >= need;
}

static int bytes_per_voxel(int datatype)
{
    switch (datatype) {
    case NIFTI_TYPE_UINT8: case NIFTI_TYPE_INT8: return 1;
    case NIFTI_TYPE_UINT16: case NIFTI_TYPE_INT16: return 2;
    case NIFTI_TYPE_UINT32: case NIFTI_TYPE_INT32: case NIFTI_TYPE_FLOAT32: return 4;
    case NIFTI_TYPE_FLOAT64: return 8;
    default: return 0;
    }
}

/* Element i of a float field (NIfTI-1) or double field (NIfTI-2) at offset. */
static double real_at(const unsigned char *b, int v2, int swap, size_t offset, int i)
{
    if (v2) {
        double d;
        memcpy(&d, b + offset + 8 * (size_t)i, 8);
        if (swap)
            nifti_swap_8bytes(1, &d);
        return d;
    }
    float f;
    memcpy(&f, b + offset + 4 * (size_t)i, 4);
    if (swap)
        nifti_swap_4bytes(1, &f);
    return (double)f;
}

/* A short (NIfTI-1) or int (NIfTI-2) code at offset. */
static int code_at(const unsigned char *b, int v2, int swap, size_t offset)
{
    if (v2) {
        int32_t c;
        memcpy(&c, b + offset, 4);
        if (swap)
            nifti_swap_4bytes(1, &c);
        return (int)c;
    }
    int16_t c;
    memcpy(&c, b + offset, 2);
    if (swap)
        nifti_swap_2bytes(1, &c);
    return c;
}

#define FIELD(name) (v2 ? offsetof(nifti_2_header, name) : offsetof(nifti_1_header, name))

static void orientation_facts(const unsigned char *b, int v2, int swap, pbc_nifti_facts *facts)
{
    facts->qform_code = code_at(b, v2, swap, FIELD(qform_code));
    facts->sform_code = code_at(b, v2, swap, FIELD(sform_code));
    facts->qfac = real_at(b, v2, swap, FIELD(pixdim), 0);
    const size_t quatern[3] = {FIELD(quatern_b), FIELD(quatern_c), FIELD(quatern_d)};
    const size_t qoffset[3] = {FIELD(qoffset_x), FIELD(qoffset_y), FIELD(qoffset_z)};
    const size_t srow[3] = {FIELD(srow_x), FIELD(srow_y), FIELD(srow_z)};
    for (int i = 0; i < 3; i++) {
        facts->quatern[i] = real_at(b, v2, swap, quatern[i], 0);
        facts->qoffset[i] = real_at(b, v2, swap, qoffset[i], 0);
        for (int c = 0; c < 4; c++)
            facts->srow[4 * i + c] = real_at(b, v2, swap, srow[i], c);
    }
}

int pbc_nifti_check_header(const char *path, pbc_nifti_facts *facts)
{
    /* A file that is not there, or a folder, is named as such (a field
     * table's row reaches here without the input's checks). */
    struct stat st;
    if (stat(path, &st) != 0)
        return pbc_fail(PBC_EXIT_USAGE, "%s: cannot read it (%s); check the path", path, strerror(errno));
    if (S_ISDIR(st.st_mode))
        return pbc_fail(PBC_EXIT_USAGE, "%s: is a folder, not an image; give the image file's path", path);
    unsigned char b[sizeof(nifti_2_header)];
    memset(b, 0, sizeof b);
    size_t n = read_some(path, b, sizeof b);
    if (n >= 13 && !memcmp(b, "<nifti_image", 12))
        return pbc_fail(PBC_EXIT_USAGE, "%s: an ASCII NIfTI (NIFTI_ASCII), which petblur does not read; convert it "
                        "to a binary .nii, e.g. with nifti_tool -copy_image", path);
    int32_t size;
    memcpy(&size, b, sizeof size);
    int swap = size != 348 && size != 540;
    if (swap)
        nifti_swap_4bytes(1, &size);
    if (n < sizeof(nifti_1_header) || (size != 348 && size != 540) || (size == 540 && n < sizeof(nifti_2_header)))
        return pbc_fail(PBC_EXIT_USAGE, "%s: not a NIfTI file (%s); check that it is a NIfTI-1 or NIfTI-2 image", path,
                        size == 348 || size == 540 ? "shorter than its header"
                        : n < 4 ? "shorter than a header" : "its first 4 bytes are not 348 or 540");
    int v2 = size == 540;
    const char *magic = (const char *)b + (v2 ? offsetof(nifti_2_header, magic) : offsetof(nifti_1_header, magic));
    if (!strcmp(magic, (v2 ? "ni2" : "ni1")))
        return pbc_fail(PBC_EXIT_USAGE, "%s: its header is that of a .hdr/.img pair (two-file NIfTI); convert it to "
                        "a single-file .nii first", path);
    if (strcmp(magic, v2 ? "n+2" : "n+1"))
        return pbc_fail(PBC_EXIT_USAGE, "%s: no NIfTI magic ('n+1' or 'n+2'): an Analyze 7.5 file or a damaged "
                        "header; convert it to NIfTI", path);
    int64_t dim[8], offset;
    int16_t datatype;
    for (int i = 0; i < 8; i++) {
        if (v2) {
            memcpy(&dim[i], b + offsetof(nifti_2_header, dim) + 8 * i, 8);
            if (swap)
                nifti_swap_8bytes(1, &dim[i]);
        } else {
            int16_t d;
            memcpy(&d, b + offsetof(nifti_1_header, dim) + 2 * i, 2);
            if (swap)
                nifti_swap_2bytes(1, &d);
            dim[i] = d;
        }
    }
    memcpy(&datatype, b + (v2 ? offsetof(nifti_2_header, datatype) : offsetof(nifti_1_header, datatype)), 2);
    if (swap)
        nifti_swap_2bytes(1, &datatype);
    if (v2) {
        memcpy(&offset, b + offsetof(nifti_2_header, vox_offset), 8);
        if (swap)
            nifti_swap_8bytes(1, &offset);
    } else {
        float f;
        memcpy(&f, b + offsetof(nifti_1_header, vox_offset), 4);
        if (swap)
            nifti_swap_4bytes(1, &f);
        offset = isfinite(f) && f >= 0 && f < (float)MAX_VOX_OFFSET && f == floorf(f) ? (int64_t)f : -1;
    }
    if (dim[0] < 1 || dim[0] > 7)
        return pbc_fail(PBC_EXIT_USAGE, "%s: dim[0] is %lld; NIfTI allows 1 to 7 dimensions, so the header is "
                        "damaged", path, (long long)dim[0]);
    uint64_t voxels = 1;
    for (int i = 1; i <= dim[0]; i++) {
        if (dim[i] < 1)
            return pbc_fail(PBC_EXIT_USAGE, "%s: dim[%d] is %lld; every dimension up to dim[0] = %lld needs at least "
                            "one voxel, so the header is damaged", path, i, (long long)dim[i], (long long)dim[0]);
        if ((uint64_t)dim[i] > (UINT64_C(1) << 40) / voxels)
            return pbc_fail(PBC_EXIT_USAGE, "%s: its dimensions promise more than 2^40 voxels; the header is damaged",
                            path);
        voxels *= (uint64_t)dim[i];
    }
    int bytes = bytes_per_voxel(datatype);
    if (!bytes)
        return pbc_fail(PBC_EXIT_USAGE, "%s: its data type %s is not supported (use float32, float64, int8, int16, "
                        "int32, uint8, uint16 or uint32); convert it, e.g. fslmaths %s out.nii.gz -odt float", path,
                        nifti_datatype_string(datatype), path);
    if (offset < size || offset > MAX_VOX_OFFSET)
        return pbc_fail(PBC_EXIT_USAGE, "%s: vox_offset (where the voxels start) is not a whole number of bytes "
                        "between the header's %d and 2^30; the header is damaged", path, (int)size);
    /* What the file must hold; a .nii.gz tells its size modulo 2^32 only. */
    uint64_t need = (uint64_t)offset + voxels * (uint64_t)bytes;
    int64_t have = nifti_is_gzfile(path) ? gzip_size(path) : (stat(path, &st) == 0 ? (int64_t)st.st_size : -1);
    if (have >= 0 && (!nifti_is_gzfile(path) || need < (UINT64_C(1) << 32)) && need > (uint64_t)have &&
        !(nifti_is_gzfile(path) && gzip_holds(path, need)))
        return pbc_fail(PBC_EXIT_USAGE, "%s: its header promises %llu voxels of %d bytes from byte %lld, %llu bytes "
                        "in all, but the file holds %lld; the file is truncated or the header is wrong", path,
                        (unsigned long long)voxels, bytes, (long long)offset, (unsigned long long)need,
                        (long long)have);
    facts->version = v2 ? 2 : 1;
    facts->swap = swap;
    facts->vox_offset = offset;
    for (int i = 0; i < 3; i++)
        facts->pixdim[i] = real_at(b, v2, swap, v2 ? offsetof(nifti_2_header, pixdim) : offsetof(nifti_1_header, pixdim),
                                   i + 1);
    orientation_facts(b, v2, swap, facts);
    facts->scl_slope = real_at(b, v2, swap, FIELD(scl_slope), 0);
    facts->scl_inter = real_at(b, v2, swap, FIELD(scl_inter), 0);
    facts->intent_p1 = real_at(b, v2, swap, FIELD(intent_p1), 0);
    return 0;
}
