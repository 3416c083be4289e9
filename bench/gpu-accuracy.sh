#!/usr/bin/env bash
# On the GPU machine: issue 31's accuracy case (bench/accuracy_case.py) on
# CUDA: AB and RM against the dense scipy reference, for path bounds from the
# default to 0.01 voxels and the paper's one segment per tracked interval,
# with each blur's time; then bench/bound_cost.py: what the bounds cost in
# kernel time on 256^3 for the paper's eight scenarios and a tracked seizure.
# The package is installed by pip beside the machine's torch
# (bench/device-env.sh). What comes back through $OUT: accuracy.txt,
# accuracy.json, bound_cost.md, bound_cost.json, machine.txt.
#   PB_COMMIT=$(git rev-parse --short HEAD) bash bench/gpu-accuracy.sh   (carry .device .whl)
set -uo pipefail
cd "$(dirname "$0")/.."
. bench/device-env.sh
write_machine "$OUT/machine.txt" </dev/null
install_package -Dopencl=disabled || exit 1
(cd /tmp && python3 "$OLDPWD/bench/accuracy_case.py" --device cuda --times 3000 \
    --bounds default,0.25,0.1,0.05,0.02,0.01,paper --methods ab,rm --out "$OUT/accuracy.json" "$@") 2>&1 |
    tee "$OUT/accuracy.txt"
status=${PIPESTATUS[0]}
(cd /tmp && python3 "$OLDPWD/bench/bound_cost.py" --out "$OUT/bound_cost.json") 2>&1 | tee "$OUT/bound_cost.md"
[ "${PIPESTATUS[0]}" = 0 ] || status=1
exit $status
