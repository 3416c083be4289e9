# Sourced by bench/gpu.sh and bench/gpu-quick.sh from the repository root on
# the GPU machine: the build environment that .device/ (bench/gpu-prepare.sh)
# brings, and meson (or its module where no meson command is installed).
dev=$PWD/.device
export CFLAGS="-I$dev/include -I$dev/include/nifti" LDFLAGS="-L$dev/lib" LIBRARY_PATH="$dev/lib"
# The program's libraries travel in .device too, with pkg-config files that
# point there.
sed -i "s|@DEVICE@|$dev|" "$dev"/lib/pkgconfig/*.pc
export PKG_CONFIG_PATH="$dev/lib/pkgconfig"
export LD_LIBRARY_PATH="$dev/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export PATH="$PATH:/usr/local/cuda/bin"
meson=(meson)
command -v meson >/dev/null || meson=(python3 -m mesonbuild.mesonmain)
