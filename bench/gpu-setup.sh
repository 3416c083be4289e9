#!/usr/bin/env bash
# On the GPU machine: the walk's per-voxel set-up cut (issue 33, item 2), before
# and after in one run. OLD is an older source tree (`git archive OLD | tar -x -C
# .base`, carried along).
#   PB_COMMIT=... PB_OLD=... bash bench/gpu-setup.sh bench .base [.variant ...]
#       the package of each tree (old, any variants, this one: new) beside the machine's torch and
#       CuPy; bench/memory_floor.py by each in turn, twice; Nsight Compute's counters of the new
#       kernels on bench/profile_floor.py's cases. $OUT: bench.tar.gz (machine.txt,
#       floor-old-1.md, floor-new-1.md, ..., counters.txt, pytest-gpu.txt: python/tests/test_gpu.py on the new)
#   PB_COMMIT=... bash bench/gpu-setup.sh tests
#       build-gpu (CUDA and NVIDIA's OpenCL); the host, cuda and opencl suites; memcheck on
#       test_adjoint, test_plan and test_frames, racecheck on test_adjoint. $OUT: machine.txt,
#       tests.txt, sanitize.log
# (carry .device .whl, and .base for bench).
set -uo pipefail
cd "$(dirname "$0")/.."
. bench/device-env.sh
echo "old: ${PB_OLD:-unknown}" | write_machine "$OUT/machine.txt"
status=0
case "${1:-}" in
bench)
    # The trees by name: the first "old", this one "new", any other by its folder's name.
    shift
    trees=("$(realpath "${1:?the old source tree}")")
    names=(old)
    shift
    for t in "$@"; do
        trees+=("$(realpath "$t")")
        names+=("$(basename "$t" | tr -d .)")
    done
    trees+=("$PWD")
    names+=(new)
    sites=$(mktemp -d)
    for i in "${!trees[@]}"; do
        package_into "${trees[$i]}" "$sites/${names[$i]}" -Dopencl=disabled || exit 1
    done
    for round in 1 2; do
        for which in "${names[@]}"; do
            echo "== $which, round $round"
            (cd /tmp && PYTHONPATH=$sites/$which python3 "$OLDPWD/bench/memory_floor.py" \
                --out "$OUT/floor-$which-$round.csv") >"$OUT/floor-$which-$round.md" 2>&1 || status=1
            grep -E 'frames|degrees|worst' "$OUT/floor-$which-$round.md"
        done
    done
    for c in frames-forward frames-adjoint turn; do
        echo "== $c (new)"
        PYTHONPATH=$sites/new profile_case $c --section SpeedOfLight --section ComputeWorkloadAnalysis \
            --section InstructionStats --section WarpStateStats --section Occupancy |
            grep -E 'Duration|Throughput|Issue Slots Busy|Executed Instructions  |Registers Per|Achieved Occ|Warp Cycles Per Issued'
    done | tee "$OUT/counters.txt"
    echo "== pytest test_gpu.py (new)"
    (cd /tmp && PYTHONPATH=$sites/new python3 -m pytest -q -p no:cacheprovider "$OLDPWD/python/tests/test_gpu.py") \
        >"$OUT/pytest-gpu.txt" 2>&1 || status=1
    tail -3 "$OUT/pytest-gpu.txt"
    (cd "$OUT" && tar -czf bench.tar.gz machine.txt floor-*.md floor-*.csv counters.txt pytest-gpu.txt &&
        rm -f floor-* counters.txt pytest-gpu.txt)
    ;;
tests)
    build_gpu
    run_suites || status=1
    sanitize_tests test_adjoint test_plan test_frames -- test_adjoint || status=1
    ;;
*)
    echo "gpu-setup.sh bench OLD | tests" >&2
    exit 2
    ;;
esac
exit $status
