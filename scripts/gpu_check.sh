#!/usr/bin/env bash
# GPU host: runs every GPU test, the benchmark and the GPU audits from a folder staged by scripts/stage_gpu.sh,
# writing full logs and JSON under OUT_DIR and printing a short summary last (CONTRIBUTING.md#one-build-two-hosts).
# taebak (4.25M Gaussians) is included when scripts/gpu_prepare_taebak.sh left /tmp/rgs_taebak/taebak.rgs.
# Usage: scripts/gpu_check.sh STAGE_DIR OUT_DIR [tests|bench|groups|lod|floor|pybench|audit|fidelity|rate|sanitize|view|ab|all|cards|big]
#   (default all; ab: see below; cards: taebak's quality card and big: the 250M-Gaussian scene, not part of all)
set -uo pipefail
stage="$(cd "$1" && pwd)"
out="$2"
what="${3:-all}"
mkdir -p "$out"
bin="$stage/bin"
if [ -f "$stage/bin.tar.xz" ]; then tar -C "$stage" -xJf "$stage/bin.tar.xz"; fi
# Another build's binaries staged for an A/B (STAGE_DIR/ab) find libzip.so.4 beside them, through their $ORIGIN.
if [ -d "$stage/ab" ] && [ -f "$bin/libzip.so.4" ]; then cp -n "$bin/libzip.so.4" "$stage/ab/"; fi
export RGS_DATA_DIR="$stage/data"
# The larger scenes travel in their own call (.device_scenes beside the stage folder; scripts/stage_gpu.sh).
scenes="$(dirname "$stage")/.device_scenes"
if [ -d "$scenes" ]; then cp -n "$scenes"/* "$RGS_DATA_DIR/"; fi
taebak_dir=/tmp/rgs_taebak
taebak="$taebak_dir/taebak.rgs"
taebak_cameras="$RGS_DATA_DIR/taebak_cameras.json"
summary="$out/summary.txt"
: >"$summary"
note() { echo "$*" | tee -a "$summary"; }

nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.sm,clocks.max.sm --format=csv >"$out/device.txt" 2>&1
note "device: $(sed -n 2p "$out/device.txt")"

# rgs-bench (or $bench_exe) in streamed mode at 1080p, its JSON and log under OUT_DIR, a summary of each run.
lod_bench() {  # NAME ARGS...
  local name="$1" t0 rc=0
  shift
  t0=$(date +%s)
  /usr/bin/time -v "${bench_exe:-$bin/rgs-bench}" "$@" --resolution 1920x1080 --json "$out/lod_$name.json" \
    >"$out/lod_$name.log" 2>&1 || rc=$?
  [ $rc -ne 0 ] && status=1
  note "lod_$name: exit $rc in $(( $(date +%s) - t0 )) s"
  grep -E "error|scene  |budgets|open  |frame time|splats  |quality|Maximum resident" "$out/lod_$name.log" |
    tee -a "$summary"
}
status=0
if [ "$what" = tests ] || [ "$what" = all ]; then
  start=$(date +%s)
  rc=0
  if [ -f "$taebak" ]; then
    # With the taebak cases (sorted pairs, a window against the CPU reference, quality over its 8 views at 4K).
    RGS_TAEBAK_RGS="$taebak" "$bin/test_gpu" --duration=true >"$out/test_gpu.log" 2>&1 || rc=$?
  else
    "$bin/test_gpu" --duration=true >"$out/test_gpu.log" 2>&1 || rc=$?
  fi
  [ $rc -ne 0 ] && status=1
  note "test_gpu: exit $rc in $(( $(date +%s) - start )) s; $(grep -E '^\[doctest\] (test cases|assertions)' "$out/test_gpu.log" | tr '\n' ' ')"
  grep -h "MESSAGE: " "$out/test_gpu.log" | sed 's/.*MESSAGE: //' >"$out/test_gpu_messages.txt"
  grep -E "ERROR|FAILED|skipped" "$out/test_gpu.log" | head -20 | tee -a "$summary"
  # The lab's RoofGS configurations technique by technique, the front door (render into caller memory, presets,
  # GPU memory per scene), the GPU audit metrics and the viewer's server (GPU frames equal the front door's,
  # stage times, GPU memory).
  for suite in test_lab_gpu test_api test_audit test_view; do
    [ -x "$bin/$suite" ] || continue
    start=$(date +%s)
    rc=0
    if [ -f "$taebak" ]; then
      RGS_TAEBAK_RGS="$taebak" "$bin/$suite" --duration=true >"$out/$suite.log" 2>&1 || rc=$?
    else
      "$bin/$suite" --duration=true >"$out/$suite.log" 2>&1 || rc=$?
    fi
    [ $rc -ne 0 ] && status=1
    note "$suite: exit $rc in $(( $(date +%s) - start )) s; $(grep -E '^\[doctest\] (test cases|assertions)' "$out/$suite.log" | tr '\n' ' ')"
    grep -E "ERROR|FAILED|skipped" "$out/$suite.log" | head -10 | tee -a "$summary"
    grep -h "MESSAGE: " "$out/$suite.log" | sed 's/.*MESSAGE: //' >"$out/${suite}_messages.txt"
  done
  # The embedding sample renders a frame into its own pitched buffer on its own stream.
  rc=0
  "$bin/rgs_sample_render_frame" "$RGS_DATA_DIR/mipnerf360_flowers_c3dgs.rgs" cuda "$out/render_frame.ppm" \
    >"$out/render_frame.log" 2>&1 || rc=$?
  [ $rc -ne 0 ] && status=1
  note "rgs_sample_render_frame (cuda): exit $rc; $(tail -1 "$out/render_frame.log")"
  # The Python module, compiled here for this host's Python, and its tests (GPU cases through DLPack).
  rc=0
  "$(dirname "${BASH_SOURCE[0]}")/gpu_python.sh" "$stage" "$out" >"$out/python.log" 2>&1 || rc=$?
  [ $rc -ne 0 ] && status=1
  note "python (roofgs module, pytest): exit $rc; $(grep -E '(passed|failed|error)' "$out/python.log" | tail -1)"
  grep -E "SKIPPED|FAILED|Error" "$out/python.log" | head -10 | tee -a "$summary"
fi

if [ "$what" = ab ]; then
  # A/B against another build's rgs-bench (STAGE_DIR/ab/rgs-bench, e.g. the landed tree's): the same views,
  # alternating A and B twice, faithful and fastest at 1080p and 4K (docs/BENCHMARKS.md "A/B"), on flowers,
  # flowers x53, and daffodils ($RGS_DAFFODILS_RGS, default the staged data's) and taebak when present. An A
  # build from before the modes took the preset names (baseline, roofgs+) runs under those, its JSON renamed
  # after. The table (bench_tables.py --ab) goes to the summary and ab_table.md.
  flowers="$RGS_DATA_DIR/mipnerf360_flowers_c3dgs.rgs"
  cameras="$RGS_DATA_DIR/mipnerf360_flowers_cameras.json"
  daffodils="${RGS_DAFFODILS_RGS:-$RGS_DATA_DIR/playcanvas_flowers_lod0.rgs}"
  [ -f "$stage/ab/rgs-bench.xz" ] && xz -dkf "$stage/ab/rgs-bench.xz" && chmod +x "$stage/ab/rgs-bench"
  scenes=(flowers flowers_x53)
  [ -f "$daffodils" ] && scenes+=(daffodils)
  [ -f "$taebak" ] && scenes+=(taebak)
  mkdir -p "$out/ab"
  for round in 1 2; do
    for side in a b; do
      exe="$bin/rgs-bench"
      [ $side = a ] && exe="$stage/ab/rgs-bench"
      modes=(--mode faithful --mode fastest)
      "$exe" --help | grep -q "faithful" || modes=(--mode baseline --mode roofgs+)
      for scene in "${scenes[@]}"; do
        case $scene in
          flowers) input=("$flowers" --cameras "$cameras" --every 8) ;;
          flowers_x53) input=("$flowers" --cameras "$cameras" --every 8 --replicate 53 --limit 8) ;;
          daffodils) input=("$daffodils" --orbit 8) ;;
          taebak) input=("$taebak" --cameras "$taebak_cameras") ;;
        esac
        json="$out/ab/ab_${scene}_${side}${round}.json"
        "$exe" "${input[@]}" --resolution 1920x1080 --resolution 3840x2160 "${modes[@]}" --warmup 3 --repeat 10 \
          --json "$json" >"$out/ab/ab_${scene}_${side}${round}.log" 2>&1 || status=1
        sed -i 's/"mode": "baseline"/"mode": "faithful"/; s/"mode": "roofgs+"/"mode": "fastest"/' "$json" || true
      done
    done
  done
  note "ab: $(ls "$out"/ab/ab_*.json 2>/dev/null | wc -l) runs"
  python3 "$(dirname "${BASH_SOURCE[0]}")/bench_tables.py" --ab "$out"/ab/ab_*.json >"$out/ab_table.md" 2>&1 || status=1
  tee -a "$summary" <"$out/ab_table.md"
fi

if [ "$what" = bench ] || [ "$what" = all ]; then
  # Per-stage times and the roofline (device peaks measured in each run; docs/lab/ROOFLINE.md), JSON under $out
  # (plot on a host: scripts/plot_roofline.py bench_X.json bench_X.png). Each run's wall time goes to the
  # summary; the replicated scene runs fewer repetitions to keep the whole bench part short.
  flowers="$RGS_DATA_DIR/mipnerf360_flowers_c3dgs.rgs"
  cameras="$RGS_DATA_DIR/mipnerf360_flowers_cameras.json"
  daffodils="$RGS_DATA_DIR/playcanvas_flowers_lod0.rgs"
  modes=(--mode faithful --mode fastest --mode paper --mode roofgs --mode fastest-fp32-blend --mode fastest-whole-tiles --mode roofgs-serial-emission
         --mode roofgs-no-subtile --mode roofgs-subtile-always)
  # The ablation: every technique alone, all off, FP32 blending (fastest-fp32-blend), long tiles blended whole instead of
  # in chunks (fastest-whole-tiles), the load balancing off (roofgs-serial-emission), sub-tile culling off or on in every
  # frame instead of chosen per frame (roofgs-no-subtile, roofgs-subtile-always; above).
  ablation=("${modes[@]}" --mode roofgs-none --mode only-compact --mode only-fused --mode only-key32
            --mode only-snugbox --mode only-folded --mode only-fastexp)
  sizes=(--resolution 1920x1080 --resolution 3840x2160)
  bench() {  # NAME ARGS...: one rgs-bench run, its log and JSON under $out, its wall time in the summary
    local name="$1"
    shift
    local t0 rc=0
    t0=$(date +%s)
    "$bin/rgs-bench" "$@" --json "$out/bench_$name.json" >"$out/bench_$name.log" 2>&1 || rc=$?
    [ $rc -ne 0 ] && status=1
    note "bench_$name: exit $rc in $(( $(date +%s) - t0 )) s"
  }
  # --quality: each mode's frames against the baseline's (PSNR, SSIM, max |d|), on the runs that hold the
  # baseline.
  bench flowers "$flowers" --cameras "$cameras" --every 8 "${sizes[@]}" "${ablation[@]}" --warmup 5 --repeat 10 \
    --quality
  bench daffodils "$daffodils" --orbit 8 "${sizes[@]}" "${ablation[@]}" --warmup 5 --repeat 10 --front-door --quality
  # 542,104 x 4 = 2,168,416 Gaussians (lab::replicate, compact attributes kept); fewer repetitions.
  bench daffodils_x4 "$daffodils" --replicate 4 --orbit 8 "${sizes[@]}" "${modes[@]}" --warmup 3 --repeat 5
  # 38,347 x 53 = 2,032,391 Gaussians seen from flowers' own cameras (its neighbours fill the background).
  bench flowers_x53 "$flowers" --cameras "$cameras" --every 8 --replicate 53 "${sizes[@]}" "${modes[@]}" --warmup 2 \
    --repeat 3
  # 7680x4320 (17 tile bits + 15 depth bits in the 32-bit key).
  bench flowers_8k "$flowers" --cameras "$cameras" --every 24 --resolution 7680x4320 "${modes[@]}" --warmup 2 \
    --repeat 3 --quality
  bench daffodils_8k "$daffodils" --orbit 4 --resolution 7680x4320 "${modes[@]}" --warmup 2 --repeat 3 --quality
  names=(flowers daffodils daffodils_x4 flowers_x53 flowers_8k daffodils_8k)
  if [ -f "$taebak" ]; then
    # The real multi-million-Gaussian scene: its 8 cameras at 1080p and the same poses at 4K (with the ablation)
    # and 8K.
    bench taebak "$taebak" --cameras "$taebak_cameras" --resolution 1920x1080 "${modes[@]}" --warmup 3 --repeat 5 \
      --quality
    bench taebak_4k "$taebak" --cameras "$taebak_cameras" --resolution 3840x2160 "${ablation[@]}" --warmup 3 \
      --repeat 5 --front-door --quality
    bench taebak_8k "$taebak" --cameras "$taebak_cameras" --resolution 7680x4320 "${modes[@]}" --warmup 2 --repeat 3 \
      --quality
    names+=(taebak taebak_4k taebak_8k)
  fi
  for name in "${names[@]}"; do
    # The tables without the progress lines ("... x N ...").
    grep -v -e ' \.\.\.$' "$out/bench_$name.log" | tee -a "$summary"
  done
fi
if [ "$what" = groups ] || [ "$what" = all ]; then
  # Bounded pair memory (docs/RENDERER.md#bounded-pair-memory): taebak at 8K without a scratch budget, within
  # 1 GiB (one pass) and within 512 MiB (groups of tile rows), and taebak x32 (136M Gaussians: 2 pairs a Gaussian
  # of pair capacity is more than one onesweep portion) at 1080p without and with a 16 GiB budget (its
  # per-Gaussian buffers alone take about 12 GB). The GPU tests check that grouped images are the one-pass ones.
  if [ -f "$taebak" ]; then
    groups_bench() {  # NAME ARGS...
      local name="$1" t0 rc=0
      shift
      t0=$(date +%s)
      "$bin/rgs-bench" "$taebak" --cameras "$taebak_cameras" --mode fastest "$@" --json "$out/groups_$name.json" \
        >"$out/groups_$name.log" 2>&1 || rc=$?
      [ $rc -ne 0 ] && status=1
      note "groups_$name: exit $rc in $(( $(date +%s) - t0 )) s"
      grep -v -e ' \.\.\.$' "$out/groups_$name.log" | grep -E "error|frame buffers|^  fastest  " | tee -a "$summary"
    }
    groups_bench taebak_8k --resolution 7680x4320 --warmup 2 --repeat 3
    groups_bench taebak_8k_1gib --resolution 7680x4320 --warmup 2 --repeat 3 --scratch-budget 1GiB
    groups_bench taebak_8k_512mib --resolution 7680x4320 --warmup 2 --repeat 3 --scratch-budget 512MiB
    groups_bench taebak_x32 --replicate 32 --resolution 1920x1080 --warmup 1 --repeat 3
    groups_bench taebak_x32_16gib --replicate 32 --resolution 1920x1080 --warmup 1 --repeat 3 --scratch-budget 16GiB
  fi
fi
if [ "$what" = lod ] || [ "$what" = all ]; then
  # Levels of detail (docs/LOD.md): the streamer's GPU tests and the >2^31-pair frame; taebak given levels of
  # detail by rgs-convert (time, peak RSS, check); then 120-view paths at 1080p under a 3M splat budget, 3 GiB
  # of device memory for the scene's pool, frame and upload arrays and 1 GiB of render scratch (4 GiB in all),
  # for taebak x1, x4 and x16 (the big scene: replicated and given its levels in memory), each scored against
  # the full detail rendered 2x2 supersampled beside the plain full render (docs/LOD.md#measuring-quality): a fly-through along taebak's cameras (--fly) and a spiral that frames the whole
  # grid (--path, the worst case: every chunk in view).
  t0=$(date +%s)
  rc=0
  "$bin/test_gpu" --duration=true -tc='*LOD*,*2^31*' >"$out/test_gpu_lod.log" 2>&1 || rc=$?
  [ $rc -ne 0 ] && status=1
  note "test_gpu LOD and 2^31: exit $rc; $(grep -E '^\[doctest\] (test cases|assertions)' "$out/test_gpu_lod.log" | tr '\n' ' ')"
  if [ -f "$taebak" ]; then
    rc=0
    /usr/bin/time -v "$bin/rgs-convert" "$taebak" "$taebak_dir/taebak_lod.rgs" --lod-levels auto \
      >"$out/lod_convert.log" 2>&1 || rc=$?
    "$bin/rgs-info" "$taebak_dir/taebak_lod.rgs" --check >>"$out/lod_convert.log" 2>&1 || rc=$?
    [ $rc -ne 0 ] && status=1
    note "lod_convert: exit $rc"
    grep -E "profile|time  |Maximum resident|check|level " "$out/lod_convert.log" | tee -a "$summary"
    fly=(--cameras "$taebak_cameras" --fly 120)
    spiral=(--path 120)
    budget=(--splat-budget 3000000 --memory-budget 3GiB --scratch-budget 1GiB)
    lod_bench taebak_x1_fly "$taebak_dir/taebak_lod.rgs" "${fly[@]}" "${budget[@]}"
    lod_bench taebak_x1_spiral "$taebak_dir/taebak_lod.rgs" "${spiral[@]}" "${budget[@]}"
    lod_bench taebak_x4_fly "$taebak" --replicate 4 "${fly[@]}" "${budget[@]}"
    lod_bench taebak_x16_fly "$taebak" --replicate 16 "${fly[@]}" "${budget[@]}"
    lod_bench taebak_x16_spiral "$taebak" --replicate 16 "${spiral[@]}" "${budget[@]}"
    # What larger splat budgets buy within the same 4 GiB: the renderer's per-Gaussian buffers need more scratch.
    lod_bench taebak_x16_fly_6m "$taebak" --replicate 16 "${fly[@]}" --splat-budget 6000000 --memory-budget 2GiB \
      --scratch-budget 2GiB
    lod_bench taebak_x16_fly_12m "$taebak" --replicate 16 "${fly[@]}" --splat-budget 12000000 --memory-budget 2GiB \
      --scratch-budget 2GiB
  fi
fi
if [ "$what" = big ]; then
  # A scene larger than the development machine's memory (docs/LOD.md#scenes-larger-than-memory): taebak tiled 59
  # times (250,708,874 Gaussians, a 17 GB PLY), converted out of core within 4 GiB, checked, then flown at 1080p
  # under a 3M splat budget in 4 GiB of device memory (3 GiB for the scene, 1 GiB of render scratch).
  big_dir=/tmp/rgs_big
  mkdir -p "$big_dir"
  rc=0
  "$bin/rgs-convert" -q "$taebak" "$big_dir/taebak.ply" >"$out/big_make.log" 2>&1 || rc=$?
  t0=$(date +%s)
  python3 "$(dirname "$0")/make_big_scene.py" "$big_dir/taebak.ply" "$big_dir/taebak_x59.ply" 59 >>"$out/big_make.log" 2>&1 || rc=$?
  note "big scene made: exit $rc in $(( $(date +%s) - t0 )) s; $(tail -1 "$out/big_make.log")"
  # taebak converted in memory and out of core (in 2 partitions) gives the same bytes.
  "$bin/rgs-convert" -q "$big_dir/taebak.ply" "$big_dir/taebak_memory.rgs" --lod-levels auto || rc=$?
  "$bin/rgs-convert" -q "$big_dir/taebak.ply" "$big_dir/taebak_out_of_core.rgs" --lod-levels auto --memory-limit 256MiB ||
    rc=$?
  if cmp -s "$big_dir/taebak_memory.rgs" "$big_dir/taebak_out_of_core.rgs"; then
    note "taebak in memory and out of core: the same bytes"
  else
    note "taebak in memory and out of core: the files differ"
    rc=1
  fi
  # With another build's rgs-convert staged (STAGE_DIR/ab/rgs-convert.xz, e.g. the landed tree's), it converts the
  # same file first, for the A/B of time and memory (docs/LOD.md#a-scene-of-250-million-gaussians).
  sides=(b)
  if [ -f "$stage/ab/rgs-convert.xz" ]; then
    xz -dkf "$stage/ab/rgs-convert.xz" && chmod +x "$stage/ab/rgs-convert"
    sides=(a b)
  fi
  for side in "${sides[@]}"; do
    exe="$bin/rgs-convert"
    [ "$side" = a ] && exe="$stage/ab/rgs-convert"
    log="$out/big_convert.log"
    [ "$side" = a ] && log="$out/big_convert_a.log"
    rm -f "$big_dir/taebak_x59_lod.rgs"
    t0=$(date +%s)
    /usr/bin/time -v "$exe" "$big_dir/taebak_x59.ply" "$big_dir/taebak_x59_lod.rgs" --lod-levels auto \
      --memory-limit 4GiB >"$log" 2>&1 || rc=$?
    note "big convert ($side): exit $rc in $(( $(date +%s) - t0 )) s"
    grep -E "output|profile|time  |Maximum resident|Elapsed" "$log" | tee -a "$summary"
  done
  rm -f "$big_dir/taebak_x59.ply" "$big_dir/taebak.ply"
  t0=$(date +%s)
  # Its levels make 292M Gaussians in all, over the readers' default limit of 2^28.
  "$bin/rgs-info" "$big_dir/taebak_x59_lod.rgs" --check --max-gaussians 300000000 >"$out/big_check.log" 2>&1 || rc=$?
  note "big check: exit $rc in $(( $(date +%s) - t0 )) s; $(grep -E '^ *check' "$out/big_check.log")"
  [ $rc -ne 0 ] && status=1
  budget=(--splat-budget 3000000 --memory-budget 3GiB --scratch-budget 1GiB --max-gaussians 300000000)
  lod_bench big_fly "$big_dir/taebak_x59_lod.rgs" --cameras "$taebak_cameras" --fly 120 "${budget[@]}"
  lod_bench big_spiral "$big_dir/taebak_x59_lod.rgs" --path 120 "${budget[@]}"
  # With another build's rgs-bench staged (STAGE_DIR/ab/rgs-bench.xz), the same two paths by it, for the A/B of
  # frame times on the same host.
  if [ -f "$stage/ab/rgs-bench.xz" ]; then
    xz -dkf "$stage/ab/rgs-bench.xz" && chmod +x "$stage/ab/rgs-bench"
    bench_exe="$stage/ab/rgs-bench" lod_bench big_fly_a "$big_dir/taebak_x59_lod.rgs" --cameras "$taebak_cameras" \
      --fly 120 "${budget[@]}"
    bench_exe="$stage/ab/rgs-bench" lod_bench big_spiral_a "$big_dir/taebak_x59_lod.rgs" --path 120 "${budget[@]}"
  fi
fi
if [ "$what" = floor ] || [ "$what" = all ]; then
  # The true floor (docs/lab/ROOFLINE.md#the-true-floor) and the pairs behind saturated tiles
  # (docs/lab/OCCLUSION.md): faithful and fastest against what each view needs, counted by the CPU reference on
  # this host's cores, at 1080p and 4K, on the scenes' own views and on a camera path of 16 views (near and far,
  # low and high) that the scenes' cameras do not show.
  floor_bench() {  # NAME ARGS...
    local name="$1"
    shift
    local t0 rc=0
    t0=$(date +%s)
    "$bin/rgs-bench" "$@" --resolution 1920x1080 --resolution 3840x2160 --mode faithful --mode fastest --warmup 3 \
      --repeat 10 --json "$out/floor_$name.json" >"$out/floor_$name.log" 2>&1 || rc=$?
    [ $rc -ne 0 ] && status=1
    note "floor_$name: exit $rc in $(( $(date +%s) - t0 )) s"
    grep -v -e ' \.\.\.$' "$out/floor_$name.log" | tee -a "$summary"
  }
  if [ -f "$taebak" ]; then
    floor_bench taebak "$taebak" --cameras "$taebak_cameras" --floor
    floor_bench taebak_path "$taebak" --path 16 --floor
  fi
  floor_bench flowers "$RGS_DATA_DIR/mipnerf360_flowers_c3dgs.rgs" --path 16 --floor  # 173 own views: too long to count
  floor_bench daffodils "$RGS_DATA_DIR/playcanvas_flowers_lod0.rgs" --orbit 8 --floor
  floor_bench daffodils_path "$RGS_DATA_DIR/playcanvas_flowers_lod0.rgs" --path 16 --floor
fi
if [ "$what" = pybench ] || [ "$what" = all ]; then
  # roofgs.rasterization() on torch CUDA tensors against rgs-bench's fastest on the same views: taebak's 8
  # cameras at 1080p when prepared, else every 8th flowers camera (the module comes from the tests part, or is
  # built here by scripts/gpu_python.sh).
  if ! ls "$stage"/py/package/roofgs*.so >/dev/null 2>&1; then
    "$(dirname "${BASH_SOURCE[0]}")/gpu_python.sh" "$stage" "$out" >"$out/python.log" 2>&1 || status=1
  fi
  if [ -f "$taebak" ]; then
    pyscene=("$taebak" --cameras "$taebak_cameras")
  else
    pyscene=("$RGS_DATA_DIR/mipnerf360_flowers_c3dgs.rgs" --cameras "$RGS_DATA_DIR/mipnerf360_flowers_cameras.json"
             --every 8)
  fi
  rc=0
  PYTHONPATH="$stage/py/package" python3 "$(dirname "${BASH_SOURCE[0]}")/bench_python_rasterization.py" \
    "${pyscene[@]}" --resolution 1920x1080 --rgs-bench "$bin/rgs-bench" --out "$out/python_bench" \
    >"$out/python_bench.log" 2>&1 || rc=$?
  [ $rc -ne 0 ] && status=1
  note "python_bench: exit $rc"
  grep -E "^(device|python|rgs-bench|view)" "$out/python_bench.log" | tee -a "$summary"
fi
if [ "$what" = audit ] || [ "$what" = all ]; then
  # What the conversion cost, on the GPU: every flowers camera at its native 5025x3312, and taebak's cameras
  # at 4K against its SOG source, each with its HTML report, JSON and images.
  audit() {  # NAME ARGS...
    local name="$1"
    shift
    local t0 rc=0
    t0=$(date +%s%N)
    "$bin/rgs-audit" "$@" --backend cuda --report "$out/audit_$name.html" >"$out/audit_$name.log" 2>&1 || rc=$?
    [ $rc -ne 0 ] && status=1
    note "audit_$name: exit $rc in $(( ($(date +%s%N) - t0) / 1000000 )) ms wall; $(grep -E '^  PSNR ' "$out/audit_$name.log" | head -1)"
  }
  audit flowers "$RGS_DATA_DIR/mipnerf360_flowers_c3dgs.ply" "$RGS_DATA_DIR/mipnerf360_flowers_c3dgs.rgs" \
    --cameras "$RGS_DATA_DIR/mipnerf360_flowers_cameras.json"
  # Every storage profile and output format of flowers against its PLY, the interop table's method (every 4th
  # camera at 960 px wide), in one run.
  t0=$(date +%s%N)
  rc=0
  RGS_TOOLS_DIR="$bin" RGS_CURVE_TARGETS="" "$(dirname "${BASH_SOURCE[0]}")/audit_formats.sh" \
    "$RGS_DATA_DIR/mipnerf360_flowers_c3dgs.ply" "$out/formats" --cameras "$RGS_DATA_DIR/mipnerf360_flowers_cameras.json" \
    --every 4 --width 960 --backend cuda >"$out/audit_formats_flowers.log" 2>&1 || rc=$?
  [ $rc -ne 0 ] && status=1
  note "audit_formats_flowers: exit $rc in $(( ($(date +%s%N) - t0) / 1000000 )) ms wall"
  grep -A7 "candidate          format" "$out/audit_formats_flowers.log" | tee -a "$summary"
  if [ -f "$taebak" ]; then
    t0=$(date +%s%N)
    rc=0
    RGS_TOOLS_DIR="$bin" RGS_CURVE_TARGETS="" "$(dirname "${BASH_SOURCE[0]}")/audit_formats.sh" \
      "$taebak_dir/taebak_lod0_sog/lod-meta.json" "$out/formats" --cameras "$taebak_cameras" --backend cuda >"$out/audit_formats_taebak.log" 2>&1 || rc=$?
    [ $rc -ne 0 ] && status=1
    note "audit_formats_taebak: exit $rc in $(( ($(date +%s%N) - t0) / 1000000 )) ms wall"
    grep -A7 "candidate          format" "$out/audit_formats_taebak.log" | tee -a "$summary"
    audit taebak_4k "$taebak_dir/taebak_lod0_sog/lod-meta.json" "$taebak" --cameras "$taebak_cameras" --width 3840 \
      --height 2160
  fi
fi
if [ "$what" = fidelity ] || [ "$what" = all ]; then
  # Each preset against faithful's render of the source (rgs-bench --quality --reference): what the conversion
  # and the preset's approximations cost together (docs/AUDITS.md#fidelity-of-the-presets), for the default
  # conversion (with the DC residual) and the paper's INT8 DC term (--sh-dc-bits 8), both converted here.
  fid=/tmp/rgs_fidelity
  mkdir -p "$fid"
  fidelity() {  # NAME SOURCE CAMERA_ARGS...
    local name="$1" source="$2" dc rc
    shift 2
    for dc in 16 8; do
      rc=0
      "$bin/rgs-convert" -q "$source" "$fid/$name.dc$dc.rgs" --sh-dc-bits "$dc" || rc=$?
      "$bin/rgs-bench" "$fid/$name.dc$dc.rgs" "$@" --resolution 1920x1080 --resolution 3840x2160 --mode faithful \
        --mode fastest --warmup 1 --repeat 3 --quality --reference "$source" --json "$out/fidelity_${name}_dc$dc.json" \
        >"$out/fidelity_${name}_dc$dc.log" 2>&1 || rc=$?
      [ $rc -ne 0 ] && status=1
      note "fidelity_${name}_dc$dc: exit $rc; $(stat -c %s "$fid/$name.dc$dc.rgs" 2>/dev/null) bytes"
      grep -A5 "^  quality" "$out/fidelity_${name}_dc$dc.log" | tee -a "$summary"
    done
    # What each attribute of the default conversion costs alone (rgs-audit --attribution).
    rc=0
    "$bin/rgs-audit" "$source" "$fid/$name.dc16.rgs" "$@" --attribution --backend cuda --no-report \
      >"$out/attribution_$name.log" 2>&1 || rc=$?
    [ $rc -ne 0 ] && status=1
    note "attribution_$name: exit $rc"
    grep -A7 "candidate          format" "$out/attribution_$name.log" | tee -a "$summary"
  }
  fidelity guitar "$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/samples/guitar.ply" --orbit 8
  fidelity flowers "$RGS_DATA_DIR/mipnerf360_flowers_c3dgs.ply" --cameras "$RGS_DATA_DIR/mipnerf360_flowers_cameras.json" \
    --every 8
  [ -f "$RGS_DATA_DIR/biker.ply" ] && fidelity biker "$RGS_DATA_DIR/biker.ply" --orbit 8
  # daffodils' PLY (89 MB) travels only when copied into the data folder by hand.
  [ -f "$RGS_DATA_DIR/playcanvas_flowers_lod0.ply" ] && fidelity daffodils "$RGS_DATA_DIR/playcanvas_flowers_lod0.ply" \
    --orbit 8
  [ -f "$taebak" ] && fidelity taebak "$taebak_dir/taebak_lod0_sog/lod-meta.json" --cameras "$taebak_cameras"
  [ -f "$taebak" ] && fidelity taebak_path "$taebak_dir/taebak_lod0_sog/lod-meta.json" --path 16
fi
if [ "$what" = rate ] || [ "$what" = all ]; then
  # Rate control on the GPU (rgs-convert --target-psnr; docs/AUDITS.md, "Rate control of the archive profile"):
  # flowers over every 8th camera at 960 px wide and taebak over its cameras, at 35, 40 and 45 dB
  # ($RGS_RATE_TARGETS; taebak's archive encodes in seconds a candidate, so its searches take minutes).
  rate=/tmp/rgs_rate
  mkdir -p "$rate"
  rate_control() {  # NAME SOURCE CAMERA_ARGS...
    local name="$1" source="$2" target rc t0
    shift 2
    for target in ${RGS_RATE_TARGETS:-35 40 45}; do
      rc=0
      t0=$(date +%s%N)
      "$bin/rgs-convert" "$source" "$rate/$name.$target.rgs" --target-psnr "$target" "$@" \
        >"$out/rate_${name}_$target.log" 2>&1 || rc=$?
      [ $rc -ne 0 ] && status=1
      note "rate_${name}_$target: exit $rc in $(( ($(date +%s%N) - t0) / 1000000 )) ms; $(grep -m1 -iE 'reached' \
        "$out/rate_${name}_$target.log")"
    done
  }
  rate_control flowers "$RGS_DATA_DIR/mipnerf360_flowers_c3dgs.ply" --cameras \
    "$RGS_DATA_DIR/mipnerf360_flowers_cameras.json" --every 8 --width 960
  [ -f "$taebak" ] && rate_control taebak "$taebak_dir/taebak_lod0_sog/lod-meta.json" --cameras "$taebak_cameras"
fi
if [ "$what" = sanitize ] || [ "$what" = all ]; then
  # compute-sanitizer's four tools (memcheck, racecheck, synccheck, initcheck) on one frame of every preset at
  # 1080p and 4K: rgs-render --backend cuda of each scene's first camera (taebak when prepared). Each run's
  # error summary goes to the summary, its log to sanitize/; any error or failed run fails the script.
  # $RGS_SANITIZE_SCENES and $RGS_SANITIZE_PRESETS pick scenes and presets (default: all three of each).
  sanitizer="$(command -v compute-sanitizer || echo /usr/local/cuda/bin/compute-sanitizer)"
  mkdir -p "$out/sanitize" /tmp/rgs_sanitize
  read -r -a sanitize_scenes <<<"${RGS_SANITIZE_SCENES:-flowers daffodils taebak}"
  [ -f "$taebak" ] || sanitize_scenes=("${sanitize_scenes[@]/taebak/}")
  errors=0
  runs=0
  for scene in "${sanitize_scenes[@]}"; do
    case $scene in
      flowers) input=("$RGS_DATA_DIR/mipnerf360_flowers_c3dgs.rgs" --cameras "$RGS_DATA_DIR/mipnerf360_flowers_cameras.json") ;;
      daffodils) input=("$RGS_DATA_DIR/playcanvas_flowers_lod0.rgs" --orbit 1) ;;
      taebak) input=("$taebak" --cameras "$taebak_cameras") ;;
    esac
    for preset in ${RGS_SANITIZE_PRESETS:-fastest faithful paper}; do
      for size in 1920x1080 3840x2160; do
        tools=(memcheck racecheck synccheck initcheck)
        render=("$bin/rgs-render" "${input[@]}" --limit 1 --width "${size%x*}" --height "${size#*x}" --backend cuda
                --preset "$preset" --format ppm)
        for tool in "${tools[@]}"; do  # the four at once, each its own process and output folder
          name="${scene}_${preset}_${size}_$tool"
          if [ "$tool" = synccheck ]; then
            # One process per kernel launch of the frame (a frame has fewer than 24): a whole frame under synccheck
            # ran for more than 9 minutes on taebak, its launches one at a time take seconds. The log holds every
            # launch's; the exit status is the worst.
            (worst=0
             for k in $(seq 0 23); do
               (timeout 900 "$sanitizer" --tool synccheck --error-exitcode 9 --launch-skip "$k" --launch-count 1 \
                  "${render[@]}" -o "/tmp/rgs_sanitize/${name}_$k" >"/tmp/rgs_sanitize/${name}_$k.log" 2>&1
                echo $? >"/tmp/rgs_sanitize/${name}_$k.rc") &
             done
             wait
             for k in $(seq 0 23); do
               cat "/tmp/rgs_sanitize/${name}_$k.log"
               rc=$(cat "/tmp/rgs_sanitize/${name}_$k.rc")
               [ "$rc" -gt "$worst" ] && worst=$rc
             done >"$out/sanitize/$name.log"
             echo "$worst" >"$out/sanitize/$name.rc") &
            continue
          fi
          (timeout 900 "$sanitizer" --tool "$tool" --error-exitcode 9 "${render[@]}" -o "/tmp/rgs_sanitize/$name" \
             >"$out/sanitize/$name.log" 2>&1
           echo $? >"$out/sanitize/$name.rc") &
        done
        wait
        for tool in "${tools[@]}"; do
          name="${scene}_${preset}_${size}_$tool"
          rc=$(cat "$out/sanitize/$name.rc")
          runs=$((runs + 1))
          # "ERROR SUMMARY: N errors" (memcheck, synccheck, initcheck); "RACECHECK SUMMARY: N hazards ..." (racecheck).
          found=$(grep -hoE "(ERROR|RACECHECK) SUMMARY: [0-9]+" "$out/sanitize/$name.log" | grep -oE "[0-9]+$" | tail -1)
          if [ "$rc" -ne 0 ] || [ "${found:-x}" != 0 ]; then
            errors=$((errors + 1))
            status=1
            note "sanitize $scene $preset $size $tool: exit $rc, $(grep -hE "SUMMARY" "$out/sanitize/$name.log" | tail -1)"
          fi
        done
      done
    done
  done
  note "sanitize: $runs runs (memcheck, racecheck, synccheck, initcheck x presets x 1080p/4K x ${sanitize_scenes[*]}), $errors with errors"
fi
if [ "$what" = view ] || [ "$what" = all ]; then
  # The viewer (docs/VIEWER.md#performance): rgs-view serving a scene on this GPU and rgs-view-bench, a scripted
  # WebSocket client on loopback, flying 600 views through taebak's cameras at 1920x1080 and 3840x2160 (JPEG; one
  # and two views in flight) and along a path of 600 views, then through the x16 taebak level-of-detail file
  # (rgs-bench --replicate 16 --save-lod) under a 3M splat budget and 4 GiB.
  view_bench() {  # NAME SCENE [rgs-view options...] -- [rgs-view-bench options...]
    local name="$1" scene="$2" url="" rc=0 server_args=() bench_args=()
    shift 2
    while [ $# -gt 0 ] && [ "$1" != -- ]; do server_args+=("$1"); shift; done
    [ $# -gt 0 ] && shift
    bench_args=("$@")
    "${view_server:-$bin/rgs-view}" "$scene" --backend cuda --port 0 "${server_args[@]}" >"$out/view_${name}_server.log" 2>&1 &
    local server=$!
    for _ in $(seq 1 600); do  # loading the scene: up to 120 s
      url=$(grep -om1 "http://127.0.0.1:[0-9]*/[^ ]*" "$out/view_${name}_server.log")
      [ -n "$url" ] && break
      kill -0 $server 2>/dev/null || break
      sleep 0.2
    done
    if [ -z "$url" ]; then
      note "view_$name: the server did not start: $(tail -2 "$out/view_${name}_server.log")"
      kill $server 2>/dev/null; status=1; return
    fi
    "$bin/rgs-view-bench" "$url" -q "${bench_args[@]}" --json "$out/view_$name.json" >"$out/view_$name.log" 2>&1 || rc=$?
    kill -TERM $server; wait $server || rc=$?
    [ $rc -ne 0 ] && status=1
    note "view_$name: exit $rc"
    grep -m1 "^rgs-view: frames " "$out/view_${name}_server.log" | tee -a "$summary"
    grep -E "frames|latency|bytes/frame|budget|server medians" "$out/view_$name.log" | tee -a "$summary"
  }
  note "view: nvJPEG on this host: $( (ldconfig -p | grep -o 'libnvjpeg.so[.0-9]*' | sort -u; ls /usr/local/cuda/lib64/libnvjpeg.so.* 2>/dev/null) | tr '\n' ' ')"
  if [ -f "$taebak" ]; then
    fly=(--cameras "$taebak_cameras" --fly 600 --width 1920 --height 1080 --warmup 16)
    fly4k=(--cameras "$taebak_cameras" --fly 600 --width 3840 --height 2160 --warmup 16)
    view_bench taebak_jpeg "$taebak" -- "${fly[@]}"
    view_bench taebak_jpeg_4k "$taebak" -- "${fly4k[@]}"
    # The same flights with frames encoded on the CPU (--cpu-jpeg): what the GPU encoder changes.
    view_bench taebak_cpujpeg "$taebak" --cpu-jpeg -- "${fly[@]}"
    view_bench taebak_cpujpeg_4k "$taebak" --cpu-jpeg -- "${fly4k[@]}"
    # A/B: another build's rgs-view (STAGE_DIR/ab/rgs-view.xz, e.g. the landed tree's) on the same flights.
    if [ -f "$stage/ab/rgs-view.xz" ]; then
      xz -dkf "$stage/ab/rgs-view.xz" && chmod +x "$stage/ab/rgs-view"
      view_server="$stage/ab/rgs-view" view_bench a_taebak_jpeg "$taebak" -- "${fly[@]}"
      view_server="$stage/ab/rgs-view" view_bench a_taebak_jpeg_4k "$taebak" -- "${fly4k[@]}"
    fi
    view_bench taebak_jpeg_2 "$taebak" -- "${fly[@]}" --in-flight 2
    # A camera path the scene's cameras do not show (near and far, low and high; rgs-bench --path).
    view_bench taebak_jpeg_path "$taebak" -- --path 600 --width 1920 --height 1080 --warmup 16
    view_bench taebak_jpeg_path_4k "$taebak" -- --path 600 --width 3840 --height 2160 --warmup 16
    view_bench taebak_webp "$taebak" -- "${fly[@]}" --encoding webp
    # The bandwidth budget (docs/VIEWER.md#bandwidth-budget): the 1080p flight through the bench's shaping relay,
    # 50 Mbit/s and 20 ms round trip, without a budget and with one of 50 Mbit/s, and the PSNR
    # of every 10th frame against the lossless frame of its view.
    shaped=(--shape-mbps 50 --shape-rtt-ms 20 --psnr-every 10)
    view_bench taebak_jpeg_shaped "$taebak" -- "${fly[@]}" "${shaped[@]}"
    view_bench taebak_jpeg_shaped_budget "$taebak" -- "${fly[@]}" "${shaped[@]}" --max-mbps 50
    x16="$taebak_dir/taebak_x16_lod.rgs"
    if [ ! -f "$x16" ]; then
      "$bin/rgs-bench" "$taebak" --replicate 16 --cameras "$taebak_cameras" --limit 2 --splat-budget 3000000 \
        --memory-budget 3GiB --scratch-budget 1GiB --save-lod "$x16" >"$out/view_x16_build.log" 2>&1 || status=1
    fi
    view_bench taebak_x16_lod "$x16" --splat-budget 3000000 --memory-budget 3GiB --scratch-budget 1GiB -- \
      "${fly[@]}"
    view_bench taebak_x16_lod_2 "$x16" --splat-budget 3000000 --memory-budget 3GiB --scratch-budget 1GiB -- \
      "${fly[@]}" --in-flight 2
  else
    note "view: no taebak (scripts/gpu_prepare_taebak.sh first)"
  fi
fi
if [ "$what" = cards ]; then
  # taebak's quality card and rate-distortion curve (docs/AUDITS.md#quality-cards): audit_formats.sh against its
  # SOG source on its cameras, with $RGS_FORMATS and $RGS_CURVE_TARGETS (a long audit splits over several calls;
  # scripts/quality_cards.py merges their JSONs). The JSON comes back as OUT_DIR/taebak.audit.json.
  if [ -f "$taebak" ]; then
    t0=$(date +%s%N)
    rc=0
    RGS_TOOLS_DIR="$bin" "$(dirname "${BASH_SOURCE[0]}")/audit_formats.sh" "$taebak_dir/taebak_lod0_sog/lod-meta.json" \
      /tmp/rgs_cards --cameras "$taebak_cameras" >"$out/cards_taebak.log" 2>&1 || rc=$?
    [ $rc -ne 0 ] && status=1
    note "cards_taebak: exit $rc in $(( ($(date +%s%N) - t0) / 1000000 )) ms wall"
    grep -E "^audit_formats: " "$out/cards_taebak.log" | tee -a "$summary"
    grep -A24 "candidate          format" "$out/cards_taebak.log" | tee -a "$summary"
    cp /tmp/rgs_cards/taebak_lod0_sog.audit.json "$out/taebak.audit.json" 2>/dev/null
  else
    note "cards: no taebak (scripts/gpu_prepare_taebak.sh first)"
    status=1
  fi
fi
echo
echo "=== summary ==="
cat "$summary"
exit $status
