#: paper [paper.sh options]  the paper's Tables 1-3 at full size with the peers, AB's floor and the plots (bench/paper.sh)
# bench/paper.sh on CUDA, with PoCL on the machine's CPU for the SciPy
# comparison; CI runs only its plumbing on 16-voxel grids, so this is where the
# whole one runs. Options go to bench/paper.sh (--size, --points, --runs).
# Back through $OUT: paper.md, paper.tar.gz (its CSVs, plots and logs),
# tables.md (the texture unit's fetch floor), machine.txt. (carry .device)
# shellcheck shell=bash
mode_paper() (
    status=0
    # Within mode all, the build and machine.txt are the kernels' run's.
    [ -n "${kernels_log:-}" ] || { write_machine "$OUT/machine.txt" </dev/null; build_gpu; }
    echo "== the paper's Tables 1-3 with the peers, AB's floor and the plots (bench/paper.sh) =="
    paper=$(mktemp -d)/paper
    OCL_ICD_VENDORS=$(icd_folder pocl) PYTHON=python3 bash bench/paper.sh build-gpu "$paper" --device cuda \
        --cpu-device opencl "$@" || status=1
    cp "$paper/paper.md" "$OUT/paper.md" 2>/dev/null
    tar -C "$(dirname "$paper")" -czf "$OUT/paper.tar.gz" paper
    {
        echo "The texture unit's fetch floor (only AB's fetches, 256^3; bench/fetch_rate.cu):"
        echo
        sed 's/^/    /' "$paper/fetch-rate.txt"
        echo
        echo "The paper's tables: paper.md"
    } | tee -a "$OUT/tables.md"
    exit $status
)
