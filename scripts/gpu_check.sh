#!/usr/bin/env bash
# GPU host: runs every GPU test and the benchmark from a folder staged by scripts/stage_gpu.sh, writing full
# logs and JSON under OUT_DIR and printing a short summary last (GPU.md "One build, two hosts").
# Usage: scripts/gpu_check.sh STAGE_DIR OUT_DIR [tests|bench|all]   (default all)
set -uo pipefail
stage="$(cd "$1" && pwd)"
out="$2"
what="${3:-all}"
mkdir -p "$out"
bin="$stage/bin"
export RGS_DATA_DIR="$stage/data"
summary="$out/summary.txt"
: >"$summary"
note() { echo "$*" | tee -a "$summary"; }

nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.sm,clocks.max.sm --format=csv >"$out/device.txt" 2>&1
note "device: $(sed -n 2p "$out/device.txt")"

status=0
if [ "$what" = tests ] || [ "$what" = all ]; then
  start=$(date +%s)
  "$bin/test_gpu" -s >"$out/test_gpu.log" 2>&1
  rc=$?
  [ $rc -ne 0 ] && status=1
  note "test_gpu: exit $rc in $(( $(date +%s) - start )) s; $(grep -E '^\[doctest\] (test cases|assertions)' "$out/test_gpu.log" | tr '\n' ' ')"
  grep -h "MESSAGE: " "$out/test_gpu.log" | sed 's/.*MESSAGE: //' >"$out/test_gpu_messages.txt"
  grep -E "ERROR|FAILED|skipped" "$out/test_gpu.log" | head -20 | tee -a "$summary"
fi

if [ "$what" = bench ] || [ "$what" = all ]; then
  flowers="$RGS_DATA_DIR/mipnerf360_flowers_c3dgs.rgs"
  cameras="$RGS_DATA_DIR/mipnerf360_flowers_cameras.json"
  daffodils="$RGS_DATA_DIR/playcanvas_flowers_lod0.rgs"
  modes=(--mode baseline --mode roofgs)
  "$bin/rgs-bench" "$flowers" --cameras "$cameras" --every 8 --resolution 1920x1080 --resolution 3840x2160 \
    "${modes[@]}" --warmup 5 --repeat 10 --json "$out/bench_flowers.json" >"$out/bench_flowers.log" 2>&1 || status=1
  "$bin/rgs-bench" "$daffodils" --orbit 8 --resolution 1920x1080 --resolution 3840x2160 \
    "${modes[@]}" --warmup 5 --repeat 10 --json "$out/bench_daffodils.json" >"$out/bench_daffodils.log" 2>&1 || status=1
  tail -n 30 "$out/bench_flowers.log" "$out/bench_daffodils.log" | tee -a "$summary"
fi
echo
echo "=== summary ==="
cat "$summary"
exit $status
