/* Every device kernel, once. The enum, the OpenCL kernel names, CUDA's launch
 * switch and check (cuda/pb_kernels.cu), what each launch reads and its work
 * group all come from this table; src/devices/kernel_choice.c picks a launch's kernel by
 * what it is (family, method, filter), never by its position.
 *
 * Columns:
 *   family  GENERAL  the forward gather: each voxel walks its own path
 *           SCATTER  the adjoint's scatter of the same walk (atomic adds)
 *           SHIFT    under translations only, voxel 0's walk moved: forward,
 *                    or mirrored, the adjoint's gather (cl/pb_shift.cl)
 *           LAYERS   SHIFT for AB HARDWARE through 2-D layers along y or z
 *           LAYERS_X the same along x, one work item per run of PB_X_RUN voxels
 *           TAPS     under translations with short paths, the convolution
 *                    they are, from taps measured once (cl/pb_taps.cl);
 *                    its _TILE kernel where the taps' window fits PB_TAP_TX/TY/TZ
 *           PERMUTE  lays a buffer out in layers for the copy into them
 *           FIELD    the forward gather along a deformation field's paths
 *                    (cl/pb_field.cl); CL is RM there
 *           FIELD_SCATTER  its adjoint's scatter
 *           FIELD_MASS, FIELD_MASS_SCATTER  the same, mass-preserving (each
 *                    segment weighed by its Jacobian determinant); REF reads
 *                    prm.jacobian in FIELD's own kernels
 *   method, filter   what it computes (ANY: either)
 *   reads   LINEAR / NEAREST  the 3-D image through a linear / point filter
 *           LAYERS  the layered image;  BUFFER  a plain device buffer
 *   group   TILES  16 x 2 x 8: rotated paths fan out, tiles keep a group's
 *                  walks close (fewer L2 lines hit by the scatters' atomics,
 *                  fewer texture lines by CL's fetches)
 *           ROWS   32 x 4 x 2: under translations a warp of x-neighbours reads
 *                  and writes coalesced
 *           (docs/performance.md says why.) */
#ifndef PB_KERNEL_TABLE_H
#define PB_KERNEL_TABLE_H

/*  id                 name                  family    method filter    reads    group */
#define PB_KERNELS(X)                                                                         \
    X(BLUR_AB,          pb_blur_ab,          GENERAL,  AB,    HARDWARE, LINEAR,  TILES)     \
    X(BLUR_AB_EXACT,    pb_blur_ab_exact,    GENERAL,  AB,    EXACT,    NEAREST, TILES)     \
    X(BLUR_AB_SWEEP,    pb_blur_ab_sweep,    GENERAL,  AB_SWEEP, HARDWARE, LINEAR, TILES)   \
    X(BLUR_AB_SWEEP_EXACT, pb_blur_ab_sweep_exact, GENERAL, AB_SWEEP, EXACT, NEAREST, TILES)  \
    X(BLUR_RM,          pb_blur_rm,          GENERAL,  RM,    HARDWARE, LINEAR,  TILES)     \
    X(BLUR_RM_EXACT,    pb_blur_rm_exact,    GENERAL,  RM,    EXACT,    NEAREST, TILES)     \
    X(BLUR_CL,          pb_blur_cl,          GENERAL,  CL,    HARDWARE, LINEAR,  TILES)     \
    X(BLUR_CL_EXACT,    pb_blur_cl_exact,    GENERAL,  CL,    EXACT,    NEAREST, TILES)     \
    X(BLUR_REF,         pb_blur_ref,         GENERAL,  REF,   ANY,      NEAREST, TILES)     \
    X(ADJOINT_AB,       pb_adjoint_ab,       SCATTER,  AB,    ANY,      BUFFER,  TILES)     \
    X(ADJOINT_AB_SWEEP, pb_adjoint_ab_sweep, SCATTER,  AB_SWEEP, ANY,   BUFFER,  TILES)     \
    X(ADJOINT_RM,       pb_adjoint_rm,       SCATTER,  RM,    ANY,      BUFFER,  TILES)     \
    X(ADJOINT_CL,       pb_adjoint_cl,       SCATTER,  CL,    ANY,      BUFFER,  TILES)     \
    X(ADJOINT_REF,      pb_adjoint_ref,      SCATTER,  REF,   ANY,      BUFFER,  TILES)     \
    X(SHIFT_AB,         pb_shift_ab,         SHIFT,    AB,    HARDWARE, LINEAR,  ROWS)      \
    X(SHIFT_AB_EXACT,   pb_shift_ab_exact,   SHIFT,    AB,    EXACT,    NEAREST, ROWS)      \
    X(SHIFT_AB_SWEEP,   pb_shift_ab_sweep,   SHIFT,    AB_SWEEP, HARDWARE, LINEAR, ROWS)    \
    X(SHIFT_AB_SWEEP_EXACT, pb_shift_ab_sweep_exact, SHIFT, AB_SWEEP, EXACT, NEAREST, ROWS)   \
    X(SHIFT_RM,         pb_shift_rm,         SHIFT,    RM,    HARDWARE, LINEAR,  ROWS)      \
    X(SHIFT_RM_EXACT,   pb_shift_rm_exact,   SHIFT,    RM,    EXACT,    NEAREST, ROWS)      \
    X(SHIFT_CL,         pb_shift_cl,         SHIFT,    CL,    HARDWARE, LINEAR,  ROWS)      \
    X(SHIFT_CL_EXACT,   pb_shift_cl_exact,   SHIFT,    CL,    EXACT,    NEAREST, ROWS)      \
    X(SHIFT_AB_LAYERS,  pb_shift_ab_layers,  LAYERS,   AB,    HARDWARE, LAYERS,  ROWS)      \
    X(SHIFT_AB_LAYERS_X, pb_shift_ab_layers_x, LAYERS_X, AB,  HARDWARE, LAYERS,  ROWS)      \
    X(SHIFT_AB_SWEEP_LAYERS, pb_shift_ab_sweep_layers, LAYERS, AB_SWEEP, HARDWARE, LAYERS, ROWS) \
    X(SHIFT_AB_SWEEP_LAYERS_X, pb_shift_ab_sweep_layers_x, LAYERS_X, AB_SWEEP, HARDWARE, LAYERS, ROWS) \
    X(SHIFT_TAPS,       pb_shift_taps,       TAPS,     ANY,   ANY,      BUFFER,  ROWS)      \
    X(SHIFT_TAPS_TILE,  pb_shift_taps_tile,  TAPS,     ANY,   ANY,      BUFFER,  ROWS)      \
    X(PERMUTE,          pb_permute,          PERMUTE,  ANY,   ANY,      BUFFER,  ROWS)      \
    X(FIELD_AB,         pb_field_ab,         FIELD,    AB,    HARDWARE, LINEAR,  TILES)     \
    X(FIELD_AB_EXACT,   pb_field_ab_exact,   FIELD,    AB,    EXACT,    NEAREST, TILES)     \
    X(FIELD_AB_SWEEP,   pb_field_ab_sweep,   FIELD,    AB_SWEEP, HARDWARE, LINEAR, TILES)   \
    X(FIELD_AB_SWEEP_EXACT, pb_field_ab_sweep_exact, FIELD, AB_SWEEP, EXACT, NEAREST, TILES)  \
    X(FIELD_RM,         pb_field_rm,         FIELD,    RM,    HARDWARE, LINEAR,  TILES)     \
    X(FIELD_RM_EXACT,   pb_field_rm_exact,   FIELD,    RM,    EXACT,    NEAREST, TILES)     \
    X(FIELD_REF,        pb_field_ref,        FIELD,    REF,   ANY,      NEAREST, TILES)     \
    X(FIELD_ADJOINT_AB, pb_field_adjoint_ab, FIELD_SCATTER, AB, ANY,    BUFFER,  TILES)     \
    X(FIELD_ADJOINT_AB_SWEEP, pb_field_adjoint_ab_sweep, FIELD_SCATTER, AB_SWEEP, ANY, BUFFER, TILES) \
    X(FIELD_ADJOINT_RM, pb_field_adjoint_rm, FIELD_SCATTER, RM, ANY,    BUFFER,  TILES)     \
    X(FIELD_ADJOINT_REF, pb_field_adjoint_ref, FIELD_SCATTER, REF, ANY, BUFFER,  TILES)     \
    X(FIELD_MASS_AB,    pb_field_mass_ab,    FIELD_MASS, AB,  HARDWARE, LINEAR,  TILES)     \
    X(FIELD_MASS_AB_EXACT, pb_field_mass_ab_exact, FIELD_MASS, AB, EXACT, NEAREST, TILES)    \
    X(FIELD_MASS_AB_SWEEP, pb_field_mass_ab_sweep, FIELD_MASS, AB_SWEEP, HARDWARE, LINEAR, TILES) \
    X(FIELD_MASS_AB_SWEEP_EXACT, pb_field_mass_ab_sweep_exact, FIELD_MASS, AB_SWEEP, EXACT, NEAREST, TILES) \
    X(FIELD_MASS_RM,    pb_field_mass_rm,    FIELD_MASS, RM,  HARDWARE, LINEAR,  TILES)     \
    X(FIELD_MASS_RM_EXACT, pb_field_mass_rm_exact, FIELD_MASS, RM, EXACT, NEAREST, TILES)    \
    X(FIELD_MASS_ADJOINT_AB, pb_field_mass_adjoint_ab, FIELD_MASS_SCATTER, AB, ANY, BUFFER, TILES) \
    X(FIELD_MASS_ADJOINT_AB_SWEEP, pb_field_mass_adjoint_ab_sweep, FIELD_MASS_SCATTER, AB_SWEEP, ANY, BUFFER, TILES) \
    X(FIELD_MASS_ADJOINT_RM, pb_field_mass_adjoint_rm, FIELD_MASS_SCATTER, RM, ANY, BUFFER, TILES)

typedef enum pb_kernel_id {
#define PB_KERNEL_ENUM_(id, ...) PB_KERNEL_##id,
    PB_KERNELS(PB_KERNEL_ENUM_)
#undef PB_KERNEL_ENUM_
    PB_KERNEL_COUNT
} pb_kernel_id;

typedef enum pb_kernel_family {
    PB_FAMILY_GENERAL, PB_FAMILY_SCATTER, PB_FAMILY_SHIFT, PB_FAMILY_LAYERS, PB_FAMILY_LAYERS_X, PB_FAMILY_TAPS,
    PB_FAMILY_PERMUTE, PB_FAMILY_FIELD, PB_FAMILY_FIELD_SCATTER, PB_FAMILY_FIELD_MASS, PB_FAMILY_FIELD_MASS_SCATTER
} pb_kernel_family;

typedef enum pb_kernel_reads { PB_READS_LINEAR, PB_READS_NEAREST, PB_READS_LAYERS, PB_READS_BUFFER } pb_kernel_reads;

/* The method and filter columns in petblur.h's values (pb_method, pb_filter);
 * -1 for ANY. */
#define PB_KT_AB 0
#define PB_KT_RM 1
#define PB_KT_CL 2
#define PB_KT_REF 3
#define PB_KT_AB_SWEEP 4 /* AB with ab_sampling SWEEP: kernels of its own */
#define PB_KT_HARDWARE 0
#define PB_KT_EXACT 1
#define PB_KT_ANY (-1)
#define PB_KT_TILES {16, 2, 8}
#define PB_KT_ROWS {32, 4, 2}

typedef struct pb_kernel_info {
    const char *name;
    pb_kernel_family family;
    int method, filter;
    pb_kernel_reads reads;
    unsigned group[3];
} pb_kernel_info;

/* The table itself, indexed by pb_kernel_id (src/devices/kernel_choice.c). */
#ifndef __cplusplus
extern const pb_kernel_info pb_kernel_table[PB_KERNEL_COUNT];
#endif

#endif
