#!/usr/bin/env bash
# A kernel experiment's quick look on the GPU machine: a CUDA-only release
# build and `petblur bench` on a few phantoms and scenarios (REF with few
# points: its errors are rough, its times are not what is asked). Not a
# substitute for bench/gpu.sh, which every kernel change still gets.
#   bash bench/gpu-quick.sh [PHANTOMS [SCENARIOS]]   (tables under $OUT/quick)
set -uo pipefail
cd "$(dirname "$0")/.."
OUT=${OUT:-$PWD/gpu-out}
dev=$PWD/.device
export CFLAGS="-I$dev/include -I$dev/include/nifti" LDFLAGS="-L$dev/lib" LIBRARY_PATH="$dev/lib"
sed -i "s|@DEVICE@|$dev|" "$dev"/lib/pkgconfig/*.pc
export PKG_CONFIG_PATH="$dev/lib/pkgconfig"
export LD_LIBRARY_PATH="$dev/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export PATH="$PATH:/usr/local/cuda/bin"
meson=(meson)
command -v meson >/dev/null || meson=(python3 -m mesonbuild.mesonmain)
"${meson[@]}" setup build-quick --buildtype=release -Dcuda=enabled -Dopencl=disabled >/dev/null 2>&1 &&
    ninja -C build-quick >/dev/null 2>&1 || { echo "gpu-quick: the build failed" >&2; exit 1; }
./build-quick/src/cli/petblur bench --device cuda --phantoms "${1:-brain,homogeneity}" --scenarios "${2:-1,2,6,7,8}" \
    --points 8 --runs 20 --out-dir "$OUT/quick" -q
