#: quick [PHANTOMS [SCENARIOS]]  a kernel experiment's quick look: CUDA-only build, petblur bench on a few phantoms and scenarios
# REF with few points: its errors are rough, its times are not what is asked.
# Not a substitute for mode all, which every kernel change still gets.
# Defaults: brain,homogeneity and 1,2,6,7,8. Back through $OUT: quick/ (the
# tables). (carry .device)
# shellcheck shell=bash disable=SC2154 # meson and the helpers: bench/gpu/lib.sh
mode_quick() (
    { "${meson[@]}" setup build-quick --buildtype=release -Dcuda=enabled -Dopencl=disabled >/dev/null 2>&1 &&
        ninja -C build-quick >/dev/null 2>&1; } || { echo "gpu.sh quick: the build failed" >&2; exit 1; }
    ./build-quick/src/cli/petblur bench --device cuda --phantoms "${1:-brain,homogeneity}" \
        --scenarios "${2:-1,2,6,7,8}" --points 8 --runs 20 --out-dir "$OUT/quick" -q
)
