#: cells OLD_TREE          issue 46's short chords read by trilinear cells: OLD_TREE's package and this tree's on the smooth drift (dense adjoint too), the cost table, the paper's eight motions, with both filters
# Before and after, the same machine, the same seeds. OLD_TREE is an older
# commit's source (`git archive OLD | tar -x -C .base`, carried along). Both
# packages are built beside the machine's torch (-Dopencl=disabled), and both
# trees' pb_bench (CUDA only). Then, old and new in turn:
#  1. bench/profile_frames.py timing (frames_cost's smooth drift, 24 frames of
#     220x220x110, CUDA events): the forward, the summed adjoint of its own
#     output and of a dense y, with AB HARDWARE and with AB EXACT;
#  2. bench/frames_cost.py at the default bound (the 1 Hz walk, the smooth
#     drift, the noisy 20 Hz log): time and the error from dense references;
#  3. pb_bench on CUDA, 256^3, the paper's eight motions, twice each, old
#     and new alternately.
# Back through $OUT: machine.txt, cells.md (the tables side by side),
# cells.tar.gz (every JSON, log and CSV).
#   PB_OLD=<commit> PB_COMMIT=<commit> bash bench/gpu.sh cells .base   (carry .device .whl .base)
# shellcheck shell=bash disable=SC2154 # meson and the helpers: bench/gpu/lib.sh
mode_cells() (
    old=$(realpath "${1:?usage: bench/gpu.sh cells OLD_TREE}")
    shift
    echo "old: ${PB_OLD:-unknown}" | write_machine "$OUT/machine.txt"
    work=$(mktemp -d)
    status=0
    export PYTHONUNBUFFERED=1
    package_into "$old" "$work/old" -Dopencl=disabled &
    p1=$!
    package_into . "$work/new" -Dopencl=disabled &
    p2=$!
    build_tree "$old" "$work/build-old" -Dopencl=disabled -- bench/pb_bench &
    b1=$!
    build_tree "$PWD" "$work/build-new" -Dopencl=disabled -- bench/pb_bench &
    b2=$!
    wait $p1 && wait $p2 && wait $b1 && wait $b2 || { echo "gpu.sh cells: a build failed"; exit 1; }
    root=$PWD
    for which in old new; do
        for filter in hardware exact; do
            echo "== $which: profile_frames timing, AB $filter"
            (cd /tmp && PYTHONPATH=$work/$which python3 "$root/bench/profile_frames.py" timing --filter $filter \
                --runs 5 --cache "$work" --out "$work/timing-$which-$filter.json") \
                >"$work/timing-$which-$filter.md" 2>&1 || status=1
            grep -E '^\|' "$work/timing-$which-$filter.md" | head -12
        done
    done
    cells_report
    for round in 1 2; do
        for which in old new; do
            "$work/build-$which/bench/pb_bench" --device cuda --size 256 --runs 10 --ref-runs 0 --label $which \
                --csv "$work/paper-$which-$round.csv" >/dev/null || status=1
        done
    done
    cells_report
    for which in old new; do
        echo "== $which: frames_cost at the default bound"
        (cd /tmp && PYTHONPATH=$work/$which python3 "$root/bench/frames_cost.py" --bounds default --runs 5 \
            --tracks smooth,20hz-noisy --out "$work/frames-$which.json") >"$work/frames-$which.md" 2>&1 || status=1
        sed -n '/^| track | bound/,/^$/p' "$work/frames-$which.md"
        grep -E 'target|Error|error:' "$work/frames-$which.md"
    done
    cells_report
    cat "$OUT/cells.md"
    exit $status
)

# cells.md from what $work holds so far, and the tarball of it: after each
# step, so that a run cut short by the time limit still brings back its part.
cells_report() {
    python3 - "$work" >"$OUT/cells.md" <<'EOF' || true
import csv, glob, json, os, sys
w = sys.argv[1]
print("# issue 46's cells: old against new\n")
for f in ("hardware", "exact"):
    print(f"## profile_frames timing, AB {f}\n")
    print("| call | old ms | new ms | new / old |\n|---|---|---|---|")
    try:
        o = json.load(open(f"{w}/timing-old-{f}.json"))["calls"]
        n = json.load(open(f"{w}/timing-new-{f}.json"))["calls"]
    except Exception as e:
        print(f"(missing: {e})\n")
        continue
    for k in n:
        a, b = o.get(k, {}).get("call_ms"), n[k].get("call_ms")
        if a and b:
            print(f"| {k} | {a:.3f} | {b:.3f} | {b / a:.3f} |")
    print()
print("## the paper's eight motions, pb_bench on CUDA at 256^3 (device ms, the better of two runs)\n")
rows = {}
for path in glob.glob(f"{w}/paper-*.csv"):
    which = os.path.basename(path).split("-")[1]
    for r in csv.DictReader(open(path)):
        key = tuple(r.get(c, "") for c in ("method", "filter", "scenario"))
        ms = r.get("device_ms") or r.get("median_ms")
        try:
            ms = float(ms)
        except (TypeError, ValueError):
            continue
        d = rows.setdefault(key, {})
        d[which] = min(d.get(which, ms), ms)
print("| method | filter | scenario | old | new | new / old |\n|---|---|---|---|---|---|")
for key in sorted(rows):
    d = rows[key]
    if "old" in d and "new" in d:
        print(f"| {' | '.join(key)} | {d['old']:.4f} | {d['new']:.4f} | {d['new'] / d['old']:.3f} |")
for which in ("old", "new"):
    try:
        lines = open(f"{w}/frames-{which}.md").read().splitlines()
    except OSError:
        continue
    print(f"\n## frames_cost, {which}\n")
    on = False
    for line in lines:
        on = on or line.startswith("| track | bound")
        if on and not line.startswith("|"):
            break
        if on or "target" in line:
            print(line)
EOF
    tar -czf "$OUT/cells.tar.gz" -C "$work" --exclude='*.npy' --exclude=old --exclude=new --exclude='build-*' .
}
