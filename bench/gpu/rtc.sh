#: rtc                     issue 32: NVRTC's kernels against nvcc's (suites, pb_bench, the first context cold and cached), OpenCL's run-time loader, test_gpu.py
# The CUDA kernels compiled at run time by NVRTC against nvcc's, and the
# OpenCL loader opened at run time:
#  - the host and cuda suites (test_cuda_rtc among them: NVRTC against nvcc,
#    the disk cache, corrupt entries, concurrent compiles, NVRTC missing), the
#    cuda suite again with every context on NVRTC's kernels, and the opencl
#    suite on NVIDIA's OpenCL through the run-time loader;
#  - pb_bench's eight scenarios at 256^3 on nvcc's and on NVRTC's kernels
#    (CUDA events), and the first context's time with an empty cache against
#    a filled one;
#  - the package installed beside the machine's torch: test_gpu.py (NVRTC from
#    the machine's nvidia-cuda-nvrtc wheel among them).
# Back through $OUT: machine.txt, tests.txt, bench.md, contexts.txt,
# pytest.txt. (carry .device .whl)
# shellcheck shell=bash disable=SC2154 # meson and the helpers: bench/gpu/lib.sh
mode_rtc() (
    LOG=$(mktemp -d)
    write_machine "$OUT/machine.txt" </dev/null
    BUILD_LOGS=$LOG build_gpu
    echo "library's dynamic dependencies: $(readelf -d build-gpu/src/libpetblur.so | grep NEEDED |
        sed 's/.*\[\(.*\)\]/\1/' | tr '\n' ' ')" | tee -a "$OUT/machine.txt"
    nv=$(icd_folder nvidia)
    status=0
    suites() { # name, environment..., -- suites...
        local name=$1 s
        shift
        local env=()
        while [ "$1" != "--" ]; do env+=("$1"); shift; done
        shift
        local args=()
        for s in "$@"; do args+=(--suite "$s"); done
        env OCL_ICD_VENDORS="$nv" ${env[@]+"${env[@]}"} "${meson[@]}" test -C build-gpu --no-rebuild \
            --print-errorlogs "${args[@]}" >"$LOG/test-$name.log" 2>&1 || status=1
        { echo "== $name"; grep -E '^ *[0-9]+/[0-9]+ |^(Ok|Fail|Skipped):' "$LOG/test-$name.log"; } | tee -a "$OUT/tests.txt"
        grep -q '^Fail: *0' "$LOG/test-$name.log" || tail -60 "$LOG/test-$name.log" >>"$OUT/tests.txt"
    }
    OCL_ICD_VENDORS=$nv ./build-gpu/src/cli/petblur devices | tee -a "$OUT/machine.txt"
    suites host -- host
    suites cuda -- cuda
    suites cuda-nvrtc PETBLUR_CUDA_KERNELS=nvrtc PETBLUR_CACHE_DIR="$LOG/cache-suite" -- cuda
    suites nvidia-opencl -- opencl

    echo "== the first context: NVRTC with an empty cache, then cached, then nvcc's ==" | tee "$OUT/contexts.txt"
    for run in empty cached builtin; do
        k=nvrtc
        [ $run = builtin ] && k=builtin
        [ $run = empty ] && rm -rf "$LOG/cache-bench"
        s=$EPOCHREALTIME
        PETBLUR_CUDA_KERNELS=$k PETBLUR_CACHE_DIR="$LOG/cache-bench" ./build-gpu/bench/pb_bench --device cuda \
            --size 16 --runs 1 --ref-runs 0 --scenario 1 >/dev/null 2>&1 || status=1
        e=$EPOCHREALTIME
        echo "$run: pb_bench on 16^3, one scenario, process wall $(awk "BEGIN { printf \"%.2f\", $e - $s }") s" |
            tee -a "$OUT/contexts.txt"
    done
    # shellcheck disable=SC2012 # a listing for the reader: the entries' sizes
    ls -l "$LOG/cache-bench" | tee -a "$OUT/contexts.txt"

    echo "== pb_bench, 256^3, the paper's eight scenarios: nvcc's kernels, then NVRTC's =="
    for k in builtin nvrtc; do
        PETBLUR_CUDA_KERNELS=$k PETBLUR_CACHE_DIR="$LOG/cache-bench" ./build-gpu/bench/pb_bench --device cuda \
            --size 256 --runs 20 --ref-runs 0 --label "cuda-$k" --csv "$LOG/bench-$k.csv" >"$LOG/bench-$k.txt" 2>&1 ||
            status=1
    done
    python3 - "$LOG/bench-builtin.csv" "$LOG/bench-nvrtc.csv" <<'PY' | tee "$OUT/bench.md"
import csv, sys
a, b = ({(r["method"], r["filter"], r["scenario"]): float(r["median_ms"]) for r in csv.DictReader(open(p))}
        for p in sys.argv[1:])
print("| method | filter | " + " | ".join(f"S{s}" for s in range(1, 9)) + " |")
print("| --- | --- |" + " --- |" * 8)
worst = 0.0
for m, f in sorted({(k[0], k[1]) for k in a}):
    cells = []
    for s in range(1, 9):
        k = (m, f, str(s))
        if k in a and k in b:
            r = b[k] / a[k]
            worst = max(worst, abs(r - 1))
            cells.append(f"{a[k]:.3f} / {b[k]:.3f}")
        else:
            cells.append("-")
    print(f"| {m} | {f} | " + " | ".join(cells) + " |")
print(f"\nnvcc's / NVRTC's kernel ms (CUDA events, median of 20); largest difference {100 * worst:.1f} %")
PY

    echo "== the package beside the machine's torch: test_gpu.py =="
    install_package -Dopencl=enabled || exit 1
    (cd /tmp && timeout 300 python3 -m pytest -v -p no:cacheprovider "$OLDPWD/python/tests/test_gpu.py") \
        >"$OUT/pytest.txt" 2>&1 || status=1
    tail -22 "$OUT/pytest.txt"
    exit $status
)
