#: frames [compare OLD | frames_cost.py options]  issue 46's cost table of 24 frames under a logged drift; with compare, an old tree against this one
# Through the package installed beside the machine's torch (-Dopencl=disabled):
#  - no word: bench/frames_cost.py on cuda:0 (24 frames of 75 s on
#    220x220x110 voxels of 2 mm; the 1 Hz random walk, its smooth drift and a
#    noisy 20 Hz log of it, at the default bound and 0.25: forward and summed
#    adjoint against the memory floor, segments per frame, errors from dense
#    CL references of the logged and the true motion), options going to it.
#    Back through $OUT: machine.txt, frames.md (its output), frames.json.
#  - compare OLD [frames_cost.py options]: before and after. OLD is an older
#    source tree (`git archive OLD | tar -x -C .base`, carried along); the
#    package of each tree (old, this one: new), and this tree's
#    bench/frames_cost.py by each in turn, the same seed and options. Back
#    through $OUT: machine.txt, frames-old.md, frames-new.md, frames-old.json,
#    frames-new.json.
#   PB_COMMIT=... PB_OLD=... bash bench/gpu.sh frames compare .base
# (carry .device .whl, and the old tree for compare)
# shellcheck shell=bash
mode_frames() (
    if [ "${1:-}" = compare ]; then
        shift
        frames_compare "$@"
        exit
    fi
    write_machine "$OUT/machine.txt" </dev/null
    install_package -Dopencl=disabled || exit 1
    (cd /tmp && python3 "$OLDPWD/bench/frames_cost.py" --out "$OUT/frames.json" "$@") 2>&1 | tee "$OUT/frames.md"
    exit "${PIPESTATUS[0]}"
)

frames_compare() (
    echo "old: ${PB_OLD:-unknown}" | write_machine "$OUT/machine.txt"
    status=0
    old=$(realpath "${1:?the old source tree}")
    shift
    sites=$(mktemp -d)
    package_into "$old" "$sites/old" -Dopencl=disabled || exit 1
    package_into . "$sites/new" -Dopencl=disabled || exit 1
    for which in old new; do
        echo "== $which"
        (cd /tmp && PYTHONPATH=$sites/$which python3 "$OLDPWD/bench/frames_cost.py" \
            --out "$OUT/frames-$which.json" "$@") >"$OUT/frames-$which.md" 2>&1 || status=1
        sed -n '/^| track | bound/,/^$/p' "$OUT/frames-$which.md"
        grep -E 'target|Error|error:' "$OUT/frames-$which.md"
    done
    exit $status
)
