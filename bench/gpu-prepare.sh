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

# The program's libraries (nifti_clib, libpng, zlib) and the library's
# (jansson): headers, shared objects and pkg-config files, whose prefix is
# rewritten by bench/gpu/lib.sh on arrival.
mkdir -p .device/include/nifti .device/lib/pkgconfig
cp /usr/include/nifti/*.h .device/include/nifti/
cp /usr/include/png.h /usr/include/pngconf.h /usr/include/pnglibconf.h /usr/include/zlib.h /usr/include/zconf.h \
    /usr/include/jansson.h /usr/include/jansson_config.h .device/include/
cp -r /usr/include/libpng16 .device/include/
for lib in libnifti2 libznz libpng16 libz libjansson; do
    cp -L /usr/lib/x86_64-linux-gnu/$lib.so* .device/lib/
done
for pc in libpng libpng16 zlib jansson; do
    sed 's|^prefix=.*|prefix=@DEVICE@|; s|^libdir=.*|libdir=${prefix}/lib|; s|^includedir=.*|includedir=${prefix}/include|' \
        /usr/lib/x86_64-linux-gnu/pkgconfig/$pc.pc >.device/lib/pkgconfig/$pc.pc
done
du -sh .device
