#!/usr/bin/env bash
# One run on the GPU machine answers every question about a kernel change:
# build (CUDA and OpenCL), the host suite, the opencl suite on NVIDIA's OpenCL
# and on PoCL, the cuda suite, how far CUDA is from PoCL and from NVIDIA's
# OpenCL on the same inputs, the demo, the benchmark of every method on a 256^3
# volume for the paper's eight motions on CUDA (CUDA events) and on NVIDIA's
# OpenCL (profiling events), twenty dynamic frames in one call against one call
# per frame (bench/pb_frames), and the paper's Tables 1-3 with the peers, AB's
# floor and the plots (bench/paper.sh). What comes back through $OUT (the
# device tool returns at most 8 files): tables.md, tests.txt, paper.md,
# paper.tar.gz (its CSVs, plots and logs), demo-cuda.png and logs.tar.gz with
# everything else. Commit under bench/results/DATE_GPU_COMMIT only what a doc
# cites (bench/results/README.md): the tarballs would outgrow the repository,
# and git history keeps what a later run supersedes.
#
# The machine has no Khronos CL/ headers and no libOpenCL.so link name: bring
# them in .device/ (git-ignored) with bench/gpu-prepare.sh on this machine.
# The copy there has no trustworthy git state: pass the commit in, as
#   PB_COMMIT=$(git rev-parse --short HEAD) bash bench/gpu.sh
set -uo pipefail
cd "$(dirname "$0")/.."
LOG=$(mktemp -d)/logs
mkdir -p "$LOG"
. bench/device-env.sh

{
    echo "date: $(date -u +%Y-%m-%dT%H:%MZ)"
    echo "commit: ${PB_COMMIT:-$(git rev-parse --short HEAD 2>/dev/null || echo unknown)}"
    nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>&1
    nvcc --version | tail -2
    nproc | sed 's/^/cpu cores: /'
} | tee "$LOG/machine.txt"

"${meson[@]}" setup build-gpu --buildtype=release -Dcuda=enabled -Dopencl=enabled >"$LOG/setup.log" 2>&1 &&
    ninja -C build-gpu >"$LOG/build.log" 2>&1 || { tail -40 "$LOG/setup.log" "$LOG/build.log"; exit 1; }
# Registers and spills of the CUDA kernels, for the record.
nvcc -arch=sm_90 -O3 -std=c++17 -Xptxas -v -c cuda/pb_kernels.cu -o /dev/null 2>&1 |
    grep -E 'entry function|registers' >"$LOG/cuda-registers.txt"

# Each OpenCL platform on its own, through a vendor folder of its own.
vend=$(mktemp -d)
mkdir -p "$vend/nvidia" "$vend/pocl"
echo libnvidia-opencl.so.1 >"$vend/nvidia/nvidia.icd"
[ -f /etc/OpenCL/vendors/pocl.icd ] && cp /etc/OpenCL/vendors/pocl.icd "$vend/pocl/"

status=0
run_suites() { # name, vendor folder, suites...
    local name=$1 vendors=$2
    shift 2
    echo "== tests: $name =="
    local args=()
    for s in "$@"; do args+=(--suite "$s"); done
    OCL_ICD_VENDORS=$vendors "${meson[@]}" test -C build-gpu --no-rebuild --print-errorlogs "${args[@]}" \
        >"$LOG/test-$name.log" 2>&1 || status=1
    cp build-gpu/meson-logs/testlog.txt "$LOG/testlog-$name.txt"
    {
        echo "== $name"
        grep -E '^ *[0-9]+/[0-9]+ |^(Ok|Fail|Skipped):' "$LOG/test-$name.log"
        grep -h 'largest relative difference\|hardware weights\|largest relative mismatch\|voxel off' build-gpu/meson-logs/testlog.txt | sed "s/^/$name: /"
    } | tee -a "$OUT/tests.txt"
}
OCL_ICD_VENDORS="$vend/nvidia:$vend/pocl" ./build-gpu/src/cli/petblur devices
run_suites host "$vend/pocl" host
run_suites cuda "$vend/pocl" cuda
run_suites nvidia-opencl "$vend/nvidia" opencl
run_suites pocl "$vend/pocl" opencl

echo "== the main job: petblur demo on CUDA and NVIDIA OpenCL (brain phantom, full 128x128x64) =="
for d in cuda opencl; do
    OCL_ICD_VENDORS="$vend/nvidia" ./build-gpu/src/cli/petblur demo --device $d --size 128 --out-dir "$LOG/demo-$d" \
        2>&1 | tee "$LOG/demo-$d.txt" || status=1
    rm -f "$LOG/demo-$d"/*.nii.gz
done
cp "$LOG/demo-cuda/demo.png" "$OUT/demo-cuda.png" 2>/dev/null

echo "== CUDA against PoCL and against NVIDIA OpenCL, same inputs =="
for platform in pocl nvidia; do
    echo "## CUDA (A) against $platform OpenCL (B)" | tee -a "$LOG/compare.txt"
    OCL_ICD_VENDORS="$vend/$platform" ./build-gpu/bench/pb_compare --size 64 cuda opencl:0 |
        tee -a "$LOG/compare.txt" || status=1
done

echo "== benchmark: CUDA, 256^3, paper scenarios 1-8 =="
./build-gpu/bench/pb_bench --device cuda --size 256 --runs 20 --ref-runs 0 \
    --label cuda --csv "$LOG/bench-cuda.csv" | tee "$LOG/bench-cuda.txt" || status=1
echo "== benchmark: NVIDIA OpenCL, 256^3, paper scenarios 1-8 =="
OCL_ICD_VENDORS="$vend/nvidia" ./build-gpu/bench/pb_bench --device opencl --size 256 --runs 20 --ref-runs 0 \
    --label nvidia-opencl --csv "$LOG/bench-nvidia-opencl.csv" | tee "$LOG/bench-nvidia-opencl.txt" || status=1
echo "== benchmark: PoCL on the GPU machine's CPU, 128^3, scenario 2 =="
OCL_ICD_VENDORS="$vend/pocl" ./build-gpu/bench/pb_bench --device opencl --size 128 --runs 5 --ref-runs 0 \
    --scenario 2 --label pocl-cpu --csv "$LOG/bench-pocl.csv" | tee "$LOG/bench-pocl.txt" || status=1

echo "== dynamic frames: 20 frames of 256^3, a 30 Hz track, one call against one call per frame =="
for d in cuda opencl; do
    OCL_ICD_VENDORS="$vend/nvidia" ./build-gpu/bench/pb_frames --device $d --size 256 --frames 20 --runs 5 \
        --label $d --csv "$LOG/frames-$d.csv" 2>&1 | tee "$LOG/frames-$d.txt" || status=1
done

# The tables and logs so far come back even if the paper's part below runs
# past the device's time limit.
{
    sed 's/^/    /' "$LOG/machine.txt"
    echo
    python3 bench/summarize.py "$LOG"
    echo "PoCL on the GPU machine's CPU, 128^3, scenario 2:"
    echo
    grep -v '^#' "$LOG/bench-pocl.txt" | sed 's/^/    /'
    echo
    for d in cuda opencl; do
        echo "petblur demo --device $d --size 128:"
        echo
        sed 's/^/    /' "$LOG/demo-$d.txt"
        echo
    done
    for d in cuda opencl; do
        echo "Twenty frames of 256^3 in one pb_blur_frames call against one pb_blur per frame ($d):"
        echo
        sed 's/^/    /' "$LOG/frames-$d.txt"
        echo
    done
} | tee "$OUT/tables.md"
tar -C "$(dirname "$LOG")" -czf "$OUT/logs.tar.gz" logs

# PB_PAPER=0 stops here: for a check of the suites and kernel times in one
# call that fits the device tool's ten minutes.
[ "${PB_PAPER:-1}" = 0 ] && exit $status

echo "== the paper's Tables 1-3 with the peers, AB's floor and the plots (bench/paper.sh) =="
paper=$(mktemp -d)/paper
OCL_ICD_VENDORS="$vend/pocl" PYTHON=python3 bash bench/paper.sh build-gpu "$paper" --device cuda \
    --cpu-device opencl || status=1
cp "$paper/paper.md" "$OUT/paper.md" 2>/dev/null
tar -C "$(dirname "$paper")" -czf "$OUT/paper.tar.gz" paper

{
    echo "The texture unit's fetch floor (only AB's fetches, 256^3; bench/fetch_rate.cu):"
    echo
    sed 's/^/    /' "$paper/fetch-rate.txt"
    echo
    echo "The paper's tables: paper.md"
} | tee -a "$OUT/tables.md"
tar -C "$(dirname "$LOG")" -czf "$OUT/logs.tar.gz" logs
exit $status
