#!/usr/bin/env bash
# A kernel experiment's quick look on the GPU machine: a CUDA-only release
# build and `petblur bench` on a few phantoms and scenarios (REF with few
# points: its errors are rough, its times are not what is asked). Not a
# substitute for bench/gpu.sh, which every kernel change still gets.
#   bash bench/gpu-quick.sh [PHANTOMS [SCENARIOS]]   (tables under $OUT/quick)
set -uo pipefail
cd "$(dirname "$0")/.."
. bench/device-env.sh
"${meson[@]}" setup build-quick --buildtype=release -Dcuda=enabled -Dopencl=disabled >/dev/null 2>&1 &&
    ninja -C build-quick >/dev/null 2>&1 || { echo "gpu-quick: the build failed" >&2; exit 1; }
./build-quick/src/cli/petblur bench --device cuda --phantoms "${1:-brain,homogeneity}" --scenarios "${2:-1,2,6,7,8}" \
    --points 8 --runs 20 --out-dir "$OUT/quick" -q
