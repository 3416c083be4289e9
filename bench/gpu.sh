#!/usr/bin/env bash
# The one entry point on the GPU machine:  bash bench/gpu.sh MODE [ARGS]
# Each mode is a file of bench/gpu/ (its first lines say what it runs and
# what comes back); the steps they share are in bench/gpu/lib.sh. Without a
# mode, or with an unknown one, the modes are listed (exit 2).
#
# The machine has no Khronos CL/ headers, no libOpenCL.so link name and not
# the program's libraries: bring them in .device/ (git-ignored) with
# bench/gpu-prepare.sh on the development machine; the Python modes take
# their wheels from .whl/ (nothing is downloaded there). Carry what the mode's
# line names. The copy there has no trustworthy git state: pass the commit in,
#   PB_COMMIT=$(git rev-parse --short HEAD) bash bench/gpu.sh MODE
# Results go to the device tool's $OUT (gpu-out/ without one), which returns
# at most 8 files: a mode writes no more, and tars the rest. Commit under
# bench/results/DATE_GPU_COMMIT only what a doc cites (bench/results/README.md).
set -uo pipefail
cd "$(dirname "$0")/.." || exit 1

usage() {
    echo "usage: bash bench/gpu.sh MODE [ARGS]; the modes:" >&2
    sed -n 's/^#: /  /p' bench/gpu/*.sh >&2
    exit 2
}
mode=${1:-}
[[ $mode =~ ^[a-z]+$ && -f bench/gpu/$mode.sh && $mode != lib ]] || usage
shift
# shellcheck source=bench/gpu/lib.sh
. bench/gpu/lib.sh
for f in bench/gpu/*.sh; do
    # shellcheck source=/dev/null
    [ "$f" = bench/gpu/lib.sh ] || . "$f"
done
"mode_$mode" "$@"
