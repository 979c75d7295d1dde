#!/usr/bin/env bash
# Configures and builds RoofGS into ${RGS_BUILD_DIR:-build} (Release). CUDA is used when nvcc is found;
# extra CMake arguments are passed through, e.g. scripts/build.sh -DRGS_WITH_CUDA=OFF.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${RGS_BUILD_DIR:-$root/build}"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release "$@"
cmake --build "$build" --parallel "$(nproc)"
