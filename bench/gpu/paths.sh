#: paths [path_cases.py options]   issue 46's validation set on CUDA, both filters, the same seeds as the host's
# The package installed by pip beside the machine's torch (-Dopencl=disabled).
# bench/path_cases.py on CUDA with the exact and the hardware filter: the
# small cases of every kind (the host's --small seed, 2027060475, unless
# options say otherwise), then the default-size drift, rotation and
# translation (seed 2100572311), each against its dense scipy references.
# Back through $OUT: machine.txt, paths.txt (the runs' output), small/ and
# default/ (path_cases.json and table.md each). (carry .device .whl)
# shellcheck shell=bash disable=SC2154 # the helpers: bench/gpu/lib.sh
mode_paths() (
    write_machine "$OUT/machine.txt" </dev/null
    install_package -Dopencl=disabled || exit 1
    status=0
    run_cases() { # out dir, options
        local out=$1
        shift
        (cd /tmp && python3 "$OLDPWD/bench/path_cases.py" --device cuda --filters exact,hardware \
            --methods ab,ab-sweep,rm --out "$OUT/$out" "$@") >>"$OUT/paths.txt" 2>&1 || status=1
    }
    if [ $# -gt 0 ]; then
        run_cases small "$@"
    else
        run_cases small --small --seed 2027060475
        run_cases default --kinds drift-1hz,rotation,translation --seed 2100572311
    fi
    tail -n 40 "$OUT/paths.txt"
    exit "$status"
)
