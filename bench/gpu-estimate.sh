#!/usr/bin/env bash
# On the GPU machine: motion from the frames (issue 30). Builds with CUDA and
# OpenCL, runs the host and cuda suites and the opencl suite on NVIDIA's
# OpenCL, the command line's tests motion_estimate and world (on the auto
# device: CUDA), and bench/estimate_validation.py on CUDA: the issue's 24 frames
# of 64^3 (3 mm) and the benchmark's 24 frames of 128^3 (1.5 mm). SimpleITK is
# not on that machine: its side of the comparison runs on the two-core machine
# the issue measured it on. nibabel comes as a wheel in .whl/.
# Two calls, each within the device's ten minutes (the build is kept between):
#   PB_COMMIT=$(git rev-parse --short HEAD) bash bench/gpu-estimate.sh tests axial
#   PB_COMMIT=$(git rev-parse --short HEAD) bash bench/gpu-estimate.sh fine
# SEED=N draws the validation's series from seed N (default: a fresh one).
set -uo pipefail
cd "$(dirname "$0")/.."
. bench/device-env.sh
write_machine "$OUT/machine.txt" </dev/null
status=0
what=" $* "
[ -f build-gpu/build.ninja ] || "${meson[@]}" setup build-gpu --buildtype=release -Dcuda=enabled -Dopencl=enabled -Dgpu_archs=90 >/tmp/setup.log 2>&1 &&
ninja -C build-gpu >/tmp/build.log 2>&1 || { tail -30 /tmp/setup.log /tmp/build.log; exit 1; }
site=$(mktemp -d)/site
python3 -m pip install -q --no-deps --no-index --find-links .whl --target "$site" nibabel 2>&1 | tail -3
export PYTHONPATH=$site
nv=$(mktemp -d)
echo libnvidia-opencl.so.1 >"$nv/nvidia.icd"
[[ $what == *" tests "* ]] && {
"${meson[@]}" test -C build-gpu --no-rebuild --print-errorlogs --suite host --suite cuda >/tmp/tests.log 2>&1 ||
    status=1
grep -h "d(Bx)/d" build-gpu/meson-logs/testlog.txt >"$OUT/pose_derivative.txt" 2>/dev/null
# The command line's tests under the machine's python3 (meson's cli suite
# names /usr/bin/python3, which there lacks numpy)
for t in motion_estimate world; do
    if PYTHONPATH=$site:tests python3 tests/test_$t.py build-gpu/src/cli/petblur >/tmp/$t.log 2>&1; then
        echo "cli - petblur:$t OK (python3 tests/test_$t.py)"
    else
        echo "cli - petblur:$t FAIL"; tail -n 40 /tmp/$t.log; status=1
    fi
done >>/tmp/tests.log
OCL_ICD_VENDORS=$nv "${meson[@]}" test -C build-gpu --no-rebuild --print-errorlogs --suite opencl \
    >/tmp/tests-ocl.log 2>&1 || status=1
for f in /tmp/tests.log /tmp/tests-ocl.log; do
    grep -E '^ *[0-9]+/[0-9]+ |^(Ok|Fail|Skipped|Timeout):|^cli - ' "$f"
done | tee "$OUT/tests.txt"
[ $status = 0 ] || tail -n 80 /tmp/tests.log /tmp/tests-ocl.log >>"$OUT/tests.txt"
}
for setup in axial fine; do
    [[ $what == *" $setup "* ]] || continue
    python3 bench/estimate_validation.py --petblur build-gpu/src/cli/petblur --device cuda --setup $setup \
        ${SEED:+--seed "$SEED"} --out "/tmp/val-$setup" --no-sitk >"$OUT/validation-$setup.txt" 2>&1 || status=1
    cp "/tmp/val-$setup/results.json" "$OUT/validation-$setup.json" 2>/dev/null
done
exit $status
