#!/usr/bin/env bash
# On the development machine: gathers what bench/gpu.sh needs on the GPU machine
# and cannot find there (Khronos CL/ headers, the ICD loader's link name) into
# .device/, which is git-ignored and travels with the device tool's `carry`.
set -euo pipefail
cd "$(dirname "$0")/.."
rm -rf .device && mkdir -p .device/include .device/lib
cp -r /usr/include/CL .device/include/
loader=$(readlink -f /usr/lib/x86_64-linux-gnu/libOpenCL.so.1)
cp "$loader" .device/lib/libOpenCL.so
cp "$loader" .device/lib/libOpenCL.so.1
