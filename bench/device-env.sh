# Sourced by bench/gpu.sh and bench/gpu-quick.sh from the repository root on
# the GPU machine: the build environment that .device/ (bench/gpu-prepare.sh)
# brings, and meson (or its module where no meson command is installed).
dev=$PWD/.device
export CFLAGS="-I$dev/include -I$dev/include/nifti" LDFLAGS="-L$dev/lib" LIBRARY_PATH="$dev/lib"
# The program's libraries travel in .device too, with pkg-config files that
# point there.
sed -i "s|@DEVICE@|$dev|" "$dev"/lib/pkgconfig/*.pc
export PKG_CONFIG_PATH="$dev/lib/pkgconfig"
export LD_LIBRARY_PATH="$dev/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export PATH="$PATH:/usr/local/cuda/bin"
meson=(meson)
command -v meson >/dev/null || meson=(python3 -m mesonbuild.mesonmain)

# The package installed by pip beside the machine's torch and CuPy, from the
# wheels in .whl/ (nothing is downloaded there), into a folder put on
# PYTHONPATH: the machine's python3 may itself be a venv, whose packages a
# nested venv would not see. Arguments: extra meson setup options.
install_package() {
    local site
    site=$(mktemp -d)/site
    python3 -m pip install -q --no-deps --no-index --find-links .whl --target "$site" meson meson-python \
        pyproject-metadata packaging nibabel 2>&1 | tail -3
    export PYTHONPATH=$site PATH="$site/bin:$PATH"
    local args=(-Csetup-args=-Dgpu_archs=90)
    for a in "$@"; do args+=("-Csetup-args=$a"); done
    python3 -m pip install -q --no-deps --no-index --no-build-isolation "${args[@]}" --target "$site" . \
        >/tmp/pip.log 2>&1 || { tail -40 /tmp/pip.log; return 1; }
}

# What machine.txt says of a run: when, which commit (PB_COMMIT: the copy
# there has no trustworthy git state), the GPU, the toolkit and the cores.
# Extra lines a script wants follow on its standard input.
write_machine() {
    {
        echo "date: $(date -u +%Y-%m-%dT%H:%MZ)"
        echo "commit: ${PB_COMMIT:-unknown}"
        nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>&1
        nvcc --version | tail -1
        nproc | sed 's/^/cpu cores: /'
        [ -t 0 ] || cat
    } | tee "$1"
}

# The C tree in build-gpu (CUDA and OpenCL, release), configured once and
# brought up to date; exits the script when it does not build.
build_gpu() {
    [ -f build-gpu/build.ninja ] || "${meson[@]}" setup build-gpu --buildtype=release -Dcuda=enabled \
        -Dopencl=enabled -Dgpu_archs=90 >/tmp/setup.log 2>&1 || { tail -30 /tmp/setup.log; exit 1; }
    ninja -C build-gpu >/tmp/build.log 2>&1 || { tail -30 /tmp/build.log; exit 1; }
}

# The host, cuda and opencl suites of build-gpu, OpenCL on NVIDIA's driver
# alone; their lines and largest differences appended to $OUT/tests.txt (a
# failed suite's log tail too) and shown. Returns 1 when a suite failed.
run_suites() {
    local nv s failed=0
    nv=$(mktemp -d)
    echo libnvidia-opencl.so.1 >"$nv/nvidia.icd"
    for s in host cuda opencl; do
        OCL_ICD_VENDORS=$nv "${meson[@]}" test -C build-gpu --no-rebuild --print-errorlogs --suite $s \
            >/tmp/test-$s.log 2>&1 || failed=1
        {
            echo "== $s"
            grep -E '^ *[0-9]+/[0-9]+ |^(Ok|Fail|Skipped):' /tmp/test-$s.log
            grep -h 'largest relative' build-gpu/meson-logs/testlog.txt | sed "s/^/$s: /"
        } >>"$OUT/tests.txt"
        [ $failed = 0 ] || tail -n 60 /tmp/test-$s.log >>"$OUT/tests.txt"
    done
    cat "$OUT/tests.txt"
    return $failed
}
