#!/usr/bin/env bash
# On the GPU machine: issue 33's table, bench/memory_floor.py (each common
# case beside its memory floor measured in the same process, and CuPy's
# affine_transform loop), through the package installed beside the machine's
# torch and CuPy. What comes back through $OUT: machine.txt, floor.md,
# floor.csv.  PB_COMMIT=$(git rev-parse --short HEAD) bash bench/gpu-floor.sh
# (carry .device .whl)
set -uo pipefail
cd "$(dirname "$0")/.."
. bench/device-env.sh
write_machine "$OUT/machine.txt" </dev/null
install_package -Dopencl=disabled || exit 1
(cd /tmp && python3 "$OLDPWD/bench/memory_floor.py" --out "$OUT/floor.csv" "$@") 2>&1 | tee "$OUT/floor.md"
exit "${PIPESTATUS[0]}"
