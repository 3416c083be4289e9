"""Issue 31's accuracy targets, as users measure them: petblur's blur at its
defaults against a dense reference made without petblur
(bench/accuracy_case.py: the mean of many scipy map_coordinates resamplings
in world coordinates under the tracked track, interpolated by scipy), on hot
spheres in an oblique LAS grid of 61 x 53 x 37 voxels of 2.0 x 2.5 x 3.0 mm
under a 30 s frame of a 20 Hz tracked seizure, all drawn fresh each run.
Targets: relative RMS <= 0.3 % and relative max <= 1.0 % (measured on the
H100, seeds 1-5 and 31: AB 0.065-0.18 % RMS and 0.09-0.57 % max, RM below;
bench/results/2026-11-25_H100_0efcaf5_accuracy). The bound before, 0.25
voxels, misses them on such a track, which shows the test can fail."""

import importlib.util
import pathlib

import numpy as np
import pytest

import petblur

CASE = pathlib.Path(__file__).resolve().parents[2] / "bench" / "accuracy_case.py"


def _case_module():
    spec = importlib.util.spec_from_file_location("accuracy_case", CASE)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def measured():
    """One fresh case, its reference (1500 times), and the blurs to check, on
    PoCL where it is there."""
    ac = _case_module()
    rng = np.random.default_rng()
    case = ac.Case(rng, ac.FULL["shape"], ac.FULL["voxel"])
    ref = ac.reference(case, times=1500)
    device = "opencl" if any(s.startswith("opencl") for s, _ in petblur.devices()) else "host"
    x = np.asfortranarray(case.x)
    out = {}
    for method, bound in (("ab", None), ("rm", None), ("ab", 0.25)):
        op = petblur.BlurOperator(case.shape, case.voxel, case.motion(), method=method, max_path_error=bound,
                                  affine=case.affine, device=device)
        y = op(x)
        assert np.isfinite(y).all() and y.shape == case.shape
        out[(method, bound)] = ac.errors(ref, y)
    return out


@pytest.mark.parametrize("method", ["ab", "rm"])
def test_defaults_meet_the_targets(measured, method):
    e = measured[(method, None)]
    print(method, e)
    assert e["rms_pct"] <= 0.3 and e["max_pct"] <= 1.0, e


def test_the_old_bound_is_coarser(measured):
    """0.25 voxels (the default before) is further from the reference than the
    default: the bound is what the targets measure."""
    old, new = measured[("ab", 0.25)], measured[("ab", None)]
    assert old["rms_pct"] > 1.2 * new["rms_pct"], (old, new)
