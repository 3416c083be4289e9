#: sanitize                the CUDA tests under compute-sanitizer (own debugoptimized build): memcheck on each, NVRTC's too; racecheck on the adjoint
# memcheck on every CUDA test, on test_plan again with NVRTC's kernels, and
# racecheck on the adjoint's scatter (its atomics), failing on any report.
# Kept apart from mode all, whose run already fills the device tool's ten
# minutes. Back through $OUT: sanitize.log. (carry .device)
# shellcheck shell=bash disable=SC2154 # meson and the helpers: bench/gpu/lib.sh
mode_sanitize() (
    {
        status=0
        { "${meson[@]}" setup build-sanitize --buildtype=debugoptimized -Dcuda=enabled -Dopencl=disabled >/dev/null &&
            ninja -C build-sanitize >/dev/null; } || { echo "gpu.sh sanitize: the build failed"; exit 1; }
        # test_no_device makes no CUDA call, which compute-sanitizer reports as an error of its own.
        for t in errors frames adjoint properties backend_vs_host plan; do
            echo "== memcheck test_$t cuda"
            compute-sanitizer --tool memcheck --error-exitcode 99 --leak-check full ./build-sanitize/tests/test_$t cuda |
                tail -3
            [ "${PIPESTATUS[0]}" = 0 ] || { echo "memcheck test_$t: FAILED"; status=1; }
        done
        # NVRTC's kernels, launched by handle like nvcc's (the frames in one call among test_plan's cases).
        echo "== memcheck test_plan cuda, NVRTC's kernels"
        PETBLUR_CUDA_KERNELS=nvrtc PETBLUR_CACHE_DIR=$(mktemp -d) compute-sanitizer --tool memcheck --error-exitcode 99 \
            --leak-check full ./build-sanitize/tests/test_plan cuda | tail -3
        [ "${PIPESTATUS[0]}" = 0 ] || { echo "memcheck test_plan (NVRTC): FAILED"; status=1; }
        echo "== racecheck test_adjoint cuda"
        compute-sanitizer --tool racecheck --error-exitcode 99 ./build-sanitize/tests/test_adjoint cuda | tail -3
        [ "${PIPESTATUS[0]}" = 0 ] || { echo "racecheck test_adjoint: FAILED"; status=1; }
        echo "gpu.sh sanitize: $([ $status = 0 ] && echo clean || echo REPORTS)"
        exit $status
    } 2>&1 | tee "$OUT/sanitize.log"
    exit "${PIPESTATUS[0]}"
)
