/*
 * petblur: 3-D motion blur of PET activity volumes on GPUs and CPUs.
 *
 * One header, plain C99. All handles are opaque; every call returns a pb_status
 * (0 = OK, negative = error) and, on error, leaves a message in the context's
 * last-error text that says what went wrong and how to fix it. The library never
 * prints, exits or aborts.
 *
 * Conventions (the same on every backend):
 *  - Volumes are float32, x fastest: value (i, j, k) sits at i + nx * (j + ny * k).
 *  - Positions are in mm from the grid's corner; voxel i spans [i*d, (i+1)*d] and
 *    its centre is (i + 0.5) * d. Outside the grid the activity is zero.
 *  - A pose maps object space to tomograph space:
 *        p_tomo = R(q) (p_obj - c) + c + t
 *    with t in mm, q a unit quaternion (w, x, y, z) and c the rotation centre
 *    (default: the grid's centre).
 */
#ifndef PETBLUR_H
#define PETBLUR_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(_WIN32) && defined(PB_BUILDING_LIBRARY)
#define PB_API __declspec(dllexport)
#elif defined(PB_BUILDING_LIBRARY)
#define PB_API __attribute__((visibility("default")))
#else
#define PB_API
#endif

/* Status codes, grouped in numeric ranges. */
typedef enum pb_status {
    PB_OK = 0,

    /* -1 .. -99: arguments and inputs */
    PB_ERR_INVALID_ARGUMENT = -1,  /* NULL pointer, unknown enum, bad option value */
    PB_ERR_ZERO_DIMS = -2,         /* a volume dimension is zero */
    PB_ERR_BAD_VOXEL_SIZE = -3,    /* a voxel size is zero, negative or not finite */
    PB_ERR_NOT_FINITE = -4,        /* NaN or infinity in a time, translation, quaternion or centre */
    PB_ERR_BAD_QUATERNION = -5,    /* a zero quaternion, or one far from unit norm */
    PB_ERR_BAD_FRAME = -6,         /* the frame's end is not after its start */
    PB_ERR_TRACK_ORDER = -7,       /* track times are not strictly increasing, or fewer than 2 poses */
    PB_ERR_TRACK_GAP = -8,         /* the track does not cover the whole frame */
    PB_ERR_SIZE_MISMATCH = -9,     /* two volumes differ in size, or belong to different contexts */
    PB_ERR_AFFINE_SHEAR = -10,     /* a voxel-to-world affine whose axes are not perpendicular (a shear) */
    PB_ERR_NOT_RIGID = -11,        /* a pose matrix that is not a rotation plus a translation */
    PB_ERR_OUT_OF_VIEW = -12,      /* the motion takes the whole grid out of the field of view for a whole frame */

    /* -200 .. -299: backends and devices */
    PB_ERR_BACKEND_UNAVAILABLE = -200, /* the backend was not compiled into this build */
    PB_ERR_NO_DEVICE = -201,           /* no device of the backend, or no device with that index */
    PB_ERR_NO_IMAGE_SUPPORT = -202,    /* the device cannot hold 3-D float images with linear filtering */
    PB_ERR_VOLUME_TOO_LARGE = -203,    /* beyond the device's 3-D image limits */
    PB_ERR_DEVICE = -204,              /* a runtime call failed; the last-error text has the native detail */

    /* -300 .. -399: kernel build */
    PB_ERR_BUILD = -300, /* the kernel did not compile; the last-error text holds the build log */

    /* -400 .. -499: kernel launch */
    PB_ERR_LAUNCH = -400,

    /* -500 .. -599: memory */
    PB_ERR_OUT_OF_MEMORY = -500, /* host or device memory */

    /* -600 .. -699: files */
    PB_ERR_BAD_FILE = -600 /* a file that cannot be opened or read, or whose content is malformed */
} pb_status;

/* A short fixed description of a status ("out of memory"). Never NULL. */
PB_API const char *pb_status_string(pb_status status);

/* A double as the shortest decimal that reads back to the same double ("0.1",
 * "10000", "1000.0000001", "1e+300"), in the C locale whatever the program's:
 * how petblur writes every number in its files and quotes values in its
 * messages. out holds PB_NUMBER_TEXT_SIZE bytes; returns out. */
#define PB_NUMBER_TEXT_SIZE 32
PB_API const char *pb_number_text(double v, char *out);

typedef enum pb_backend {
    PB_BACKEND_AUTO = 0, /* CUDA if a GPU is there, else an OpenCL GPU, else OpenCL on the CPU */
    PB_BACKEND_HOST = 1, /* plain C, double precision: the reference, slow */
    PB_BACKEND_OPENCL = 2,
    PB_BACKEND_CUDA = 3
} pb_backend;

PB_API const char *pb_backend_name(pb_backend backend);

/* Parses a device name as the command line takes it: "auto", "host",
 * "opencl", "opencl:N", "cuda" or "cuda:N" (N from 0). */
PB_API pb_status pb_device_parse(const char *spec, pb_backend *backend, int *index);

/* 1 when the backend was compiled into this build (it may still find no device). */
PB_API int pb_backend_compiled(pb_backend backend);

typedef struct pb_device_info {
    char name[256];     /* "NVIDIA H100 80GB HBM3", "pthread-skylake-avx512-..." */
    char platform[256]; /* OpenCL platform, "CUDA" or "host" */
    int is_gpu;
    int image_support;         /* 3-D float images with linear filtering */
    size_t image3d_max[3];     /* largest 3-D image (x, y, z); 0 = no limit */
    uint64_t max_alloc_bytes;  /* largest single allocation; 0 = no limit known */
    uint64_t global_mem_bytes; /* 0 = unknown */
    unsigned compute_units;
} pb_device_info;

/* Devices of a backend (PB_BACKEND_AUTO is not a backend here). A backend that
 * is compiled in but finds no device reports a count of 0 and PB_OK. */
PB_API pb_status pb_device_count(pb_backend backend, int *count);
PB_API pb_status pb_device_get_info(pb_backend backend, int index, pb_device_info *info);

/* The device "auto" means for pb_motion_estimate: a GPU where there is one
 * (CUDA, else an OpenCL GPU), as for a blur; else the host backend. The
 * estimate runs small blurs between host work, and an OpenCL CPU device
 * (PoCL) ran it slower than the host backend on the same cores (2.5 s
 * against 6.9 s for 12 frames of 16^3, 15 s against 20 s for 8 frames of
 * 32^3; docs/motion.md); without any device the host backend runs it too. */
PB_API pb_status pb_device_auto_estimate(pb_backend *backend, int *index);

typedef struct pb_context pb_context;

typedef struct pb_context_options {
    pb_backend backend; /* PB_BACKEND_AUTO by zero-initialisation */
    int device_index;   /* within the backend; ignored for AUTO and HOST */
    /* Extra OpenCL compiler options (for example "-cl-fast-relaxed-math"); NULL for
     * none. Ignored by the host and CUDA backends. */
    const char *build_options;
} pb_context_options;

/* Creates a context on a device and, for device backends, builds the kernels
 * once. options may be NULL (auto). On failure *ctx is NULL and the message is
 * in pb_last_error(NULL) of the calling thread. */
PB_API pb_status pb_context_create(const pb_context_options *options, pb_context **ctx);
/* Releases the context once its last volume and plan are destroyed: they may
 * be destroyed before or after it, in any order (as garbage-collected bindings
 * do). After pb_context_destroy the context must not be used again; its
 * plans and volumes still work. A context, its volumes and its plans take one
 * thread at a time (they share the context's queue, kernels and timers): a
 * call made while another thread works in the context is refused
 * (PB_ERR_INVALID_ARGUMENT) and does nothing. */
PB_API void pb_context_destroy(pb_context *ctx);

/* The backend and device the context runs on. */
PB_API pb_backend pb_context_backend(const pb_context *ctx);
PB_API pb_status pb_context_device_info(const pb_context *ctx, pb_device_info *info);

/* What the context did that works but that its user may want to change, one
 * line each: "NVRTC: the cache folder ... cannot be used (...); set
 * PETBLUR_CACHE_DIR ..." where compiled kernels could not be kept. "" when
 * there is nothing. The library never prints: a front end shows these. */
PB_API const char *pb_context_notes(const pb_context *ctx);

/* The message of a failure. pb_last_error(NULL): the calling thread's last
 * failed call, whatever it was given (every failing call writes it, so it
 * always matches the status just returned on this thread). pb_last_error(ctx):
 * the last failed call on ctx, from whichever thread used it. "" when there
 * was none. Successful calls leave both as they were. */
PB_API const char *pb_last_error(const pb_context *ctx);

/* Progress of long work (REF on large volumes on a CPU takes minutes): fn is
 * called from the thread in pb_blur with the fraction done, between pieces of
 * the work, and with 1 at the end. Every backend then runs the volume in
 * slabs of z-slices (a little slower: one launch and wait per slab). fn ==
 * NULL (the default) turns it off. */
typedef void (*pb_progress_fn)(double fraction, void *user);
PB_API pb_status pb_context_set_progress(pb_context *ctx, pb_progress_fn fn, void *user);

/* Kernel time in milliseconds of the context's last blur or adjoint (a
 * one-shot call or a plan's; for frames, their total), from device events
 * (OpenCL profiling events, CUDA events) or the host clock. After a call
 * queued on a caller's stream (pb_context_set_stream) it waits for that call. */
PB_API pb_status pb_context_last_kernel_ms(const pb_context *ctx, double *ms);

/* ---- volumes ----------------------------------------------------------- */

typedef struct pb_geometry {
    size_t dims[3];        /* nx, ny, nz; any size, not only cubes */
    double voxel_size[3];  /* mm, from PB_MIN_VOXEL_MM to PB_MAX_VOXEL_MM */
} pb_geometry;
/* Voxel sizes petblur takes: a tenth of a micrometre to ten metres. */
#define PB_MIN_VOXEL_MM 1e-4
#define PB_MAX_VOXEL_MM 1e4

typedef struct pb_volume pb_volume;

/* A float32 volume held on the context's device, uninitialised until uploaded
 * or written by pb_blur. */
PB_API pb_status pb_volume_create(pb_context *ctx, const pb_geometry *geometry, pb_volume **volume);
PB_API void pb_volume_destroy(pb_volume *volume);
PB_API pb_status pb_volume_get_geometry(const pb_volume *volume, pb_geometry *geometry);
/* host holds nx*ny*nz floats, x fastest. */
PB_API pb_status pb_volume_upload(pb_volume *volume, const float *host);
PB_API pb_status pb_volume_download(const pb_volume *volume, float *host);
/* The volume's memory on its device: a CUDA device pointer, a cl_mem, or host
 * memory on the host backend; valid until the volume is destroyed. It can be
 * the input or output of pb_plan_forward_device and pb_plan_adjoint_device
 * (which keep the volume's texture current), or be read by the caller. Write
 * it otherwise only through pb_volume_upload: a texture made from the volume
 * before would not see another write. */
PB_API pb_status pb_volume_memory(const pb_volume *volume, void **memory);

/* ---- motion ------------------------------------------------------------ */

typedef struct pb_pose {
    double translation[3]; /* mm */
    double rotation[4];    /* unit quaternion w, x, y, z. Quaternions whose norm is
                            * within 1e-3 of 1 are normalised; a zero quaternion or
                            * one farther from unit norm is refused
                            * (PB_ERR_BAD_QUATERNION). q and -q are the same pose. */
} pb_pose;

/* Motion inside one frame: a track of time-stamped poses that covers
 * [frame_start, frame_end] (at least its two ends). Between two tracked poses the
 * translation is interpolated linearly and the rotation spherically (SLERP). */
typedef struct pb_motion {
    const double *times;  /* seconds, strictly increasing */
    const pb_pose *poses;
    size_t count;         /* >= 2 */
    double frame_start, frame_end;
    int has_center;       /* 0: rotate about the grid's centre */
    double center[3];     /* mm from the grid's corner, when has_center */
} pb_motion;

/* The pose at time t of a track (LERP / SLERP between its tracked poses). */
PB_API pb_status pb_motion_pose_at(const pb_motion *motion, double t, pb_pose *pose);

/* Rotation of angle_deg (right-hand rule) about axis (need not be unit). */
PB_API pb_status pb_quaternion_from_axis_angle(const double axis[3], double angle_deg, double q[4]);

/* A pose as a row-major 4x4 rigid matrix about the origin, p' = R p + t, and
 * back. pb_pose_from_matrix refuses a matrix whose upper 3x3 is not a rotation
 * to 1e-4 (a reflection, a scaling, a shear: PB_ERR_NOT_RIGID) or whose last
 * row is not 0 0 0 1; the quaternion it returns has w >= 0. */
PB_API pb_status pb_pose_from_matrix(const double matrix[16], pb_pose *pose);
PB_API pb_status pb_pose_to_matrix(const pb_pose *pose, double matrix[16]);

/* ---- world coordinates ------------------------------------------------- */

/* Motions are usually known in the scanner's world frame (mm; NIfTI's RAS+
 * for a NIfTI image), while pb_blur takes them in the grid frame (mm from the
 * grid's corner along the array axes). A grid lies in the world by a
 * voxel-to-world affine: row-major 4x4, voxel index (i, j, k) at the voxel's
 * centre to world mm, as NIfTI's sform and qform and nibabel's img.affine.
 *
 * pb_motion_world_to_grid converts a motion whose poses and centre are in
 * world mm (w' = R (w - c) + c + t; has_center 0: about the grid's centre)
 * into the grid frame of that grid: with D the affine's direction matrix
 * (its columns divided by their lengths, which must equal the geometry's voxel
 * sizes to 1e-4), R_grid = D^T R D, t_grid = D^T t and c_grid = D^T (c - o),
 * o being the grid corner's world position. Reflections (LAS, LPS files) are
 * fine; a shear is refused (PB_ERR_AFFINE_SHEAR). It writes motion->count
 * poses into grid_poses and makes *grid a motion of those poses, the same times
 * and frame, and the centre in grid mm. */
PB_API pb_status pb_motion_world_to_grid(const pb_geometry *geometry, const double affine[16],
                                         const pb_motion *world, pb_pose *grid_poses, pb_motion *grid);

/* ---- pose tracks from files -------------------------------------------- */

/* Trackers and toolkits log motion in their own formats; pb_track_read reads
 * them as the command line's --motion does (the same poses, the same
 * messages), so that a binding needs no parser of its own:
 *  - PB_TRACK_CSV: petblur's own, a header naming t,tx,ty,tz,qw,qx,qy,qz (s,
 *    mm, unit quaternion; any order, extra columns ignored; the quaternion may
 *    be numbered q0..q3 or q1..q4 instead of named);
 *  - PB_TRACK_MATRIX_CSV: t and a 3x4 rigid matrix row by row,
 *    r00,r01,r02,tx,r10,...,tz, as yrt-pet writes it (header optional; a 14th
 *    column, yrt-pet's error, ignored; fields split at commas and blanks);
 *  - PB_TRACK_POLARIS: NDI Polaris logs in the two layouts STIR reads, .mt
 *    ("time rand tool q0 qx qy qz tx ty tz rms", time in s) and the NDI
 *    Toolviewer CSV ("Frame,Q0,Qx,Qy,Qz,x,y,z,Error,OOV" on a 60 Hz frame
 *    clock, time counted from the first record); missing samples are skipped
 *    and counted.
 * PB_TRACK_AUTO tells the format from the file's first line. It is 0, so that
 * zero-initialised options are the defaults, as everywhere in this header. */
typedef enum pb_track_format {
    PB_TRACK_AUTO = 0,
    PB_TRACK_CSV = 1,
    PB_TRACK_MATRIX_CSV = 2,
    PB_TRACK_POLARIS = 3
} pb_track_format;

/* The conventions a file does not carry. Zero-initialised options (or NULL)
 * are the defaults: the format told from the content, seconds, w,x,y,z. */
typedef struct pb_track_read_options {
    pb_track_format format;
    /* csv and matrix-csv: the file's time units per second, 1 (or 0) for
     * seconds, 1000 for milliseconds (yrt-pet's). A Polaris log gives seconds. */
    double time_divisor;
    /* csv: nonzero when a header's numbered quaternion columns (q0..q3) are
     * x,y,z,w rather than w,x,y,z. Named columns (qw,qx,qy,qz) carry their
     * order, and the other formats no choice: they refuse it. */
    int xyzw;
} pb_track_read_options;

/* A track read from a file: samples in time order, each with its line. */
typedef struct pb_track pb_track;

/* Reads the track at path. Every number must be finite, the times strictly
 * increasing, csv quaternions of unit norm to 1e-3 (Polaris's are normalised,
 * as NDI's manual allows them not to be), matrices rigid, and there must be
 * at least two poses. options may be NULL (defaults). On failure *track is
 * NULL, and pb_last_error(NULL) of the calling thread says
 * "FILE:LINE: what is wrong; how to fix it" (the command line's words, its
 * option names included):
 *   PB_ERR_BAD_FILE          the file cannot be opened or read, or is malformed
 *   PB_ERR_NOT_FINITE        a number beyond double's range, NaN or infinity
 *   PB_ERR_BAD_QUATERNION    a zero quaternion, or a csv one far from unit norm
 *   PB_ERR_NOT_RIGID         a matrix that is no rotation plus translation
 *   PB_ERR_TRACK_ORDER       times that do not increase, or fewer than two poses
 *   PB_ERR_INVALID_ARGUMENT  NULL path or track, an unknown format, a time
 *                            divisor that is negative or not finite, or an
 *                            option the file's format does not take
 *   PB_ERR_OUT_OF_MEMORY */
PB_API pb_status pb_track_read(const char *path, const pb_track_read_options *options, pb_track **track);
PB_API void pb_track_free(pb_track *track);

/* What a track holds: pb_track_count samples, each of the arrays below that
 * long, owned by the track and valid until pb_track_free. For a NULL track:
 * 0, PB_TRACK_AUTO and NULL. */
PB_API size_t pb_track_count(const pb_track *track);
/* The format read: for PB_TRACK_AUTO, the one told from the content. */
PB_API pb_track_format pb_track_get_format(const pb_track *track);
/* Seconds, strictly increasing. */
PB_API const double *pb_track_times(const pb_track *track);
/* The poses as the file gives them, untouched by any convention (calibration,
 * reference pose, inversion: the caller's to apply). csv: poses about the
 * motion's centre, as pb_motion takes them (the grid's centre, or its
 * has_center). matrix-csv and polaris: rigid 4x4 maps about the origin of
 * their frame, p' = R p + t (pb_pose_to_matrix gives the matrix back); as a
 * pb_motion they need has_center = 1 and a centre at that origin, in world mm
 * through pb_motion_world_to_grid. A Polaris pose is the tool's in the
 * tracker's frame. */
PB_API const pb_pose *pb_track_poses(const pb_track *track);
/* Each pose's line in the file, from 1: what messages about a sample name. */
PB_API const size_t *pb_track_lines(const pb_track *track);
/* Missing samples skipped just before each pose (Polaris logs; 0 elsewhere):
 * interpolating across a long run of them would invent the motion. */
PB_API const size_t *pb_track_missing(const pb_track *track);

/* "auto", "csv", "matrix-csv", "polaris"; "unknown" for any other value. */
PB_API const char *pb_track_format_name(pb_track_format format);
/* The format of one of those names ("unknown" is none); otherwise
 * PB_ERR_INVALID_ARGUMENT and a message that lists the formats with their
 * columns. */
PB_API pb_status pb_track_format_parse(const char *name, pb_track_format *format);

/* A track from arrays (copied), as a binding or a program holds one: count
 * (>= 2) samples at strictly increasing finite times, poses as the format
 * has them (PB_TRACK_CSV: about the motion's centre; PB_TRACK_MATRIX_CSV and
 * PB_TRACK_POLARIS: rigid maps about the world's origin), the same checks as
 * pb_track_read. lines and missing (each sample's line in its file, the
 * samples skipped before it) may be NULL: none. source names the track in
 * messages (a path, "--translate/--rotate"); NULL is "the track". */
PB_API pb_status pb_track_create(const char *source, pb_track_format format, const double *times,
                                 const pb_pose *poses, const size_t *lines, const size_t *missing, size_t count,
                                 pb_track **track);
/* The name messages give the track: its path, or create's source. */
PB_API const char *pb_track_source(const pb_track *track);

/* ---- the motion layer: conventions, placement, frames, checks ---------- */

/* What turns a tracker's log into the patient's motion, M(t) = C P(t)
 * P(ref)^-1 C^-1 (P inverted first when inverse is set), applied in
 * pb_track_world. Zero-initialised: none of them, and the grid's centre. */
typedef struct pb_track_conventions {
    int inverse;            /* the poses map scanner to object (yrt-pet's): inverted first */
    int has_reference_time; /* else absolute poses; a Polaris log's reference is its first sample, with a warning */
    double reference_time;  /* s: the poses become relative to the pose at this time */
    int has_calibration;
    double calibration[16]; /* C: tracker to scanner, a row-major rigid 4x4 (pb_calibration_read) */
    int has_center;         /* csv tracks: the rotation centre, world mm; else the grid's centre */
    double center[3];
} pb_track_conventions;

/* A calibration file: 16 numbers (or the top 3x4 as 12) row by row,
 * separated by blanks, commas or semicolons, '#' comments to the end of a
 * line; the matrix rigid. On failure the message names the file, its line
 * and the problem. */
PB_API pb_status pb_calibration_read(const char *path, double matrix[16]);

/* The grid frame as a world of its own: voxel (i, j, k)'s centre at
 * ((i + 0.5) dx, (j + 0.5) dy, (k + 0.5) dz), the affine a grid without a
 * placement (a .raw file; --coords grid) is taken at. */
PB_API pb_status pb_geometry_grid_affine(const pb_geometry *geometry, double affine[16]);

/* What a track or its frames hold that is allowed but looks like a mistake:
 * one line per warning in text ("SOURCE:LINE: what; what to check"), and a
 * bit per kind in flags. A front end prints them (the command line) or
 * raises them as warnings (Python). */
enum {
    PB_WARN_REFERENCE = 1,      /* no reference time: relative to the first sample */
    PB_WARN_TURN_STEP = 2,      /* a sample turns over 90 degrees from the one before */
    PB_WARN_FAR_FROM_REST = 4,  /* every pose turns over 90 degrees from rest, or from the first */
    PB_WARN_TIME_UNIT = 8,      /* times that look like milliseconds */
    PB_WARN_FRAMES_SPAN = 16,   /* frames that cover almost none of the track */
    PB_WARN_OUT_OF_VIEW = 32,   /* the grid wholly out of view at some poses of a frame */
    PB_WARN_BACKGROUND = 64,    /* pb_motion_estimate: frames on a uniform background to the grid's faces */
    PB_WARN_NO_STRUCTURE = 128  /* pb_motion_estimate: frames that show nothing but noise */
};
typedef struct pb_warnings {
    unsigned flags;
    char text[4096];
} pb_warnings;

/* The track's motion in the world: conventions applied, poses about the
 * world centre (world->has_center, center: the origin for matrix-csv and
 * Polaris tracks, else conventions->center or the centre of the grid of
 * geometry placed by affine, a voxel-to-world 4x4 as
 * pb_motion_world_to_grid takes; NULL: pb_geometry_grid_affine). geometry may
 * be NULL when the centre needs no grid. world_poses holds the track's count
 * poses; *world spans the whole track. conventions may be NULL (none).
 * Warnings (may be NULL): PB_WARN_REFERENCE, PB_WARN_TURN_STEP,
 * PB_WARN_FAR_FROM_REST (with the quaternion order that would fit, where
 * one does), PB_WARN_TIME_UNIT. Refused: a reference time outside the track,
 * a centre for a track that turns about the origin, a calibration that is not
 * rigid. */
PB_API pb_status pb_track_world(const pb_track *track, const pb_track_conventions *conventions,
                                const pb_geometry *geometry, const double affine[16], pb_pose *world_poses,
                                pb_motion *world, pb_warnings *warnings);

/* pb_track_world, then pb_motion_world_to_grid: the track's motion in the
 * grid frame of that grid, as pb_plan_create takes it (grid_poses holds
 * count poses; *grid spans the whole track, its times the track's). */
PB_API pb_status pb_track_place(const pb_track *track, const pb_track_conventions *conventions,
                                const pb_geometry *geometry, const double affine[16], pb_pose *grid_poses,
                                pb_motion *grid, pb_warnings *warnings);

/* Frames [bounds[i], bounds[i+1]] of a placed track (grid: pb_track_place's)
 * checked before a blur trusts them. Refused: frames outside the track
 * (PB_ERR_TRACK_GAP), missing samples (Polaris) that leave a gap over 1 s
 * inside a frame (PB_ERR_TRACK_GAP), a motion that takes the whole grid out
 * of the field of view for a whole frame (PB_ERR_OUT_OF_VIEW: the blur would
 * be zero). Warned: PB_WARN_OUT_OF_VIEW, PB_WARN_TIME_UNIT (a frame over 6
 * h), PB_WARN_FRAMES_SPAN. */
PB_API pb_status pb_track_check_frames(const pb_track *track, const pb_motion *grid, const pb_geometry *geometry,
                                       const double *bounds, size_t frames, pb_warnings *warnings);

/* Frame bounds on their own, where they are given and before any track is at
 * hand: pb_track_check_frames' rules on the bounds (finite, increasing) and
 * its warning on them, PB_WARN_TIME_UNIT where a frame lasts over 6 h (bounds
 * in milliseconds). */
PB_API pb_status pb_frames_check(const double *bounds, size_t frames, pb_warnings *warnings);

/* Frames from BIDS-PET's FrameTimesStart and FrameDuration (n of each, s):
 * n + 1 bounds. Durations positive, each frame starting where the one before
 * ends (to 1e-6 s relative). */
PB_API pb_status pb_frames_from_starts(const double *starts, const double *durations, size_t n, double *bounds);
/* Frames from a BIDS-PET sidecar (the JSON beside a PET image): its top-level
 * FrameTimesStart and FrameDuration, by pb_frames_from_starts' rules. Read as
 * strict JSON (RFC 8259, UTF-8), as Python's json reads it: keys inside nested
 * objects are not the sidecar's, of duplicate keys the last counts, numbers
 * are any JSON number (finite). *frames is the frame count; the bounds (frames
 * + 1) are written when capacity holds them: call with capacity 0 to learn the
 * count. Files over 4 MiB are refused. */
PB_API pb_status pb_frames_read_sidecar(const char *path, double *bounds, size_t capacity, size_t *frames);

/* The part of a track (a motion over its whole span) that frame [t0, t1]
 * needs: from the last sample at or before t0 to the first at or after t1,
 * with the frame set. Every frame of a plan is cut by this one rule. */
PB_API pb_status pb_motion_frame(const pb_motion *track, double t0, double t1, pb_motion *part);

/* The time-weighted mean pose over the motion's frame: the mean translation
 * of its LERP, and the rotation whose quaternion is the normalised mean of
 * its SLERP (the chordal L2 mean), about the motion's centre: what a model of
 * one pose per frame takes. */
PB_API pb_status pb_motion_mean_pose(const pb_motion *motion, pb_pose *mean);

/* What a frame of a motion holds, as `petblur motion` reports it: the
 * tracked samples inside [t0, t1], and from the frame's first pose to each of
 * them and to its end, the largest turn (degrees) and the largest
 * displacement of the grid's eight corners (mm; the grid of geometry, placed
 * as the motion's poses are, about the motion's centre, or the grid's centre
 * where it has none). The motion must be valid over [t0, t1]. */
typedef struct pb_frame_summary {
    size_t samples;
    double max_turn_deg;
    double max_corner_mm;
} pb_frame_summary;
PB_API pb_status pb_motion_frame_summary(const pb_motion *motion, const pb_geometry *geometry, double t0, double t1,
                                         pb_frame_summary *summary);

/* What a track holds: its samples' span (s), the median step between them
 * (s; its inverse is the tracker's rate), and the samples the reader found
 * missing (pb_track_missing): how many, in how many gaps, the longest gap's
 * length (s). */
typedef struct pb_track_summary {
    size_t samples;
    double first, last;
    double median_step;
    size_t missing, gaps;
    double longest_gap;
} pb_track_summary;
PB_API pb_status pb_track_summarize(const pb_track *track, pb_track_summary *summary);

/* Where a pose about centre takes point p: centre + t + R (p - centre). */
PB_API void pb_pose_apply(const pb_pose *pose, const double center[3], const double p[3], double out[3]);
/* The pose T G(xi)^-1 of pose T under the object-side perturbation
 * xi = (v, w): G(xi) p = R(w) (p - c) + c + v about the pose's centre c, v in
 * mm, w a rotation vector in radians (angle |w| about w / |w|). The
 * perturbation pb_blur_pose_derivative differentiates in, and the step of the
 * estimate's registration. */
PB_API pb_status pb_pose_perturb(const pb_pose *pose, const double xi[6], pb_pose *out);
/* The angle in degrees of the turn between two poses' rotations. */
PB_API double pb_pose_turn_deg(const pb_pose *a, const pb_pose *b);

/* ---- blurring ---------------------------------------------------------- */

typedef enum pb_method {
    /* Antialiased Bresenham: each tomograph voxel's object-space path is a
     * polyline (one segment per pair of consecutive poses), walked slice by slice
     * along its major axis, four voxels weighted per slice. A segment of at
     * most 5 voxels along that axis is read as the trilinear image's exact
     * time average over it, one of 6 or more by the walk, both weighed
     * between (docs/methods.md, "Short segments"). */
    PB_METHOD_AB = 0,
    /* Ray marching: S equidistant trilinear samples along each polyline
     * segment; with steps 0, short segments exactly, as AB. */
    PB_METHOD_RM = 1,
    /* Classical: S time steps per segment, each interpolates the pose (LERP and
     * SLERP) and takes one trilinear sample. */
    PB_METHOD_CL = 2,
    /* The paper's reference: classical with dense time steps and K random points
     * inside each tomograph voxel, each looking up the object voxel that holds it. */
    PB_METHOD_REF = 3
} pb_method;

typedef enum pb_filter {
    /* One linearly filtered image/texture fetch per sample (per slice for AB).
     * On NVIDIA hardware the weights carry 8 fractional bits. */
    PB_FILTER_HARDWARE = 0,
    /* Nearest reads weighted in float (4 per slice for AB, 8 per trilinear sample). */
    PB_FILTER_EXACT = 1
} pb_filter;

/* How AB and RM turn a voxel's true path (LERP translation, SLERP rotation)
 * into the straight segments they walk. CL and REF follow the true path and
 * ignore it. */
typedef enum pb_path_model {
    PB_PATH_DEFAULT = 0, /* bounded by PB_DEFAULT_MAX_PATH_ERROR voxels */
    PB_PATH_BOUNDED = 1, /* bounded by max_path_error voxels */
    PB_PATH_TRACKED = 2  /* one segment per tracked interval: the paper's polyline */
} pb_path_model;

/* How AB reads a segment. Short segments (up to 5 voxels along their major
 * axis) are always read exactly, as the trilinear image's time average over
 * the chord; long ones (6 voxels on, and in part between) by the paper's
 * walk, which reads each slice at one point, where the path crosses the
 * slice's centre plane, and so does not see the path sweep sideways across
 * the slice: on sharp objects that is up to several percent
 * (docs/methods.md, "Long segments"). SWEEP reads a slice at two points of
 * the path where it sweeps sideways by more than an eighth of a voxel a
 * slice ("AB's own sampling"); CHORD reads every segment exactly, whatever
 * its length, at a cost that grows with the voxels the chord crosses. Set
 * with RM, CL or REF, it is refused. */
typedef enum pb_ab_sampling {
    PB_AB_SAMPLING_DEFAULT = 0, /* PB_AB_SAMPLING_SLICE */
    PB_AB_SAMPLING_SLICE = 1,   /* one point a slice: the paper's AB */
    PB_AB_SAMPLING_SWEEP = 2,   /* two points a slice where the path sweeps sideways */
    PB_AB_SAMPLING_CHORD = 3    /* every segment read exactly, never walked */
} pb_ab_sampling;

/* Zero-initialised options are the defaults. pb_options_check states every
 * range once; the command line and the Python package pass its message on. */
typedef struct pb_blur_options {
    pb_method method;
    pb_filter filter;
    /* CL and RM: samples per segment; 0 takes as many as AB visits slices on that
     * segment for that voxel (the paper's choice), RM reading short segments
     * exactly as AB does. AB: sub-segments per segment, each read by AB's rule;
     * 0 means 1 (the paper). REF: unused. At most 100000. */
    unsigned steps;
    unsigned ref_points;     /* REF: random points per voxel; 0 = 200 (the paper); at most 100000 */
    /* REF: time steps per segment; 0 = max(16, 2 * the largest displacement of the
     * grid's corners over the segment, each axis in its own voxels), so that every
     * path is sampled at least every half voxel. At most 100000. */
    unsigned ref_time_steps;
    uint32_t seed;           /* REF: random points are a pure function of the seed */
    /* AB and RM walk straight segments between key poses; a voxel's true path
     * bends away from them under rotation. Under a bound every tracked
     * interval is cut into as many equal pieces as it takes for no voxel
     * centre of the grid to leave its polyline by more than the bound, in
     * voxels of the smallest voxel size. pb_path_segments says how many
     * segments a motion gets. */
    pb_path_model path;
    double max_path_error;   /* PB_PATH_BOUNDED only: the bound, in [PB_MIN_MAX_PATH_ERROR, 1000] voxels; else 0 */
    pb_ab_sampling ab_sampling; /* AB only */
    /* Field motions: 0 the blur of concentrations (activity per volume, as
     * a PET image holds it); 1 mass-preserving, each tomograph voxel's
     * reading weighed by the Jacobian determinant |det(I + dD/dr)| of its
     * field, for images of counts (a segment takes the determinant's time
     * mean over it, Simpson's rule; central differences of the field between
     * the voxel's neighbours, one-sided at the grid's faces). A rigid motion's
     * determinant is 1: it changes nothing there. */
    int jacobian;
} pb_blur_options;

/* The names the program and the bindings give these options: methods "ab",
 * "rm", "cl", "ref"; filters "hardware", "exact"; AB samplings "default",
 * "slice", "sweep", "chord". A _name call returns NULL for a value that has none; a
 * _parse call that does not know the name fails with PB_ERR_INVALID_ARGUMENT
 * and a message that lists every name with what it means. */
PB_API const char *pb_method_name(pb_method method);
PB_API pb_status pb_method_parse(const char *name, pb_method *method);
PB_API const char *pb_filter_name(pb_filter filter);
PB_API pb_status pb_filter_parse(const char *name, pb_filter *filter);
PB_API const char *pb_ab_sampling_name(pb_ab_sampling sampling);
PB_API pb_status pb_ab_sampling_parse(const char *name, pb_ab_sampling *sampling);

/* Checks options as every call that takes them does: the status and
 * message of the first problem (on the calling thread: pb_last_error(NULL)),
 * naming the field and its range. NULL is the defaults. */
PB_API pb_status pb_options_check(const pb_blur_options *options);

/* The default bound of a voxel's polyline against its true path, in voxels:
 * chosen by measurement so that the model's error stays below 0.3 % RMS and
 * 1 % max on a tracked seizure against a dense reference, at no more than
 * 1.3x the time of 0.25 on the paper's motions (docs/methods.md,
 * "Error-bounded paths", gives the runs). */
#define PB_DEFAULT_MAX_PATH_ERROR 0.1
/* The tightest bound: a 1/1000 voxel is below what the walk resolves (the
 * texture unit's weights step by 1/256 voxel, float32 positions by 1e-5 of a
 * 512-voxel grid), while every halving of the bound costs 1.4x the segments,
 * so a tighter one would only buy time without bound (docs/cli.md). */
#define PB_MIN_MAX_PATH_ERROR 0.001

/* The segments AB and RM walk for a motion on a grid under options (NULL:
 * defaults): each tracked interval inside the frame gets
 *     n = max(1, ceil(sqrt(D / (8 E))))
 * equal pieces, where D bounds the path's curvature |p''| over the interval in
 * voxels: D = (theta^2 (r + |t|max) + 2 theta |dt|) / vmin, with theta the
 * interval's rotation angle (radians), r the largest distance of a voxel
 * centre from the interval's rotation axis through the rotation centre,
 * |t|max the larger translation of its two poses and |dt| the translation's
 * change, both across that axis (all in mm), vmin the smallest voxel
 * size and E the bound. A C2 curve leaves its chord over a piece of
 * parameter length h by at most h^2 max|p''| / 8. Where the frame holds
 * tracked poses, they are first replaced by the knots of a continuous
 * polyline fitted to the track by least squares over time, each of its pieces
 * within E of every tracked pose it spans at the grid's corners (a 30 Hz log
 * of a smooth motion needs few; a steady motion logged at any rate is one
 * segment), beyond the tracker's white noise, measured from the log
 * (docs/methods.md, "Tracker noise"); the intervals between the knots are then cut as above and not
 * merged (docs/methods.md, "Short segments, read exactly"). Without tracked
 * poses inside the frame, runs of consecutive pieces are merged into one chord
 * while every voxel, at every time, stays within E of its true path. */
PB_API pb_status pb_path_segments(const pb_geometry *geometry, const pb_motion *motion,
                                  const pb_blur_options *options, size_t *segments);
/* The tracker's noise in the motion's frame that the path of these options
 * (NULL: the defaults) treats as noise and does not follow: the RMS of the 3D
 * scatter of the grid's corners about the motion, mm, the largest corner's,
 * measured from the frame's tracked poses (docs/methods.md, "Tracker noise").
 * A frame of fewer than 64 tracked poses is measured on the 512 of the whole
 * track about it. 0 where every tracked pose is followed: fewer than 64 in
 * the whole track, a scatter that is not white (a tremor is motion, and so
 * is a jerk beside a short frame), PB_PATH_TRACKED, or CL and REF, which
 * follow the track itself. segments (may be NULL): what
 * pb_path_segments gives, from the same plan, so that a report of both
 * plans the frame once. */
PB_API pb_status pb_path_noise(const pb_geometry *geometry, const pb_motion *motion,
                               const pb_blur_options *options, double *noise_mm, size_t *segments);

/* Blurs an object-space volume along the motion into a tomograph-space volume of
 * the same geometry (the paper's eq. 1, gather form: one work item per
 * tomograph voxel). options may be NULL (defaults). object and tomograph must be
 * different volumes of the same context. A motion that carries the object
 * along an axis more than 16 times the grid's voxels along it (and 1024) in
 * a segment, or 64 times that in a frame or a gate's intervals, is refused
 * with PB_ERR_INVALID_ARGUMENT before anything runs, for every method but
 * those with fixed steps (its walk would take hours; the units are the
 * likely cause); field motions alike. Fixed steps (RM and CL's steps, REF's
 * time steps) are refused where steps times the frame's segments pass 1e7. */
PB_API pb_status pb_blur(pb_context *ctx, const pb_volume *object, const pb_motion *motion,
                         const pb_blur_options *options, pb_volume *tomograph);

/* The transpose of pb_blur, for back projection (MLEM's B^T): with the same
 * motion and options, <pb_blur(x), y> = <x, pb_blur_adjoint(y)> for every
 * object x and tomograph y, for every method. It reads the tomograph-space
 * volume and overwrites the object-space one. Each tomograph voxel walks the
 * very path the forward walks and scatters its value with the forward's
 * weights (float atomic adds on devices, so the last bits of a sum may differ
 * between runs). The weights are the forward's own, in float. For HARDWARE,
 * PoCL's image sampler uses float weights too, so the transpose is exact; on
 * NVIDIA (CUDA, and NVIDIA's OpenCL) each axis's weight is rounded to 1/256
 * (ties up) as the texture unit rounds it, but the unit's 3-D blend is not
 * reproducible bit for bit: there <B x, y> and <x, B^T y> agree to about 1e-4
 * (relative) instead of 1e-6. Use EXACT where the pair must match exactly. */
PB_API pb_status pb_blur_adjoint(pb_context *ctx, const pb_volume *tomograph, const pb_motion *motion,
                                 const pb_blur_options *options, pb_volume *object);

/* Dynamic PET: the frames of one pose track (markers at 30 Hz or more over
 * minutes) in one call. Frame i spans [bounds[i], bounds[i+1]] (frames + 1
 * increasing bounds inside the track); objects[i] is its activity (one volume
 * may serve several frames: it stays on the device, its image refreshed once)
 * and tomographs[i] receives its blur, which equals pb_blur's of that frame.
 * The track's frame_start and frame_end are not used. Every frame is checked
 * and planned before any is blurred: on an error nothing was written. Every
 * volume has one geometry (a plan of frames, pb_plan_create_frames). A
 * frame's tomograph must not be any frame's object or another frame's
 * tomograph. pb_context_last_kernel_ms then gives the frames' total. */
PB_API pb_status pb_blur_frames(pb_context *ctx, const pb_volume *const *objects, const pb_motion *track,
                                const double *bounds, size_t frames, const pb_blur_options *options,
                                pb_volume *const *tomographs);

/* The transpose of pb_blur_frames, for back projection in dynamic or
 * motion-compensated reconstruction: frame i's tomograph-space volume
 * tomographs[i] goes back through frame i's part of the track into
 * objects[i]. Frames that name one object volume get the sum of their back
 * projections in it (the transpose of one activity blurred into every frame:
 * a motion-compensated image from all frames); otherwise objects[i] equals
 * pb_blur_adjoint of frame i. The same checks as pb_blur_frames, except that
 * objects may repeat: an object must not be any frame's tomograph.
 * pb_context_last_kernel_ms then gives the frames' total. */
PB_API pb_status pb_blur_frames_adjoint(pb_context *ctx, const pb_volume *const *tomographs, const pb_motion *track,
                                        const double *bounds, size_t frames, const pb_blur_options *options,
                                        pb_volume *const *objects);

/* ---- non-rigid motion: deformation fields ------------------------------- */

/* Motion that a field describes: breathing, the heart, any deformation.
 * count displacement fields D_k, at times[k], on a field grid of dims. The
 * resampling convention: a field is defined on the tomograph grid and points
 * into object space, so the tomograph voxel centred at r (mm in the image's
 * grid frame, its corner at 0) sits at object point r + D(t)(r) at time t.
 * For a rigid pose P, D(t)(r) = P(t)^-1 r - r. Between samples D is
 * interpolated linearly in time, so a voxel's path is a polyline through its
 * points at the sample times: AB and RM walk it exactly (the path error bound
 * has nothing to cut), CL's per-step interpolation gives RM's points, and REF
 * samples dense times and random points in each voxel, the field interpolated
 * trilinearly at each. With a surrogate the key times also hold the times
 * where the signal crosses a field's value, where the motion bends. Where
 * the field grid is not the image grid, D is
 * interpolated trilinearly in space between the field's voxel centres, and
 * held at its edge values beyond them.
 *
 * displacements: count fields one after the other, each dims[0] * dims[1] *
 * dims[2] vectors of three floats (mm along the image grid's x, y and z, the
 * vector's components fastest, then x, y, z of the field grid). Fields in
 * world coordinates (NIfTI's RAS, ITK's LPS) are turned into the grid frame
 * by the image's direction matrix first (D^T d): the command line and the
 * Python package do it. */
typedef struct pb_field_motion {
    const double *times;        /* seconds, strictly increasing, count of them */
    const float *displacements; /* count * dims[0] * dims[1] * dims[2] * 3 floats, mm */
    size_t count;               /* >= 2; the same field twice is a still deformation (a gate's warp) */
    size_t dims[3];             /* the field grid */
    /* 0: the field grid is the image grid (dims must equal the geometry's).
     * 1: field_from_grid (row-major 3x4) maps an image voxel index (i, j, k),
     * at the voxel's centre, to the field voxel index there. */
    int has_map;
    double field_from_grid[12];
    double frame_start, frame_end; /* inside [times[0], times[count - 1]] (the signal's times, with one) */
    /* Surrogate-driven motion (a respiratory belt, a data-driven breathing
     * signal): with signal_count >= 2, times[k] is field k's surrogate value
     * (an amplitude, increasing) instead of a time, and the motion at time t
     * is the field at the surrogate's value s(t), linear between the fields'
     * values; s is sampled at signal_times (seconds, increasing), linear
     * between samples. A signal beyond the fields' values is refused, naming
     * the time: add a field for that amplitude. 0: fields at times. */
    const double *signal_times, *signal;
    size_t signal_count;
} pb_field_motion;

/* Where a field folds: the voxels of the field grid at which the map r -> r
 * + D_k(r) of some field k has a Jacobian determinant of at most zero
 * (central differences inside, one-sided at the faces), how many, and the
 * first (field index, voxel index x fastest), -1 where none does. A fold
 * makes the blur read one place for two, which registrations sometimes
 * leave: the front ends warn of it. */
typedef struct pb_field_folds {
    size_t voxels;
    long field, voxel;
    double worst_determinant; /* the smallest determinant found */
} pb_field_folds;
PB_API pb_status pb_field_check_folds(const pb_geometry *geometry, const pb_field_motion *field,
                                      pb_field_folds *folds);

/* ---- motion from the frames -------------------------------------------- */

/* The six gradient images whose blurs pb_blur_pose_derivative returns, on
 * the host: dx/dp_j by central differences (zero outside the grid), then
 * ((p - c) x grad x)_j, p a voxel's centre and c center, both in mm of the
 * grid (its corner at 0). x and out[0..5] hold the geometry's voxels, x
 * fastest, computed in double. */
PB_API pb_status pb_pose_gradient_images(const pb_geometry *geometry, const float *x, const double center[3],
                                         float *const out[6]);

/* The derivative of a blur with respect to its pose: the six volumes
 * d(B x)/d(xi_j) for a rigid perturbation xi = (v, w) (mm, radians) applied
 * to every pose of the motion on the object's side, T(t) -> T(t) G(xi)^-1
 * with G(xi) p = p + v + w x (p - c) to first order about the motion's centre
 * c: v moves the object, w turns it. They are B applied to the object's
 * gradient images, dx/dp_j and ((p - c) x grad x)_j, taken by central
 * differences (zero outside the grid): the derivative of the continuous model
 * that B discretises, which a Gauss-Newton registration needs. It matches
 * finite differences of B x to the object's sampling (docs/motion.md, "Motion
 * from the frames", gives the measurement). derivatives[0..5] are tomograph
 * volumes of the object's context and geometry, all different from it. */
PB_API pb_status pb_blur_pose_derivative(pb_context *ctx, const pb_volume *object, const pb_motion *motion,
                                         const pb_blur_options *options, pb_volume *const derivatives[6]);

/* One frame of what pb_motion_estimate found: how far to trust its pose
 * (pb_estimate_options.frames). */
typedef struct pb_estimate_frame {
    double explained;      /* the share of the frame's variance about its mean that its registration to its own
                            * reference explains, 0 to 1: low where counts are few or the contrast is unlike the
                            * other frames' */
    double motion_from, motion_to; /* moving: when the motion inside the frame began and ended, s; else both the
                            * frame's mid-time */
    int structure;         /* 0: no structure above the frame's noise: it took its nearest structured frame's pose */
    int moving;            /* nonzero: the track follows a path inside the frame (a jerk, or a nod held across its end) */
    int jumped_at_start;   /* nonzero: the head jumped at the frame's start, so the track holds the frame before's pose
                            * to it and this frame's from it (where both frames show their poses held) */
    double unfollowed;     /* a frame the track holds still (not moving) that shows motion inside it: the share of its
                            * one pose's residual that a path inside it explains, 0 to 1, which the track does not
                            * follow (the neighbours' poses do not show where the motion went); its pose is a mean
                            * of poses the frame held, to be trusted less. 0: no motion shows (or frame_poses_only;
                            * the series' first and last frames: under the 15 % their one path must gain) */
} pb_estimate_frame;

/* pb_estimate_options.reference: the estimate chooses the frame (the
 * program's and Python's default), and says which in pb_estimate_report.reference */
#define PB_ESTIMATE_REFERENCE_AUTO ((size_t)-1)

/* How pb_motion_estimate works. Zero-initialised: the defaults. */
typedef struct pb_estimate_options {
    size_t reference;      /* the frame whose object the motion moves: poses are relative to it (0: the first);
                            * PB_ESTIMATE_REFERENCE_AUTO: the frame held still whose pose its registration
                            * determines best, so that an early frame of few counts, whose pose is off by its
                            * noise, does not move every other frame's */
    unsigned levels;       /* resolution levels, each halving the grid, at most this many: none under 4 voxels a side
                            * or of voxels over PB_MAX_VOXEL_MM; 0: as many as keep 12 voxels a side, at most 3 */
    unsigned iterations;   /* Gauss-Newton iterations at most per level and frame; 0: 12 */
    int frame_poses_only;  /* nonzero: one pose per frame; 0: a frame that holds a jerk gets the poses on both sides */
    double fwhm_mm;        /* smoothing before registration, mm; 0: two voxels of each level */
    pb_estimate_frame *frames; /* the caller's array of one per frame, filled on success with how far to trust
                            * each; NULL: not wanted */
} pb_estimate_options;

/* What pb_motion_estimate found, frame by frame (may be NULL). */
typedef struct pb_estimate_report {
    double seconds;        /* the whole call's wall time */
    size_t moving_frames;  /* frames given motion inside them */
    pb_warnings warnings;  /* PB_WARN_BACKGROUND, PB_WARN_NO_STRUCTURE: what was found and what was done */
    size_t reference;      /* the frame the track is relative to: the options' reference, or the one chosen */
} pb_estimate_report;

/* The patient's rigid motion estimated from the frames themselves. frames
 * holds count volumes of geometry, frame after frame (a 4-D NIfTI's order,
 * x fastest), placed in the world by affine (row-major voxel-to-world 4x4 as
 * pb_motion_world_to_grid takes; NULL: the grid frame, pb_geometry_grid_affine);
 * frame i spans [bounds[i], bounds[i+1]] seconds. Each frame is registered
 * rigidly (multi-resolution Levenberg-Marquardt on d(B x)/d(pose) with a
 * per-frame scale and offset, which is normalised cross-correlation: tracer
 * uptake may change from frame to frame) to its neighbour towards the
 * reference frame, then to its own reference: its projection onto the
 * principal images of its 32 nearest frames moved back onto the reference
 * frame, so that the time grows linearly with the frames.
 * A frame whose blur along a path between its neighbours' poses reproduces
 * it better than any one pose gets that path, timed by how long the frame
 * dwells along it (non-negative least squares): a jerk inside a frame lands
 * between the right poses at the right time. In a series of 12 frames or
 * more whose contrast changes along a curve in time, every pose then gets
 * one rigid correction scaled by its frame's contrast, which takes out the
 * bias that changing uptake leaves (docs/motion.md). *track (pb_track_free) is a PB_TRACK_MATRIX_CSV
 * track in the world of affine: rigid maps about the world's origin that take
 * a point of the reference frame's object to where it is at each time, with
 * a pose at every frame's mid-time and at the first and last bound, a path's
 * poses inside a moving frame, each pose held to the boundary where the
 * head jumped between two still frames, and between the mid-times of
 * neighbouring still frames a monotone cubic through their poses (seven
 * poses on it between each two, linear between those); the reference
 * frame's pose is the identity. Refused: fewer than two frames, a
 * reference out of range, bounds that are not finite and increasing, frames
 * with NaN or infinite voxels, frames with no counts (all zero or negative),
 * grids under 8 voxels a side, voxel sizes outside PB_MIN_VOXEL_MM to
 * PB_MAX_VOXEL_MM.
 * Warned (report->warnings): a uniform background that reaches the grid's
 * faces, which is subtracted from each frame before registration (it would
 * pull every pose towards the grid's), and frames that show no structure
 * above their noise, which take their nearest structured frame's pose (the
 * identity where none has any). ctx's progress report, if any, hears the
 * whole call's progress. The host's loops over voxels (on grids of 2^15
 * voxels or more) run on threads, one per core this process may run on (its
 * CPU affinity; at most 32), made and joined within the call; the track is the
 * same bits whatever their number. */
PB_API pb_status pb_motion_estimate(pb_context *ctx, const pb_geometry *geometry, const double affine[16],
                                    const float *frames, size_t count, const double *bounds,
                                    const pb_estimate_options *options, pb_track **track,
                                    pb_estimate_report *report);

/* ---- plans ------------------------------------------------------------- */

/* A blur operator made once and applied many times, as an MLEM loop applies
 * B and B^T hundreds of times (VkFFT's life cycle: create, apply, destroy).
 * Creating it validates the motion and options, plans the key poses of every
 * frame and uploads them to the device; applying it does only the device
 * work. A plan keeps its context alive, as volumes do. pb_blur,
 * pb_blur_adjoint, pb_blur_frames and pb_blur_frames_adjoint are one-shot
 * plans and give the same results bit for bit, but for the adjoint's scatter
 * (motions that turn, and REF), whose float atomic adds land in an order that
 * differs from run to run. */
typedef struct pb_plan pb_plan;

/* A plan of one frame (frame 0): motion over [frame_start, frame_end] on
 * grids of geometry. options may be NULL (defaults). */
PB_API pb_status pb_plan_create(pb_context *ctx, const pb_geometry *geometry, const pb_motion *motion,
                                const pb_blur_options *options, pb_plan **plan);
/* A plan of `frames` frames of one track, frame i spanning [bounds[i],
 * bounds[i+1]] (as pb_blur_frames; the track's frame_start and frame_end are
 * not used). Errors name the frame. */
PB_API pb_status pb_plan_create_frames(pb_context *ctx, const pb_geometry *geometry, const pb_motion *track,
                                       const double *bounds, size_t frames, const pb_blur_options *options,
                                       pb_plan **plan);
/* Gates of a track as frames: frame i is the union of counts[i] intervals,
 * the next ones of intervals[] (a start and an end each, seconds): every
 * visit of the breath to an amplitude or phase bin, as a gated
 * reconstruction bins its counts (pb_plan_create_field_gates for fields).
 * Its blur is the time-weighted mean of its intervals' blurs, each interval
 * planned as a frame of its own (path error bound, clipping, REF's steps),
 * the gaps between them skipped; every method and filter, the transpose
 * exact as for one interval. One interval gives pb_plan_create_frames' plan
 * of that frame. A frame's intervals increase and do not overlap
 * (PB_ERR_BAD_FRAME), lie inside the track (PB_ERR_TRACK_GAP) and are finite
 * (PB_ERR_NOT_FINITE); a frame has 1 to 2^24 of them. Errors name the frame
 * and the interval. */
PB_API pb_status pb_plan_create_gates(pb_context *ctx, const pb_geometry *geometry, const pb_motion *track,
                                      const double *intervals, const size_t *counts, size_t frames,
                                      const pb_blur_options *options, pb_plan **plan);
/* Plans of field motions, as pb_plan_create and pb_plan_create_frames plan a
 * track: one frame, [frame_start, frame_end], or frames [bounds[i],
 * bounds[i+1]] (frame_start and frame_end not used). Every method and filter,
 * the adjoint exact as for a track; the path options do not apply. A frame
 * keeps the fields its time covers, on the device, in texel units: about 12
 * bytes a field voxel each (docs/motion.md). The field is checked first:
 * NaN or infinite values (PB_ERR_NOT_FINITE, naming the field and voxel),
 * dims that differ from the geometry without a map, a singular map
 * (PB_ERR_SIZE_MISMATCH, PB_ERR_INVALID_ARGUMENT), times (PB_ERR_TRACK_ORDER)
 * and frames outside them (PB_ERR_TRACK_GAP). */
PB_API pb_status pb_plan_create_field(pb_context *ctx, const pb_geometry *geometry, const pb_field_motion *field,
                                      const pb_blur_options *options, pb_plan **plan);
PB_API pb_status pb_plan_create_field_frames(pb_context *ctx, const pb_geometry *geometry,
                                             const pb_field_motion *field, const double *bounds, size_t frames,
                                             const pb_blur_options *options, pb_plan **plan);
/* Gates as frames: frame i is the union of counts[i] intervals, the next
 * ones of intervals[] (a start and an end each, seconds): every visit of the
 * breath to an amplitude or phase bin, as a gated reconstruction bins its
 * counts. Its blur is the time-weighted mean of its intervals' blurs, and the
 * transpose is exact as for one interval. A frame's intervals increase and
 * do not overlap. */
PB_API pb_status pb_plan_create_field_gates(pb_context *ctx, const pb_geometry *geometry,
                                            const pb_field_motion *field, const double *intervals,
                                            const size_t *counts, size_t frames, const pb_blur_options *options,
                                            pb_plan **plan);

PB_API void pb_plan_destroy(pb_plan *plan);
PB_API size_t pb_plan_frame_count(const pb_plan *plan);
PB_API pb_status pb_plan_get_geometry(const pb_plan *plan, pb_geometry *geometry);

/* Frame `frame` forward, tomograph = B object, and its transpose, object =
 * B^T tomograph (overwritten, or with accumulate != 0 added into, as frames
 * that share one object sum their back projections). Volumes of the plan's
 * context and geometry. */
PB_API pb_status pb_plan_forward(pb_plan *plan, size_t frame, const pb_volume *object, pb_volume *tomograph);
PB_API pb_status pb_plan_adjoint(pb_plan *plan, size_t frame, const pb_volume *tomograph, pb_volume *object,
                                 int accumulate);

/* The same on the caller's memory, nx*ny*nz floats each, x fastest: a CUDA
 * device pointer (cudaMalloc, CuPy, PyTorch) on the CUDA backend, a cl_mem
 * (the handle itself, cast to void *) of the context's cl_context
 * (pb_context_native) on OpenCL, host memory on the host backend. The input is
 * copied into the plan's texture on the device; nothing touches host memory.
 *   Ordering. The call queues its work on the context's queue
 *   (pb_context_native: the cl_command_queue, or the cudaStream_t) after
 *   everything queued there before, and returns with it finished (on a
 *   caller's stream, pb_context_set_stream, once queued): the output
 *   is ready, and pb_context_last_kernel_ms holds its device time (the copy
 *   included; pb_context_last_input_ms the copy alone). On CUDA that stream
 *   is a blocking stream: it also waits for work queued earlier on the legacy
 *   default stream (CuPy's and PyTorch's default), and work queued there later
 *   waits for it. Input written on any other stream or queue (a per-thread
 *   default stream included) must be finished (synchronised) by the caller.
 * On OpenCL a valid cl_mem is checked to belong to the context, to hold the
 * volume and to be readable (input) or writable (output); on CUDA the pointer
 * to be device or managed memory of the context's GPU (its size cannot be
 * asked). Input and output must not overlap. Values are not checked for NaN
 * here, as pb_volume_upload does. Under a motion of translations only along
 * x, AB HARDWARE reads a volume through layers along x but device memory,
 * laid out anew every call, through the 3-D image: on NVIDIA the two differ
 * by the texture unit's rounding (about 1e-3 of the values), elsewhere not. */
PB_API pb_status pb_plan_forward_device(pb_plan *plan, size_t frame, const void *object, void *tomograph);
PB_API pb_status pb_plan_adjoint_device(pb_plan *plan, size_t frame, const void *tomograph, void *object,
                                        int accumulate);
/* Frames first to first + count - 1 of a plan in one call, on the caller's
 * memory as above: the forward of one object into tomographs[0..count-1]
 * (the object copied into the plan's texture once, not once a frame), and
 * the adjoint of tomographs[0..count-1] summed into one object (accumulate:
 * added to what it holds). The frames are queued back to back and waited for
 * once; pb_context_last_kernel_ms gives their total (the forward's object
 * copy included, and alone in pb_context_last_input_ms; the adjoint's copies
 * of the tomographs a gather reads are counted with the kernels). No output
 * may overlap an input or another output. Progress is reported at the end. */
PB_API pb_status pb_plan_forward_frames_device(pb_plan *plan, size_t first, size_t count, const void *object,
                                               void *const *tomographs);
PB_API pb_status pb_plan_adjoint_frames_device(pb_plan *plan, size_t first, size_t count,
                                               const void *const *tomographs, void *object, int accumulate);

/* The runtime objects behind a context, for device memory in and out: on
 * OpenCL the cl_context, cl_command_queue and cl_device_id; on CUDA the
 * cudaStream_t in queue and the device ordinal (the runtime's primary
 * context); on the host backend all NULL. */
typedef struct pb_native {
    void *context;
    void *queue;
    void *device;
    int device_index;
} pb_native;
PB_API pb_status pb_context_native(const pb_context *ctx, pb_native *native);

/* Of the last call's device time, the part spent making its input current
 * (the copy of device memory into the texture), in milliseconds. */
PB_API pb_status pb_context_last_input_ms(const pb_context *ctx, double *ms);

/* CUDA only: queue the context's work on the caller's stream (a cudaStream_t
 * of the context's device: CuPy's or PyTorch's current stream;
 * cudaStreamLegacy, ((cudaStream_t)0x1), for the legacy default stream, whose
 * handle CuPy and PyTorch report as 0), or, with NULL, on its own stream
 * again. The new stream first waits for the end of the context's last call,
 * so calls stay in order across stream changes; the old stream is not
 * touched. While a caller's stream is set, blurs (pb_plan_*, pb_blur*) return
 * once their work is queued there, without waiting, as the caller's own
 * kernels do: the output is ready in stream order, a kernel's fault surfaces
 * at the caller's next synchronisation, and pb_context_last_kernel_ms waits
 * for the last call to give its time. Copies to and from host memory
 * (pb_volume_upload, pb_volume_download, plan creation's) still return
 * finished. The stream must stay alive while it is set: set NULL before
 * destroying it. On the host and OpenCL backends NULL is accepted and
 * anything else refused. */
PB_API pb_status pb_context_set_stream(pb_context *ctx, void *stream);

/* This header's structs and enums as the library was built, one per line:
 * "struct NAME SIZE", "field NAME.FIELD OFFSET SIZE", "enum NAME VALUE". A
 * binding that copies them (Python's ctypes) checks itself against it when
 * it loads. */
PB_API const char *pb_abi_layout(void);

/* How far x is from a reference, as users measure it, in percent. */
typedef struct pb_comparison {
    double rms_percent;     /* relative L2: 100 * sqrt(sum (x - ref)^2 / sum ref^2) */
    double max_percent;     /* relative max: 100 * max |x - ref| / max |ref| */
    double max_difference;  /* max |x - ref|, in the volumes' unit */
    size_t worst;           /* the index of that voxel (the first, on ties) */
    double eq5_percent;     /* the paper's eq. (5), 100 * sum (x - ref)^2 / sum ref^2: the square of
                               rms_percent / 10, kept where the paper's tables are reproduced */
} pb_comparison;

/* Compares n values of x with a reference (double sums). Refuses NULL
 * pointers, n = 0, a reference that is zero everywhere (no relative error
 * exists; PB_ERR_INVALID_ARGUMENT) and a value that is NaN or infinite in
 * either (PB_ERR_NOT_FINITE, naming the first such index). */
PB_API pb_status pb_compare(const float *reference, const float *x, size_t n, pb_comparison *out);

/* The paper's eq. (5) alone (pb_comparison.eq5_percent): 100 * sum (x -
 * ref)^2 / sum ref^2 over n voxels, in double. A squared ratio: 0.05 here is
 * a relative RMS error of 2.2 %. Returns NaN when ref is all zeros or either
 * pointer is NULL. */
PB_API double pb_error_percent(const float *reference, const float *x, size_t n);

#ifdef __cplusplus
}
#endif

#endif /* PETBLUR_H */
