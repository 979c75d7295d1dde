#!/usr/bin/env bash
# Development host: builds the GPU binaries (CUDA on, no OpenImageIO: GPU.md) into build-gpu and stages them
# with the scenes they need into .device_data/ (ignored; carried to the GPU host, < 64 MiB in all):
#   .device_data/bin/   test_gpu, rgs-render, rgs-bench
#   .device_data/data/  flowers PLY + cameras.json, the 542k daffodils scene as a zstd .rgs
# Then, on the GPU host: scripts/gpu_check.sh .device_data "$OUT".
# Usage: scripts/stage_gpu.sh [DATA_DIR]   (DATA_DIR: the real scenes, default ../shared/data)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
data="${1:-$root/../shared/data}"
build="$root/build-gpu"
stage="$root/.device_data"

cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DRGS_WITH_CUDA=ON -DRGS_WITH_OPENIMAGEIO=OFF \
  -DCMAKE_CUDA_ARCHITECTURES="89;90" -DRGS_BUILD_TESTS=ON -DRGS_BUILD_TOOLS=ON -DRGS_BUILD_SAMPLES=OFF \
  -DRGS_INSTALL=OFF >/dev/null
cmake --build "$build" -j"$(nproc)" --target test_gpu rgs-render rgs-bench rgs-convert

mkdir -p "$stage/bin" "$stage/data"
for exe in tests/gpu/test_gpu tools/rgs-render tools/rgs-bench; do
  cp "$build/$exe" "$stage/bin/"
  strip "$stage/bin/$(basename "$exe")"
done
# GPU binaries must not need any shared library beyond the C/C++ runtime (GPU.md).
for exe in "$stage"/bin/*; do
  if ldd "$exe" | grep -vE 'linux-vdso|libstdc\+\+|libm\.so|libgcc_s|libc\.so|ld-linux' | grep -q .; then
    echo "stage_gpu.sh: $exe links more than the C/C++ runtime:" >&2; ldd "$exe" >&2; exit 1
  fi
done

cp "$data/mipnerf360_flowers_c3dgs.ply" "$data/mipnerf360_flowers_cameras.json" "$stage/data/"
# flowers also as a .rgs, so the benchmark's RoofGS mode reads compact attributes.
"$build/tools/rgs-convert" -q "$data/mipnerf360_flowers_c3dgs.ply" "$stage/data/mipnerf360_flowers_c3dgs.rgs"
daffodils="$stage/data/playcanvas_flowers_lod0.rgs"
if [ ! -f "$daffodils" ] || [ "$data/playcanvas_flowers_lod0.ply" -nt "$daffodils" ]; then
  "$build/tools/rgs-convert" -q "$data/playcanvas_flowers_lod0.ply" "$daffodils" --zstd all --zstd-level 3
fi
du -sh "$stage"
