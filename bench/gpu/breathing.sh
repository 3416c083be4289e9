#: breathing [study.py options]  issue 45's breathing study (examples/breathing_study) at full size on CUDA, its table and figures, then family.py over four more draws
# The thorax breathing inside respiratory gates: the program built, the
# package installed by pip beside the machine's torch, the study on CUDA
# (torch tensors; the projector as torch sparse), then its table and
# figures; then family.py: the claims' differences over seeds 2-5. Back
# through $OUT: results.json, table.md, slices.png, curves.png, study.log,
# machine.txt, family.md, family.json. ASTRA's projector matrix is made on
# the development machine and carried, git-ignored, as
# .study/astra-128-180.npz (the head study's: the same grid and angles):
#   python3 examples/motion_study/study.py --preset full --matrix .study/astra-128-180.npz --make-matrix
# (carry .device .whl .study)
# shellcheck shell=bash
mode_breathing() (
    write_machine "$OUT/machine.txt" </dev/null
    install_package -Dopencl=disabled || exit 1
    python3 examples/breathing_study/study.py --preset full --device cuda --matrix .study/astra-128-180.npz \
        --out "$OUT/run" "$@" 2>&1 | tee "$OUT/study.log"
    status=${PIPESTATUS[0]}
    python3 examples/breathing_study/report.py "$OUT/run" >/dev/null 2>>"$OUT/study.log" || status=1
    for f in results.json table.md curves.png slices.png; do cp "$OUT/run/$f" "$OUT/" 2>/dev/null; done
    rm -rf "$OUT/run"
    python3 examples/breathing_study/family.py --preset full --device cuda --matrix .study/astra-128-180.npz \
        --seeds 2,3,4,5 --out "$OUT/family" 2>&1 | grep -v -i "warn\|lambda" | tee -a "$OUT/study.log"
    [ "${PIPESTATUS[0]}" = 0 ] || status=1
    cp "$OUT/family/family.md" "$OUT/family/family.json" "$OUT/" 2>/dev/null
    rm -rf "$OUT/family"
    exit "$status"
)
