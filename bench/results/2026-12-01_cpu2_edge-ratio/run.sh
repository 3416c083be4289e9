#!/bin/bash
cd /work/main
PETBLUR_TEST_SEED=$1 PYTHONPATH=python PETBLUR_LIBRARY=$PWD/build/src/libpetblur.so PETBLUR_CLI=$PWD/build/src/cli/petblur /work/venv-py/bin/python -m pytest -q -p no:cacheprovider python/tests/test_motion_from_frames.py -k test_jerk_in_the_series_first_or_last_frame -s 2>&1 | grep -E "^frame [0-9]" | sed "s/^/$1 /"
