#: family [SEEDS [JOBS]]  the motion study's small version over fresh seeds on PoCL, as CI runs it (bench/study_family.py)
# What python/tests/test_motion_study.py asserts on one draw, on SEEDS draws
# (default 16), JOBS at a time (default 8) on the machine's cores: the
# package from this tree's build (PYTHONPATH), PoCL as in CI. The small
# projector's matrix is carried, git-ignored, as .study/astra-48-60.npz:
#   python3 examples/motion_study/study.py --preset small --matrix .study/astra-48-60.npz --make-matrix
# Back through $OUT: machine.txt, family.txt, family.json, family.md.
# (carry .device .whl .study/astra-48-60.npz)
# shellcheck shell=bash disable=SC2154 # the helpers: bench/gpu/lib.sh
mode_family() (
    write_machine "$OUT/machine.txt" </dev/null
    build_gpu -Dopencl=enabled -Dpython=true || exit 1
    install_nibabel
    PYTHONPATH=$PWD/python:$PYTHONPATH PETBLUR_LIBRARY=$PWD/build-gpu/src/libpetblur.so PETBLUR_CLI=$PWD/build-gpu/src/cli/petblur \
        python3 bench/study_family.py --seeds "${1:-16}" --jobs "${2:-8}" --device opencl \
        --matrix .study/astra-48-60.npz --out /tmp/family >"$OUT/family.txt" 2>&1
    status=$?
    cp /tmp/family/family.json /tmp/family/family.md "$OUT/" 2>/dev/null
    tail -n 30 "$OUT/family.txt"
    exit $status
)
