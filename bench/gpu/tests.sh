#: tests [--cli T,..] [MEMCHECK.. [-- RACECHECK..]]  build; host, cuda, opencl (NVIDIA) suites; tests/test_<T>.py; compute-sanitizer on tests named
# build-gpu (CUDA and OpenCL); the host, cuda and opencl suites, OpenCL on
# NVIDIA's driver. With --cli, the command line's tests named (tests/test_<T>.py
# for each T) with CUDA as the auto device, under the machine's python3: meson's
# cli suite names /usr/bin/python3, which there lacks numpy; nibabel comes
# from .whl/. Tests named after the options run under compute-sanitizer:
# memcheck (with leaks) on those before "--", racecheck on those after, e.g.
#   bash bench/gpu.sh tests --cli world,cli
#   bash bench/gpu.sh tests test_shift_taps test_plan -- test_shift_taps
# Back through $OUT: machine.txt, tests.txt, pose_derivative.txt (where a suite
# printed the pose derivative's errors), sanitize.log. (carry .device, and
# .whl for --cli)
# shellcheck shell=bash
mode_tests() (
    status=0 cli=()
    if [ "${1:-}" = --cli ]; then
        IFS=, read -ra cli <<<"${2:?tests --cli NAME,NAME}"
        shift 2
    fi
    write_machine "$OUT/machine.txt" </dev/null
    build_gpu
    OCL_ICD_VENDORS=$(icd_folder nvidia) ./build-gpu/src/cli/petblur devices | tee -a "$OUT/machine.txt"
    run_suites || status=1
    if [ ${#cli[@]} -gt 0 ]; then
        install_nibabel
        log=$(mktemp -d)
        for t in "${cli[@]}"; do
            if PYTHONPATH=$PYTHONPATH:tests python3 tests/test_"$t".py build-gpu/src/cli/petblur >"$log/$t.log" 2>&1; then
                echo "cli - petblur:$t OK (python3 tests/test_$t.py)"
            else
                echo "cli - petblur:$t FAIL"
                tail -n 40 "$log/$t.log"
                status=1
            fi
        done >"$log/cli.txt"
        tee -a "$OUT/tests.txt" <"$log/cli.txt"
    fi
    if [ $# -gt 0 ]; then sanitize_tests "$@" || status=1; fi
    exit $status
)
