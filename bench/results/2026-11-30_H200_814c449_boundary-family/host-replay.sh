#!/bin/bash
# host replay of the fresh family's draws with the final rule: errors and the boundaries' evidence
# DRAW_PY: bench/results/2026-11-29_cpu2_50373c2_heads-replay/draw.py with its bench path set; PETBLUR: the program
# built at eb56ec5 with a line to stderr a boundary (PB_DEBUG_SIDES, not kept); run from a scratch folder
P=/work/venv-py/bin/python
for sd in "$@"; do
  d=/tmp/replay/d$sd; mkdir -p $d
  $P DRAW_PY $sd $d >/dev/null 2>&1
  PB_DEBUG_SIDES=1 PETBLUR motion estimate $d/f.nii.gz --frames-from $d/f.json -o $d/final.csv --device host -q 2> $d/debug.txt
  echo "== $sd $(grep -c 'step 1' $d/debug.txt) steps"; $P DRAW_PY $sd x $d/final.csv 2>/dev/null | head -1
  rm -f $d/f.nii.gz
done
