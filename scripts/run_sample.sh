#!/usr/bin/env bash
# The main job on the bundled sample: install dependencies, build, convert samples/guitar.ply into
# build/samples/guitar.rgs, print the conversion summary and the file's description, validate it, and
# convert it back to a standard 3DGS PLY.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${RGS_BUILD_DIR:-$root/build}"
"$root/scripts/install_deps.sh"
"$root/scripts/build.sh" >/dev/null
mkdir -p "$build/samples"
"$build/tools/rgs-convert" "$root/samples/guitar.ply" "$build/samples/guitar.rgs"
echo
"$build/tools/rgs-info" --check "$build/samples/guitar.rgs"
echo
"$build/tools/rgs-convert" "$build/samples/guitar.rgs" "$build/samples/guitar_restored.ply"
