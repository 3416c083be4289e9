#!/usr/bin/env bash
# On the GPU machine: short translations as taps (issue 33, item 2). Two calls,
# each within the device's ten minutes (the build is kept between them):
#   PB_COMMIT=... bash bench/gpu-taps.sh tests   build (CUDA and OpenCL); the host, cuda and opencl suites (NVIDIA's
#                                                OpenCL; the walk's runs and test_shift_taps among them);
#                                                memcheck on test_shift_taps and test_plan, racecheck on
#                                                test_shift_taps
#   PB_COMMIT=... bash bench/gpu-taps.sh bench   bench/pb_bench on the paper's eight motions, with the taps and
#                                                with the walk; the package beside the machine's torch and CuPy;
#                                                bench/shift_taps.py (taps against the walk by translation) and
#                                                bench/python_overhead.py (the Python call's host time);
#                                                bench/memory_floor.py with the taps and with the walk
#                                                (PETBLUR_SHIFT_TAPS=0), in one process each
# (carry .device .whl). What comes back through $OUT: machine.txt, tests.txt, sanitize.log, shift_taps.md/.csv,
# floor.md/.csv, floor-walk.md/.csv, python_overhead.txt, paper-taps/-walk.csv/.txt.
set -uo pipefail
cd "$(dirname "$0")/.."
. bench/device-env.sh
write_machine "$OUT/machine.txt" </dev/null
status=0
case "${1:-}" in
tests)
    build_gpu
    run_suites || status=1
    sanitize_tests test_shift_taps test_plan -- test_shift_taps || status=1
    ;;
bench)
    build_gpu
    # The paper's eight motions on 256^3 through C (pb_bench, volumes), with the taps and with the walk.
    for mode in taps walk; do
        [ $mode = walk ] && export PETBLUR_SHIFT_TAPS=0
        ./build-gpu/bench/pb_bench --device cuda --size 256 --runs 20 --ref-runs 0 --label $mode \
            --csv "$OUT/paper-$mode.csv" >"$OUT/paper-$mode.txt" 2>&1 || status=1
        unset PETBLUR_SHIFT_TAPS
    done
    tail -n 30 "$OUT/paper-taps.txt"
    install_package -Dopencl=disabled || exit 1
    (cd /tmp && python3 "$OLDPWD/bench/shift_taps.py" --out "$OUT/shift_taps.csv") 2>&1 | tee "$OUT/shift_taps.md"
    [ "${PIPESTATUS[0]}" = 0 ] || status=1
    (cd /tmp && python3 "$OLDPWD/bench/python_overhead.py") >"$OUT/python_overhead.txt" 2>&1 || status=1
    head -3 "$OUT/python_overhead.txt"
    (cd /tmp && python3 "$OLDPWD/bench/memory_floor.py" --out "$OUT/floor.csv") 2>&1 | tee "$OUT/floor.md"
    [ "${PIPESTATUS[0]}" = 0 ] || status=1
    (cd /tmp && PETBLUR_SHIFT_TAPS=0 python3 "$OLDPWD/bench/memory_floor.py" --out "$OUT/floor-walk.csv") 2>&1 |
        tee "$OUT/floor-walk.md"
    [ "${PIPESTATUS[0]}" = 0 ] || status=1
    ;;
*)
    echo "gpu-taps.sh tests|bench" >&2
    exit 2
    ;;
esac
exit $status
