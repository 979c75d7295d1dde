#!/usr/bin/env bash
# GPU host: converts the taebak SOG staged by scripts/stage_gpu.sh (its chunk folders split between
# .device_taebak_a and .device_taebak_b, carried by two calls) into a .rgs under /tmp/rgs_taebak, where
# scripts/gpu_check.sh finds it in a later call (the scene is too large to travel together with the binaries).
# Prints the conversion's time.
# Usage: scripts/gpu_prepare_taebak.sh STAGE_DIR... [--out OUT_DIR]
set -euo pipefail
out=""
stages=()
while [ $# -gt 0 ]; do
  case "$1" in
    --out) out="$2"; shift 2 ;;
    *) stages+=("$(cd "$1" && pwd)"); shift ;;
  esac
done
dest=/tmp/rgs_taebak
rm -rf "$dest"
mkdir -p "$dest/taebak_lod0_sog"
for stage in "${stages[@]}"; do
  cp -r "$stage/taebak_lod0_sog/." "$dest/taebak_lod0_sog/"
  if [ -f "$stage/rgs-convert.xz" ]; then xz -dc "$stage/rgs-convert.xz" >"$dest/rgs-convert"; fi
  if [ -f "$stage/libzip.so.4" ]; then cp "$stage/libzip.so.4" "$dest/"; fi  # beside rgs-convert, its $ORIGIN
done
chmod +x "$dest/rgs-convert"
(cd "$dest/taebak_lod0_sog" && sha256sum --quiet -c SHA256SUMS)
start=$(date +%s%N)
"$dest/rgs-convert" "$dest/taebak_lod0_sog/lod-meta.json" "$dest/taebak.rgs" | tee "$dest/convert.log"
echo "taebak: converted in $(( ($(date +%s%N) - start) / 1000000 )) ms on $(nproc) cores"
ls -l "$dest"
if [ -n "$out" ]; then cp "$dest/convert.log" "$out/taebak_convert.log"; fi
