/* The public plan: made once and applied many times, it must give what the
 * one-shot calls give, bit for bit, in both directions and for frames, on
 * volumes and on the caller's own device memory (a cl_mem on OpenCL, a CUDA
 * device pointer on CUDA, host memory on the host backend), with or without
 * progress slabs; and it must refuse what does not fit it. The one exception
 * to "bit for bit" is the adjoint's scatter (motions that turn), whose float
 * atomic adds land in an order that differs between runs: there the runs must
 * agree to 1e-5 of the largest value. Fresh random volumes and motions every
 * run; outputs poisoned first. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef PB_HAVE_OPENCL
#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>
#endif
#ifdef PB_HAVE_CUDA
#include <cuda_runtime_api.h>
#endif

#include "objects.h" /* which kernel a plan chose */
#include "testlib.h"

static const char *method_names[] = {"AB", "RM", "CL", "REF"};

/* ---- the caller's device memory, per backend --------------------------- */

static void *dev_alloc(pb_context *ctx, size_t bytes)
{
    pb_native nat;
    pb_context_native(ctx, &nat);
    switch (pb_context_backend(ctx)) {
#ifdef PB_HAVE_OPENCL
    case PB_BACKEND_OPENCL: {
        cl_int e;
        cl_mem m = clCreateBuffer((cl_context)nat.context, CL_MEM_READ_WRITE, bytes, NULL, &e);
        return e == CL_SUCCESS ? m : NULL;
    }
#endif
#ifdef PB_HAVE_CUDA
    case PB_BACKEND_CUDA: {
        void *p = NULL;
        cudaSetDevice(nat.device_index);
        return cudaMalloc(&p, bytes) == cudaSuccess ? p : NULL;
    }
#endif
    default: return malloc(bytes);
    }
}

static void dev_free(pb_backend backend, void *mem)
{
    if (!mem)
        return;
    switch (backend) {
#ifdef PB_HAVE_OPENCL
    case PB_BACKEND_OPENCL: clReleaseMemObject((cl_mem)mem); return;
#endif
#ifdef PB_HAVE_CUDA
    case PB_BACKEND_CUDA: cudaFree(mem); return;
#endif
    default: free(mem);
    }
}

/* Writes (to_device) or reads the caller's memory, finished on return. The
 * writes go through the context's own queue or stream, as a caller that
 * shares it would. */
static int dev_copy(pb_context *ctx, void *mem, float *host, size_t bytes, int to_device)
{
    pb_native nat;
    pb_context_native(ctx, &nat);
    switch (pb_context_backend(ctx)) {
#ifdef PB_HAVE_OPENCL
    case PB_BACKEND_OPENCL: {
        cl_command_queue q = (cl_command_queue)nat.queue;
        cl_int e = to_device ? clEnqueueWriteBuffer(q, (cl_mem)mem, CL_TRUE, 0, bytes, host, 0, NULL, NULL)
                             : clEnqueueReadBuffer(q, (cl_mem)mem, CL_TRUE, 0, bytes, host, 0, NULL, NULL);
        return e == CL_SUCCESS;
    }
#endif
#ifdef PB_HAVE_CUDA
    case PB_BACKEND_CUDA: {
        cudaStream_t s = (cudaStream_t)nat.queue;
        cudaError_t e = to_device ? cudaMemcpyAsync(mem, host, bytes, cudaMemcpyHostToDevice, s)
                                  : cudaMemcpyAsync(host, mem, bytes, cudaMemcpyDeviceToHost, s);
        return e == cudaSuccess && cudaStreamSynchronize(s) == cudaSuccess;
    }
#endif
    default:
        if (to_device)
            memcpy(mem, host, bytes);
        else
            memcpy(host, mem, bytes);
        return 1;
    }
}

/* ---- helpers ----------------------------------------------------------- */

static void poison(float *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        v[i] = -1e30f;
}

/* a and b equal bit for bit, or (exact 0) to tol of b's largest value. */
static int same(const float *a, const float *b, size_t n, int exact, double tol)
{
    if (exact)
        return memcmp(a, b, n * sizeof *a) == 0;
    return pb_max_abs_diff(a, b, n) <= tol * fmax(pb_max_abs(b, n), 1e-30);
}

static void run_volume(pb_status (*fn)(pb_plan *, size_t, const pb_volume *, pb_volume *), pb_plan *plan,
                       pb_volume *in, pb_volume *out, const float *data, float *result, size_t n)
{
    float *p = malloc(n * sizeof *p);
    poison(p, n);
    pb_volume_upload(out, p);
    pb_volume_upload(in, data);
    pb_check(fn(plan, 0, in, out) == PB_OK, "plan apply: %s", pb_last_error(NULL));
    pb_volume_download(out, result);
    free(p);
}

static pb_status adjoint_overwrite(pb_plan *plan, size_t frame, const pb_volume *in, pb_volume *out)
{
    return pb_plan_adjoint(plan, frame, in, out, 0);
}

static pb_status adjoint_device_overwrite(pb_plan *plan, size_t frame, const void *in, void *out)
{
    return pb_plan_adjoint_device(plan, frame, in, out, 0);
}

/* One motion and options: the one-shot calls, the plan on volumes (twice,
 * with the other direction between), the plan on device memory, and the plan
 * with progress slabs, all against each other. */
static void check_case(pb_context *ctx, const pb_geometry *g, const pb_motion *m, const pb_blur_options *opt,
                       int turns, int along_x, const char *what)
{
    size_t n = g->dims[0] * g->dims[1] * g->dims[2], bytes = n * sizeof(float);
    float *x = pb_random_volume(n), *y = pb_random_volume(n);
    float *once = malloc(bytes), *planned = malloc(bytes), *again = malloc(bytes), *dev = malloc(bytes);
    pb_volume *in, *out;
    pb_volume_create(ctx, g, &in);
    pb_volume_create(ctx, g, &out);
    pb_plan *plan = NULL;
    if (!pb_check(pb_plan_create(ctx, g, m, opt, &plan) == PB_OK, "%s: plan: %s", what, pb_last_error(ctx)))
        goto done;
    void *din = dev_alloc(ctx, bytes), *dout = dev_alloc(ctx, bytes);
    if (!pb_check(din && dout, "%s: the test could not allocate device memory", what)) {
        dev_free(pb_context_backend(ctx), din);
        dev_free(pb_context_backend(ctx), dout);
        goto done;
    }
    for (int adjoint = 0; adjoint < 2; adjoint++) {
        const float *data = adjoint ? y : x;
        /* The scatter's atomics (motions that turn, and REF always): the only
         * result that is not reproducible. */
        int exact = !(adjoint && (turns || opt->method == PB_METHOD_REF));
        const char *dir = adjoint ? "adjoint" : "forward";
        pb_status st = adjoint ? pb_test_adjoint(ctx, g, data, m, opt, once) : pb_test_blur(ctx, g, data, m, opt, once);
        pb_check(st == PB_OK, "%s %s: one-shot: %s", what, dir, pb_last_error(ctx));
        run_volume(adjoint ? adjoint_overwrite : pb_plan_forward, plan, in, out, data, planned, n);
        pb_check(same(planned, once, n, exact, 1e-5), "%s %s: the plan differs from the one-shot call (largest "
                 "difference %g)", what, dir, pb_max_abs_diff(planned, once, n));
        /* The other direction in between, then this one again on the same plan. */
        run_volume(adjoint ? pb_plan_forward : adjoint_overwrite, plan, in, out, adjoint ? x : y, again, n);
        run_volume(adjoint ? adjoint_overwrite : pb_plan_forward, plan, in, out, data, again, n);
        pb_check(same(again, once, n, exact, 1e-5), "%s %s: the plan's second use differs", what, dir);

        /* Device memory in and out. */
        poison(dev, n);
        pb_check(dev_copy(ctx, dout, dev, bytes, 1) && dev_copy(ctx, din, (float *)data, bytes, 1),
                 "%s: writing device memory", what);
        st = adjoint ? adjoint_device_overwrite(plan, 0, din, dout) : pb_plan_forward_device(plan, 0, din, dout);
        pb_check(st == PB_OK, "%s %s: device memory: %s", what, dir, pb_last_error(ctx));
        /* The device time holds the copy into the texture, and the copy is part of it. */
        double kernel_ms = -1.0, input_ms = -1.0;
        pb_context_last_kernel_ms(ctx, &kernel_ms);
        pb_context_last_input_ms(ctx, &input_ms);
        int device = pb_context_backend(ctx) != PB_BACKEND_HOST;
        /* The scatter and a short translation's taps (cl/pb_taps.cl) read no texture. */
        int reads_buffer = (adjoint && (turns || opt->method == PB_METHOD_REF)) ||
                           pb_kernel_table[plan->set.frame[0].forward_fresh].family == PB_FAMILY_TAPS;
        pb_check(device && !reads_buffer ? input_ms > 0.0 && input_ms < kernel_ms : input_ms == 0.0,
                 "%s %s: device time %g ms, of it the input's %g ms", what, dir, kernel_ms, input_ms);
        pb_check(dev_copy(ctx, dout, dev, bytes, 0), "%s: reading device memory back", what);
        /* AB HARDWARE moving along x reads a volume through layers along x,
         * but device memory, laid out anew every call, through the 3-D image
         * (src/devices/kernel_choice.c): the same weights, blended by the texture unit
         * in another order, so equal to its rounding (tests/testlib.h). */
        int other_kernel = !adjoint && along_x && opt->method == PB_METHOD_AB && opt->filter == PB_FILTER_HARDWARE;
        pb_check(same(dev, once, n, exact && !other_kernel, other_kernel ? PB_TEX_TRILINEAR_ERROR : 1e-5),
                 "%s %s: device memory differs from volumes (largest difference %g)", what, dir,
                 pb_max_abs_diff(dev, once, n));
        /* The input untouched. */
        pb_check(dev_copy(ctx, din, dev, bytes, 0) && memcmp(dev, data, bytes) == 0,
                 "%s %s: the input memory was changed", what, dir);

        /* Progress slabs give the same voxels. */
        pb_test_progress_log log = {0, 0, 0.0};
        pb_context_set_progress(ctx, pb_test_record_progress, &log);
        run_volume(adjoint ? adjoint_overwrite : pb_plan_forward, plan, in, out, data, again, n);
        pb_context_set_progress(ctx, NULL, NULL);
        pb_check(same(again, once, n, exact, 1e-5), "%s %s: slabs differ from one launch", what, dir);
        pb_check(log.calls >= 2 && log.bad == 0 && log.last == 1.0, "%s %s: progress: %d calls, %d bad, last %g",
                 what, dir, log.calls, log.bad, log.last);
    }
    dev_free(pb_context_backend(ctx), din);
    dev_free(pb_context_backend(ctx), dout);
done:
    pb_plan_destroy(plan);
    pb_volume_destroy(in);
    pb_volume_destroy(out);
    free(x), free(y), free(once), free(planned), free(again), free(dev);
}

/* A volume's texture follows its buffer through every kind of write: B and
 * B^T applied in turn to two volumes with no upload between, and a device
 * call that writes a volume's own memory, each step against the one-shot call
 * on what the step before left. */
static void check_staleness(pb_context *ctx, const pb_geometry *g, const pb_motion *m, const pb_blur_options *opt,
                            int scatter, const char *what)
{
    size_t n = g->dims[0] * g->dims[1] * g->dims[2], bytes = n * sizeof(float);
    float *host = pb_random_volume(n), *want = malloc(bytes), *got = malloc(bytes);
    pb_volume *a, *b;
    pb_volume_create(ctx, g, &a);
    pb_volume_create(ctx, g, &b);
    pb_volume_upload(a, host);
    pb_plan *plan;
    if (!pb_check(pb_plan_create(ctx, g, m, opt, &plan) == PB_OK, "%s: plan: %s", what, pb_last_error(ctx)))
        goto done;
    for (int step = 0; step < 5; step++) {
        int adjoint = step % 2;
        pb_volume *in = adjoint ? b : a, *out = adjoint ? a : b;
        pb_volume_download(in, host);
        pb_status st;
        if (step == 4) { /* the device path into b's own memory, then b read by a gather */
            void *ma, *mb;
            pb_volume_memory(a, &ma);
            pb_volume_memory(b, &mb);
            st = pb_plan_forward_device(plan, 0, ma, mb);
            pb_check(st == PB_OK, "%s: device path into a volume: %s", what, pb_last_error(ctx));
            pb_volume_download(b, host);
            in = b, out = a, adjoint = 1;
        }
        st = adjoint ? pb_test_adjoint(ctx, g, host, m, opt, want) : pb_test_blur(ctx, g, host, m, opt, want);
        pb_check(st == PB_OK, "%s: one-shot: %s", what, pb_last_error(ctx));
        st = adjoint ? pb_plan_adjoint(plan, 0, in, out, 0) : pb_plan_forward(plan, 0, in, out);
        pb_check(st == PB_OK, "%s step %d: %s", what, step, pb_last_error(ctx));
        pb_volume_download(out, got);
        pb_check(same(got, want, n, !(adjoint && scatter), 1e-5), "%s step %d (%s): the plan read a stale "
                 "texture (largest difference %g)", what, step, adjoint ? "adjoint" : "forward",
                 pb_max_abs_diff(got, want, n));
    }
    /* accumulate adds the back projection onto what the object holds. */
    pb_volume_download(a, host);
    pb_volume_download(b, want);
    float *alone = malloc(bytes);
    pb_test_adjoint(ctx, g, want, m, opt, alone);
    pb_check(pb_plan_adjoint(plan, 0, b, a, 1) == PB_OK, "%s: accumulate: %s", what, pb_last_error(ctx));
    pb_volume_download(a, got);
    for (size_t i = 0; i < n; i++)
        want[i] = host[i] + alone[i];
    pb_check(same(got, want, n, 0, 1e-5), "%s: accumulate is not the sum (largest difference %g)", what,
             pb_max_abs_diff(got, want, n));
    free(alone);
    pb_plan_destroy(plan);
done:
    pb_volume_destroy(a);
    pb_volume_destroy(b);
    free(host), free(want), free(got);
}

/* A plan of frames equals pb_blur_frames bit for bit. */
/* pb_plan_forward_frames_device and pb_plan_adjoint_frames_device on the
 * caller's memory: every frame, and a run of them, against one call a frame
 * (the forward bit for bit: the same kernels; the adjoint's sum to float
 * rounding, its scatter adding in another order), accumulate, refusals. */
static void check_frames_device(pb_context *ctx, pb_plan *plan, const float *x, size_t n, const pb_blur_options *opt)
{
    enum { F = 3 };
    size_t bytes = n * sizeof(float);
    float *want = malloc(bytes), *got = malloc(bytes), *y[F];
    void *xd = dev_alloc(ctx, bytes), *yd[F], *sd = dev_alloc(ctx, bytes), *one = dev_alloc(ctx, bytes);
    dev_copy(ctx, xd, (float *)x, bytes, 1);
    for (int f = 0; f < F; f++) {
        yd[f] = dev_alloc(ctx, bytes);
        poison(got, n);
        dev_copy(ctx, yd[f], got, bytes, 1);
        y[f] = pb_random_volume(n);
    }
    const char *m = method_names[opt->method];
    for (size_t first = 0; first < 2; first++) {
        size_t count = F - first;
        pb_check(pb_plan_forward_frames_device(plan, first, count, xd, yd) == PB_OK, "%s forward frames %zu+%zu: %s",
                 m, first, count, pb_last_error(ctx));
        for (size_t i = 0; i < count; i++) {
            pb_plan_forward_device(plan, first + i, xd, one);
            dev_copy(ctx, one, want, bytes, 0);
            dev_copy(ctx, yd[i], got, bytes, 0);
            pb_check(memcmp(want, got, bytes) == 0, "%s frames in one call: frame %zu differs from its own call", m,
                     first + i);
        }
    }
    /* The adjoint of every frame, summed; then added onto that sum again. */
    for (int f = 0; f < F; f++)
        dev_copy(ctx, yd[f], y[f], bytes, 1);
    for (int f = 0; f < F; f++)
        pb_plan_adjoint_device(plan, (size_t)f, yd[f], one, f > 0);
    dev_copy(ctx, one, want, bytes, 0);
    poison(got, n);
    dev_copy(ctx, sd, got, bytes, 1);
    pb_check(pb_plan_adjoint_frames_device(plan, 0, F, (const void *const *)yd, sd, 0) == PB_OK,
             "%s adjoint frames: %s", m, pb_last_error(ctx));
    dev_copy(ctx, sd, got, bytes, 0);
    pb_check(same(got, want, n, 0, 1e-5), "%s adjoint frames summed in one call: %.3g off", m,
             pb_max_abs_diff(got, want, n));
    pb_check(pb_plan_adjoint_frames_device(plan, 0, F, (const void *const *)yd, sd, 1) == PB_OK,
             "%s adjoint frames, accumulate: %s", m, pb_last_error(ctx));
    dev_copy(ctx, sd, got, bytes, 0);
    for (size_t i = 0; i < n; i++)
        want[i] *= 2.0f;
    pb_check(same(got, want, n, 0, 1e-5), "%s adjoint frames added to what the object held: %.3g off", m,
             pb_max_abs_diff(got, want, n));
    /* Refusals: no frames, frames past the end, an output twice, NULL. */
    void *twice[F] = {yd[0], yd[0], yd[2]};
    pb_check(pb_plan_forward_frames_device(plan, 0, 0, xd, yd) == PB_ERR_INVALID_ARGUMENT, "no frames accepted");
    pb_check(pb_plan_forward_frames_device(plan, 1, F, xd, yd) == PB_ERR_INVALID_ARGUMENT &&
                 strstr(pb_last_error(ctx), "frames 1 to 3"), "frames past the end: %s", pb_last_error(ctx));
    pb_check(pb_plan_forward_frames_device(plan, 0, F, xd, twice) == PB_ERR_INVALID_ARGUMENT &&
                 strstr(pb_last_error(ctx), "overlaps"), "an output twice: %s", pb_last_error(ctx));
    pb_check(pb_plan_adjoint_frames_device(plan, 0, F, (const void *const *)yd, yd[1], 0) == PB_ERR_INVALID_ARGUMENT,
             "the sum into one of its tomographs accepted");
    void *none[F] = {yd[0], NULL, yd[2]};
    pb_check(pb_plan_forward_frames_device(plan, 0, F, xd, none) == PB_ERR_INVALID_ARGUMENT, "a NULL output accepted");
    pb_backend b = pb_context_backend(ctx);
    for (int f = 0; f < F; f++) {
        dev_free(b, yd[f]);
        free(y[f]);
    }
    dev_free(b, xd), dev_free(b, sd), dev_free(b, one);
    free(want), free(got);
}

static void check_frames(pb_context *ctx, const pb_geometry *g, const pb_blur_options *opt)
{
    enum { TRACK = 31, FRAMES = 3 };
    double times[TRACK], axis[3] = {0.2, 0.4, 1.0}, deg = 0.0, t[3] = {0, 0, 0};
    pb_pose poses[TRACK];
    for (int k = 0; k < TRACK; k++) {
        times[k] = k / 30.0;
        for (int i = 0; i < 3; i++)
            t[i] += pb_rand_range(-0.3, 0.4);
        deg = k < 12 ? deg + pb_rand_range(-0.5, 0.8) : deg; /* frame 0 turns, the others only move */
        poses[k] = pb_test_pose(t[0], t[1], t[2], axis, deg);
    }
    pb_motion track = {times, poses, TRACK, 0.0, 0.0, 0, {0, 0, 0}};
    double bounds[FRAMES + 1] = {0.05, 0.4, pb_rand_range(0.5, 0.7), 0.95};
    size_t n = g->dims[0] * g->dims[1] * g->dims[2];
    float *x = pb_random_volume(n), *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b);
    pb_volume *obj, *tomo[FRAMES], *out;
    pb_volume_create(ctx, g, &obj);
    pb_volume_create(ctx, g, &out);
    pb_volume_upload(obj, x);
    const pb_volume *objs[FRAMES];
    for (int f = 0; f < FRAMES; f++) {
        pb_volume_create(ctx, g, &tomo[f]);
        poison(a, n);
        pb_volume_upload(tomo[f], a);
        objs[f] = obj;
    }
    pb_check(pb_blur_frames(ctx, objs, &track, bounds, FRAMES, opt, tomo) == PB_OK, "frames: %s",
             pb_last_error(ctx));
    pb_plan *plan;
    if (pb_check(pb_plan_create_frames(ctx, g, &track, bounds, FRAMES, opt, &plan) == PB_OK, "plan of frames: %s",
                 pb_last_error(ctx))) {
        pb_check(pb_plan_frame_count(plan) == FRAMES, "the plan has %zu frames", pb_plan_frame_count(plan));
        for (int f = FRAMES - 1; f >= 0; f--) { /* any order */
            poison(b, n);
            pb_volume_upload(out, b);
            pb_check(pb_plan_forward(plan, (size_t)f, obj, out) == PB_OK, "frame %d: %s", f, pb_last_error(ctx));
            pb_volume_download(out, b);
            pb_volume_download(tomo[f], a);
            pb_check(memcmp(a, b, n * sizeof *a) == 0, "%s frame %d: the plan differs from pb_blur_frames",
                     method_names[opt->method], f);
        }
        pb_check(pb_plan_forward(plan, FRAMES, obj, out) == PB_ERR_INVALID_ARGUMENT, "frame %d of %d accepted",
                 FRAMES, FRAMES);
        check_frames_device(ctx, plan, x, n, opt);
        pb_plan_destroy(plan);
    }
    for (int f = 0; f < FRAMES; f++)
        pb_volume_destroy(tomo[f]);
    pb_volume_destroy(obj);
    pb_volume_destroy(out);
    free(x), free(a), free(b);
}

/* What a plan must refuse, each with its status. */
/* A caller's stream (CUDA): calls queue on it, after the caller's own work
 * there, and return unfinished; what the caller then queues there sees their
 * output, equal to the context's own stream's. The stream is held shut by a
 * gate (a host function that spins until the test opens it), with the input
 * written behind the gate: a call that ran anywhere else, or waited, would
 * read the stale input or never return. Then a second caller's stream after
 * the first was destroyed. Elsewhere only NULL is taken. */
#ifdef PB_HAVE_CUDA
static void CUDART_CB gate_wait(void *flag)
{
    while (!__atomic_load_n((int *)flag, __ATOMIC_ACQUIRE))
        ;
}
#endif

static void check_caller_stream(pb_context *ctx, const pb_geometry *g, const pb_motion *m)
{
    int dummy;
    if (pb_context_backend(ctx) != PB_BACKEND_CUDA) {
        pb_check(pb_context_set_stream(ctx, &dummy) == PB_ERR_INVALID_ARGUMENT && pb_context_set_stream(ctx, NULL) ==
                 PB_OK, "pb_context_set_stream off CUDA: %s", pb_last_error(ctx));
        return;
    }
#ifdef PB_HAVE_CUDA
    size_t n = g->dims[0] * g->dims[1] * g->dims[2], bytes = n * sizeof(float);
    float *x = pb_random_volume(n), *stale = pb_random_volume(n), *own = malloc(bytes), *got = malloc(bytes);
    float *pinned = NULL;
    void *din = dev_alloc(ctx, bytes), *dout = dev_alloc(ctx, bytes);
    pb_plan *plan = NULL;
    cudaStream_t s = NULL;
    if (!pb_check(din && dout && pb_plan_create(ctx, g, m, NULL, &plan) == PB_OK &&
                  cudaMallocHost((void **)&pinned, bytes) == cudaSuccess,
                  "caller's stream: setting up: %s", pb_last_error(ctx)))
        goto done;
    for (int adjoint = 0; adjoint < 2; adjoint++) {
        /* The own stream's result. */
        pb_check(dev_copy(ctx, din, x, bytes, 1), "caller's stream: writing device memory");
        pb_status st = adjoint ? pb_plan_adjoint_device(plan, 0, din, dout, 0) : pb_plan_forward_device(plan, 0, din, dout);
        pb_check(st == PB_OK && dev_copy(ctx, dout, own, bytes, 0), "own stream: %s", pb_last_error(ctx));
        /* Stale input and poisoned output in place; the true input waits behind the gate. */
        poison(got, n);
        pb_check(dev_copy(ctx, din, stale, bytes, 1) && dev_copy(ctx, dout, got, bytes, 1), "caller's stream: poisoning");
        memcpy(pinned, x, bytes);
        if (!pb_check(cudaStreamCreateWithFlags(&s, cudaStreamNonBlocking) == cudaSuccess, "cudaStreamCreate"))
            break;
        int open = 0;
        pb_check(cudaLaunchHostFunc(s, gate_wait, &open) == cudaSuccess &&
                 cudaMemcpyAsync(din, pinned, bytes, cudaMemcpyHostToDevice, s) == cudaSuccess, "the gate");
        pb_check(pb_context_set_stream(ctx, s) == PB_OK, "pb_context_set_stream: %s", pb_last_error(ctx));
        st = adjoint ? pb_plan_adjoint_device(plan, 0, din, dout, 0) : pb_plan_forward_device(plan, 0, din, dout);
        pb_check(st == PB_OK, "caller's stream: %s", pb_last_error(ctx));
        pb_check(cudaStreamQuery(s) == cudaErrorNotReady, "caller's stream: the call did not return before its work");
        pb_check(pb_context_set_stream(ctx, NULL) == PB_OK, "back to the own stream: %s", pb_last_error(ctx));
        __atomic_store_n(&open, 1, __ATOMIC_RELEASE);
        pb_check(cudaMemcpyAsync(got, dout, bytes, cudaMemcpyDeviceToHost, s) == cudaSuccess &&
                 cudaStreamSynchronize(s) == cudaSuccess, "caller's stream: reading back");
        double ms = -1.0;
        pb_check(pb_context_last_kernel_ms(ctx, &ms) == PB_OK && ms > 0.0, "caller's stream: kernel time %g ms", ms);
        pb_check(same(got, own, n, !adjoint, 1e-5), "caller's stream %s: differs from the own stream's by %g",
                 adjoint ? "adjoint" : "forward", pb_max_abs_diff(got, own, n));
        /* The stream destroyed (the context left it), then another one. */
        cudaStreamDestroy(s);
        s = NULL;
        pb_check(cudaStreamCreateWithFlags(&s, cudaStreamNonBlocking) == cudaSuccess &&
                 pb_context_set_stream(ctx, s) == PB_OK, "a second caller's stream: %s", pb_last_error(ctx));
        poison(got, n);
        st = adjoint ? pb_plan_adjoint_device(plan, 0, din, dout, 0) : pb_plan_forward_device(plan, 0, din, dout);
        pb_check(st == PB_OK && pb_context_set_stream(ctx, NULL) == PB_OK && cudaStreamSynchronize(s) == cudaSuccess &&
                 dev_copy(ctx, dout, got, bytes, 0), "a second caller's stream: %s", pb_last_error(ctx));
        pb_check(same(got, own, n, !adjoint, 1e-5), "a second caller's stream %s: differs by %g",
                 adjoint ? "adjoint" : "forward", pb_max_abs_diff(got, own, n));
        cudaStreamDestroy(s);
        s = NULL;
    }
done:
    pb_context_set_stream(ctx, NULL);
    if (s)
        cudaStreamDestroy(s);
    pb_plan_destroy(plan);
    dev_free(PB_BACKEND_CUDA, din);
    dev_free(PB_BACKEND_CUDA, dout);
    cudaFreeHost(pinned);
    free(x), free(stale), free(own), free(got);
#else
    (void)g, (void)m, (void)dummy;
#endif
}

static void check_refusals(pb_context *ctx)
{
    pb_geometry g = {{9, 8, 7}, {1.5, 1.5, 2.0}}, other = {{9, 8, 6}, {1.5, 1.5, 2.0}};
    pb_test_motion tm;
    pb_pose a = pb_test_pose(0, 0, 0, (double[3]){0, 0, 1}, 0), b = pb_test_pose(2, 1, 0, (double[3]){0, 0, 1}, 9);
    pb_test_motion_init(&tm, &a, &b);
    pb_plan *plan;
    pb_check(pb_plan_create(NULL, &g, &tm.motion, NULL, &plan) == PB_ERR_INVALID_ARGUMENT, "NULL ctx");
    pb_check(pb_plan_create(ctx, &g, NULL, NULL, &plan) == PB_ERR_INVALID_ARGUMENT, "NULL motion");
    pb_check(pb_plan_create(ctx, &g, &tm.motion, NULL, NULL) == PB_ERR_INVALID_ARGUMENT, "NULL plan");
    if (!pb_check(pb_plan_create(ctx, &g, &tm.motion, NULL, &plan) == PB_OK, "plan: %s", pb_last_error(ctx)))
        return;
    pb_volume *v1, *v2, *w;
    pb_volume_create(ctx, &g, &v1);
    pb_volume_create(ctx, &g, &v2);
    pb_volume_create(ctx, &other, &w);
    pb_check(pb_plan_forward(plan, 0, v1, w) == PB_ERR_SIZE_MISMATCH, "a volume of another geometry");
    pb_check(pb_plan_forward(plan, 0, v1, v1) == PB_ERR_INVALID_ARGUMENT, "in and out one volume");
    pb_check(pb_plan_forward(plan, 1, v1, v2) == PB_ERR_INVALID_ARGUMENT, "frame 1 of 1");
    pb_check(pb_plan_forward(NULL, 0, v1, v2) == PB_ERR_INVALID_ARGUMENT, "NULL plan");
    pb_check(pb_plan_adjoint(plan, 0, NULL, v2, 0) == PB_ERR_INVALID_ARGUMENT, "NULL volume");
    size_t bytes = 9 * 8 * 7 * sizeof(float);
    void *d1 = dev_alloc(ctx, bytes), *small = dev_alloc(ctx, bytes / 2);
    pb_check(pb_plan_forward_device(plan, 0, d1, NULL) == PB_ERR_INVALID_ARGUMENT, "NULL device memory");
    pb_check(pb_plan_forward_device(plan, 0, d1, d1) == PB_ERR_INVALID_ARGUMENT, "in and out one memory");
    pb_backend backend = pb_context_backend(ctx);
    if (backend == PB_BACKEND_OPENCL)
        pb_check(pb_plan_forward_device(plan, 0, d1, small) == PB_ERR_SIZE_MISMATCH, "a cl_mem too small: %s",
                 pb_last_error(ctx));
    if (backend == PB_BACKEND_CUDA) {
        float host[4];
        pb_check(pb_plan_forward_device(plan, 0, host, d1) == PB_ERR_INVALID_ARGUMENT, "host memory on CUDA: %s",
                 pb_last_error(ctx));
    }
    /* A plan keeps its context alive: destroyed first, the plan still works. */
    float *x = pb_random_volume(9 * 8 * 7);
    pb_check(dev_copy(ctx, d1, x, bytes, 1), "writing device memory");
    void *d2 = dev_alloc(ctx, bytes);
    dev_free(backend, small);
    pb_volume_destroy(w);
    pb_volume_destroy(v1);
    pb_volume_destroy(v2);
    pb_context_destroy(ctx);
    pb_geometry got;
    pb_check(pb_plan_get_geometry(plan, &got) == PB_OK && got.dims[2] == 7, "the plan's geometry");
    pb_check(pb_plan_forward_device(plan, 0, d1, d2) == PB_OK && pb_plan_adjoint_device(plan, 0, d2, d1, 1) == PB_OK,
             "a plan whose context was destroyed: %s", pb_last_error(NULL));
    pb_plan_destroy(plan); /* releases the context: ASan's leak check sees it */
    dev_free(backend, d1);
    dev_free(backend, d2);
    free(x);
}

int main(int argc, char **argv)
{
    pb_test_seed();
    pb_context *ctx = pb_test_context(argc, argv);
    /* Not a cube, odd sizes, anisotropic voxels; deep enough in z for slabs
     * of several work groups. */
    pb_geometry g = {{21, 14, 40}, {1.2, 1.5, 1.1}};
    double z[3] = {0, 0, 1}, tilt[3] = {0.3, -0.2, 1.0};
    pb_pose start = pb_test_pose(pb_rand_range(-1, 1), pb_rand_range(-1, 1), 0, z, 0);
    struct {
        const char *name;
        pb_pose end;
        int turns, along_x;
    } motions[] = {
        {"turn", pb_test_pose(pb_rand_range(-4, 4), pb_rand_range(-4, 4), pb_rand_range(-3, 3), tilt,
                              pb_rand_range(8, 25)), 1, 0},
        /* Translations only: the shift-invariant kernels, the gather, and the
         * layers along z, y and x (long walks along x). */
        {"move along z", pb_test_pose(0.3, -0.2, pb_rand_range(6, 12), z, 0), 0, 0},
        {"move along y", pb_test_pose(0.2, pb_rand_range(6, 12), 0.4, z, 0), 0, 0},
        {"move along x", pb_test_pose(pb_rand_range(12, 18), 0.5, -0.3, z, 0), 0, 1},
    };
    for (size_t k = 0; k < sizeof motions / sizeof motions[0]; k++) {
        pb_test_motion tm;
        pb_test_motion_init(&tm, &start, &motions[k].end);
        for (int method = PB_METHOD_AB; method <= PB_METHOD_REF; method++)
            for (int filter = PB_FILTER_HARDWARE; filter <= PB_FILTER_EXACT; filter++) {
                if (method == PB_METHOD_REF && (filter == PB_FILTER_EXACT || k > 1))
                    continue; /* REF has one kernel, and is slow on the host */
                pb_blur_options opt = {(pb_method)method, (pb_filter)filter, 0, 16, 16, 7, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
                char what[96];
                snprintf(what, sizeof what, "%s %s, %s", method_names[method],
                         filter == PB_FILTER_EXACT ? "EXACT" : "HARDWARE", motions[k].name);
                check_case(ctx, &g, &tm.motion, &opt, motions[k].turns, motions[k].along_x, what);
            }
    }
    /* AB in sub-segments, under the turn and along z. */
    for (size_t k = 0; k < 2; k++) {
        pb_test_motion tm;
        pb_test_motion_init(&tm, &start, &motions[k].end);
        pb_blur_options opt = {PB_METHOD_AB, PB_FILTER_HARDWARE, 3, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
        check_case(ctx, &g, &tm.motion, &opt, motions[k].turns, 0, k ? "AB 3 steps, along z" : "AB 3 steps, turn");
        /* Staleness and accumulate, under the turn (the scatter) and along z
         * (the gather; the forward through layers). */
        for (int method = PB_METHOD_AB; method <= PB_METHOD_CL; method++) {
            pb_blur_options o = {(pb_method)method, PB_FILTER_HARDWARE, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
            char what[64];
            snprintf(what, sizeof what, "%s, %s", method_names[method], motions[k].name);
            check_staleness(ctx, &g, &tm.motion, &o, motions[k].turns, what);
        }
    }
    pb_geometry small = {{13, 11, 9}, {1.4, 1.2, 1.7}};
    for (int method = PB_METHOD_AB; method <= PB_METHOD_CL; method++)
        check_frames(ctx, &small, &(pb_blur_options){(pb_method)method, PB_FILTER_HARDWARE, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0,
                                                         PB_AB_SAMPLING_DEFAULT, 0});
    {
        pb_test_motion tm;
        pb_test_motion_init(&tm, &start, &motions[0].end);
        check_caller_stream(ctx, &g, &tm.motion);
    }
    check_refusals(ctx); /* destroys ctx */
    return pb_test_finish();
}
