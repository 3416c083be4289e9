#: taps                    issue 33's short translations as taps against the walk: pb_bench, shift_taps.py, python_overhead.py, memory_floor.py
# Each measured with the taps and with the walk (PETBLUR_SHIFT_TAPS=0): the
# paper's eight motions on 256^3 through C (bench/pb_bench, volumes); then the
# package beside the machine's torch and CuPy: bench/shift_taps.py (taps
# against the walk by translation), bench/python_overhead.py (the Python
# call's host time), bench/memory_floor.py in one process each. The suites and
# the sanitizers on the taps: mode tests test_shift_taps test_plan --
# test_shift_taps. Back through $OUT: machine.txt, shift_taps.md/.csv,
# floor.md/.csv, floor-walk.md/.csv, python_overhead.txt,
# paper-taps/-walk.csv/.txt. (carry .device .whl)
# shellcheck shell=bash
mode_taps() (
    write_machine "$OUT/machine.txt" </dev/null
    status=0
    build_gpu
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
    exit $status
)
