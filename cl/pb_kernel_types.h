/* Types and pure integer helpers shared, byte for byte, by the host C code and
 * the kernels (OpenCL C and CUDA). Only 4-byte scalars, so the layout is the same
 * for every compiler. */
#ifndef PB_KERNEL_TYPES_H
#define PB_KERNEL_TYPES_H

#ifndef PB_FN
#define PB_FN static inline
#endif

/* Kernel arguments that are the same for every voxel. */
typedef struct pb_kparams {
    int dims[3];
    int segments;    /* key poses - 1 */
    int steps;       /* CL/RM: samples per segment (0: AB's slice count, RM's short segments exact); AB: sub-segments (>= 1) */
    int chord;       /* AB: every segment read exactly (PB_AB_SAMPLING_CHORD), never walked */
    int ref_points;  /* REF: points per voxel */
    int ref_steps;   /* REF: time steps over the frame */
    unsigned int seed;
    float voxel[3];  /* mm */
    float inv_voxel[3]; /* 1 / voxel: CL's steps multiply, a division a step costs more than the rest of its map */
    float center[3]; /* mm from the grid's corner */
    /* Adjoint: the steps the forward's texture unit rounds its weights to (256
     * on NVIDIA: 8 fractional bits), or 0 for float weights. */
    float weight_steps;
    float weight_step; /* 1 / weight_steps, exact for the unit's power of two: a multiply, not a division */
    /* The shift-invariant kernels (cl/pb_shift.cl): 0 the forward, 1 the
     * adjoint (the walk mirrored); with mirror, accumulate adds into out. */
    int mirror;
    int accumulate;
    /* pb_shift_ab_layers: the axis the layers run along, every segment's
     * major axis; pb_permute: the axis to make the slowest. */
    int layer_axis;
    /* The first z-slice of the launch: a launch covers a slab of slices when
     * the caller asks for progress (src/devices/launch.c). */
    int z0;
    /* pb_shift_taps (cl/pb_taps.cl): how many taps it reads, and their
     * largest offset along each axis either way; pb_shift_taps_tile: the
     * window of the offsets it reads (mirrored for the adjoint), from its
     * least corner tap_lo, tap_size voxels along each axis. */
    int taps;
    int tap_reach[3];
    int tap_lo[3];
    int tap_size[3];
    /* The field kernels (cl/pb_field.cl): the field grid, whether it is the
     * image grid, where the fields start in the plan buffer (in knots), and
     * the map from image texel coordinates to field voxel coordinates (centre
     * at i), row-major 3x4. */
    int field_dims[3];
    int field_same;
    int field_start;
    int jacobian;    /* weigh each segment by its mean Jacobian determinant (mass-preserving) */
    float field_map[12];
} pb_kparams;

/* AB reads a segment that moves at most PB_AB_EXACT_TO voxels along its
 * major axis exactly, one of at least PB_AB_WALK_FROM by the paper's walk
 * (cl/pb_blur.cl's pb_ab_walk_weight; the host backend and the kernel choice
 * follow them). One in between is read both ways, which costs more than the
 * chord alone: a narrow band keeps the blur continuous in the motion at the
 * least cost (docs/methods.md, "Short segments, read exactly"). */
#define PB_AB_EXACT_TO 5.0f
#define PB_AB_WALK_FROM 6.0f

/* Voxels along x per work item of pb_shift_ab_layers_x: 8 floats fill a
 * 32-byte sector. */
#define PB_X_RUN 8

/* Voxels along z per work item of pb_shift_taps: each tap read once for
 * them, their reads of the input in flight together. */
#define PB_TAP_RUN 8

/* The input a work group of pb_shift_taps_tile holds in local memory: its
 * voxels and the taps' window about them, for the ROWS group of 32 x 4 x 2
 * work items of PB_TAP_RUN voxels each and a window of at most 9 x 4 x 4
 * voxels. The strides are constants, so that a tap's eight reads are one
 * address and eight immediate offsets. 20.8 KiB a group: within OpenCL's
 * least local memory (32 KiB), ten groups of a Hopper multiprocessor's
 * 228 KiB, seven of an A100's 164 KiB; on the H200 its 48 registers, not
 * the tile, limit it to five groups. */
#define PB_TAP_TX 40
#define PB_TAP_TY 7
#define PB_TAP_TZ 19
/* How the group of 256 (PB_TAP_LINES lines of 32) reads it: the rows' first
 * 32 voxels a line a row, PB_TAP_BODY_STEPS rows each; the PB_TAP_RIM past
 * them, PB_TAP_RIM_STEPS voxels each work item. */
#define PB_TAP_GROUP 256
#define PB_TAP_LINES 8
#define PB_TAP_RIM (PB_TAP_TX - 32)
#define PB_TAP_BODY_STEPS ((PB_TAP_TY * PB_TAP_TZ + PB_TAP_LINES - 1) / PB_TAP_LINES)
#define PB_TAP_RIM_STEPS ((PB_TAP_RIM * PB_TAP_TY * PB_TAP_TZ + PB_TAP_GROUP - 1) / PB_TAP_GROUP)
#if PB_TAP_LINES != PB_TAP_TY + 1
#error "a line's rows step by PB_TAP_TY + 1 (cl/pb_taps.cl, pb_tile_reads)"
#endif

/* The two axes across the layers of axis m, in their own order: a layer's x
 * and y. Along y or z a layer's rows run along x, as a warp's work items do;
 * along x they run along y, as pb_shift_ab_layers_x's warps do. */
PB_FN int pb_layer_across(int m, int i)
{
    return i == 0 ? (m == 0 ? 1 : 0) : (m == 2 ? 1 : 2);
}

/* One key pose, as the kernels read it: 24 floats, so that in a buffer of
 * them every map starts on 16 bytes and is read by three vector loads
 * (pb_map_pose): a segment's scalar loads of it were a tenth of the forward's
 * instructions on a slow drift (docs/methods.md, "Less set-up a segment"). */
typedef struct pb_kpose {
    float map[12];      /* object texel coords from tomograph texel coords, row-major 3x4 */
    float rotation[4];  /* unit quaternion w, x, y, z, same hemisphere as the previous pose */
    float translation[3]; /* mm */
    float weight;       /* fraction of the frame spent on the segment to the next pose */
    float angle;        /* SLERP angle to the next pose's rotation, from the host in double:
                         * acos of a float dot product near 1 would lose most of it */
    float cos_angle;    /* its cosine and 1 / its sine (0 for angle 0), from the host in double, */
    float inv_sin_angle; /* so that CL's step needs one sincos and no division */
    float unused;        /* to 96 bytes */
} pb_kpose;

/* One key point of a field motion's frame, or one of REF's time steps: the
 * field (1 - alpha) F[f0] + alpha F[f1], and the share of the frame of the
 * segment to the next key point (of the step, for REF). The frame's fields
 * follow the knots in the same buffer, at knot prm.field_start. */
typedef struct pb_kknot {
    int f0, f1;
    float alpha;
    float weight;
} pb_kknot;

/* One weight of the convolution that a motion of translations is
 * (cl/pb_taps.cl): tomograph voxel W reads object voxel W + offset, `linear`
 * places apart in the grid's memory. */
typedef struct pb_ktap {
    int offset[3];
    int linear;
    float weight;
    int tile[2]; /* pb_shift_taps_tile: its place in the tile, forward and mirrored */
} pb_ktap;

/* One REF time step. */
typedef struct pb_kstep {
    float map[12];
    float weight;
} pb_kstep;

/* Counter-based random numbers (lowbias32 hash), so that REF's points are a
 * pure function of (seed, voxel, sample) on every backend. */
PB_FN unsigned int pb_hash(unsigned int x)
{
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

PB_FN unsigned int pb_ref_key(unsigned int seed, unsigned int voxel)
{
    return pb_hash(voxel ^ pb_hash(seed));
}

/* Coordinate d (0..2) of REF sample c of a voxel, as a 24-bit integer: the
 * point's offset inside the voxel is (value + 0.5) / 2^24, exact in float. */
PB_FN unsigned int pb_ref_bits(unsigned int key, unsigned int c, unsigned int d)
{
    return pb_hash(key + 3u * c + d) >> 8;
}

#endif
