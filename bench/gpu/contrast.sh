#: contrast [SEEDS [JOBS [pass4_family.py options]]]   pass 4 of the motion estimate on a family of fresh 24-frame series (bench/pass4_family.py)
# The command line's test of pass 4 draws one series a run; this draws SEEDS
# (default 16), JOBS at a time (default 8) on the machine's cores, each
# estimated with the pass on and off by the CUDA build. Back through $OUT:
# machine.txt, pass4.txt (the run), pass4.json and pass4.md. (carry .device .whl)
# shellcheck shell=bash disable=SC2154 # the helpers: bench/gpu/lib.sh
mode_contrast() (
    write_machine "$OUT/machine.txt" </dev/null
    build_gpu -- src/cli/petblur || exit 1
    install_nibabel
    python3 bench/pass4_family.py --petblur build-gpu/src/cli/petblur --seeds "${1:-16}" --jobs "${2:-8}" \
        --out "$OUT" "${@:3}" >"$OUT/pass4.txt" 2>&1
    status=$?
    tail -n 30 "$OUT/pass4.txt"
    exit $status
)
