#: heads [estimate_family.py options]  issue 47's family of fresh head series: petblur motion estimate on CUDA beside SimpleITK
# bench/estimate_family.py with the CUDA build (--device cuda; no OpenCL, so
# .device's CL/ headers and libOpenCL may stay behind for room), its draws run
# side by side on the machine's cores (default --draws 20 --jobs 8, two
# threads each for SimpleITK's registration), options going to it. SimpleITK
# and nibabel from .whl/. SimpleITK's wheel (53 MB) no longer fits the 64 MiB
# carry beside the tree (8 MB at 8a06d47), nibabel and .device, even with the
# meson wheels and .device's CL/ and libOpenCL set aside: run --no-sitk (petblur
# and its --variant runs alone) with --seed's, SimpleITK for the same seeds on
# the development machine (estimate_family.py --sitk-only), and merge the two
# there (--summarize DRAWS.JSONL --sitk-from THE-HOST'S.JSONL).
# Back through $OUT: machine.txt, family.txt (the run), draws.jsonl and
# family.md. (carry .device .whl)
# shellcheck shell=bash disable=SC2154 # the helpers: bench/gpu/lib.sh
mode_heads() (
    write_machine "$OUT/machine.txt" </dev/null
    build_gpu -Dopencl=disabled -- src/cli/petblur || exit 1
    install_nibabel
    python3 -m pip install -q --no-deps --no-index --find-links .whl --target "$PYTHONPATH" SimpleITK 2>&1 | tail -3
    python3 bench/estimate_family.py --petblur build-gpu/src/cli/petblur --device cuda --draws 20 --jobs 8 \
        --out "$OUT" "$@" >"$OUT/family.txt" 2>&1
    status=$?
    tail -n 40 "$OUT/family.txt"
    exit $status
)
