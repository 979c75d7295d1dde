#!/usr/bin/env bash
# Builds the fuzz configuration with clang (libraries instrumented with -fsanitize=fuzzer-no-link, ASan and
# UBSan; cmake/RgsTargets.cmake) and runs every libFuzzer target of tests/fuzz for a bounded time, one after
# the other. Prints the edges covered (libFuzzer's final `cov:`) and the executions of each target, and
# exits non-zero if any target crashed, leaked, hit undefined behaviour, timed out or broke a property
# check. Crashing inputs are kept in $RGS_FUZZ_OUT/crashes/<target>/ and listed at the end.
#
#   scripts/run_fuzzers.sh [seconds-per-target]          # default 60
#
# Environment: RGS_BUILD_DIR (default build-fuzz), RGS_FUZZ_OUT (default $RGS_BUILD_DIR/fuzz-out, where the
# corpus each run grows is kept between runs), RGS_FUZZ_JOBS (build parallelism, default nproc).
# Needs clang, libclang-rt-dev (libFuzzer and the sanitizer runtimes) and llvm (llvm-symbolizer for the
# stack traces), besides the packages of scripts/install_deps.sh.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
seconds="${1:-60}"
build="${RGS_BUILD_DIR:-$root/build-fuzz}"
out="${RGS_FUZZ_OUT:-$build/fuzz-out}"
jobs="${RGS_FUZZ_JOBS:-$(nproc)}"
targets=(rgs_read ply_read interop_read ksplat_read sog_meta sog_folder gltf_json zip render_cpu camera_json view_message
         view_request)

if ! [[ "$seconds" =~ ^[0-9]+$ ]] || [ "$seconds" -lt 1 ]; then
  echo "run_fuzzers: seconds per target must be a positive integer, got '$seconds'" >&2
  exit 2
fi
for tool in clang clang++; do
  if ! command -v "$tool" >/dev/null; then
    echo "run_fuzzers: $tool not found (apt-get install clang libclang-rt-14-dev llvm)" >&2
    exit 2
  fi
done

# -O1 with line tables only, as OSS-Fuzz builds its fuzzers (CONTRIBUTING.md#tests): the sanitizers' reports still
# name file and line.
CC=clang CXX=clang++ cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O1 -gline-tables-only -DNDEBUG" \
  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -gline-tables-only -DNDEBUG" \
  -DRGS_BUILD_FUZZERS=ON -DRGS_WITH_CUDA=OFF -DRGS_BUILD_TESTS=ON -DRGS_BUILD_TOOLS=OFF \
  -DRGS_BUILD_SAMPLES=OFF -DRGS_INSTALL=OFF -DRGS_WITH_OPENIMAGEIO=OFF >/dev/null
cmake --build "$build" --parallel "$jobs" --target "${targets[@]/#/fuzz_}"

# Seed corpora: tests/fuzz/corpus/<target>/ (made from guitar by tests/fuzz/make_fuzz_corpus.py) and the golden
# and must-fail files of tests/data, the hostile scenes of tests/data/hostile included (CTest's replays leave
# those to test_converter, which reads them in a child process with a memory limit). libFuzzer writes what
# it finds into the first directory only.
seeds_rgs_read=("$root/tests/fuzz/corpus/rgs_read" "$root/tests/data/v1.0" "$root/tests/data/v1.2" "$root/tests/data/bad"
                "$root/tests/data/bad/archive")
seeds_ply_read=("$root/tests/fuzz/corpus/ply_read" "$root/tests/data/bad")
seeds_interop_read=("$root/tests/fuzz/corpus/interop_read" "$root/tests/data/interop" "$root/tests/data/sog")
seeds_ksplat_read=("$root/tests/fuzz/corpus/ksplat_read" "$root/tests/data/ksplat" "$root/tests/data/hostile/ksplat")
seeds_sog_meta=("$root/tests/fuzz/corpus/sog_meta")
seeds_sog_folder=("$root/tests/fuzz/corpus/sog_folder")
seeds_gltf_json=("$root/tests/fuzz/corpus/gltf_json" "$root/tests/data/hostile/gltf"
                 "$root/tests/data/hostile/gltf_escape")
seeds_zip=("$root/tests/fuzz/corpus/zip" "$root/tests/data/sog" "$root/tests/data/hostile/sog_bundle")
seeds_render_cpu=("$root/tests/fuzz/corpus/render_cpu")
seeds_camera_json=("$root/tests/fuzz/corpus/camera_json")
seeds_view_message=("$root/tests/fuzz/corpus/view_message")
seeds_view_request=("$root/tests/fuzz/corpus/view_request")
args_rgs_read=(-max_len=16384 "-dict=$root/tests/fuzz/fuzz_rgs_read.dict")
args_ply_read=(-max_len=8192 "-dict=$root/tests/fuzz/fuzz_ply_read.dict")
args_interop_read=(-max_len=20480 "-dict=$root/tests/fuzz/fuzz_interop_read.dict")
args_ksplat_read=(-max_len=16384 "-dict=$root/tests/fuzz/fuzz_ksplat_read.dict")
args_sog_meta=(-max_len=16384 "-dict=$root/tests/fuzz/fuzz_sog_meta.dict")
args_sog_folder=(-max_len=16384 "-dict=$root/tests/fuzz/fuzz_sog_folder.dict")
args_gltf_json=(-max_len=16384 "-dict=$root/tests/fuzz/fuzz_gltf_json.dict")
args_zip=(-max_len=32768 "-dict=$root/tests/fuzz/fuzz_zip.dict")
args_render_cpu=(-max_len=4096)
args_camera_json=(-max_len=4096 "-dict=$root/tests/fuzz/fuzz_camera_json.dict")
args_view_message=(-max_len=70000)
args_view_request=(-max_len=9000 "-dict=$root/tests/fuzz/fuzz_view_request.dict")

export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:allocator_may_return_null=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
symbolizer="$(command -v llvm-symbolizer || ls /usr/lib/llvm-*/bin/llvm-symbolizer 2>/dev/null | tail -n 1 || true)"
if [ -n "$symbolizer" ]; then export ASAN_SYMBOLIZER_PATH="$symbolizer"; fi

failed=()
summary=()
for t in "${targets[@]}"; do
  corpus="$out/corpus/$t"
  crashes="$out/crashes/$t"
  log="$out/logs/$t.log"
  mkdir -p "$corpus" "$crashes" "$(dirname "$log")"
  seeds_var="seeds_${t}[@]"
  args_var="args_${t}[@]"
  echo "== fuzz_$t for ${seconds}s (log: $log)"
  status=0
  # -timeout: an input running over 10 s is a hang; -rss_limit_mb: one over 2 GiB is a memory blow-up.
  (cd "$crashes" && "$build/tests/fuzz/fuzz_$t" "${!args_var}" -max_total_time="$seconds" -timeout=10 \
      -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$crashes/" "$corpus" "${!seeds_var}") \
      >"$log" 2>&1 || status=$?
  # Edges: the final DONE line, or the last report before a crash.
  cov="$(grep -Eo 'cov: [0-9]+' "$log" | tail -n 1 | grep -Eo '[0-9]+$' || echo '?')"
  execs="$(grep -Eo 'stat::number_of_executed_units: [0-9]+' "$log" | grep -Eo '[0-9]+$' || echo '?')"
  units="$(ls "$corpus" | wc -l)"
  line="fuzz_$t: cov $cov edges, $execs executions in ${seconds}s, corpus $units files"
  if [ "$status" -ne 0 ]; then
    line="$line: FAILED (exit $status)"
    failed+=("$t")
    # The line after a broken property holds the Status that broke it.
    grep -E -A1 '^(==[0-9]+==ERROR|SUMMARY|.*runtime error|.*fuzz property failed|artifact_prefix|Test unit written)' \
      "$log" | grep -v '^--$' | head -n 12 | sed 's/^/    /'
  fi
  echo "$line"
  summary+=("$line")
done

echo
echo "Fuzzing summary (${seconds}s per target):"
printf '  %s\n' "${summary[@]}"
if [ ${#failed[@]} -ne 0 ]; then
  echo "Crashing inputs kept under $out/crashes/:"
  find "$out/crashes" -type f | sed 's/^/  /'
  exit 1
fi
