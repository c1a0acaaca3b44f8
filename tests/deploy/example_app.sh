#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Installs the build into a scratch prefix, then builds examples/app against it the way a user
# would: find_package(drivebus) from the installed CMake package, and pkg-config.
#   example_app.sh BUILD_DIR SOURCE_DIR SCRATCH_DIR
set -eu
build=$1 source=$2 scratch=$3
rm -rf "$scratch"
cmake --install "$build" --prefix "$scratch/root" >/dev/null
cmake -S "$source/examples/app" -B "$scratch/app" -DCMAKE_PREFIX_PATH="$scratch/root" >/dev/null
cmake --build "$scratch/app" >/dev/null
test -x "$scratch/app/pump_control"
test -x "$scratch/app/poll_loop"
pc=$(find "$scratch/root" -name drivebus.pc)
flags=$(PKG_CONFIG_PATH=$(dirname "$pc") pkg-config --cflags --libs drivebus)
case "$flags" in
  *"-I$scratch/root/"*include*"-ldrivebus"*) ;;
  *) echo "pkg-config gives '$flags', not the scratch prefix" >&2; exit 1 ;;
esac
soname=$(objdump -p "$scratch"/root/lib*/*/libdrivebus.so.* 2>/dev/null | awk '/SONAME/ {print $2}' | head -1)
test "$soname" = "libdrivebus.so.0" || { echo "SONAME is '$soname'" >&2; exit 1; }
echo "example app built against $scratch/root; pkg-config: $flags; SONAME $soname"
