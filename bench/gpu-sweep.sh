#!/usr/bin/env bash
# On the GPU machine: AB's sweep sampling (issue 31, item 3). Two calls, each
# within the device's ten minutes (the build is kept between them):
#   PB_COMMIT=... bash bench/gpu-sweep.sh tests      build (CUDA and OpenCL); the host and cuda suites (NVRTC's
#                                                    kernels against nvcc's included) and the opencl suite on
#                                                    NVIDIA's OpenCL: backend_vs_host and adjoint draw sweep runs
#   PB_COMMIT=... bash bench/gpu-sweep.sh accuracy   (or cost: the second half alone) the package beside the machine's torch; issue 31's accuracy
#                                                    case (bench/accuracy_case.py) with AB, AB sweep and RM on CUDA
#                                                    against 3000 resamplings; bench/bound_cost.py: AB's and AB
#                                                    sweep's kernel time on 256^3 for the paper's eight motions and
#                                                    the tracked seizure
# (carry .device .whl). What comes back through $OUT: tests.txt, accuracy.txt, accuracy.json, cost.md, cost.json,
# machine.txt.
set -uo pipefail
cd "$(dirname "$0")/.."
. bench/device-env.sh
write_machine "$OUT/machine.txt" </dev/null
status=0
case "${1:-}" in
tests)
    build_gpu
    run_suites || status=1
    ;;
accuracy | cost)
    install_package -Dopencl=disabled || exit 1
    if [ "$1" = accuracy ]; then
        (cd /tmp && python3 "$OLDPWD/bench/accuracy_case.py" --device cuda --times 3000 \
            --bounds default,0.25,0.1,0.05,0.01 --methods ab,ab-sweep,rm --out "$OUT/accuracy.json") 2>&1 |
            tee "$OUT/accuracy.txt"
        status=${PIPESTATUS[0]}
    fi
    (cd /tmp && python3 "$OLDPWD/bench/bound_cost.py" --bounds 0.1,0.05,0.01 --methods ab,ab-sweep,rm \
        --out "$OUT/cost.json") 2>&1 | tee "$OUT/cost.md"
    [ "${PIPESTATUS[0]}" = 0 ] || status=1
    ;;
*)
    echo "gpu-sweep.sh tests|accuracy|cost" >&2
    exit 2
    ;;
esac
exit $status
