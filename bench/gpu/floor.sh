#: floor [compare OLD [VARIANT..] | memory_floor.py options]  issue 33's memory floor table; with compare, old trees against this one
# Through the package installed beside the machine's torch and CuPy:
#  - no word: bench/memory_floor.py (each common case beside its memory floor
#    measured in the same process, and CuPy's affine_transform loop), options
#    going to it. Back through $OUT: machine.txt, floor.md, floor.csv.
#  - compare OLD [VARIANT...]: before and after (issue 33's per-voxel set-up
#    cut). OLD is an older source tree (`git archive OLD | tar -x -C .base`,
#    carried along), VARIANTs other trees; the package of each tree (old, any
#    variants by folder name, this one: new); bench/memory_floor.py by each in
#    turn, twice; Nsight Compute's counters of the new kernels on
#    bench/profile_floor.py's cases; python/tests/test_gpu.py on the new. Back
#    through $OUT: bench.tar.gz (machine.txt, floor-old-1.md, floor-new-1.md,
#    ..., counters.txt, pytest-gpu.txt).
#   PB_COMMIT=... PB_OLD=... bash bench/gpu.sh floor compare .base [.variant ...]
# (carry .device .whl, and the trees for compare)
# shellcheck shell=bash
mode_floor() (
    if [ "${1:-}" = compare ]; then
        shift
        floor_compare "$@"
        exit
    fi
    write_machine "$OUT/machine.txt" </dev/null
    install_package -Dopencl=disabled || exit 1
    (cd /tmp && python3 "$OLDPWD/bench/memory_floor.py" --out "$OUT/floor.csv" "$@") 2>&1 | tee "$OUT/floor.md"
    exit "${PIPESTATUS[0]}"
)

floor_compare() (
    echo "old: ${PB_OLD:-unknown}" | write_machine "$OUT/machine.txt"
    status=0
    # The trees by name: the first "old", this one "new", any other by its folder's name.
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
    exit $status
)
