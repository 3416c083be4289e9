#!/usr/bin/env bash
# On the GPU machine: what a change to the estimator (first the dwell's
# threshold, src/estimate/estimate.c DWELL_GAIN; then pass 4, collective.c)
# moves where docs/motion.md cites it: the motion study's (e) and (g) at full
# size (bench/gpu-study.sh), then bench/estimate_validation.py's axial series
# with the seed its table gives.
#   PB_COMMIT=$(git rev-parse --short HEAD) bash bench/gpu-dwell.sh [validation-only]   (carry .device .whl .study)
set -uo pipefail
cd "$(dirname "$0")/.."
OUT=${OUT:-$PWD/gpu-out}
mkdir -p "$OUT"
[[ " $* " == *" validation-only "* ]] || OUT=$OUT/study bash bench/gpu-study.sh --methods eg || exit 1
. bench/device-env.sh
site=$(mktemp -d)/site
python3 -m pip install -q --no-deps --no-index --find-links .whl --target "$site" nibabel 2>&1 | tail -3
export PYTHONPATH=$site
python3 bench/estimate_validation.py --petblur build-gpu/src/cli/petblur --device cuda --setup axial \
    --seed 1622154048 --out /tmp/val-axial --no-sitk >"$OUT/validation-axial.txt" 2>&1
status=$?
cp /tmp/val-axial/results.json "$OUT/validation-axial.json" 2>/dev/null
exit $status
