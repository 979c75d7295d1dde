#!/usr/bin/env bash
# GPU host: converts the taebak SOG staged by scripts/stage_gpu.sh (.device_taebak) into a .rgs under
# /tmp/rgs_taebak, where scripts/gpu_check.sh finds it in the next call (the scene is too large to travel
# together with the binaries). Prints the conversion's time and peak RSS.
# Usage: scripts/gpu_prepare_taebak.sh STAGE_DIR [OUT_DIR]
set -euo pipefail
stage="$(cd "$1" && pwd)"
out="${2:-}"
dest=/tmp/rgs_taebak
rm -rf "$dest"
mkdir -p "$dest"
cp -r "$stage/taebak_lod0_sog" "$dest/"
xz -dc "$stage/rgs-convert.xz" >"$dest/rgs-convert"
chmod +x "$dest/rgs-convert"
start=$(date +%s%N)
"$dest/rgs-convert" "$dest/taebak_lod0_sog/lod-meta.json" "$dest/taebak.rgs" | tee "$dest/convert.log"
echo "taebak: converted in $(( ($(date +%s%N) - start) / 1000000 )) ms on $(nproc) cores"
ls -l "$dest"
if [ -n "$out" ]; then cp "$dest/convert.log" "$out/taebak_convert.log"; fi
