# shellcheck shell=bash
# Sourced by bench/gpu.sh from the repository root on the GPU machine, before
# a mode: the build environment that .device/ (bench/gpu-prepare.sh) brings,
# meson (or its module where no meson command is installed), and the steps
# the modes share.
# Where a mode's results go: the run tool's $OUT, or gpu-out here.
OUT=${OUT:-$PWD/gpu-out}
mkdir -p "$OUT"
dev=$PWD/.device
export CFLAGS="-I$dev/include -I$dev/include/nifti" LDFLAGS="-L$dev/lib" LIBRARY_PATH="$dev/lib"
# The program's libraries travel in .device too, with pkg-config files that
# point there (the wheel mode carries no .device).
[ -d "$dev/lib/pkgconfig" ] && sed -i "s|@DEVICE@|$dev|" "$dev"/lib/pkgconfig/*.pc
export PKG_CONFIG_PATH="$dev/lib/pkgconfig"
export LD_LIBRARY_PATH="$dev/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export PATH="$PATH:/usr/local/cuda/bin"
meson=(meson)
command -v meson >/dev/null || meson=(python3 -m mesonbuild.mesonmain)

# A folder for OCL_ICD_VENDORS that offers one OpenCL platform alone: nvidia
# (NVIDIA's driver) or pocl (where the machine has it).
#   vend=$(icd_folder nvidia)
icd_folder() {
    local d
    d=$(mktemp -d)
    case $1 in
    nvidia) echo libnvidia-opencl.so.1 >"$d/nvidia.icd" ;;
    pocl) [ -f /etc/OpenCL/vendors/pocl.icd ] && cp /etc/OpenCL/vendors/pocl.icd "$d/" ;;
    esac
    echo "$d"
}

# The package of source tree TREE installed by pip into folder SITE, from the
# wheels in .whl/ (nothing is downloaded there): a folder to put on PYTHONPATH
# beside the machine's torch and CuPy, as the machine's python3 may itself be
# a venv, whose packages a nested venv would not see.
#   package_into TREE SITE [meson setup options]
package_into() {
    local tree=$1 site=$2
    shift 2
    python3 -m pip install -q --no-deps --no-index --find-links "$PWD/.whl" --target "$site" meson meson-python \
        pyproject-metadata packaging nibabel 2>&1 | tail -3
    local args=(-Csetup-args=-Dgpu_archs=90)
    for a in "$@"; do args+=("-Csetup-args=$a"); done
    PATH="$site/bin:$PATH" PYTHONPATH=$site python3 -m pip install -q --no-deps --no-index --no-build-isolation \
        "${args[@]}" --target "$site" "$tree" >/tmp/pip.log 2>&1 || { tail -40 /tmp/pip.log; return 1; }
}

# This tree's package, put on PYTHONPATH and PATH. Arguments: extra meson setup
# options.
install_package() {
    local site
    site=$(mktemp -d)/site
    package_into . "$site" "$@" || return 1
    export PYTHONPATH=$site PATH="$site/bin:$PATH"
}

# nibabel alone from .whl/, on PYTHONPATH: for the command line's Python tests
# and bench/estimate_validation.py, which need no package.
install_nibabel() {
    local site
    site=$(mktemp -d)/site
    python3 -m pip install -q --no-deps --no-index --find-links .whl --target "$site" nibabel 2>&1 | tail -3
    export PYTHONPATH=$site
}

# Nsight Compute on one launch of bench/profile_floor.py's CASE (of the
# frames, the 12th frame's), with the ncu options given; its report on
# standard output. Runs the package on PYTHONPATH.
#   profile_case CASE [ncu options]
profile_case() {
    local c=$1 root=$PWD skip=0
    shift
    case $c in frames-*) skip=11 ;; esac
    (cd /tmp && ncu --clock-control none --kernel-name regex:'^pb_(blur|adjoint)_ab$' --launch-skip $skip \
        --launch-count 1 "$@" python3 "$root/bench/profile_floor.py" "$c") 2>&1
}

# What machine.txt says of a run: when, which commit (PB_COMMIT: the copy
# there has no trustworthy git state), the GPU, the toolkit and the cores.
# Extra lines a mode wants follow on its standard input.
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

# The C tree in build-gpu (release, CUDA for sm_90), configured once with the
# meson options given (default: OpenCL too) and brought up to date, all of it
# or, after "--", the targets named; exits when it does not build. Its logs go
# to $BUILD_LOGS (default /tmp).
#   build_gpu [-Dopencl=disabled] [-- src/cli/petblur]
build_gpu() {
    local opts=() targets=() logs=${BUILD_LOGS:-/tmp}
    while [ $# -gt 0 ] && [ "$1" != -- ]; do opts+=("$1"); shift; done
    [ $# -gt 0 ] && shift && targets=("$@")
    [ ${#opts[@]} -gt 0 ] || opts=(-Dopencl=enabled)
    [ -f build-gpu/build.ninja ] || "${meson[@]}" setup build-gpu --buildtype=release -Dcuda=enabled -Dgpu_archs=90 \
        "${opts[@]}" >"$logs/setup.log" 2>&1 || { tail -30 "$logs/setup.log"; exit 1; }
    ninja -C build-gpu ${targets[@]+"${targets[@]}"} >"$logs/build.log" 2>&1 || { tail -30 "$logs/build.log"; exit 1; }
}

# Another tree's build beside build-gpu, for the modes that compare an old
# tree with this one: the source at SRC built into DIR (release, CUDA for the
# H200) with the meson options before "--" and the ninja targets after it;
# returns 1, with the log's tail, when it does not build, so that two builds
# may run in the background and be waited for.
#   build_tree SRC DIR -Dopencl=disabled -- src/cli/petblur
build_tree() {
    local src=$1 dir=$2 opts=() log
    shift 2
    while [ $# -gt 0 ] && [ "$1" != -- ]; do opts+=("$1"); shift; done
    [ $# -gt 0 ] && shift
    log=$(mktemp)
    (cd "$src" && "${meson[@]}" setup "$dir" --buildtype=release -Dcuda=enabled -Dgpu_archs=90 \
        ${opts[@]+"${opts[@]}"} && ninja -C "$dir" "$@") >"$log" 2>&1 ||
        { echo "gpu.sh: building $src into $dir failed:"; tail -30 "$log"; rm -f "$log"; return 1; }
    rm -f "$log"
}

# OLD_TREE and this tree built CUDA-only into build-NAME-old and
# build-NAME-new, then petblur bench with the arguments given run old, new,
# old, new; each run's results.csv copied to DIR/{old,new}-{1,2}.csv.
#   bench_old_new OLD_TREE NAME DIR [petblur bench options]
bench_old_new() {
    local old=$1 name=$2 dir=$3 p1 p2 round which
    shift 3
    build_tree "$old" "$PWD/build-$name-old" -Dopencl=disabled -- src/cli/petblur &
    p1=$!
    build_tree "$PWD" "$PWD/build-$name-new" -Dopencl=disabled -- src/cli/petblur &
    p2=$!
    wait $p1 && wait $p2 || return 1
    for round in 1 2; do
        for which in old new; do
            "./build-$name-$which/src/cli/petblur" bench --device cuda "$@" --out-dir "$dir/run-$which-$round" -q \
                >/dev/null || { echo "gpu.sh $name: $which's bench failed"; return 1; }
            cp "$dir/run-$which-$round/results.csv" "$dir/$which-$round.csv"
        done
    done
}

# The host, cuda and opencl suites of build-gpu, OpenCL on NVIDIA's driver
# alone; their lines and largest differences appended to $OUT/tests.txt (a
# failed suite's log tail too) and shown; the pose derivative's errors, where
# a suite printed them, to $OUT/pose_derivative.txt. Returns 1 when a suite
# failed.
run_suites() {
    local nv pd s failed=0
    nv=$(icd_folder nvidia)
    pd=$(mktemp)
    for s in host cuda opencl; do
        OCL_ICD_VENDORS=$nv "${meson[@]}" test -C build-gpu --no-rebuild --print-errorlogs --suite $s \
            >/tmp/test-$s.log 2>&1 || failed=1
        {
            echo "== $s"
            grep -E '^ *[0-9]+/[0-9]+ |^(Ok|Fail|Skipped|Timeout):' /tmp/test-$s.log
            grep -h 'largest relative' build-gpu/meson-logs/testlog.txt | sed "s/^/$s: /"
        } >>"$OUT/tests.txt"
        grep -h "d(Bx)/d" build-gpu/meson-logs/testlog.txt | sed "s/^/$s: /" >>"$pd"
        [ $failed = 0 ] || tail -n 60 /tmp/test-$s.log >>"$OUT/tests.txt"
    done
    [ -s "$pd" ] && mv "$pd" "$OUT/pose_derivative.txt"
    cat "$OUT/tests.txt"
    return $failed
}

# compute-sanitizer on build-gpu's tests on CUDA: memcheck (leaks too) on each
# test named before "--", racecheck on each after it, e.g.
#   sanitize_tests test_adjoint test_plan -- test_adjoint
# Their summaries go to $OUT/sanitize.log; returns 1 when one failed.
sanitize_tests() {
    local tool=memcheck t
    {
        for t in "$@"; do
            [ "$t" = -- ] && { tool=racecheck; continue; }
            echo "== $tool $t cuda"
            if [ $tool = memcheck ]; then
                compute-sanitizer --tool memcheck --error-exitcode 99 --leak-check full ./build-gpu/tests/"$t" cuda
            else
                compute-sanitizer --tool racecheck --error-exitcode 99 ./build-gpu/tests/"$t" cuda
            fi | grep -E 'FAIL|passed|SUMMARY|rror' | tail -5
            [ "${PIPESTATUS[0]}" = 0 ] || echo "$tool $t: FAILED"
        done
    } 2>&1 | tee "$OUT/sanitize.log"
    ! grep -q FAILED "$OUT/sanitize.log"
}
