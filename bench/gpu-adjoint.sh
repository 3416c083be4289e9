#!/usr/bin/env bash
# The adjoint on the GPU machine, quicker than bench/gpu.sh: build, the
# adjoint and properties suites on CUDA and NVIDIA's OpenCL, then the adjoint
# against the forward (petblur bench's adjoint_ms against kernel_ms) on the
# homogeneity phantom for some of the paper's motions, with the local-memory
# window (cl/pb_adjoint.cl) and without it (PETBLUR_ADJOINT_WINDOW=0), on both
# device backends. Needs .device/ from bench/gpu-prepare.sh, as bench/gpu.sh.
#   SCENARIOS=1,6,8 bash bench/gpu-adjoint.sh      (writes $OUT/adjoint.md)
set -uo pipefail
cd "$(dirname "$0")/.."
OUT=${OUT:-$PWD/gpu-out}
SCENARIOS=${SCENARIOS:-1,2,3,4,5,6,7,8}
mkdir -p "$OUT"
dev=$PWD/.device
export CFLAGS="-I$dev/include -I$dev/include/nifti" LDFLAGS="-L$dev/lib" LIBRARY_PATH="$dev/lib"
sed -i "s|@DEVICE@|$dev|" "$dev"/lib/pkgconfig/*.pc
export PKG_CONFIG_PATH="$dev/lib/pkgconfig"
export LD_LIBRARY_PATH="$dev/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export PATH="$PATH:/usr/local/cuda/bin"
meson=(meson)
command -v meson >/dev/null || meson=(python3 -m mesonbuild.mesonmain)
"${meson[@]}" setup build-gpu --buildtype=release -Dcuda=enabled -Dopencl=enabled >/dev/null 2>&1
ninja -C build-gpu >"$OUT/build.log" 2>&1 || { tail -30 "$OUT/build.log"; exit 1; }
nvcc -arch=sm_90 -O3 -std=c++17 -Xptxas -v -c cuda/pb_kernels.cu -o /dev/null 2>&1 |
    grep -A1 'pb_adjoint' | grep -E 'registers|entry' >"$OUT/adjoint-registers.txt"
vend=$(mktemp -d)
echo libnvidia-opencl.so.1 >"$vend/nvidia.icd"
status=0
for s in cuda opencl; do
    OCL_ICD_VENDORS=$vend "${meson[@]}" test -C build-gpu --no-rebuild --print-errorlogs --suite $s adjoint \
        properties >"$OUT/test-$s.log" 2>&1 || status=1
    grep -E '^ *[0-9]+/[0-9]+ |largest relative mismatch|voxel off' "$OUT/test-$s.log" build-gpu/meson-logs/testlog.txt
done
for d in cuda opencl; do
    for w in 8192 0; do
        OCL_ICD_VENDORS=$vend PETBLUR_ADJOINT_WINDOW=$w ./build-gpu/src/cli/petblur bench --device $d -q \
            --phantoms homogeneity --scenarios "$SCENARIOS" --points 16 --runs 5 --out-dir "$OUT/bench-$d-$w" \
            >"$OUT/bench-$d-$w.log" 2>&1 || status=1
    done
done
python3 - "$OUT" <<'PY' | tee "$OUT/adjoint.md"
import csv, sys, os
out = sys.argv[1]
print("| device | scenario | method | filter | forward ms | adjoint ms, window | ratio | adjoint ms, no window | ratio |")
print("|---|---|---|---|---|---|---|---|---|")
for d in ("cuda", "opencl"):
    rows = {}
    for w in ("8192", "0"):
        f = os.path.join(out, f"bench-{d}-{w}", "results.csv")
        if not os.path.exists(f):
            continue
        for r in csv.DictReader(open(f)):
            if r["adjoint_ms"]:
                rows.setdefault((r["scenario"], r["method"], r["filter"]), {})[w] = r
    for (s, m, flt), v in rows.items():
        if "8192" not in v or "0" not in v:
            continue
        f = float(v["8192"]["kernel_ms"]); a = float(v["8192"]["adjoint_ms"]); a0 = float(v["0"]["adjoint_ms"])
        print(f"| {d} | {s} | {m} | {flt} | {f:.3f} | {a:.3f} | {a/f:.2f} | {a0:.3f} | {a0/f:.2f} |")
PY
exit $status
