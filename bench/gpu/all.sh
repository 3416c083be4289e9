#: all                     kernels, then paper: the full run every kernel change gets (PB_PAPER=0: kernels alone)
# Both halves' files through $OUT: tables.md, tests.txt, demo-cuda.png,
# logs.tar.gz, paper.md, paper.tar.gz. The kernels' half alone fits the
# device tool's ten minutes; its files are written before the paper's half
# starts, so they come back if that half runs past it. (carry .device)
# shellcheck shell=bash
mode_all() (
    kernels_log=$(mktemp -d)/logs
    mkdir -p "$kernels_log"
    BUILD_LOGS=$kernels_log build_gpu
    status=0
    mode_kernels || status=1
    [ "${PB_PAPER:-1}" = 0 ] && exit $status
    mode_paper || status=1
    exit $status
)
