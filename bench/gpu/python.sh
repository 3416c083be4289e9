#: python                  the Python package end to end: host and cuda suites, memcheck on test_plan, pytest, python_torch.py on 256^3
# The C tree's host and cuda suites (the caller's-stream test among them) and
# test_plan under compute-sanitizer's memcheck; the package installed with pip
# beside the machine's torch and CuPy (meson-python and nibabel from .whl/);
# the whole pytest suite (numpy, CuPy and torch CUDA, autograd, threads) and
# bench/python_torch.py on a 256^3 tensor. Back through $OUT: machine.txt,
# tests.txt, sanitize.log, pytest.txt, python_torch.md and .csv.
# (carry .device .whl)
# shellcheck shell=bash disable=SC2154 # meson and the helpers: bench/gpu/lib.sh
mode_python() (
    {
        python3 -c 'import sys, numpy, torch; print("python", sys.version.split()[0], "numpy", numpy.__version__, "torch", torch.__version__)'
        python3 -c 'import cupy; print("cupy", cupy.__version__)' 2>&1 | tail -1
    } | write_machine "$OUT/machine.txt"

    status=0
    build_gpu
    vend=$(icd_folder pocl)
    OCL_ICD_VENDORS=$vend "${meson[@]}" test -C build-gpu --no-rebuild --print-errorlogs --suite host --suite cuda \
        >/tmp/tests.log 2>&1 || status=1
    grep -E '^ *[0-9]+/[0-9]+ |^(Ok|Fail|Skipped):' /tmp/tests.log | tee "$OUT/tests.txt"
    [ $status = 0 ] || tail -60 /tmp/tests.log >>"$OUT/tests.txt"
    sanitize_tests test_plan || status=1

    echo "== pip install . beside the machine's torch and CuPy =="
    install_package || exit 1
    python3 -c 'import petblur; print("installed:", petblur.__file__, petblur.devices())'
    echo "== pytest =="
    # The motion study's small version needs ASTRA, whose wheel cannot load here
    # (CUDA 12's cudart and cuFFT); CI runs it, and mode study the full one.
    (cd /tmp && OCL_ICD_VENDORS=$vend PETBLUR_CLI=$OLDPWD/build-gpu/src/cli/petblur \
        python3 -m pytest -v -p no:cacheprovider "$OLDPWD/python/tests" \
        -k "not test_motion_study_small") >"$OUT/pytest.txt" 2>&1 || status=1
    tail -25 "$OUT/pytest.txt"
    echo "== bench/python_torch.py =="
    (cd /tmp && python3 "$OLDPWD/bench/python_torch.py" --out "$OUT/python_torch.csv") 2>&1 |
        tee "$OUT/python_torch.md" || status=1
    exit $status
)
