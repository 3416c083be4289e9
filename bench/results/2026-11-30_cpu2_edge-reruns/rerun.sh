#!/bin/bash
# rerun.sh TEST_ID N OUT: run a pytest node N times with fresh seeds, one line each
cd /work/main
export PYTHONPATH=python PETBLUR_LIBRARY=$PWD/build/src/libpetblur.so PETBLUR_CLI=$PWD/build/src/cli/petblur
for i in $(seq 1 $2); do
  out=$(/work/venv-py/bin/python -m pytest -q -s -p no:cacheprovider "$1" 2>&1)
  seed=$(echo "$out" | grep -m1 "^seed" | awk '{print $2}')
  res=$(echo "$out" | tail -1)
  echo "$seed | $res | $(echo "$out" | grep -E "^frame|^E   " | head -3 | tr '\n' ' ')" >> $3
done
