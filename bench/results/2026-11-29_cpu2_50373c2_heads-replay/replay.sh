#!/bin/bash
# As run: /tmp/s47/dbg held the instrumented build the README names; seeds from the two records.
cd /work/main
export LD_LIBRARY_PATH=/tmp/s47/dbg
PY=/work/venv-py/bin/python
run() { # seed sitkfile
  PBDBG_FILE=/tmp/s47/heads/$1.dbg $PY bench/estimate_family.py --petblur /tmp/s47/dbg/petblur --device host --jobs 1 --seed $1 --sitk-from $2 --out /tmp/s47/heads/$1 > /tmp/s47/heads/$1.log 2>&1
  echo "$1 $(cat /tmp/s47/heads/$1.dbg 2>/dev/null | tr '\n' ' ') $(grep -h '"petblur"' /tmp/s47/heads/$1/draws.jsonl | python3 -c 'import json,sys; d=json.loads(sys.stdin.read()); print(d["from_injection"], d["petblur"]["mean_mm"])')"
}
A=bench/results/2026-11-29_H200_e5d8d46_heads/draws.jsonl
B=bench/results/2026-11-29_H200_073418e_heads/draws.jsonl
for f in $A $B; do
  for s in $(python3 -c "import json; print(' '.join(str(json.loads(l)['seed']) for l in open('$f') if json.loads(l)['from_injection']))"); do run $s $f; done
done
for f in $A $B; do
  for s in $(python3 -c "import json; print(' '.join(str(json.loads(l)['seed']) for l in open('$f') if not json.loads(l)['from_injection']))"); do run $s $f; done
done
