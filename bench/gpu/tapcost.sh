#: tapcost                 what taps cost against the kernels they replace: petblur bench on the paper's translations (CUDA, homogeneity, 256^3) as the library chooses and with every translation's taps forced, alternately
# Under translations a frame runs as taps (cl/pb_taps.cl) where they are few
# (src/devices/shift_taps.c); past the limit it runs its walk, sweep, chord
# or samples. This times both on scenarios 1-4, every method and filter:
# petblur bench as chosen (PETBLUR_SHIFT_TAPS unset) and forced
# (PETBLUR_SHIFT_TAPS=100000), chosen, forced, chosen, forced, each row's
# better time of the two rounds, with each run's error beside it (the taps are
# the kernel's own impulse response, so both agree to rounding).
# Back through $OUT: machine.txt, tapcost.md, runs.tar.gz.
#   PB_COMMIT=<commit> bash bench/gpu.sh tapcost   (carry .device)
# shellcheck shell=bash disable=SC2154 # meson and the helpers: bench/gpu/lib.sh
mode_tapcost() (
    write_machine "$OUT/machine.txt" </dev/null
    work=$(mktemp -d)
    build_tree "$PWD" "$PWD/build-tapcost" -Dopencl=disabled -- src/cli/petblur || exit 1
    for round in 1 2; do
        for which in chosen forced; do
            if [ $which = forced ]; then export PETBLUR_SHIFT_TAPS=100000; else unset PETBLUR_SHIFT_TAPS; fi
            ./build-tapcost/src/cli/petblur bench --device cuda --phantoms homogeneity --scenarios 1,2,3,4 \
                --points 4 --runs 20 --out-dir "$work/run-$which-$round" -q >/dev/null ||
                { echo "gpu.sh tapcost: the $which bench failed"; exit 1; }
            cp "$work/run-$which-$round/results.csv" "$work/$which-$round.csv"
        done
    done
    unset PETBLUR_SHIFT_TAPS
    python3 bench/gpu/best_of.py "$work" --runs chosen,forced --rms | tee "$OUT/tapcost.md"
    tar -C "$work" -czf "$OUT/runs.tar.gz" chosen-1.csv forced-1.csv chosen-2.csv forced-2.csv
)
