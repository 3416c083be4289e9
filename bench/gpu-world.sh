#!/usr/bin/env bash
# On the GPU machine: motions in world coordinates and from trackers' logs
# (tests/test_world.py, tests/test_cli.py) with CUDA as the default device,
# plus the host suites. nibabel comes from the wheel in .whl/ (carry it with
# .device; bench/gpu-prepare.sh makes .device, `pip download nibabel -d .whl`
# the wheel).   bash bench/gpu-world.sh   (the log under $OUT)
set -uo pipefail
cd "$(dirname "$0")/.."
. bench/device-env.sh
python3 -m pip install --no-deps --no-index -q .whl/nibabel-*.whl 2>&1 | tail -1
{
    nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
    "${meson[@]}" setup build-world --buildtype=release -Dcuda=enabled -Dopencl=enabled >/dev/null &&
        ninja -C build-world >/dev/null || { echo "gpu-world: the build failed"; exit 1; }
    ./build-world/src/cli/petblur devices
    "${meson[@]}" test -C build-world --suite host --suite cuda --print-errorlogs
    # The Python with numpy and SciPy here is the one on the PATH, not Debian's
    # /usr/bin/python3 that meson's cli suite names.
    for t in world cli; do
        PYTHONPATH=tests python3 tests/test_$t.py build-world/src/cli/petblur 2>&1 | grep -v " ok$"
    done
} 2>&1 | tee "$OUT/world.log"
