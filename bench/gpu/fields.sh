#: fields [nospeed]        issue 45: field motions on CUDA, NVRTC and NVIDIA OpenCL (every suite), compute-sanitizer on test_fields, test_fields.py and test_field_gates.py, bench/field_speed.py at 256^3
# The field kernels (cl/pb_field.cl) on the GPU:
#  - the host, cuda and opencl suites (test_fields among them: every method
#    against the host's double reference, the dot test), and test_fields
#    again on NVRTC's kernels;
#  - compute-sanitizer memcheck and racecheck on test_fields;
#  - the package beside the machine's torch: test_fields.py and
#    test_field_gates.py (host and NVIDIA's OpenCL), and bench/field_speed.py: the field blur of a 256^3
#    frame with 20 field samples against the rigid blur of paths as long and
#    a torch grid_sample loop over the same samples.
# Back through $OUT: machine.txt, tests.txt, sanitize.log, pytest.txt,
# speed.md (not with nospeed: the suites alone). (carry .device .whl)
# shellcheck shell=bash disable=SC2154 # meson and the helpers: bench/gpu/lib.sh
mode_fields() (
    write_machine "$OUT/machine.txt" </dev/null
    build_gpu
    status=0
    run_suites || status=1
    nv=$(icd_folder nvidia)
    PETBLUR_CUDA_KERNELS=nvrtc PETBLUR_CACHE_DIR=$(mktemp -d) OCL_ICD_VENDORS=$nv ./build-gpu/tests/test_fields cuda 2>&1 |
        tail -2 | sed 's/^/cuda-nvrtc test_fields: /' | tee -a "$OUT/tests.txt"
    [ "${PIPESTATUS[0]}" = 0 ] || status=1
    sanitize_tests test_fields -- test_fields || status=1
    install_package -Dopencl=enabled || exit 1
    (cd /tmp && OCL_ICD_VENDORS=$nv timeout 300 python3 -m pytest -q -p no:cacheprovider \
        "$OLDPWD/python/tests/test_fields.py" "$OLDPWD/python/tests/test_field_gates.py") >"$OUT/pytest.txt" 2>&1 || status=1
    tail -3 "$OUT/pytest.txt"
    if [ "${1:-}" != nospeed ]; then
        timeout 400 python3 bench/field_speed.py --size 256 --runs 10 >"$OUT/speed.md" 2>&1 || status=1
        cat "$OUT/speed.md"
    fi
    exit $status
)
