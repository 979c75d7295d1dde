#!/usr/bin/env bash
# Configures and builds RoofGS into ${RGS_BUILD_DIR:-build} (Release), showing the build's progress and any
# compile error. CUDA is used when nvcc is found.
# Usage: scripts/build.sh [--target T ...] [-- CMAKE_ARGS...]   e.g. scripts/build.sh -- -DRGS_WITH_CUDA=OFF
#   (CMake arguments may also be given without the "--" when no --target is used.)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${RGS_BUILD_DIR:-$root/build}"
targets=()
while [ $# -gt 0 ]; do
  case "$1" in
    --target) shift; while [ $# -gt 0 ] && [ "$1" != "--" ] && [[ "$1" != -D* ]]; do targets+=("$1"); shift; done ;;
    --) shift; break ;;
    *) break ;;
  esac
done
echo "build: configuring $build"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release --log-level=WARNING "$@"
echo "build: building ${targets[*]:-everything} with $(nproc) jobs"
if [ ${#targets[@]} -gt 0 ]; then
  cmake --build "$build" --parallel "$(nproc)" --target "${targets[@]}"
else
  cmake --build "$build" --parallel "$(nproc)"
fi
