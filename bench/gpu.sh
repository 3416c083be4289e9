#!/usr/bin/env bash
# One run on the GPU machine answers every question about a kernel change:
# build, the host and opencl suites on NVIDIA's OpenCL and on PoCL, then the
# benchmark of every method on a 256^3 volume for the paper's eight motions.
# Tables go to $OUT (the device tool brings them back); commit them under
# bench/results/ with the date, GPU and commit.
#
# The machine has no Khronos CL/ headers and no libOpenCL.so link name: bring
# them in .device/ (git-ignored) with bench/gpu-prepare.sh on this machine.
set -uo pipefail
cd "$(dirname "$0")/.."
OUT=${OUT:-$PWD/gpu-out}
mkdir -p "$OUT"
dev=$PWD/.device
export CFLAGS="-I$dev/include" LDFLAGS="-L$dev/lib" LIBRARY_PATH="$dev/lib"
export LD_LIBRARY_PATH="$dev/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
meson=(meson)
command -v meson >/dev/null || meson=(python3 -m mesonbuild.mesonmain)

{
    echo "date: $(date -u +%Y-%m-%dT%H:%MZ)"
    echo "commit: $(git rev-parse --short HEAD 2>/dev/null || echo unknown)$(git diff --quiet 2>/dev/null || echo +dirty)"
    nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>&1
} | tee "$OUT/machine.txt"

"${meson[@]}" setup build-gpu --buildtype=release >"$OUT/setup.log" 2>&1 &&
    ninja -C build-gpu >"$OUT/build.log" 2>&1 || { tail -40 "$OUT/setup.log" "$OUT/build.log"; exit 1; }

# Each OpenCL platform on its own, through a vendor folder of its own.
vend=$(mktemp -d)
mkdir -p "$vend/nvidia" "$vend/pocl"
echo libnvidia-opencl.so.1 >"$vend/nvidia/nvidia.icd"
[ -f /etc/OpenCL/vendors/pocl.icd ] && cp /etc/OpenCL/vendors/pocl.icd "$vend/pocl/"

status=0
for platform in nvidia pocl; do
    echo "== tests on $platform OpenCL =="
    OCL_ICD_VENDORS="$vend/$platform" ./build-gpu/src/petblur devices
    OCL_ICD_VENDORS="$vend/$platform" "${meson[@]}" test -C build-gpu --no-rebuild --print-errorlogs \
        --suite host --suite opencl >"$OUT/test-$platform.log" 2>&1 || status=1
    grep -E '^(Ok|Fail|Skipped):' "$OUT/test-$platform.log"
    grep -h 'largest relative difference' build-gpu/meson-logs/testlog.txt | sed "s/^/$platform: /"
done

echo "== benchmark: NVIDIA OpenCL, 256^3, paper scenarios 1-8 =="
OCL_ICD_VENDORS="$vend/nvidia" ./build-gpu/bench/pb_bench --device opencl --size 256 --runs 20 \
    --label nvidia-opencl --csv "$OUT/bench-nvidia-opencl.csv" | tee "$OUT/bench-nvidia-opencl.txt"
echo "== benchmark: PoCL on the GPU machine's CPU, 128^3, scenario 2 =="
OCL_ICD_VENDORS="$vend/pocl" ./build-gpu/bench/pb_bench --device opencl --size 128 --runs 5 --scenario 2 \
    --label pocl-cpu --csv "$OUT/bench-pocl.csv" | tee "$OUT/bench-pocl.txt"
exit $status
