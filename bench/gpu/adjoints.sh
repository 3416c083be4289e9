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
    python3 bench/gpu/best_of.py "$OUT" --columns adjoint_ms,kernel_ms | tee "$OUT/adjoints.md"
)
