cd /work/main
export PETBLUR_LIBRARY=$PWD/build-k/src/libpetblur.so PYTHONPATH=python
for v in PBOLDSLOPE PBOLDFLAT; do
  env $v=1 /work/venv-py/bin/python bench/path_cases.py --device host --filters exact --methods ab --kinds drift-20hz,nod --draws 8 --seed 424242 --small --out /work/scratch/flat/cases-$v > /work/scratch/flat/cases-$v.log 2>&1 &
  for s in $(seq 9000 9039); do env $v=1 /work/venv-py/bin/python /work/scratch/short_floor.py $s drift-20hz >> /work/scratch/flat/$v.jsonl 2>/dev/null; done
  wait
done
echo done > /work/scratch/flat/split-done
