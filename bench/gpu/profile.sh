#: profile [grids|source]  what bounds issue 33's slowest cases: Nsight Compute's counters, the kernels' registers and SASS counts
# bench/profile_floor.py's cases (the drifting frames' forward and summed
# adjoint, 3 degrees on 256^3) through the package beside the machine's torch.
# Back through $OUT: machine.txt, profile.tar.gz (ncu-*.txt, sass-counts.txt,
# resources.txt); with grids, grids.tar.gz instead (the turns on 256^3, 512^3,
# 700^3: their caches' hit rates and throughputs); with source, source.tar.gz
# instead (each SASS instruction's executed count). (carry .device .whl)
# shellcheck shell=bash
mode_profile() (
    write_machine "$OUT/machine.txt" </dev/null
    work=$(mktemp -d)
    status=0
    install_package -Dopencl=disabled || exit 1
    # The kernels as the library's nvcc build makes them, for their resources and SASS.
    nvcc -arch=sm_90 -O3 -std=c++17 -cubin -Xptxas -v -o "$work/k.cubin" cuda/pb_kernels.cu >"$work/ptxas.txt" 2>&1 ||
        { cat "$work/ptxas.txt"; exit 1; }
    grep -A3 "entry function '\(pb_blur_ab\|pb_adjoint_ab\|pb_shift_taps\)'" "$work/ptxas.txt" >"$work/resources.txt"
    cuobjdump -sass "$work/k.cubin" >"$work/sass.txt"
    for k in pb_blur_ab pb_adjoint_ab pb_shift_taps; do
        awk -v k="$k" '/Function : /{on = ($3 == k)} on && /\/\*[0-9a-f][0-9a-f][0-9a-f][0-9a-f]+\*\//' "$work/sass.txt" >"$work/sass-$k.txt"
        echo "$k: $(wc -l <"$work/sass-$k.txt") SASS instructions, $(grep -c 'TEX\|TLD' "$work/sass-$k.txt") texture," \
            "$(grep -c 'LDG' "$work/sass-$k.txt") LDG, $(grep -c 'RED\|ATOM' "$work/sass-$k.txt") atomic"
    done | tee "$work/sass-counts.txt"
    cat "$work/resources.txt"
    sections=(--section SpeedOfLight --section ComputeWorkloadAnalysis --section MemoryWorkloadAnalysis
        --section Occupancy --section LaunchStats --section SchedulerStats --section WarpStateStats
        --section InstructionStats --section SourceCounters)
    case ${1:-} in
    grids)
        for c in turn turn512 turn700; do
            echo "== $c"
            profile_case $c --section SpeedOfLight --section MemoryWorkloadAnalysis --section ComputeWorkloadAnalysis \
                --section InstructionStats | tee "$work/ncu-$c.txt" |
                grep -E 'pb_blur|Duration|Throughput|Hit Rate|Issue Slots Busy|Executed Instructions  |Mem Busy|Max Bandwidth'
        done
        tar -C "$work" -czf "$OUT/grids.tar.gz" ncu-turn.txt ncu-turn512.txt ncu-turn700.txt
        ;;
    source)
        # ncu's source page.
        for c in frames-forward frames-adjoint; do
            profile_case $c --section SourceCounters --section InstructionStats --import-source no --page source \
                --print-source sass --csv >"$work/source-$c.csv" || status=1
            head -c 600 "$work/source-$c.csv"
        done
        tar -C "$work" -czf "$OUT/source.tar.gz" source-frames-forward.csv source-frames-adjoint.csv
        ;;
    *)
        for c in frames-forward frames-adjoint turn; do
            profile_case $c "${sections[@]}" >"$work/ncu-$c.txt" || status=1
            echo "== $c"
            grep -E 'pb_|Duration|Throughput|Issue Slots Busy|Executed Ipc A|Achieved Occupancy|Registers Per|Theoretical Occ|No Eligible|Warp Cycles Per Issued|Branch Efficiency|Avg. Divergent|L1/TEX Hit|L2 Hit|Executed Instructions  |Block Limit' \
                "$work/ncu-$c.txt" | head -40
            grep -iE 'stall|bound|bottleneck' "$work/ncu-$c.txt" | head -12
        done
        tar -C "$work" -czf "$OUT/profile.tar.gz" ncu-frames-forward.txt ncu-frames-adjoint.txt ncu-turn.txt \
            sass-counts.txt resources.txt sass-pb_blur_ab.txt ptxas.txt
        ;;
    esac
    exit $status
)
