#!/usr/bin/env bash
# The main job on the bundled sample: install what it needs, build rgs-convert and rgs-info (nothing else),
# convert samples/guitar.ply into build/samples/guitar.rgs, print the conversion summary and the file's
# description, validate it, and convert it back to a standard 3DGS PLY. Build progress and any compile error
# are shown as they happen.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${RGS_BUILD_DIR:-$root/build}"
"$root/scripts/install_deps.sh" sample
# The CUDA renderer only where it can run (scripts/build.sh decides).
"$root/scripts/build.sh" --target rgs-convert rgs-info -- \
  -DRGS_BUILD_TESTS=OFF -DRGS_BUILD_SAMPLES=OFF -DRGS_WITH_OPENIMAGEIO=OFF
mkdir -p "$build/samples"
"$build/tools/rgs-convert" "$root/samples/guitar.ply" "$build/samples/guitar.rgs"
echo
"$build/tools/rgs-info" --check "$build/samples/guitar.rgs"
echo
"$build/tools/rgs-convert" "$build/samples/guitar.rgs" "$build/samples/guitar_restored.ply"
