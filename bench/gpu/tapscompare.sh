#: tapscompare OLD_TREE     the taps kernels before and after: OLD_TREE's and this tree's petblur bench on the paper's (2,2,2) (CUDA, homogeneity, 256^3), ncu on this tree's taps kernel, both trees' SASS of it
# A short look for a change to cl/pb_taps.cl, where mode adjoints would time
# all eight motions: both trees built CUDA-only, petblur bench on scenario 1
# (and 2, a walk, as the control) old, new, old, new, each row's better time
# of the two rounds; then Nsight Compute on one launch of this tree's taps
# kernel (the bench's third), and cuobjdump's SASS of both trees' taps kernels.
# Back through $OUT: machine.txt, taps.md, ncu.txt, sass.tar.gz, runs.tar.gz.
#   PB_OLD=<commit> PB_COMMIT=<commit> bash bench/gpu.sh tapscompare .base   (carry .device .base)
# shellcheck shell=bash disable=SC2154 # meson and the helpers: bench/gpu/lib.sh
mode_tapscompare() (
    old=$(realpath "${1:?usage: bench/gpu.sh tapscompare OLD_TREE}")
    echo "old: ${PB_OLD:-unknown}" | write_machine "$OUT/machine.txt"
    work=$(mktemp -d)
    bench_old_new "$old" taps "$work" --phantoms homogeneity --scenarios 1,2 --points 4 --runs 20 || exit 1
    python3 bench/gpu/best_of.py "$work" | tee "$OUT/taps.md"
    tar -C "$work" -czf "$OUT/runs.tar.gz" old-1.csv new-1.csv old-2.csv new-2.csv
    (cd /tmp && ncu --clock-control none --kernel-name regex:'^pb_shift_taps' --launch-skip 2 --launch-count 1 \
        --section SpeedOfLight --section ComputeWorkloadAnalysis --section MemoryWorkloadAnalysis --section Occupancy \
        --section SchedulerStats --section WarpStateStats --section InstructionStats --section LaunchStats \
        "$OLDPWD/build-taps-new/src/cli/petblur" bench --device cuda --phantoms homogeneity --scenarios 1 --points 4 \
        --runs 3 --out-dir "$work/ncu" -q) >"$OUT/ncu.txt" 2>&1
    grep -E 'pb_shift|Duration|DRAM Throughput|Issue Slots Busy|Executed Instructions  |Registers Per|Achieved Occ|No Eligible' \
        "$OUT/ncu.txt"
    for which in old new; do
        for k in pb_shift_taps pb_shift_taps_tile; do
            cuobjdump -sass -fun $k build-taps-$which/src/libpetblur.so >"$work/sass-$which-$k.txt" 2>&1 &&
                echo "$which $k: $(grep -c '/\*[0-9a-f]\{4\}\*/' "$work/sass-$which-$k.txt") SASS instructions"
        done
    done
    (cd "$work" && tar -czf "$OUT/sass.tar.gz" sass-*.txt)
)
