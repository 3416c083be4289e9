#!/bin/bash
# ab.sh SEED...: default against PETBLUR_ESTIMATE_TWO=1 on the host
P=build-t/src/cli/petblur; D=bench/results/2026-12-05_cpu2_161f6d3_two-poses
for s in "$@"; do
  [ -d d$s ] || python3 $D/dump_draw.py $s d$s > /dev/null 2>&1
  $P motion estimate d$s/f.nii.gz --frames-from d$s/f.json --device host -o d$s/a.csv > d$s/a.txt 2>&1
  PETBLUR_ESTIMATE_TWO=1 $P motion estimate d$s/f.nii.gz --frames-from d$s/f.json --device host -o d$s/b.csv > d$s/b.txt 2>&1
  echo "$s A $(python3 $D/eval_draw.py $s d$s/a.csv d$s/a.txt)"
  echo "$s B $(python3 $D/eval_draw.py $s d$s/b.csv d$s/b.txt)"
  diff d$s/a.txt d$s/b.txt | grep '^>' | grep -v poses
done
