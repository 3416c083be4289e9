"""Issue 47: PATH_TWO on fresh synthetic series of three jerks in consecutive frames (4-7 degrees and 4-7 mm each,
at 0.35-0.65 of frames k-1, k, k+1 of 7 frames of 10 s; the test module's phantom, grid and noise), the default
against PETBLUR_ESTIMATE_TWO=0 and one pose a frame. Run from python/tests as a pytest file (it fails on purpose,
to print): PETBLUR_LIBRARY=... PYTHONPATH=python pytest -q -s THIS_FILE. Its output on 16 runs: three_jerks.txt."""
from test_motion_from_frames import _frame_errors, _moving_series, _rigid, np, petblur


def test_a_jerk_inside_a_frame_whose_neighbours_move(rng, monkeypatch):
    nf, seconds = 7, 10.0
    k = int(rng.integers(2, nf - 2))
    jerks = []
    for f in (k - 1, k, k + 1):
        j = _rigid(rng, float(rng.uniform(4.0, 7.0)), 0.0)
        w = rng.normal(size=3)
        j[:3, 3] = rng.uniform(4.0, 7.0) * w / np.linalg.norm(w)
        jerks.append(((f + rng.uniform(0.35, 0.65)) * seconds, j))
    at = jerks[1][0]

    def truth(t):
        m = np.eye(4)
        for when, j in jerks:
            if t >= when:
                m = j @ m
        return m

    frames, affine, starts, durations, phantom = _moving_series(rng, nf, truth, seconds=seconds, steps=40)
    points = phantom.inside(rng)
    runs = {}
    for name in ("two", "off", "one"):
        monkeypatch.setenv("PETBLUR_ESTIMATE_TWO", "0" if name == "off" else "2")
        m = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0, device="host",
                                       frame_poses_only=name == "one")
        runs[name] = (_frame_errors(m, truth, points, starts, durations),
                      [(f["frame"], [round(x, 2) for x in f["motion_inside"]]) for f in m.frame_report if f["motion_inside"]],
                      [(f["frame"], round(f["unfollowed"], 3)) for f in m.frame_report if f["unfollowed"] > 0])
    msg = (f"the jerk in frame {k} at {at:.2f} s; " + "; ".join(
        f"{n}: errors {np.round(e, 3)} mm, moving {mv}, reported not followed {r}" for n, (e, mv, r) in runs.items()))
    print(msg)
    assert False, msg
