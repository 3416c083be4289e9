#: estimate [study] [tests] [axial] [fine]  motion from the frames: the study's (e), (g); tests --cli motion_estimate,world; estimate_validation.py
# What a change to the estimator moves (issue 30): with "study", the motion
# study's (e) and (g) at full size (mode study, into $OUT/study) where
# docs/motion.md cites them; with "tests", mode tests with the command line's
# motion_estimate and world; with "axial" and "fine", bench/estimate_validation.py
# on CUDA: the 24 frames of 64^3 (3 mm) and the benchmark's 24 frames of
# 128^3 (1.5 mm). SEED=N draws the validation's series from seed N (default: a
# fresh one); docs/motion.md's axial table is seed 1622154048:
#   SEED=1622154048 PB_COMMIT=... bash bench/gpu.sh estimate study axial
#   PB_COMMIT=... bash bench/gpu.sh estimate tests axial
#   PB_COMMIT=... bash bench/gpu.sh estimate fine
# Each within the device's ten minutes (the build is kept between calls).
# SimpleITK is not on that machine: its side of the comparison runs on the
# two-core machine the issue measured it on. Back through $OUT: study/ (six
# files), machine.txt (not with study, for the 8 files), tests.txt,
# pose_derivative.txt, validation-SETUP.txt and .json. (carry .device .whl,
# and .study for study)
# shellcheck shell=bash
mode_estimate() (
    what=" $* " status=0
    if [[ $what == *" study "* ]]; then
        mkdir -p "$OUT/study" && OUT=$OUT/study mode_study --methods eg || exit 1
    else
        write_machine "$OUT/machine.txt" </dev/null
    fi
    if [[ $what == *" tests "* ]]; then
        mode_tests --cli motion_estimate,world || status=1
    else
        build_gpu -- src/cli/petblur
    fi
    install_nibabel
    for setup in axial fine; do
        [[ $what == *" $setup "* ]] || continue
        python3 bench/estimate_validation.py --petblur build-gpu/src/cli/petblur --device cuda --setup $setup \
            ${SEED:+--seed "$SEED"} --out "/tmp/val-$setup" --no-sitk >"$OUT/validation-$setup.txt" 2>&1 || status=1
        cp "/tmp/val-$setup/results.json" "$OUT/validation-$setup.json" 2>/dev/null
    done
    exit $status
)
