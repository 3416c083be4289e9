#: driftprof [profile_frames.py case options]  issue 46's smooth drift (frames_cost's 25.9x row) kernel by kernel: time, launch, occupancy, cache hit rates, DRAM (Nsight Compute)
# bench/profile_frames.py through the package beside the machine's torch
# (-Dopencl=disabled), frames_cost's case (24 frames of 220x220x110, the
# smooth 1 Hz log, seed 46046, default bound, AB HARDWARE; its options change
# it: --track, --bound, --seed, ...). About 3 minutes with the build:
#  1. timing: each call by CUDA events and the library's device time, and
#     every launch's duration, grid, block, registers and CUPTI's occupancy
#     estimate (torch.profiler): the forward F.apply(x); the summed adjoint of
#     y = F.apply(x), as frames_cost times it; the same of a dense y
#     (torch.rand); the forward of a dense x. Also the voxels of x and y that
#     are not zero, the segments a frame, the memory floor.
#  2. Nsight Compute, where it reads the counters (not on gVisor), on launches
#     PB_NCU_SKIP (11: frame 11) on, PB_NCU_COUNT (2) of them, of the forward,
#     the adjoint and the dense adjoint, one process each: speed of light,
#     launch, occupancy, memory (and its tables), compute, scheduler, warp
#     states, instructions, source counters; and the source page: each SASS
#     instruction with its executed count (ncu-*-source.csv).
#  3. meanwhile on the CPU: nvcc -Xptxas -v on cuda/pb_kernels.cu (registers,
#     stack frame, spills of pb_blur_ab and pb_adjoint_ab, their SASS counts),
#     and cuobjdump -res-usage of the library the package built.
# Back through $OUT: machine.txt, summary.md (all of it as tables),
# timing.json, timing.md, driftprof.tar.gz (ncu-*.txt, ncu-*-details.csv,
# ncu-*-raw.csv, ncu-*-source.csv, ncu-*.log, ptxas.txt, resources.txt, res-usage.txt,
# sass-*.txt), ncu-reports.tar (the .ncu-rep files, where under 15 MiB).
#   PB_COMMIT=$(git rev-parse --short HEAD) bash bench/gpu.sh driftprof [--bound 0.25] [--track 20hz-noisy]
# (carry .device .whl)
# shellcheck shell=bash
mode_driftprof() (
    write_machine "$OUT/machine.txt" </dev/null
    root=$PWD
    work=$(mktemp -d)
    case_opts=("$@")
    skip=${PB_NCU_SKIP:-11}
    count=${PB_NCU_COUNT:-2}
    status=0
    export PYTHONUNBUFFERED=1
    install_package -Dopencl=disabled || exit 1

    # The kernels' resources, on the CPU while the GPU runs the rest.
    (
        lib=$(find "${PYTHONPATH%%:*}" -name 'libpetblur*.so*' 2>/dev/null | head -1)
        if [ -n "$lib" ]; then
            cuobjdump -res-usage "$lib" 2>&1 | grep -A1 -E 'Function (pb_blur_ab|pb_adjoint_ab)\b' >"$work/res-usage.txt"
        fi
        timeout 180 nvcc -arch=sm_90 -O3 -std=c++17 -cubin -Xptxas -v -o "$work/k.cubin" cuda/pb_kernels.cu \
            >"$work/ptxas.txt" 2>&1 || echo "nvcc failed or timed out" >>"$work/ptxas.txt"
        {
            grep -A4 "entry function '\(pb_blur_ab\|pb_adjoint_ab\)'" "$work/ptxas.txt"
            [ -s "$work/res-usage.txt" ] && echo "== cuobjdump -res-usage of $lib" && cat "$work/res-usage.txt"
        } >"$work/resources.txt"
        if [ -s "$work/k.cubin" ]; then
            cuobjdump -sass "$work/k.cubin" >"$work/sass.txt" 2>/dev/null
            for k in pb_blur_ab pb_adjoint_ab; do
                awk -v k="$k" '/Function : /{on = ($3 == k)} on && /\/\*[0-9a-f][0-9a-f][0-9a-f][0-9a-f]+\*\//' "$work/sass.txt" \
                    >"$work/sass-$k.txt"
                echo "$k: $(wc -l <"$work/sass-$k.txt") SASS instructions, $(grep -c 'TEX\|TLD' "$work/sass-$k.txt")" \
                    "texture, $(grep -c 'LDG' "$work/sass-$k.txt") LDG, $(grep -c 'RED\|ATOM' "$work/sass-$k.txt")" \
                    "atomic, $(grep -c 'LDL\|STL' "$work/sass-$k.txt") local (spill) load/store"
            done >"$work/sass-counts.txt"
        fi
    ) &
    cpu_job=$!

    echo "== timing"
    (cd /tmp && python3 "$root/bench/profile_frames.py" timing --out "$work/timing.json" --cache "$work" \
        ${case_opts[@]+"${case_opts[@]}"}) 2>&1 | tee "$work/timing.md"
    [ "${PIPESTATUS[0]}" = 0 ] || status=1

    # The kernels each call launched (timing.json), else AB's.
    kernels() {
        python3 -c 'import json, sys
try:
    n = json.load(open(sys.argv[1]))["calls"][sys.argv[2]]["kernel_names"]
except Exception:
    n = []
print("|".join(n) or sys.argv[3])' "$work/timing.json" "$1" "$2"
    }
    frames=$(python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["frames"])' "$work/timing.json" \
        2>/dev/null || echo 24)
    ncu_bin=$(command -v ncu) || for f in /opt/nvidia/nsight-compute/*/ncu; do [ -x "$f" ] && ncu_bin=$f; done
    full=(--section SpeedOfLight --section LaunchStats --section Occupancy --section MemoryWorkloadAnalysis
        --section MemoryWorkloadAnalysis_Tables --section ComputeWorkloadAnalysis --section SchedulerStats
        --section WarpStateStats --section InstructionStats --section SourceCounters)
    basic=(--section SpeedOfLight --section LaunchStats --section Occupancy --section MemoryWorkloadAnalysis
        --section ComputeWorkloadAnalysis --section SchedulerStats --section WarpStateStats --section InstructionStats)
    ncu_ok=1
    # run_ncu KIND REGEX SKIP: one process making one call of KIND, its
    # launches SKIP.. (count of them) whose names match REGEX profiled.
    run_ncu() {
        local kind=$1 re=$2 from=$3 sections=("${full[@]}") try
        for try in full basic; do
            [ $try = basic ] && sections=("${basic[@]}")
            (cd /tmp && timeout 240 "$ncu_bin" --clock-control none --kernel-name "regex:^($re)\$" \
                --launch-skip "$from" --launch-count "$count" "${sections[@]}" -f -o "$work/ncu-$kind" \
                python3 "$root/bench/profile_frames.py" call "$kind" --cache "$work" \
                ${case_opts[@]+"${case_opts[@]}"}) >"$work/ncu-$kind.log" 2>&1
            [ -f "$work/ncu-$kind.ncu-rep" ] && break
            if grep -qE 'LibraryNotLoaded|ERR_NVGPUCTRPERM|Failed to initialize the profiler' "$work/ncu-$kind.log"; then
                ncu_ok=0
                break
            fi
            grep -q 'No kernels were profiled' "$work/ncu-$kind.log" && break
        done
        if [ ! -f "$work/ncu-$kind.ncu-rep" ]; then
            echo "ncu on $kind made no report:"
            tail -8 "$work/ncu-$kind.log"
            return 1
        fi
        "$ncu_bin" -i "$work/ncu-$kind.ncu-rep" --page details --csv >"$work/ncu-$kind-details.csv" 2>&1
        "$ncu_bin" -i "$work/ncu-$kind.ncu-rep" --page raw --csv >"$work/ncu-$kind-raw.csv" 2>&1
        "$ncu_bin" -i "$work/ncu-$kind.ncu-rep" --page details >"$work/ncu-$kind.txt" 2>&1
        # Every SASS instruction with how often it ran: where the issue slots go.
        "$ncu_bin" -i "$work/ncu-$kind.ncu-rep" --page source --csv --print-source sass \
            >"$work/ncu-$kind-source.csv" 2>&1
        echo "== ncu $kind"
        grep -E 'pb_|Duration|Registers Per|Theoretical Occ|Achieved Occ|L1/TEX Hit|L2 Hit|DRAM Throughput|Issue Slots Busy|Warp Cycles Per Issued' \
            "$work/ncu-$kind.txt" | head -40 || true
        return 0
    }
    if [ -z "$ncu_bin" ]; then
        echo "no ncu on this machine: the counters are left out (timing.json has CUPTI's durations and launches)"
    else
        fwd=$(kernels forward pb_blur_ab)
        adj=$(kernels adjoint pb_adjoint_ab)
        dense=$(kernels adjoint-dense pb_adjoint_ab)
        # The adjoint's process makes y with the forward first: where both
        # directions run the same kernels (a gather), skip its launches too.
        adj_from=$skip
        [ "$adj" = "$fwd" ] && adj_from=$((skip + frames))
        echo "Nsight Compute: launches $skip to $((skip + count - 1)) of each call's kernels (frames $skip-$((skip + count - 1)));" \
            "the forward's: $fwd; the adjoint's: $adj; the dense adjoint's: $dense" >"$work/ncu-picked.txt"
        run_ncu forward "$fwd" "$skip" || status=1
        if [ $ncu_ok = 1 ]; then
            run_ncu adjoint "$adj" "$adj_from" || status=1
            run_ncu adjoint-dense "$dense" "$skip" || status=1
        else
            echo "ncu cannot read the counters here (gVisor?): the rest of its runs left out"
        fi
    fi

    wait "$cpu_job"
    python3 "$root/bench/profile_frames.py" summary "$work" | tee "$OUT/summary.md"
    cp "$work/timing.json" "$work/timing.md" "$OUT/" 2>/dev/null
    (
        cd "$work" || exit 1
        shopt -s nullglob
        files=(ncu-*.txt ncu-*.csv ncu-*.log ptxas.txt resources.txt res-usage.txt sass-counts.txt sass-pb_*.txt)
        [ ${#files[@]} -gt 0 ] && tar -czf "$OUT/driftprof.tar.gz" "${files[@]}"
        reports=(ncu-*.ncu-rep)
        if [ ${#reports[@]} -gt 0 ]; then
            tar -cf "$OUT/ncu-reports.tar" "${reports[@]}"
            [ "$(stat -c %s "$OUT/ncu-reports.tar")" -lt 15728640 ] || {
                rm -f "$OUT/ncu-reports.tar"
                echo "the .ncu-rep files are over 15 MiB together: not sent back"
            }
        fi
    )
    exit $status
)
