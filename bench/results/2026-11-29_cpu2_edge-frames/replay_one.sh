#!/bin/bash
# one draw: series (cached), the edge build's estimate, its errors
# As run on the two-core machine (/tmp/s47/edge held the build; see README.md)
s=$1; d=/tmp/s47/rep/$s; mkdir -p $d
cd /work/main/bench/results/2026-11-29_cpu2_50373c2_heads-replay
[ -f $d/f.nii.gz ] || /work/venv-py/bin/python draw.py $s $d > /dev/null 2>&1
(cd $d && LD_LIBRARY_PATH=/tmp/s47/edge nice /tmp/s47/edge/petblur motion estimate f.nii.gz --frames-from f.json -o edge.csv --device host -q)
/work/venv-py/bin/python draw.py $s $d $d/edge.csv | head -1 | sed "s/^/$s /" >> /tmp/s47/edge_results.txt
