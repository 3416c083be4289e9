#!/usr/bin/env bash
# The paper's Tables 1-3 on this machine, with the peers and the report:
#   1. petblur bench on DEVICE: three phantoms, eight motions, every method,
#      the references kept for what follows;
#   2. petblur bench on CPU_DEVICE (PoCL) on the brain phantom, against the same
#      references, for the SciPy comparison;
#   3. bench/peers.py: PyTorch grid_sample on the GPU (every phantom) and SciPy
#      map_coordinates on the CPU (the brain), same volumes, S and reference;
#   4. bench/fetch_rate.cu (where nvcc and a GPU are): the texture unit's fetch
#      rate and the copy bandwidth, for AB's floor;
#   5. bench/paper_report.py: paper.md, paper.csv and the plots.
#
#   bench/paper.sh BUILD_DIR RUN_DIR [--device DEV] [--cpu-device DEV] [--quick]
#                  [--size N] [--points K] [--runs N]
#
# DEV defaults to auto (CUDA where there is a GPU); CPU_DEVICE to none (step 2
# left out). --quick is the small version (48-voxel grids); --size, --points
# and --runs go to both benches (the tests run the pipeline's plumbing on
# 16-voxel grids; the whole one runs on the GPU machine, bench/gpu.sh paper). PYTHON picks the
# interpreter for the peers and the report (default python3). The volumes
# (2 GB at full size) are deleted at the end; RUN_DIR keeps the tables.
set -uo pipefail
status=0
here=$(cd "$(dirname "$0")" && pwd)
build=${1:?usage: bench/paper.sh BUILD_DIR RUN_DIR [--device DEV] [--cpu-device DEV] [--quick] [--size N] [--points K] [--runs N]}
run=${2:?usage: bench/paper.sh BUILD_DIR RUN_DIR [--device DEV] [--cpu-device DEV] [--quick] [--size N] [--points K] [--runs N]}
shift 2
device=auto cpu_device= quick=() sizes=() cpu_runs=(--runs 5)
while [ $# -gt 0 ]; do
    case $1 in
    --device) device=$2; shift 2 ;;
    --cpu-device) cpu_device=$2; shift 2 ;;
    --quick) quick=(--quick); shift ;;
    --size | --points) sizes+=("$1" "$2"); shift 2 ;;
    --runs) sizes+=("$1" "$2"); cpu_runs=(); shift 2 ;;
    *) echo "paper.sh: unknown option $1" >&2; exit 2 ;;
    esac
done
py=${PYTHON:-python3}
petblur=$build/src/cli/petblur
mkdir -p "$run"
start=$(date +%s)
stamp() { echo "== $* ($(($(date +%s) - start)) s)"; }

stamp "petblur bench on $device"
# Everything after needs this run's references: stop here if it failed.
"$petblur" bench "${quick[@]}" "${sizes[@]}" --device "$device" --out-dir "$run" --keep-volumes -q | tee "$run/bench.txt" || exit 1

if [ -n "$cpu_device" ]; then
    stamp "petblur bench on $cpu_device (the brain phantom, the same references)"
    "$petblur" bench "${quick[@]}" "${sizes[@]}" "${cpu_runs[@]}" --device "$cpu_device" --phantoms brain --reference "$run" \
        --out-dir "$run/cpu" -q | tee "$run/bench-cpu.txt" && mv "$run/cpu/results.csv" "$run/results-pocl.csv" ||
        status=1
    rm -rf "$run/cpu"
fi

stamp "peers"
"$py" "$here/peers.py" "$run/cases.csv" "$run/peers.csv" --runs "$([ ${#quick[@]} -gt 0 ] && echo 3 || echo 10)" |
    tee "$run/peers.txt" || status=1

if command -v nvcc >/dev/null && command -v nvidia-smi >/dev/null && nvidia-smi -L >/dev/null 2>&1; then
    stamp "fetch rate and bandwidth"
    arch=$(nvidia-smi --query-gpu=compute_cap --format=csv,noheader | head -1 | tr -d .)
    { nvcc -O3 -arch="sm_$arch" -o "$build/fetch_rate" "$here/fetch_rate.cu" &&
        "$build/fetch_rate" "$run/rates.csv" | tee "$run/fetch-rate.txt"; } || status=1
fi

stamp "report"
"$py" "$here/paper_report.py" "$run" >/dev/null || status=1
rm -rf "$run/volumes"
stamp "done: $run/paper.md (status $status)"
exit $status
