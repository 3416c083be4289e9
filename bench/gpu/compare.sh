#: compare OLD_TREE        before and after: OLD_TREE and this tree built, pb_bench alternately, forward outputs byte for byte
# OLD_TREE is an older commit's source (e.g. `git archive OLD | tar -x -C
# bench-old`, carried along). Both are built and pb_bench runs on CUDA and
# NVIDIA OpenCL (256^3, the paper's eight motions) alternately, old, new, old,
# new, so that both see the same machine in the same state. Then both builds'
# `petblur blur` on one random volume for every method and filter under a
# turn and translations along x, y and z, on both backends, forward: are the
# outputs the same bytes? Back through $OUT: the CSVs, compare.md (new / old
# per method and motion, the better of each build's two medians; the identity
# table).
#   PB_OLD=<commit> PB_COMMIT=<commit> bash bench/gpu.sh compare bench-old   (carry .device bench-old)
# shellcheck shell=bash disable=SC2154 # meson and the helpers: bench/gpu/lib.sh
mode_compare() (
    OLD=${1:?usage: bench/gpu.sh compare OLD_TREE}
    build_tree "$OLD" "$PWD/build-old" -Dopencl=enabled -- bench/pb_bench src/cli/petblur &
    p1=$!
    build_tree "$PWD" "$PWD/build-new" -Dopencl=enabled -- bench/pb_bench src/cli/petblur &
    p2=$!
    wait $p1 && wait $p2 || exit 1
    nv=$(icd_folder nvidia)
    for round in 1 2; do
        for which in old new; do
            for d in cuda opencl; do
                OCL_ICD_VENDORS=$nv ./build-$which/bench/pb_bench --device $d --size 256 --runs 20 \
                    --ref-runs 0 --label $which --csv "$OUT/$which-$d-$round.csv" >/dev/null || exit 1
            done
        done
    done
    python3 - "$OUT" "${PB_OLD:-old}" "${PB_COMMIT:-new}" <<'PY' | tee "$OUT/compare.md"
import csv, sys, os
out, old, new = sys.argv[1:4]
rows = [("AB", "hardware"), ("AB", "exact"), ("RM", "hardware"), ("RM", "exact"), ("CL", "hardware"), ("CL", "exact")]
def best(which, dev):
    t = {}
    for r in (1, 2):
        for row in csv.DictReader(open(os.path.join(out, f"{which}-{dev}-{r}.csv"))):
            k = (row["method"], row["filter"], int(row["scenario"]))
            t[k] = min(t.get(k, 1e30), float(row["median_ms"]))
    return t
worst = 0.0
for dev, label in (("cuda", "CUDA (CUDA events)"), ("opencl", "NVIDIA OpenCL (profiling events)")):
    a, b = best("old", dev), best("new", dev)
    print(f"### {label}: kernel ms at {old} -> {new}, and new / old\n")
    print("| method | " + " | ".join(str(s) for s in range(1, 9)) + " |")
    print("|---|" + "---|" * 8)
    for m, f in rows:
        cells = []
        for s in range(1, 9):
            k = (m, f, s)
            r = b[k] / a[k]
            worst = max(worst, r)
            cells.append(f"{a[k]:.3f} -> {b[k]:.3f} ({r:.3f})")
        print(f"| {m} {'HW' if f == 'hardware' else 'EX'} | " + " | ".join(cells) + " |")
    print()
print(f"Largest new / old: {worst:.3f} (target: at most 1.03)")
PY

    # The same bytes out? Forward blurs of one random 64 x 56 x 48 volume.
    work=$(mktemp -d)
    python3 -c "import numpy as np; np.random.default_rng(7).random(64*56*48, dtype=np.float32).tofile('$work/in.raw')"
    {
        echo
        echo "### Forward outputs of the two builds, byte for byte (64 x 56 x 48, petblur blur)"
        echo
        echo "| device | method | filter | turn | along x | along y | along z |"
        echo "|---|---|---|---|---|---|---|"
        for d in cuda opencl; do
            for m in ab rm cl ref; do
                for f in hardware exact; do
                    [ $m = ref ] && [ $f = exact ] && continue
                    row="| $d | $m | $f |"
                    for motion in "--translate 3,-2,1 --rotate 12 --axis 0.2,0.3,1" "--translate 14,0.5,-0.3" \
                        "--translate 0.4,11,0.3" "--translate -0.3,0.2,9"; do
                        ok=1
                        for which in old new; do
                            rm -f "$work/$which.raw"
                            # shellcheck disable=SC2046,SC2086 # $motion and the REF option split into words
                            OCL_ICD_VENDORS=$nv ./build-$which/src/cli/petblur blur -i "$work/in.raw" \
                                --dims 64,56,48 -o "$work/$which.raw" --device $d --method $m --filter $f $motion -q \
                                $([ $m = ref ] && echo --points 32) >"$work/log" 2>&1 || { ok=0; cat "$work/log" >&2; }
                        done
                        if [ $ok = 0 ]; then row="$row FAILED |"
                        elif cmp -s "$work/old.raw" "$work/new.raw"; then row="$row same |"
                        else row="$row DIFFERENT |"; fi
                    done
                    echo "$row"
                done
            done
        done
    } | tee -a "$OUT/compare.md"
)
