import sys, ctypes, numpy as np
sys.path.insert(0, "python"); sys.path.insert(0, "python/tests")
import repo_scripts, petblur
from petblur import _lib
from petblur.operator import _affine4
pc = repo_scripts.load("bench/path_cases.py", "path_cases")
def segments(case, bound):
    m = case.logged
    vox = np.asarray(case.voxel, float); a = _affine4(case.affine)
    g, placed, keep = m._c_motion(tuple(case.shape), vox, a, np.array(case.frame, float), warn=False, refuse=False)
    op = petblur.BlurOperator(case.shape, case.voxel, m, frame=case.frame, method="ab", filter="exact",
                              affine=case.affine, device="host", max_path_error=bound)
    frame = _lib.CMotion.from_buffer_copy(placed); frame.frame_start, frame.frame_end = case.frame
    noise, s = ctypes.c_double(), ctypes.c_size_t()
    assert _lib.lib.pb_path_noise(ctypes.byref(g), ctypes.byref(frame), ctypes.byref(op._options), ctypes.byref(noise), ctypes.byref(s)) == 0
    return s.value, op
if __name__ == "__main__":
    for seed in map(int, sys.argv[1:]):
        case = pc.draw_case("drift-1hz", np.random.default_rng(seed), small=True)
        ref = pc.reference(case, "logged", times=min(pc.reference_times(case, "logged"), 1500))
        x = np.asfortranarray(case.x)
        out = [seed]
        for b in (None, 0.07, 0.05, 0.03):
            n, op = segments(case, b)
            e = pc.errors(ref, np.asarray(op(x)))
            out.append(f"{b}: {n} segs {e['rms_pct']:.3f}/{e['max_pct']:.3f}")
        print(*out, flush=True)
