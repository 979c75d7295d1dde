#!/usr/bin/env bash
# GPU host: Nsight Compute profiles of the RoofGS frame's kernels on one view, from a folder staged by
# scripts/stage_gpu.sh, to find what bounds each stage (the evidence behind docs/lab/TRIED.md#tried-and-not-kept).
# Writes, per scene, the kernel durations (<scene>_times.csv) and the full sections of the kernels named
# by KERNELS (<scene>_full.txt: occupancy, issue, stall reasons, memory throughput) under OUT_DIR.
# Usage: scripts/gpu_profile.sh STAGE_DIR OUT_DIR [MODE]   (MODE: an rgs-bench mode, default roofgs)
set -uo pipefail
stage="$(cd "$1" && pwd)"
out="$2"
mode="${3:-roofgs}"
mkdir -p "$out"
if [ -f "$stage/bin.tar.xz" ] && [ ! -x "$stage/bin/rgs-bench" ]; then tar -C "$stage" -xJf "$stage/bin.tar.xz"; fi
bench="$stage/bin/rgs-bench"
data="$stage/data"
ncu="$(command -v ncu || echo /usr/local/cuda/bin/ncu)"
# The frame's kernels (the device-peak kernels rgs-bench also runs are left out).
frame_kernels='regex:fused|emit_large|render_|Onesweep|Histogram|Exclusive|ranges|order_|preprocess|duplicate'
full_kernels="${KERNELS:-regex:fused_kernel|emit_large|render_folded}"

profile() {  # NAME ARGS...: one view at 3840x2160, one frame (no warm-up), every frame kernel timed
  local name="$1"
  shift
  local run=("$bench" "$@" --limit 1 --resolution 3840x2160 --mode "$mode" --warmup 0 --repeat 1)
  "$ncu" --clock-control none -k "$frame_kernels" --metrics gpu__time_duration.sum --csv "${run[@]}" \
    >"$out/${name}_times.csv" 2>"$out/${name}_times.err"
  "$ncu" --clock-control none -k "$full_kernels" --set full "${run[@]}" >"$out/${name}_full.txt" 2>&1
  echo "== $name: kernel, µs"
  grep gpu__time_duration "$out/${name}_times.csv" | awk -F'","' '{printf "%-60.60s %s %s\n", $5, $NF, $(NF-1)}' | tr -d '"'
}

profile flowers "$data/mipnerf360_flowers_c3dgs.rgs" --cameras "$data/mipnerf360_flowers_cameras.json" --every 8
profile daffodils_x4 "$data/playcanvas_flowers_lod0.rgs" --replicate 4 --orbit 8
# taebak (4.25M Gaussians), when scripts/gpu_prepare_taebak.sh left it in /tmp/rgs_taebak in an earlier call.
if [ -f /tmp/rgs_taebak/taebak.rgs ]; then
  profile taebak /tmp/rgs_taebak/taebak.rgs --cameras "$data/taebak_cameras.json"
fi
