#!/usr/bin/env bash
# On the GPU machine: the Python package end to end. Builds the C tree (the
# CUDA and host suites, the caller's-stream test among them; test_plan under
# compute-sanitizer's memcheck), installs the package with pip beside the
# machine's torch and CuPy (meson-python and nibabel come as
# wheels in .whl/, nothing is downloaded there), runs the whole pytest suite
# (numpy, CuPy and torch CUDA, autograd, threads) and bench/python_torch.py on
# a 256^3 tensor. What comes back through $OUT: tests.txt, pytest.txt,
# python_torch.md and .csv, sanitize.txt, machine.txt.
#   PB_COMMIT=$(git rev-parse --short HEAD) bash bench/gpu-python.sh
set -uo pipefail
cd "$(dirname "$0")/.."
. bench/device-env.sh
{
    python3 -c 'import sys, numpy, torch; print("python", sys.version.split()[0], "numpy", numpy.__version__, "torch", torch.__version__)'
    python3 -c 'import cupy; print("cupy", cupy.__version__)' 2>&1 | tail -1
} | write_machine "$OUT/machine.txt"

status=0
"${meson[@]}" setup build-gpu --buildtype=release -Dcuda=enabled -Dopencl=enabled -Dgpu_archs=90 >/tmp/setup.log 2>&1 &&
    ninja -C build-gpu >/tmp/build.log 2>&1 || { tail -30 /tmp/setup.log /tmp/build.log; exit 1; }
vend=$(mktemp -d)
[ -f /etc/OpenCL/vendors/pocl.icd ] && cp /etc/OpenCL/vendors/pocl.icd "$vend/"
OCL_ICD_VENDORS=$vend "${meson[@]}" test -C build-gpu --no-rebuild --print-errorlogs --suite host --suite cuda \
    >/tmp/tests.log 2>&1 || status=1
grep -E '^ *[0-9]+/[0-9]+ |^(Ok|Fail|Skipped):' /tmp/tests.log | tee "$OUT/tests.txt"
[ $status = 0 ] || tail -60 /tmp/tests.log >>"$OUT/tests.txt"
compute-sanitizer --tool memcheck --error-exitcode 99 --leak-check full ./build-gpu/tests/test_plan cuda 2>&1 |
    tail -4 | tee "$OUT/sanitize.txt"
[ "${PIPESTATUS[0]}" = 0 ] || { echo "memcheck test_plan: FAILED" | tee -a "$OUT/sanitize.txt"; status=1; }

echo "== pip install . beside the machine's torch and CuPy =="
install_package || exit 1
python3 -c 'import petblur; print("installed:", petblur.__file__, petblur.devices())'
echo "== pytest =="
# The motion study's small version needs ASTRA, whose wheel cannot load here
# (CUDA 12's cudart and cuFFT); CI runs it, and bench/gpu-study.sh the full one.
(cd /tmp && OCL_ICD_VENDORS=$vend PETBLUR_CLI=$OLDPWD/build-gpu/src/cli/petblur \
    python3 -m pytest -v -p no:cacheprovider "$OLDPWD/python/tests" \
    -k "not test_motion_study_small") >"$OUT/pytest.txt" 2>&1 || status=1
tail -25 "$OUT/pytest.txt"
echo "== bench/python_torch.py =="
(cd /tmp && python3 "$OLDPWD/bench/python_torch.py" --out "$OUT/python_torch.csv") 2>&1 |
    tee "$OUT/python_torch.md" || status=1
exit $status
