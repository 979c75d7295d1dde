#!/usr/bin/env bash
# Development host: builds the GPU binaries (CUDA on, no OpenImageIO: CONTRIBUTING.md#one-build-two-hosts)
# into build-gpu and stages what the GPU host needs into ignored folders, each small enough to travel with the
# repository in one call (a call carries at most 64 MiB with the working tree):
#   .device_data/bin.tar.xz  test_gpu, test_api, test_audit, rgs-render, rgs-bench, rgs-convert, rgs-audit, rgs-info,
#                            rgs-view (and rgs-view-bench), test_view and the render_frame sample, stripped
#   .device_data/py.tar.xz   the Python module's parts for the GPU host's own Python (3.12 there, 3.11 here):
#                            libroofgs_core.so (every RoofGS library, code generated here), pybind11's headers
#                            and the generated config.h; scripts/gpu_python.sh compiles the module there
#   .device_data/data/       flowers as .rgs with its cameras.json, taebak_cameras.json
#   .device_scenes/          flowers and biker PLY and the 542k daffodils scene as .rgs; scripts/gpu_check.sh reads them
#                            from there or from .device_data/data
#   .device_taebak_a/, .device_taebak_b/
#                            the 4.25M-Gaussian taebak scene as streamed SOG (55 MB), its chunk folders split in
#                            two halves, and rgs-convert, which converts it on the GPU host
#                            (scripts/gpu_prepare_taebak.sh)
# Then, on the GPU host, one call each while the machine stays warm (what an earlier call carried stays there):
# carry .device_taebak_a; carry .device_taebak_b and run scripts/gpu_prepare_taebak.sh .device_taebak_a
# .device_taebak_b; carry .device_scenes; carry .device_data and run scripts/gpu_check.sh .device_data "$OUT".
# Usage: scripts/stage_gpu.sh [DATA_DIR]   (DATA_DIR: the real scenes, default data/ in the checkout)
#   RGS_CUDA_ARCHITECTURES: the GPUs to build for (default "89;90"; "90" alone for an H100 or H200 halves the
#   kernels' compile)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
data="${1:-$root/data}"
build="$root/build-gpu"
stage="$root/.device_data"
scenes="$root/.device_scenes"

cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DRGS_WITH_CUDA=ON -DRGS_WITH_OPENIMAGEIO=OFF \
  -DCMAKE_CUDA_ARCHITECTURES="${RGS_CUDA_ARCHITECTURES:-89;90}" -DRGS_BUILD_TESTS=ON -DRGS_BUILD_LAB=ON -DRGS_BUILD_TOOLS=ON -DRGS_BUILD_SAMPLES=ON \
  -DRGS_INSTALL=OFF -DRGS_BUILD_PYTHON=ON -DCMAKE_BUILD_RPATH='$ORIGIN' >/dev/null
exes=(tests/gpu/test_gpu tests/api/test_api tests/audit/test_audit tools/rgs-render lab/rgs-bench tools/rgs-convert
      tools/rgs-audit tools/rgs-info samples/rgs_sample_render_frame tools/rgs-view tests/view/test_view lab/rgs-view-bench
      lab/tests/test_lab_gpu)
targets=()
for exe in "${exes[@]}"; do targets+=("$(basename "$exe")"); done
cmake --build "$build" -j"$(nproc)" --target "${targets[@]}" rgs_api rgs_audit rgs_view

# The Python module: a Python extension built here would be for this host's Python, so the libraries go over
# as one shared library with their code generated here (LTO resolved by this compiler), and the GPU host
# compiles only the bindings against its own Python headers (scripts/gpu_python.sh). zstd and zlib come from
# the host's libzstd.so.1, liblzma.so.5 and libz.so.1 (Debian's static archives of them are not
# position-independent).
py="$stage/py"
rm -rf "$py"
mkdir -p "$py/include"
libs=(view/librgs_view.a audit/librgs_audit.a api/librgs_api.a converter/librgs_converter.a runtime/librgs_runtime.a
      format/librgs_format.a kernels/librgs_kernels.a)
# roofgs.view(): the viewer library goes in too, with libturbojpeg's shared library beside it (Debian's archive
# of it is not position-independent; the GPU host has none), found through the core library's $ORIGIN.
# libzip likewise (Debian ships no archive of it).
cp -L /usr/lib/x86_64-linux-gnu/libturbojpeg.so.0 /usr/lib/x86_64-linux-gnu/libzip.so.4 "$py/"
(cd "$build" && c++ -shared -fPIC -O3 -flto -o "$py/libroofgs_core.so" -Wl,--whole-archive "${libs[@]}" \
  -Wl,--no-whole-archive -Wl,-rpath,'$ORIGIN' "$py/libturbojpeg.so.0" "$py/libzip.so.4" /usr/lib/x86_64-linux-gnu/libwebp.a \
  /usr/lib/x86_64-linux-gnu/libxxhash.a /usr/lib/x86_64-linux-gnu/libdraco.a \
  /usr/local/cuda/lib/libcudart_static.a -l:libzstd.so.1 -l:liblzma.so.5 -l:libz.so.1 -ldl -lrt -lpthread)
strip "$py/libroofgs_core.so"
touch "$py/with_viewer"
cp -r /usr/include/pybind11 "$py/include/"
cp -r "$build/generated/rgs" "$py/include/"
tar -C "$stage" -cJf "$stage/py.tar.xz" py
rm -rf "$py"

rm -rf "$stage/bin" "$stage/bin.tar.xz"
mkdir -p "$stage/bin" "$stage/data" "$scenes" "$root/.device_taebak_a" "$root/.device_taebak_b"
for exe in "${exes[@]}"; do
  cp "$build/$exe" "$stage/bin/"
  strip "$stage/bin/$(basename "$exe")"
done
# GPU binaries must not need any shared library beyond the C/C++ runtime, libzstd.so.1, liblzma.so.5 and libzip.so.4
# (CONTRIBUTING.md#one-build-two-hosts). libzip.so.4 goes beside them (found through their $ORIGIN run path), and
# what it needs (libbz2, libcrypto, libz) the GPU host has.
cp -L /usr/lib/x86_64-linux-gnu/libzip.so.4 "$stage/bin/"
for exe in "$stage"/bin/*; do
  allowed='linux-vdso|libstdc\+\+|libm\.so|libgcc_s|libc\.so|ld-linux|libzstd\.so\.1|liblzma\.so\.5|libzip\.so\.4|libbz2|libcrypto|libz\.so'
  if ldd "$exe" | grep -vE "$allowed" | grep -q .; then
    echo "stage_gpu.sh: $exe links more than the C/C++ runtime, libzstd, liblzma and libzip:" >&2; ldd "$exe" >&2; exit 1
  fi
done
xz -c "$stage/bin/rgs-convert" >"$root/.device_taebak_a/rgs-convert.xz"  # every byte counts in that call
cp -L /usr/lib/x86_64-linux-gnu/libzip.so.4 "$root/.device_taebak_a/"
tar -C "$stage" -cJf "$stage/bin.tar.xz" bin
rm -rf "$stage/bin"

cp "$data/mipnerf360_flowers_cameras.json" "$data/taebak_cameras.json" "$stage/data/"
cp "$data/mipnerf360_flowers_c3dgs.ply" "$data/biker.ply" "$scenes/"
# flowers also as a .rgs, so the benchmark's RoofGS mode reads compact attributes.
"$build/tools/rgs-convert" -q "$data/mipnerf360_flowers_c3dgs.ply" "$stage/data/mipnerf360_flowers_c3dgs.rgs"
daffodils="$scenes/playcanvas_flowers_lod0.rgs"
if [ ! -f "$daffodils" ] || [ "$data/playcanvas_flowers_lod0.ply" -nt "$daffodils" ] ||
   [ "$build/tools/rgs-convert" -nt "$daffodils" ]; then
  "$build/tools/rgs-convert" -q "$data/playcanvas_flowers_lod0.ply" "$daffodils" --zstd all --zstd-level 3
fi
# The SOG's files split in two halves by chunk folder; gpu_prepare_taebak.sh puts them together again.
for half in a b; do rm -rf "$root/.device_taebak_$half/taebak_lod0_sog"; mkdir -p "$root/.device_taebak_$half/taebak_lod0_sog"; done
cp "$data"/taebak_lod0_sog/*.json "$data"/taebak_lod0_sog/SHA256SUMS "$root/.device_taebak_a/taebak_lod0_sog/"
chunks=("$data"/taebak_lod0_sog/*/)
for i in "${!chunks[@]}"; do
  half=a
  [ "$i" -ge $(( ${#chunks[@]} / 2 )) ] && half=b
  cp -r "${chunks[$i]%/}" "$root/.device_taebak_$half/taebak_lod0_sog/"
done
chmod -R u+w "$root"/.device_taebak_?
du -sh "$stage" "$scenes" "$root"/.device_taebak_?
