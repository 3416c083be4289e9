#!/usr/bin/env bash
# On the GPU machine: issue 21's motion-compensated reconstruction study at
# full size (examples/motion_study): the program (for the phantom) built, the
# package installed by pip beside the machine's torch, the study on CUDA
# (torch tensors; the projector as torch sparse), then its
# table and figures. What comes back through $OUT: results.json, table.md,
# curves.png, slices.png, study.log, machine.txt. ASTRA's wheel needs CUDA
# 12's cudart and cuFFT, which that machine lacks: its projector matrix is made
# on this machine and carried, git-ignored, as .study/astra-128-180.npz:
#   python3 examples/motion_study/study.py --preset full --matrix .study/astra-128-180.npz --make-matrix
#   PB_COMMIT=$(git rev-parse --short HEAD) bash bench/gpu-study.sh   (carry .device .whl .study)
set -uo pipefail
cd "$(dirname "$0")/.."
. bench/device-env.sh
write_machine "$OUT/machine.txt" </dev/null
"${meson[@]}" setup build-gpu --buildtype=release -Dcuda=enabled -Dopencl=disabled -Dgpu_archs=90 >/tmp/setup.log 2>&1 &&
    ninja -C build-gpu src/cli/petblur >/tmp/build.log 2>&1 || { tail -30 /tmp/setup.log /tmp/build.log; exit 1; }
install_package -Dopencl=disabled || exit 1
export PETBLUR_CLI=$PWD/build-gpu/src/cli/petblur
python3 examples/motion_study/study.py --preset full --device cuda --matrix .study/astra-128-180.npz \
    --out "$OUT/run" "$@" 2>&1 | tee "$OUT/study.log"
status=${PIPESTATUS[0]}
python3 examples/motion_study/report.py "$OUT/run" >/dev/null 2>>"$OUT/study.log" || status=1
for f in results.json table.md curves.png slices.png; do cp "$OUT/run/$f" "$OUT/" 2>/dev/null; done
rm -rf "$OUT/run"
exit $status
