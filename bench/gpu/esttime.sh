#: esttime OLD_TREE [estimate_time.py options]  the motion estimate's time: OLD_TREE's program against this tree's (and its views as sampled) on one series, in turn
# Where the estimate's time went between two commits, on one machine whose
# cores drift (bench/estimate_time.py: the fine setup's 24 frames of 128^3 by
# default, three rounds). OLD_TREE is an older commit's source
# (`git archive OLD | tar -x -C .base`, carried along). Both programs are
# built with CUDA alone, side by side. Back through $OUT: machine.txt,
# time.txt and times.json.
#   PB_OLD=<commit> PB_COMMIT=<commit> bash bench/gpu.sh esttime .base   (carry .device .whl .base)
# shellcheck shell=bash disable=SC2154 # the helpers: bench/gpu/lib.sh
mode_esttime() (
    if [ $# -lt 1 ] || [ ! -d "$1" ]; then
        echo "usage: bench/gpu.sh esttime OLD_TREE [estimate_time.py options]" >&2
        exit 2
    fi
    old=$(realpath "$1")
    shift
    echo "old: ${PB_OLD:-unknown}" | write_machine "$OUT/machine.txt"
    work=$(mktemp -d)
    build_tree "$old" "$work/build-old" -Dopencl=disabled -- src/cli/petblur &
    b1=$!
    build_tree "$PWD" "$work/build-new" -Dopencl=disabled -- src/cli/petblur &
    b2=$!
    built=0
    wait $b1 || built=1
    wait $b2 || built=1
    [ $built = 0 ] || { echo "gpu.sh esttime: a build failed"; exit 1; }
    install_nibabel
    python3 bench/estimate_time.py --device cuda --out "$work/series" "$@" \
        "old=$work/build-old/src/cli/petblur" "new=$work/build-new/src/cli/petblur" \
        "sampled=$work/build-new/src/cli/petblur:PETBLUR_ESTIMATE_VIEWS=sampled" 2>&1 | tee "$OUT/time.txt"
    status=${PIPESTATUS[0]}
    cp "$work/series/times.json" "$OUT/" 2>/dev/null
    exit "$status"
)
