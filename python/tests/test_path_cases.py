"""Issue 46's validation set in CI: a fresh small case of every kind of
bench/path_cases.py (a still head with tracker noise, a drift logged at 1 Hz
and at 20 Hz with noise, a nod, a seizure's jerk inside the frame, large
rotations, an oblique translation; oblique anisotropic grids; sharp spheres
or a smooth brain), blurred from its logged track on the host and on PoCL and
compared with the dense scipy reference of that track (the mean of order-1
map_coordinates resamplings, made without petblur); every kind on PoCL, those
with short logs on the host too.

What is asserted is what the kernels now earn: on these cases every segment
is short (at most 5 voxels along its major axis), and AB and RM read it as
the trilinear image's exact time average. With a fine path bound (0.01
voxels) both stand within 0.5 % max and 0.3 % RMS of the reference (measured
over 8 runs of the 7 kinds: at most 0.29 % max and 0.18 % RMS, on the
translation), AB and RM within float rounding of each other, on every draw.
The translation's excess over the other kinds' 0.11 % is the fine bound's own
error: its first logged second moves about 12 % slower than the rest (the frame
starts between samples), the planner merges it into one chord that leaves the
track by 0.005 voxels, and on spheres whose edge steps by most of the largest
value across one voxel that shift alone is 0.2-0.3 % of the largest value (seeds
2887532700 and 3668248385: 0.21 and 0.29 % max at 0.01 voxels, 0.015 % at 0.001
and 0 % with the frame on the samples; CL, the mean of resamplings at poses of the track
itself, 0.003-0.008 %). At the default bound
(0.1 voxels) what was left is the path's own error, the merged chords'
through the samples: measured up to 2.3 % max and 1.1 % RMS (a sharp drift
logged at 1 Hz; bench/results/2026-11-29_H200_1e88361_paths). The planner now
fits the key poses to the track (src/paths/path_fit.c), and
test_default_bound_fitted holds the noise-free kinds to issue 46's targets
there; this test keeps AB at the default below 3 % and 1.5 % on every kind.
At the default the planner measures a log's white noise and does not follow
it (test_tracker_noise_is_not_followed), at any bound, so a noisy log's
default is compared with the true motion's reference, and its exact walk is
its own polyline (max_path_error='paper', one segment a logged interval)
against the log's."""

import numpy as np
import pytest

import repo_scripts


def _cases():
    return repo_scripts.load("bench/path_cases.py", "path_cases")


def _devices():
    """conftest's devices: the host, and OpenCL where a device is there."""
    import petblur
    return ["host"] + (["opencl"] if any(s.startswith("opencl") for s, _ in petblur.devices()) else [])


# Every kind on OpenCL (PoCL in CI), where a device is there; on the host
# (the double-precision reference, written for clarity, not speed) the kinds
# whose logs are short: the 20 Hz noisy logs plan hundreds of segments, and
# the host's agreement with the kernels is test_backend_vs_host's.
HOST_TOO = ("drift-1hz", "rotation", "translation")


@pytest.mark.parametrize("kind", ["still", "drift-1hz", "drift-20hz", "nod", "seizure", "rotation", "translation"])
def test_short_segments_read_exactly(rng, kind):
    import petblur
    pc = _cases()
    case = pc.draw_case(kind, rng, small=True)
    # At most 1500 times: a third of them was within 0.01 % of the whole on the
    # noisiest logs (bench/results/2026-11-29_cpu2_5e57b97_path-cases), far
    # below the bounds asserted here.
    ref = pc.reference(case, "logged", times=min(pc.reference_times(case, "logged"), 1500))
    noisy = case.noise_mm > 0
    true = pc.reference(case, "true", times=min(pc.reference_times(case, "true"), 1500)) if noisy else ref
    x = np.asfortranarray(case.x)
    devices = _devices()
    for device in devices:
        if device == "host" and len(devices) > 1 and kind not in HOST_TOO:
            continue
        # A noisy log's exact walk is its own polyline ('paper'): a bound is on
        # the motion, and the planner does not follow the log's noise.
        fine = "paper" if noisy else 0.01
        got = {}
        for method, bound in (("ab", fine), ("rm", fine), ("ab", None)):
            op = petblur.BlurOperator(case.shape, case.voxel, case.logged, frame=case.frame, method=method,
                                      filter="exact", affine=case.affine, device=device, max_path_error=bound)
            y = np.full(case.shape, np.nan, np.float32, order="F")
            y[...] = op(x)
            assert np.all(np.isfinite(y))
            e = pc.errors(true if bound is None else ref, y)
            got[method, bound] = (e["rms_pct"], e["max_pct"], y)
        msg = f"{device}, {pc.describe(case)}: " + ", ".join(f"{m} bound {b}: {v[0]:.3f} % RMS {v[1]:.3f} % max"
                                                             for (m, b), v in got.items())
        print(msg)
        for method in ("ab", "rm"):
            rms, mx, _ = got[method, fine]
            assert rms < 0.3 and mx < 0.5, msg
        a, r = got["ab", fine][2], got["rm", fine][2]
        assert np.abs(a - r).max() <= 2e-5 * np.abs(ref).max(), msg
        rms, mx, _ = got["ab", None]
        # The path bound's error, not the kernels' (docstring). On a noisy log
        # the default does not follow the noise, so against the true motion
        # it is held to this test's 1.5 % / 3 % or, as in
        # test_tracker_noise_is_not_followed, where following the noise is
        # itself further from it, within 0.9 of that (seed 1546600137: a 2.1
        # deg nod under 0.198 mm of noise, 1.602 % RMS where following the
        # noise stands at 2.715 %).
        if noisy:
            follow = pc.errors(true, ref)
            assert rms < max(1.5, 0.9 * follow["rms_pct"]) and mx < max(3.0, 0.9 * follow["max_pct"]), msg
        else:
            assert rms < 1.5 and mx < 3.0, msg


@pytest.mark.parametrize("kind", ["still", "drift-20hz", "nod", "seizure"])
def test_tracker_noise_is_not_followed(rng, kind):
    """Issue 46: a noisy 20 Hz log costs about what its motion costs. At the
    default the planner measures each corner's white noise from the log
    (src/paths/path_fit.c: lags 1-3 of the samples' offsets from their
    neighbours' chords, as white noise has them, so that a tremor is not taken
    for noise) and fits its pieces beyond it. AB on the host, against the true
    motion's dense reference (sampled at 100 Hz without noise): the log's
    segments at most 4x the true motion's plus 10, and the blur within 1.0 %
    RMS (1.5 % on a nod) and 2.5 % max of the true motion's, or, where
    following the noise (the log's own dense reference) is further than
    that, within 0.9 of its error. What no planner removes is the noise's
    part at the motion's own time scales and its mean over the frame: on 80
    noisy nods that mean alone stood at up to 0.905 % RMS, and a smoother
    with its lambda chosen knowing the truth at up to 0.892 %
    (bench/results/2026-12-02_cpu2_nod-bound). Since a noisy run keeps the
    noise-free share of the bound (bench/results/2026-12-02_cpu2_noisy-share),
    on 200 fresh nods (7000-7199) RMS median / 99th / worst 0.405 / 1.143 /
    1.297 % (the rule before: 0.470 / 1.375 / 1.689), two of 300 above both
    1.0 % and 0.9 of following the noise (at 1.14x of it at worst; none above
    both 1.25 % and that); on 50 fresh draws of each other kind RMS median / worst 0.157 /
    0.534 % (drift), 0.211 / 0.597 % (seizure), 0.214 / 0.703 % (still),
    segments at most 1.81x the true motion's. Following the noise stands at up
    to 6.3 / 11.0 % RMS / max on those draws, on hundreds of segments. Since
    the noise measure's own error and the lag-1 test
    (bench/results/2026-12-02_cpu2_measure-scatter), the same 200 nods
    0.375 % median, worst 1.328 %, two above 1.25 % and none above 1.5 %."""
    import petblur
    pc = _cases()
    case = pc.draw_case(kind, rng, small=True)
    true = pc.reference(case, "true", times=min(pc.reference_times(case, "true"), 1500))
    logged = pc.reference(case, "logged", times=min(pc.reference_times(case, "logged"), 1500))
    op = petblur.BlurOperator(case.shape, case.voxel, case.logged, frame=case.frame, method="ab",
                              filter="exact", affine=case.affine, device="host")
    y = np.full(case.shape, np.nan, np.float32, order="F")
    y[...] = op(np.asfortranarray(case.x))
    e, noise = pc.errors(true, y), pc.errors(true, logged)
    segments, true_segments = pc.path_segments(op), pc.path_segments(op, case.true)
    msg = (f"{pc.describe(case)}: {segments} segments (true motion {true_segments}), "
           f"{e['rms_pct']:.3f} % RMS {e['max_pct']:.3f} % max from the true motion's blur, following the noise "
           f"{noise['rms_pct']:.3f} % and {noise['max_pct']:.3f} %")
    print(msg)
    assert segments <= 4 * true_segments + 10, msg
    assert e["rms_pct"] < max(1.5 if kind == "nod" else 1.0, 0.9 * noise["rms_pct"]), msg
    assert e["max_pct"] < max(2.5, 0.9 * noise["max_pct"]), msg


@pytest.mark.parametrize("kind", ["drift-1hz", "rotation", "translation"])
def test_default_bound_fitted(rng, kind):
    """Issue 46's targets at the default bound, on the noise-free kinds: the
    planner fits the key poses to the track by least squares over time
    (src/paths/path_fit.c) instead of walking chords through the samples, whose
    one-sided shift of every voxel's time average was the default bound's error
    above. AB and RM, on the host, within 0.3 % RMS and 1.0 % max of the logged
    track's dense reference. Measured on 30 fresh seeds of each kind
    (bench/results/2026-11-29_cpu2_fit-main): drifts at most 0.27 % RMS and
    0.65 % max, translations 0.10 % and 0.16 %, rotations 0.30 % and 0.55 %
    (through the samples, 10 seeds: up to 0.71 / 1.29, 1.29 / 1.65 and
    0.57 / 1.17). The tails of drifts and rotations were still the fit's:
    a piece within the bound of every sample but wandering about it all
    along (a slow drift of a third of a voxel on one chord: CI's seeds
    387157710 and 2940284256 at 0.32 and 0.355 % RMS, seed 5035 at 0.64 %; a
    rotation, seed 909, at 0.304 %). A noise-free run's RMS residual is now
    within 0.35 of the bound too: on fresh seeds 8000-8099
    (bench/results/2026-11-30_cpu2_rms-share) drifts at most 0.12 % RMS and
    0.35 % max where they had stood at 0.30 / 0.92 %, rotations (8000-8029)
    0.11 / 0.25 % where 0.31 / 0.68 %; seed 909 at 0.10 %. So every kind is
    held to issue 46's 0.3 % RMS and 1.0 % max."""
    import petblur
    pc = _cases()
    case = pc.draw_case(kind, rng, small=True)
    ref = pc.reference(case, "logged", times=min(pc.reference_times(case, "logged"), 1500))
    x = np.asfortranarray(case.x)
    for method in ("ab", "rm"):
        op = petblur.BlurOperator(case.shape, case.voxel, case.logged, frame=case.frame, method=method,
                                  filter="exact", affine=case.affine, device="host")
        y = np.full(case.shape, np.nan, np.float32, order="F")
        y[...] = op(x)
        e = pc.errors(ref, y)
        msg = f"{method}, {pc.describe(case)}: {e['rms_pct']:.3f} % RMS {e['max_pct']:.3f} % max"
        print(msg)
        assert e["rms_pct"] < 0.3 and e["max_pct"] < 1.0, msg


@pytest.mark.parametrize("kind", ["still", "drift-20hz"])
def test_short_frame_noise_measured_about_it(rng, kind):
    """A frame of fewer than 64 samples (1.5-3 s of a 20 Hz log, as the first
    frames of a dynamic protocol) has too few to measure the tracker's noise
    in; it is measured on the 512 samples of the log about the frame
    (src/paths/path_fit.c, window_noise). Before, such frames followed their
    noise, about a segment a sample: on 20 draws of each kind 27-30 segments
    on average (up to 51) and 2.3 / 1.1 % RMS from the true motion's blur
    (median, still / drift), up to 6.8 / 4.0 %; measuring it about them, on
    40 draws 1.1 and 1.4 segments on average (at most 15 of 45 samples: a
    run shorter than 64 samples fails its noise's mean square now and then),
    0.64 / 0.55 % (bench/results/2026-11-30_cpu2_short-frames). What is left
    is the noise's mean over the frame's few samples, which no reading of the
    log removes (white noise's mean over a frame is a motion still within
    it): the true motion moved by the log's mean noise over the frame
    (path_cases.noise_floor). A mean 4.2 standard errors out (seed
    1885628044: 0.068 mm in y over 47 samples) put the default, at the
    floor, above the share of following the noise it was held to, so the
    floor is a bound too. On 40 fresh draws of each kind the default stood
    at 0.998-1.004x the floor's RMS error (0.998-1.006x its max) on a still
    head (on 40 more, 38 at the floor and two held on lines, below); on a
    drift at 0.978-1.042x its RMS and 0.943-1.097x its max, but for one whose floor
    was 0.027 %, at 0.093 %, the line's own fit to the drift
    (bench/results/2026-12-03_cpu2_short-frame-floor). On a drift, following
    the noise stands near the floor too: there the segments' bound is what
    tells a path that follows it. AB on the host."""
    import petblur
    pc = _cases()
    case = pc.draw_short_frame(kind, rng)
    true = pc.reference(case, "true", times=400)
    follow = pc.errors(true, pc.reference(case, "logged", times=400))
    floor = pc.errors(true, pc.noise_floor(case, times=400))
    op = petblur.BlurOperator(case.shape, case.voxel, case.logged, frame=case.frame, method="ab",
                              filter="exact", affine=case.affine, device="host")
    y = np.full(case.shape, np.nan, np.float32, order="F")
    y[...] = op(np.asfortranarray(case.x))
    e = pc.errors(true, y)
    segments, true_segments = pc.path_segments(op), pc.path_segments(op, case.true)
    noise = case.logged.summary(list(case.frame), case.shape, case.voxel, affine=case.affine)["frames"][0]["noise_mm"]
    msg = (f"{pc.describe(case)}, frame {case.frame[0]:.2f}-{case.frame[1]:.2f} s: {segments} segments (true motion "
           f"{true_segments}), noise {noise:.3f} mm measured, {e['rms_pct']:.3f} % RMS {e['max_pct']:.3f} % max from "
           f"the true motion's blur, following the noise {follow['rms_pct']:.3f} % and {follow['max_pct']:.3f} %, the "
           f"noise's mean alone {floor['rms_pct']:.3f} % and {floor['max_pct']:.3f} %")
    print(msg)
    # the corners' 3-D scatter: sqrt(3) of the translations' sigma and the rotations' share (1.90-2.57 of it measured)
    assert 1.5 * case.noise_mm < noise < 3.5 * case.noise_mm, msg
    samples = int(np.sum((case.log_times > case.frame[0]) & (case.log_times < case.frame[1])))
    assert segments <= samples // 2, msg
    # Within a share of following the noise (or an absolute bound), or near
    # the floor: a still head's flat piece is the noise's mean itself, which
    # can stand above the share (seed 1885628044); where the flat test
    # refuses the noise (a slope in it, or a scatter at 2 standard deviations
    # on a short run), the frame is held on a line or a few, which can stand
    # well above the floor (seeds 7030 and 7032, 1.33x and 2.53x) but not
    # above the share (bench/results/2026-12-03_cpu2_flat-tests-tried). A
    # drift's line also takes the noise's slope.
    still = kind == "still"
    share = 0.7 if still else 1.3
    (rms_share, rms_add), (max_share, max_add) = ((1.25, 0.03), (1.25, 0.05)) if still else ((1.2, 0.15), (1.3, 0.25))
    assert e["rms_pct"] < max(1.0 if still else 1.5, share * follow["rms_pct"],
                              rms_share * floor["rms_pct"] + rms_add), msg
    assert e["max_pct"] < max(2.5 if still else 3.0, share * follow["max_pct"],
                              max_share * floor["max_pct"] + max_add), msg


def test_long_segment_walked_or_read_exactly(rng):
    """Long segments (docs/methods.md, "Long segments: the walk's own error"): an
    oblique translation 4-12 voxels long logged at 1 Hz is one straight segment
    (or a few, where the frame starts between samples), mostly longer than AB
    reads exactly (PB_AB_EXACT_TO, 5 voxels along its major axis). From
    PB_AB_WALK_FROM (6) on, AB reads it by the paper's walk, one point a slice,
    which misses the trilinear filter's kinks across each slice: on 120 fresh
    small draws (bench/results/2026-12-04_cpu2_long-segments) 0.60 % RMS median
    and up to 2.2 % on the smooth brain, 0.98 % and up to 8.6 % RMS (11.8 % max)
    on sharp spheres, where the short kinds stand within 0.3 %. AB's chord
    sampling reads every segment exactly, as do AB's `steps` at ceil(move / 3)
    sub-segments a segment (each at most 3 voxels): with the fine 0.01-voxel
    bound (as test_short_segments_read_exactly) both are held within 0.3 % RMS
    and 0.5 % max of the dense reference (steps measured at most 0.016 % RMS on
    those draws). At the default bound what chord leaves is the path's own error
    (the polyline fitted to a fast track whose frame starts between samples):
    measured at most 0.255 % RMS and 0.35 % max on 60 draws, held here within
    0.5 % and issue 46's 1.0 %. The default's walk, whose tail is heavy, is held
    within 20 % RMS and 30 % max, over twice the worst measured: that catches a
    walk broken, not one a little worse. On the host and on PoCL."""
    import petblur
    pc = _cases()
    case = pc.draw_case("translation-long", rng, small=True)
    ref = pc.reference(case, "logged", times=min(pc.reference_times(case, "logged"), 1500))
    x = np.asfortranarray(case.x)
    steps = int(np.ceil(case.params["target_vox"] / 3.0))
    for device in _devices():
        got = {}
        for name, bound, s, sampling in (("default", None, 0, None), ("chord", None, 0, "chord"),
                                         ("chord, fine bound", 0.01, 0, "chord"), ("steps", 0.01, steps, None)):
            op = petblur.BlurOperator(case.shape, case.voxel, case.logged, frame=case.frame, method="ab",
                                      filter="exact", affine=case.affine, device=device, max_path_error=bound,
                                      steps=s, ab_sampling=sampling)
            y = np.full(case.shape, np.nan, np.float32, order="F")
            y[...] = op(x)
            assert np.all(np.isfinite(y))
            got[name] = pc.errors(ref, y)
        msg = (f"{device}, {pc.describe(case)}, steps {steps}: " +
               ", ".join(f"{k} {e['rms_pct']:.3f} % RMS {e['max_pct']:.3f} % max" for k, e in got.items()))
        print(msg)
        for name in ("chord, fine bound", "steps"):
            assert got[name]["rms_pct"] < 0.3 and got[name]["max_pct"] < 0.5, msg
        assert got["chord"]["rms_pct"] < 0.5 and got["chord"]["max_pct"] < 1.0, msg
        assert got["default"]["rms_pct"] < 20.0 and got["default"]["max_pct"] < 30.0, msg
