#: tapcost [ARGS]          what taps cost against the kernels they replace: petblur bench on the paper's translations (CUDA, homogeneity, 256^3) as the library chooses and with every translation's taps forced, alternately; then bench/tap_cost.py ARGS on fresh translations
# Under translations a frame runs as taps (cl/pb_taps.cl) where they are few
# (src/devices/shift_taps.c); past the limit it runs its walk, sweep, chord
# or samples. This times both on scenarios 1-4, every method and filter:
# petblur bench as chosen (PETBLUR_SHIFT_TAPS unset) and forced
# (PETBLUR_SHIFT_TAPS=100000), chosen, forced, chosen, forced, each row's
# better time of the two rounds, with each run's error beside it (the taps are
# the kernel's own impulse response, so both agree to rounding). Then the
# package, and bench/tap_cost.py with the mode's arguments (e.g. --draws 24
# --seed 5): chosen, kernel alone and taps forced on fresh translations.
# Back through $OUT: machine.txt, tapcost.md, runs.tar.gz, tap_cost.md/.csv.
# --no-paper first skips petblur bench.
#   PB_COMMIT=<commit> bash bench/gpu.sh tapcost [--no-paper] [ARGS]   (carry .device .whl)
# shellcheck shell=bash disable=SC2154 # meson and the helpers: bench/gpu/lib.sh
mode_tapcost() (
    write_machine "$OUT/machine.txt" </dev/null
    if [ "${1:-}" = --no-paper ]; then
        shift
    else
        paper_taps || exit 1
    fi
    install_package -Dopencl=disabled || exit 1
    (cd /tmp && python3 "$OLDPWD/bench/tap_cost.py" --out "$OUT/tap_cost.csv" "$@") 2>&1 | tee "$OUT/tap_cost.md"
    exit "${PIPESTATUS[0]}"
)

paper_taps() {
    local work round which
    work=$(mktemp -d)
    build_tree "$PWD" "$PWD/build-tapcost" -Dopencl=disabled -- src/cli/petblur || return 1
    for round in 1 2; do
        for which in chosen forced; do
            if [ $which = forced ]; then export PETBLUR_SHIFT_TAPS=100000; else unset PETBLUR_SHIFT_TAPS; fi
            ./build-tapcost/src/cli/petblur bench --device cuda --phantoms homogeneity --scenarios 1,2,3,4 \
                --points 4 --runs 20 --out-dir "$work/run-$which-$round" -q >/dev/null ||
                { echo "gpu.sh tapcost: the $which bench failed"; return 1; }
            cp "$work/run-$which-$round/results.csv" "$work/$which-$round.csv"
        done
    done
    unset PETBLUR_SHIFT_TAPS
    python3 bench/gpu/best_of.py "$work" --runs chosen,forced --rms | tee "$OUT/tapcost.md"
    tar -C "$work" -czf "$OUT/runs.tar.gz" chosen-1.csv forced-1.csv chosen-2.csv forced-2.csv
}
