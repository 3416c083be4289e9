cd /work/main
export PETBLUR_LIBRARY=$PWD/build-k/src/libpetblur.so PYTHONPATH=python
for v in new old; do
  if [ $v = old ]; then export PBOLDFLAT=1 PBOLDSLOPE=1; fi
  /work/venv-py/bin/python bench/path_cases.py --device host --filters exact --methods ab,rm --kinds still,drift-20hz,nod,seizure --draws 8 --seed 424242 --small --out /work/scratch/flat/cases-$v > /work/scratch/flat/cases-$v.log 2>&1
done
echo done > /work/scratch/flat/cases-done
