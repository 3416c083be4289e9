#!/bin/bash
# As run on the two-core machine: /tmp/wt-old held a build of bf1d11a, /tmp/s47/final one of 50373c2.
cd /tmp/s47
for s in "$@"; do
  d=/tmp/s47/fresh/$s; mkdir -p $d
  /work/venv-py/bin/python draw.py $s $d
  (cd $d && /tmp/wt-old/build/src/cli/petblur motion estimate f.nii.gz --frames-from f.json -o before.csv --device host -q && LD_LIBRARY_PATH=/tmp/s47/final /tmp/s47/final/petblur motion estimate f.nii.gz --frames-from f.json -o after.csv --device host -q)
  /work/venv-py/bin/python draw.py $s $d $d/before.csv $d/after.csv | sed "s/^/$s /"
done
