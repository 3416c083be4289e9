#!/bin/bash
P=build-t/src/cli/petblur; D=bench/results/2026-12-05_cpu2_161f6d3_two-poses
for s in "$@"; do
  [ -d d$s ] || python3 $D/dump_draw.py $s d$s > /dev/null 2>&1
  PETBLUR_ESTIMATE_TWO=2 $P motion estimate d$s/f.nii.gz --frames-from d$s/f.json --device host -o d$s/c.csv > d$s/c.txt 2>&1
  echo "$s C $(python3 $D/eval_draw.py $s d$s/c.csv d$s/c.txt)"
done
