#: adjoints OLD_TREE       before and after for the adjoint: OLD_TREE's and this tree's petblur bench (CUDA, the homogeneity phantom at 256^3, the paper's eight motions, every method and filter), alternately; adjoint_ms side by side
# OLD_TREE is an older commit's source (`git archive OLD | tar -x -C .base`,
# carried along). Both trees are built CUDA-only; petblur bench runs old,
# new, old, new (REF with 4 points: its errors are rough, the times are what
# is asked), and adjoints.md takes each row's better adjoint time of the two
# rounds, with the forward's kernel time beside it as the control.
# Back through $OUT: machine.txt, adjoints.md, and each run's results.csv as
# old-1.csv, new-1.csv, old-2.csv and new-2.csv.
#   PB_OLD=<commit> PB_COMMIT=<commit> bash bench/gpu.sh adjoints .base   (carry .device .base)
# shellcheck shell=bash disable=SC2154 # meson and the helpers: bench/gpu/lib.sh
mode_adjoints() (
    old=$(realpath "${1:?usage: bench/gpu.sh adjoints OLD_TREE}")
    echo "old: ${PB_OLD:-unknown}" | write_machine "$OUT/machine.txt"
    work=$(mktemp -d)
    bench_old_new "$old" adj "$work" --phantoms homogeneity --points 4 --runs 10 || exit 1
    cp "$work"/old-1.csv "$work"/new-1.csv "$work"/old-2.csv "$work"/new-2.csv "$OUT/"
    python3 - "$OUT" <<'PY' | tee "$OUT/adjoints.md"
import csv, sys
out = sys.argv[1]
best = {}
for which in ("old", "new"):
    for r in (1, 2):
        for row in csv.DictReader(open(f"{out}/{which}-{r}.csv")):
            key = (row["scenario"], row["method"], row["filter"])
            for col in ("adjoint_ms", "kernel_ms"):
                v = float(row[col]) if row[col] else float("nan")
                k = (which, col) + key
                best[k] = min(best.get(k, v), v)
keys = sorted({k[2:] for k in best}, key=lambda k: (int(k[0]), k[1], k[2]))
print("| scenario | method | filter | adjoint old ms | adjoint new ms | new / old | forward old ms | forward new ms |")
print("|---|---|---|---|---|---|---|---|")
nan = float("nan")  # a method one tree's bench does not run
for k in keys:
    ao, an = best.get(("old", "adjoint_ms") + k, nan), best.get(("new", "adjoint_ms") + k, nan)
    fo, fn = best.get(("old", "kernel_ms") + k, nan), best.get(("new", "kernel_ms") + k, nan)
    print(f"| {k[0]} | {k[1]} | {k[2]} | {ao:.4f} | {an:.4f} | {an / ao:.3f} | {fo:.4f} | {fn:.4f} |")
PY
)
