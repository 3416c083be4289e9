/* Interfile 3.3 images as STIR reads and writes them: a text header (.hv)
 * naming a data file (.v) beside it. */
#define _XOPEN_SOURCE 700 /* realpath */
#include <ctype.h>
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "atomic_file.h"
#include "cli.h"
#include "commands.h"
#include "image_formats.h"

/* Headers are a few kB; anything this big is not one. */
#define MAX_HEADER_BYTES (1 << 20)
#define TEXT_SIZE 4096

/* The keys petblur uses; counts are -1 and numbers NaN while not given. */
typedef struct interfile_header {
    int seen_interfile;
    char data_file[TEXT_SIZE];
    char number_format[TEXT_SIZE];
    char byte_order[TEXT_SIZE];
    long long bytes_per_pixel, matrix[3], data_offset, dimensions, frames;
    double scale[3], rescale_slope, rescale_offset, image_scale;
    double first_pixel_offset[3]; /* mm, the first voxel's centre in STIR's gantry frame */
    char patient_orientation[TEXT_SIZE], patient_rotation[TEXT_SIZE];
} interfile_header;

typedef enum key_kind { KEY_TEXT, KEY_COUNT, KEY_NUMBER } key_kind;

/* Keys as normalise_key leaves them: lower case, no '!', single spaces, no
 * spaces in or before the index. */
static const struct { const char *key; key_kind kind; size_t offset; } keys[] = {
    {"name of data file", KEY_TEXT, offsetof(interfile_header, data_file)},
    {"number format", KEY_TEXT, offsetof(interfile_header, number_format)},
    {"imagedata byte order", KEY_TEXT, offsetof(interfile_header, byte_order)},
    {"number of bytes per pixel", KEY_COUNT, offsetof(interfile_header, bytes_per_pixel)},
    {"matrix size[1]", KEY_COUNT, offsetof(interfile_header, matrix[0])},
    {"matrix size[2]", KEY_COUNT, offsetof(interfile_header, matrix[1])},
    {"matrix size[3]", KEY_COUNT, offsetof(interfile_header, matrix[2])},
    {"scaling factor (mm/pixel)[1]", KEY_NUMBER, offsetof(interfile_header, scale[0])},
    {"scaling factor (mm/pixel)[2]", KEY_NUMBER, offsetof(interfile_header, scale[1])},
    {"scaling factor (mm/pixel)[3]", KEY_NUMBER, offsetof(interfile_header, scale[2])},
    {"data offset in bytes[1]", KEY_COUNT, offsetof(interfile_header, data_offset)},
    {"data offset in bytes", KEY_COUNT, offsetof(interfile_header, data_offset)},
    {"number of dimensions", KEY_COUNT, offsetof(interfile_header, dimensions)},
    {"number of time frames", KEY_COUNT, offsetof(interfile_header, frames)},
    {"data rescale slope[1]", KEY_NUMBER, offsetof(interfile_header, rescale_slope)},
    {"data rescale slope", KEY_NUMBER, offsetof(interfile_header, rescale_slope)},
    {"data rescale offset[1]", KEY_NUMBER, offsetof(interfile_header, rescale_offset)},
    {"data rescale offset", KEY_NUMBER, offsetof(interfile_header, rescale_offset)},
    {"image scaling factor[1]", KEY_NUMBER, offsetof(interfile_header, image_scale)},
    {"image scaling factor", KEY_NUMBER, offsetof(interfile_header, image_scale)},
    {"first pixel offset (mm)[1]", KEY_NUMBER, offsetof(interfile_header, first_pixel_offset[0])},
    {"first pixel offset (mm)[2]", KEY_NUMBER, offsetof(interfile_header, first_pixel_offset[1])},
    {"first pixel offset (mm)[3]", KEY_NUMBER, offsetof(interfile_header, first_pixel_offset[2])},
    {"patient orientation", KEY_TEXT, offsetof(interfile_header, patient_orientation)},
    {"patient rotation", KEY_TEXT, offsetof(interfile_header, patient_rotation)},
};

static void init_header(interfile_header *h)
{
    memset(h, 0, sizeof *h);
    h->bytes_per_pixel = h->data_offset = h->dimensions = h->frames = -1;
    h->matrix[0] = h->matrix[1] = h->matrix[2] = -1;
    h->scale[0] = h->scale[1] = h->scale[2] = (double)NAN;
    h->rescale_slope = h->rescale_offset = h->image_scale = (double)NAN;
    for (int i = 0; i < 3; i++)
        h->first_pixel_offset[i] = (double)NAN;
}

/* Interfile keys are case-insensitive, may start with '!' and have free
 * spacing ("matrix size [1]" and "!Matrix Size[1]" are one key). */
static void normalise_key(const char *raw, char *out, size_t size)
{
    size_t n = 0;
    int space = 0, in_index = 0;
    while (isspace((unsigned char)*raw))
        raw++;
    if (*raw == '!')
        raw++;
    for (; *raw && n + 2 < size; raw++) {
        unsigned char c = (unsigned char)*raw;
        if (isspace(c)) {
            space = 1;
            continue;
        }
        in_index = c == '[' ? 1 : in_index;
        if (space && n > 0 && !in_index)
            out[n++] = ' ';
        space = 0;
        in_index = c == ']' ? 0 : in_index;
        out[n++] = (char)tolower(c);
    }
    out[n] = '\0';
}

static char *trim(char *s)
{
    while (isspace((unsigned char)*s))
        s++;
    size_t n = strlen(s);
    while (n > 0 && isspace((unsigned char)s[n - 1]))
        s[--n] = '\0';
    return s;
}

static int store_value(const char *path, int line, const char *key, key_kind kind, char *value, void *field)
{
    char *end;
    errno = 0;
    if (kind == KEY_TEXT) {
        if (strlen(value) >= TEXT_SIZE)
            return pbc_fail(PBC_EXIT_USAGE, "%s:%d: the value of '%s' is too long; shorten it", path, line, key);
        strcpy(field, value);
    } else if (kind == KEY_COUNT) {
        long long v = strtoll(value, &end, 10);
        if (end == value || *end || errno || v < 0)
            return pbc_fail(PBC_EXIT_USAGE, "%s:%d: '%s' should be a whole number >= 0, not '%s'; fix the header",
                            path, line, key, value);
        *(long long *)field = v;
    } else {
        double v = strtod(value, &end);
        if (end == value || *end || !isfinite(v))
            return pbc_fail(PBC_EXIT_USAGE, "%s:%d: '%s' should be a number, not '%s'; fix the header", path, line,
                            key, value);
        *(double *)field = v;
    }
    return 0;
}

/* Returns 0 to go on, 1 at "!END OF INTERFILE", or an exit status (> 1). */
static int parse_line(const char *path, int line, char *text, interfile_header *h)
{
    char *comment = strchr(text, ';');
    if (comment)
        *comment = '\0';
    char *sep = strstr(text, ":=");
    if (!sep)
        return 0;
    *sep = '\0';
    char key[256];
    normalise_key(text, key, sizeof key);
    if (!h->seen_interfile && strcmp(key, "interfile") != 0)
        return pbc_fail(PBC_EXIT_USAGE, "%s: not an Interfile header (its first key is not '!INTERFILE :='); check "
                        "the file", path);
    h->seen_interfile = 1;
    if (!strcmp(key, "end of interfile"))
        return 1;
    for (size_t i = 0; i < sizeof keys / sizeof keys[0]; i++)
        if (!strcmp(key, keys[i].key))
            return store_value(path, line, trim(text), keys[i].kind, trim(sep + 2), (char *)h + keys[i].offset);
    return 0;
}

static int parse_header(const char *path, char *text, interfile_header *h)
{
    init_header(h);
    int line = 1;
    for (char *p = text; p; line++) {
        char *next = strchr(p, '\n');
        if (next)
            *next++ = '\0';
        int rc = parse_line(path, line, p, h);
        if (rc == 1)
            break;
        if (rc)
            return rc;
        p = next;
    }
    if (!h->seen_interfile)
        return pbc_fail(PBC_EXIT_USAGE, "%s: not an Interfile header (no '!INTERFILE :=' line); check the file",
                        path);
    return 0;
}

/* The header is NUL-terminated in a malloc'ed buffer. */
static int load_header(const char *path, char **text)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return pbc_fail(PBC_EXIT_USAGE, "%s: cannot read it (%s); check the path", path, strerror(errno));
    *text = malloc(MAX_HEADER_BYTES + 1);
    size_t n = *text ? fread(*text, 1, MAX_HEADER_BYTES + 1, f) : 0;
    int failed = ferror(f);
    fclose(f);
    if (!*text)
        return pbc_fail(PBC_EXIT_RUNTIME, "%s: not enough memory to read the header", path);
    (*text)[n > MAX_HEADER_BYTES ? MAX_HEADER_BYTES : n] = '\0';
    if (failed)
        return pbc_fail(PBC_EXIT_USAGE, "%s: cannot read it (%s); check the file", path, strerror(errno));
    if (n > MAX_HEADER_BYTES)
        return pbc_fail(PBC_EXIT_USAGE, "%s: more than 1 MiB, too big for an Interfile header; check that it is "
                        "the .hv header and not the data", path);
    return 0;
}

static int missing(const char *path, const char *key, const char *what)
{
    return pbc_fail(PBC_EXIT_USAGE, "%s: the key '%s' is missing; add it to the header (%s)", path, key, what);
}

static int sample_type(const char *path, const interfile_header *h, pbc_sample_type *type)
{
    static const struct { const char *format; long long bytes; pbc_sample_type type; } types[] = {
        {"float", 4, PBC_SAMPLE_F32}, {"float", 8, PBC_SAMPLE_F64},
        {"short float", 4, PBC_SAMPLE_F32}, {"long float", 8, PBC_SAMPLE_F64},
        {"signed integer", 1, PBC_SAMPLE_I8}, {"signed integer", 2, PBC_SAMPLE_I16},
        {"signed integer", 4, PBC_SAMPLE_I32}, {"unsigned integer", 1, PBC_SAMPLE_U8},
        {"unsigned integer", 2, PBC_SAMPLE_U16}, {"unsigned integer", 4, PBC_SAMPLE_U32},
    };
    char format[64];
    normalise_key(h->number_format, format, sizeof format);
    if (!format[0])
        return missing(path, "!number format", "float, signed integer or unsigned integer");
    int known = 0;
    for (size_t i = 0; i < sizeof types / sizeof types[0]; i++) {
        if (strcmp(format, types[i].format) != 0)
            continue;
        known = 1;
        /* "short float" and "long float" say their size themselves. */
        int implied = h->bytes_per_pixel < 0 && strcmp(format, "float") != 0 && !strstr(format, "integer");
        if (h->bytes_per_pixel == types[i].bytes || implied) {
            *type = types[i].type;
            return 0;
        }
    }
    if (!known)
        return pbc_fail(PBC_EXIT_USAGE, "%s: '!number format := %s' is not supported; petblur reads float, short "
                        "float, long float, signed integer and unsigned integer", path, h->number_format);
    if (h->bytes_per_pixel < 0)
        return missing(path, "!number of bytes per pixel", "the size of one voxel's value, e.g. 4 for float");
    return pbc_fail(PBC_EXIT_USAGE, "%s: '!number of bytes per pixel := %lld' does not fit '!number format := %s'; "
                    "fix the header", path, h->bytes_per_pixel, h->number_format);
}

/* Interfile 3.3 makes big-endian the default. */
static int byte_order(const char *path, const interfile_header *h, int *big_endian)
{
    char order[32];
    normalise_key(h->byte_order, order, sizeof order);
    *big_endian = !order[0] || !strcmp(order, "bigendian");
    if (order[0] && !*big_endian && strcmp(order, "littleendian") != 0)
        return pbc_fail(PBC_EXIT_USAGE, "%s: 'imagedata byte order := %s' is neither LITTLEENDIAN nor BIGENDIAN; fix "
                        "the header", path, h->byte_order);
    return 0;
}

static int check_shape(const char *path, const interfile_header *h)
{
    static const char *const size_keys[] = {"!matrix size [1]", "!matrix size [2]", "!matrix size [3]"};
    static const char *const size_whats[] = {"the number of voxels along x", "the number of voxels along y",
                                             "the number of voxels along z"};
    if (h->dimensions >= 0 && h->dimensions != 3)
        return pbc_fail(PBC_EXIT_USAGE, "%s: 'number of dimensions := %lld', but petblur reads 3-D images only; "
                        "give it a 3-D image", path, h->dimensions);
    if (h->frames > 1)
        return pbc_fail(PBC_EXIT_USAGE, "%s: has %lld time frames and petblur blurs one 3-D volume; extract one "
                        "frame first (e.g. with STIR's extract_single_images_from_dynamic_image)", path, h->frames);
    for (int i = 0; i < 3; i++)
        if (h->matrix[i] < 0)
            return missing(path, size_keys[i], size_whats[i]);
    if (!h->data_file[0])
        return missing(path, "!name of data file", "the data file's name, relative to the header's folder");
    return 0;
}

/* Everything but the data file from a parsed header; a missing voxel size is
 * left 0 for --voxel-size to fill in. */
static int take_header(const char *path, const interfile_header *h, pbc_image *img, pbc_sample_format *format,
                       long long *offset)
{
    int big_endian;
    int rc = check_shape(path, h);
    if (!rc)
        rc = sample_type(path, h, &format->type);
    if (!rc)
        rc = byte_order(path, h, &big_endian);
    if (rc)
        return rc;
    format->swap = big_endian != pbc_host_is_big_endian();
    double image_scale = isnan(h->image_scale) ? 1 : h->image_scale;
    format->slope = image_scale * (isnan(h->rescale_slope) ? 1 : h->rescale_slope);
    format->inter = image_scale * (isnan(h->rescale_offset) ? 0 : h->rescale_offset);
    for (int i = 0; i < 3; i++) {
        img->dims[i] = (size_t)h->matrix[i];
        img->voxel_size[i] = isnan(h->scale[i]) ? 0 : h->scale[i];
    }
    *offset = h->data_offset >= 0 ? h->data_offset : 0;
    return 0;
}

/* Where a header's data file may live (docs/cli.md, "Outputs"): named
 * relative to the header, without "..", and, once every link on the way is
 * resolved, inside the header's folder or below it, as STIR writes it. A link
 * inside that folder is fine (git-annex and DataLad keep data as links), one
 * that leads out of it is not: a header is small and easily sent, and must not
 * make petblur read /etc/passwd or ~/.ssh as voxels, block on a FIFO, or write
 * an output over a file elsewhere. */
static int check_data_name(const char *path, const char *name)
{
    int up = !strcmp(name, "..") || !strncmp(name, "../", 3) || strstr(name, "/../") ||
             (strlen(name) >= 3 && !strcmp(name + strlen(name) - 3, "/.."));
    if (name[0] == '/' || up)
        return pbc_fail(PBC_EXIT_USAGE, "%s: its data file '%s' lies outside the header's folder; petblur reads data "
                        "files named beside their header or below it, as STIR writes them (move the pair together "
                        "and name the data file relative to the header)", path, name);
    return 0;
}

static int check_data_file(const char *path, const char *data_path)
{
    struct stat st;
    if (stat(data_path, &st) != 0)
        return pbc_fail(PBC_EXIT_USAGE, "%s: cannot open its data file %s (%s); check '!name of data file' in the "
                        "header, or put the data file beside the header", path, data_path, strerror(errno));
    if (!S_ISREG(st.st_mode))
        return pbc_fail(PBC_EXIT_USAGE, "%s: its data file %s is %s, not a file of voxels; check '!name of data "
                        "file'", path, data_path, S_ISDIR(st.st_mode) ? "a folder" : "a device, pipe or socket");
    return 0;
}

/* The name's "inside" once links are resolved: the data file's real path
 * starts with the real path of the header's folder. */
static int check_data_inside(const char *path, const char *data_path)
{
    /* The folders on the way must stay inside the header's folder; the file
     * itself may be a link to a regular file anywhere, as git-annex and
     * DataLad keep data (check_data_file has made sure it is one). */
    char dir[PATH_MAX], data_dir[PATH_MAX], folder[PATH_MAX], real[PATH_MAX];
    const char *slash = strrchr(path, '/'), *data_slash = strrchr(data_path, '/');
    snprintf(dir, sizeof dir, "%.*s", slash ? (int)(slash - path) + 1 : 1, slash ? path : ".");
    snprintf(data_dir, sizeof data_dir, "%.*s", data_slash ? (int)(data_slash - data_path) + 1 : 1,
             data_slash ? data_path : ".");
    if (!realpath(dir, folder) || !realpath(data_dir, real))
        return pbc_fail(PBC_EXIT_USAGE, "%s: cannot resolve its data file %s (%s); check the header's folder and "
                        "'!name of data file'", path, data_path, strerror(errno));
    size_t n = strlen(folder);
    int root = n == 1; /* "/": everything is below it */
    if (!strncmp(real, folder, n) && (root || real[n] == '/' || real[n] == '\0'))
        return 0;
    return pbc_fail(PBC_EXIT_USAGE, "%s: its data file %s lies in %s, outside the header's folder %s (through a link "
                    "to a folder); petblur reads data files only in their header's folder or below it: copy the data "
                    "file there (cp --dereference), or move the header beside it", path, data_path, real, folder);
}

/* A relative data file name is relative to the header's folder. */
static int data_file_path(const char *path, const char *name, char *out, size_t size)
{
    const char *slash = strrchr(path, '/');
    int dirlen = !slash ? 0 : (int)(slash - path + 1);
    if (snprintf(out, size, "%.*s%s", dirlen, path, name) >= (int)size)
        return pbc_fail(PBC_EXIT_USAGE, "%s: the path of its data file is too long; move the files to a shorter "
                        "path", path);
    return 0;
}

/* The data file of a parsed header, by the rule above. */
static int locate_data(const char *path, const interfile_header *h, char *out, size_t size)
{
    int rc = h->data_file[0] ? 0 : missing(path, "!name of data file", "the data file's name, relative to the "
                                           "header's folder");
    if (!rc)
        rc = check_data_name(path, h->data_file);
    if (!rc)
        rc = data_file_path(path, h->data_file, out, size);
    if (!rc)
        rc = check_data_file(path, out);
    return rc ? rc : check_data_inside(path, out);
}

int pbc_interfile_data_of(const char *path, char *data, size_t size)
{
    char *text = NULL;
    interfile_header h;
    int rc = load_header(path, &text);
    if (!rc)
        rc = parse_header(path, text, &h);
    free(text);
    return rc ? rc : locate_data(path, &h, data, size);
}

static int read_data(const char *path, const char *data_path, long long offset, const pbc_sample_format *format,
                     pbc_image *img)
{
    int rc = 0;
    FILE *f = fopen(data_path, "rb");
    if (!f)
        return pbc_fail(PBC_EXIT_USAGE, "%s: cannot open its data file %s (%s); check '!name of data file' in the "
                        "header, or put the data file beside the header", path, data_path, strerror(errno));
    struct stat st;
    size_t n = pbc_image_voxels(img), size = pbc_sample_size(format->type);
    if (fstat(fileno(f), &st) != 0)
        rc = pbc_fail(PBC_EXIT_USAGE, "%s: cannot read its data file %s (%s)", path, data_path, strerror(errno));
    else if (st.st_size < offset || st.st_size - offset < (long long)(n * size))
        rc = pbc_fail(PBC_EXIT_USAGE, "%s: its data file %s has %lld bytes, too few for %zu voxels of %zu bytes from "
                      "byte %lld on; the data file is truncated or the header is wrong", path, data_path,
                      (long long)st.st_size, n, size, offset);
    else if (fseeko(f, (off_t)offset, SEEK_SET) != 0)
        rc = pbc_fail(PBC_EXIT_USAGE, "%s: cannot seek to byte %lld of its data file %s (%s)", path, offset,
                      data_path, strerror(errno));
    else
        rc = pbc_samples_read(data_path, pbc_read_stdio, f, format, img);
    fclose(f);
    return rc;
}

int pbc_interfile_read(const char *path, const pbc_read_hints *hints, pbc_image *img)
{
    char *text = NULL;
    interfile_header h;
    pbc_sample_format format;
    long long offset = 0;
    char data_path[2 * TEXT_SIZE];
    int rc = load_header(path, &text);
    if (!rc)
        rc = parse_header(path, text, &h);
    free(text);
    if (!rc)
        rc = take_header(path, &h, img, &format, &offset);
    if (!rc)
        rc = locate_data(path, &h, data_path, sizeof data_path);
    if (!rc)
        rc = pbc_image_prepare(path, hints, img);
    double affine[16];
    if (!rc && !(rc = pbc_stir_affine(path, h.patient_orientation, h.patient_rotation, h.first_pixel_offset,
                                      img->dims, img->voxel_size, affine)))
        pbc_orientation_set_affine(&img->orientation, affine);
    if (!rc && snprintf(img->source, sizeof img->source, "%s", data_path) >= (int)sizeof img->source)
        rc = pbc_fail(PBC_EXIT_USAGE, "%s: the path of its data file is too long; move the files to a shorter path",
                      path);
    return rc ? rc : read_data(path, data_path, offset, &format, img);
}

/* As short as reads back to the same double. */
static void format_number(double v, char *out, size_t size)
{
    snprintf(out, size, "%.15g", v);
    if (strtod(out, NULL) != v)
        snprintf(out, size, "%.17g", v);
}

/* STIR's placement keys of an image; `placed` is 0 when it has none to write. */
typedef struct stir_keys {
    int placed;
    const char *orientation, *rotation;
    double fpo[3];
} stir_keys;

/* The header in the form STIR writes for an image. */
static void write_header(FILE *f, const char *data_name, const pbc_image *img, const stir_keys *placement)
{
    fprintf(f, "!INTERFILE  :=\n!imaging modality := PT\n!version of keys := 3.3\n!GENERAL DATA :=\n"
            "!name of data file := %s\n!GENERAL IMAGE DATA :=\n!type of data := PET\n"
            "imagedata byte order := LITTLEENDIAN\n!PET STUDY (General) :=\n!PET data type := Image\n"
            "process status := Reconstructed\n!number format := float\n!number of bytes per pixel := 4\n"
            "number of dimensions := 3\n", data_name);
    for (int i = 0; i < 3; i++) {
        char size[32];
        format_number(img->voxel_size[i], size, sizeof size);
        fprintf(f, "matrix axis label [%d] := %c\n!matrix size [%d] := %zu\nscaling factor (mm/pixel) [%d] := %s\n",
                i + 1, "xyz"[i], i + 1, img->dims[i], i + 1, size);
    }
    if (placement->placed) {
        fprintf(f, "patient orientation := %s\npatient rotation := %s\n", placement->orientation, placement->rotation);
        for (int i = 0; i < 3; i++) {
            char v[32];
            format_number(placement->fpo[i], v, sizeof v);
            fprintf(f, "first pixel offset (mm) [%d] := %s\n", i + 1, v);
        }
    }
    fputs("number of time frames := 1\nimage scaling factor[1] := 1\ndata offset in bytes[1] := 0\n"
          "quantification units := 1\n!END OF INTERFILE :=\n", f);
}

/* OUT.hv's data goes to OUT.v, as STIR names it. */
int pbc_interfile_data_name(const char *path, char *out, size_t size)
{
    if (snprintf(out, size, "%.*s.v", (int)strlen(path) - 3, path) >= (int)size)
        return pbc_fail(PBC_EXIT_USAGE, "%s: the output path is too long; choose a shorter one", path);
    return 0;
}

/* The data file is moved into place first and the header last, so that a
 * header never names data that is not there. */
int pbc_interfile_write(const char *path, const pbc_image *img)
{
    char data_path[4096];
    int rc = pbc_interfile_data_name(path, data_path, sizeof data_path);
    if (rc)
        return rc;
    stir_keys stir = {0, NULL, NULL, {0, 0, 0}};
    double affine[16];
    int has_affine = pbc_image_affine(img, affine);
    if (has_affine)
        stir.placed = pbc_stir_placement(affine, img->voxel_size, &stir.orientation, &stir.rotation, stir.fpo);
    if (has_affine && !stir.placed)
        fprintf(stderr, "petblur: warning: %s: Interfile places an image only along STIR's gantry axes, head or feet "
                "first, supine or prone; this image's affine is oblique or mirrored otherwise, so the header "
                "carries no placement (write NIfTI to keep it)\n", path);
    const char *slash = strrchr(data_path, '/');
    pbc_temp data_temp, header_temp;
    FILE *data, *header;
    rc = pbc_raw_write_temp(data_path, img, &data_temp, &data);
    if (rc)
        return rc;
    rc = pbc_temp_open(&header_temp, path, &header);
    if (rc) {
        pbc_temp_abort(&data_temp, data);
        return rc;
    }
    write_header(header, slash ? slash + 1 : data_path, img, &stir);
    /* An existing pair stays whole until the new one is: the old data file is
     * kept under a second name (a hard link) until the new header is in
     * place, and put back if that fails. */
    pbc_temp backup;
    int kept = 0;
    rc = pbc_backup_make(&backup, data_path, &kept);
    if (rc) {
        pbc_temp_abort(&header_temp, header);
        pbc_temp_abort(&data_temp, data);
        return rc;
    }
    rc = pbc_temp_commit(&data_temp, data);
    int moved = rc == 0;
    if (rc)
        pbc_temp_abort(&header_temp, header);
    else
        rc = pbc_temp_commit(&header_temp, header);
    if (!rc) {
        if (kept)
            pbc_backup_drop(&backup);
        return 0;
    }
    /* A failure leaves the old pair as it was; new data without its header
     * would be an orphan nobody can read. */
    int restored = kept && pbc_backup_restore(&backup) == 0;
    if (moved && !restored)
        unlink(data_path);
    return rc;
}
