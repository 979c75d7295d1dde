#!/usr/bin/env bash
# Configures and builds RoofGS into ${RGS_BUILD_DIR:-build} (Release), showing the build's progress and any
# compile error.
# Usage: scripts/build.sh [--target T ...] [-- CMAKE_ARGS...]   e.g. scripts/build.sh -- -DRGS_WITH_CUDA=ON
#   (CMake arguments may also be given without the "--" when no --target is used.)
# CUDA: the kernels and the GPU renderer are built where they can run, when nvcc and a CUDA device
# (/dev/nvidia<N>) are both found, as `pip install .` decides; or when asked for, by -DRGS_WITH_CUDA=ON|OFF
# among the arguments or RGS_WITH_CUDA=ON|OFF in the environment. Without a device, compiling the kernels for
# every architecture would take most of a build for tests that then skip.
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
cuda=()
if [[ " $* " != *" -DRGS_WITH_CUDA"* ]]; then
  case "${RGS_WITH_CUDA:-AUTO}" in
    ON | OFF) cuda=(-DRGS_WITH_CUDA="$RGS_WITH_CUDA"); why="RGS_WITH_CUDA=$RGS_WITH_CUDA given" ;;
    *)
      cuda=(-DRGS_WITH_CUDA=OFF); why="no CUDA device or no nvcc; RGS_WITH_CUDA=ON builds it anyway"
      if compgen -G "/dev/nvidia[0-9]*" >/dev/null && { command -v nvcc >/dev/null || [ -x /usr/local/cuda/bin/nvcc ]; }; then
        cuda=(-DRGS_WITH_CUDA=ON); why="nvcc and a CUDA device found"
      fi ;;
  esac
  echo "build: CUDA ${cuda[0]#-DRGS_WITH_CUDA=} ($why)"
fi
echo "build: configuring $build"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release --log-level=WARNING "${cuda[@]}" "$@"
echo "build: building ${targets[*]:-everything} with $(nproc) jobs"
if [ ${#targets[@]} -gt 0 ]; then
  cmake --build "$build" --parallel "$(nproc)" --target "${targets[@]}"
else
  cmake --build "$build" --parallel "$(nproc)"
fi
