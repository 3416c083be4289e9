/* Non-rigid motion from the command line: --fields TABLE.csv, a table of
 * registrations' displacement fields (NIfTI files) and their times, read
 * into the library's pb_field_motion on an image's grid (petblur.h,
 * "non-rigid motion: deformation fields"). The table (field_table.c), the
 * files and their conventions (field_load.c), and a frame's blur and
 * summary (field_frames.c). */
#ifndef PBC_FIELDS_H
#define PBC_FIELDS_H

#include <stdio.h>

#include "commands.h"
#include "image_io.h"
#include "options.h"
#include "petblur.h"

/* The option rows of blur and motion. */
#define PBC_FIELD_OPTIONS                                                                                             \
    {"--fields", NULL, "TABLE.csv", "non-rigid motion instead of a track: a table 'time,path' of NIfTI displacement " \
                                    "fields (s; paths relative to the table), world mm on any grid; 'value,path': "  \
                                    "fields at a surrogate's values, with --signal"},                                \
    {"--field-convention", NULL, "nifti|niftyreg|itk", "the fields' vectors: RAS displacements (intent 1006), "      \
                                                       "NiftyReg's or SIRF's (intent_p1 0: deformation, 1: "          \
                                                       "displacement), ITK's/ANTs' LPS displacements; default: told " \
                                                       "by each file's intent, else refused"}

/* A table's rows at most: a breathing cycle's gates or a dynamic series'
 * frames are tens to hundreds; more is a mistake, refused before anything
 * is read. */
enum { PBC_MAX_FIELDS = 10000 };
/* A surrogate's samples at most: a day at 25 Hz is 2.2 million; the file is
 * refused by its size before it is read. */
enum { PBC_MAX_SIGNAL = 4000000 };

/* blur's option rows of a surrogate-driven motion. */
#define PBC_SIGNAL_OPTIONS                                                                                            \
    {"--signal", NULL, "TRACE.csv", "a surrogate (a belt) 'time,value', s: with a 'value,path' --fields table the "  \
                                    "motion at t is the field at its value then; with --gates it bins fields or a "  \
                                    "track alike"},                                                                   \
    {"--gates", NULL, "E0,E1,...", "with --signal: amplitude gates [Ei, Ei+1), each every visit of the signal there "  \
                                   "in the --frame (default: the whole signal); OUT a 4-D NIfTI, a gate a frame"}

typedef enum pbc_field_convention {
    PBC_FIELDS_AUTO = -1, /* told by each file: intent 1006, or 1007 with NiftyReg's name */
    PBC_FIELDS_NIFTI,
    PBC_FIELDS_NIFTYREG,
    PBC_FIELDS_ITK
} pbc_field_convention;

typedef struct pbc_fields {
    const char *table;      /* --fields; NULL when not given */
    int convention;         /* a pbc_field_convention */
    size_t rows;
    double *times;          /* the table's times, seconds, increasing */
    char **paths;           /* the table's files, relative ones resolved against its folder */
    int has_frame;
    double frame[2];        /* --frame, else the table's first and last time */
    /* Once loaded (pbc_fields_load): the rows first .. first + motion.count - 1 that the frames cover. */
    size_t first;
    float *vectors;         /* the library's layout: mm along the image grid's axes */
    pbc_vector_header grid; /* the files' grid */
    pb_geometry geometry;   /* the image's grid */
    pb_field_motion motion;
    /* A surrogate (--signal): the table's times are then its values. */
    int by_value;           /* the table's header is 'value,path' */
    const char *signal_path;
    size_t signal_count;
    double *signal_times, *signal;
    /* --gates: gates = edges - 1 of them, gate g the intervals counts[g], one after the other. */
    size_t gates;
    double *edges, *intervals;
    size_t *counts;
} pbc_fields;

/* --fields and --field-convention, checked against the track options and
 * --frame; the table read (field_table.c). With no --fields, f->table is
 * NULL and nothing else is done. Returns 0 or an exit status after the
 * message. */
int pbc_fields_from_args(const pbc_command *cmd, const pbc_args *args, pbc_fields *f);
/* Reads the table: "time,path" then a row per field. */
int pbc_field_table_read(const char *table, pbc_fields *f);

/* --signal and --gates (blur): the trace read, the value table paired with
 * it (or, with no --fields, the track's gates: --gates required), the
 * gates' intervals computed over the --frame (or the whole signal); a gate
 * the signal never visits refused. Returns 0 or an exit status. */
int pbc_fields_signal(const pbc_command *cmd, const pbc_args *args, pbc_fields *f);
/* Reads a surrogate's trace: "time,value" then a row per sample. */
int pbc_signal_read(const char *path, pbc_fields *f);
/* Gate g = [edges[g], edges[g+1]), g < gates: every interval of [t0, t1]
 * (inside [t[0], t[n-1]]) where the signal s, linear between its n >= 2
 * samples at increasing times t, lies in it, touching ones merged. Writes
 * counts[g] (if counts) and the intervals one gate after the other, a start
 * and an end each (if intervals); returns how many there are in all. Call
 * it with NULLs first to size intervals. */
size_t pbc_amplitude_gates(const double *t, const double *s, size_t n, const double *edges, size_t gates, double t0,
                           double t1, double *intervals, size_t *counts);

/* Adds the table and every file it names to the files a command reads. */
void pbc_fields_files(const pbc_fields *f, pbc_files *files);

/* Reads the fields that frames bounds[0..frames] (NULL: the --frame) cover
 * onto img's grid (NULL: the fields' own grid, for petblur motion without
 * -i): every file checked (shape, grid, finite values, convention), the map
 * from image to field voxels made from the two affines, the vectors turned
 * from world mm into the grid's frame; a fold is a warning. Returns 0 or an
 * exit status after the message, which names the file and the fix. */
int pbc_fields_load(pbc_fields *f, const pbc_image *img, const char *in_path, const double *bounds, size_t frames);

void pbc_fields_free(pbc_fields *f);

/* As pbc_blur_frames_image (blur_run.h), along the loaded fields: frames
 * bounds[0..frames] (NULL: f->gates frames, the --gates, if any, else the one
 * frame f->motion gives). */
int pbc_blur_fields_image(pb_context *ctx, const pbc_image *in, const pbc_fields *f, const double *bounds,
                          size_t frames, const pb_blur_options *options, int adjoint, int sum, const char *label,
                          float *out, double *ms);

/* What frame [t0, t1] of the loaded fields does: the field samples it
 * walks (its ends and the field times inside), and the largest displacement
 * of any field voxel from where the frame's first field puts it, mm. */
void pbc_fields_frame_summary(const pbc_fields *f, double t0, double t1, size_t *samples, double *max_mm);

/* The tables' text (field_table.c, shared with signal.c): a cell without
 * its surrounding blanks and line end, in place; two header words equal but
 * for case. */
char *pbc_field_trim(char *s);
int pbc_field_same_words(const char *a, const char *b);
/* The next row of such a table into buf (size bytes: its longest line and
 * two), trimmed, a byte-order mark dropped from line 1, blank lines skipped;
 * *line counts the lines read. 0 with *row NULL at the end; an exit status
 * for a line too long, naming option, path and the row's form. */
int pbc_field_next_row(FILE *in, char *buf, size_t size, size_t *line, char **row, const char *option,
                       const char *path, const char *form);

#endif
