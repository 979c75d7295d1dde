#!/usr/bin/env bash
# Benchmark of rgs-convert: wall time, PLY input throughput and peak RSS of whole conversions.
#
#   scripts/bench_convert.sh [PLY] [REPEATS] [extra rgs-convert options...]
#
# Default PLY: $RGS_DATA_DIR/playcanvas_flowers_lod0.ply (the 542k-Gaussian daffodils scene), 5 repeats after
# one unmeasured warm-up run (so the input is in the page cache: this measures the converter, not the disk).
# Prints one line per run and a Markdown summary row with the medians and the converter's memory budget:
# peak RSS <= input bytes + output bytes + 64 MiB.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${RGS_BUILD_DIR:-$root/build}"
data="${RGS_DATA_DIR:-$root/data}"
ply="${1:-$data/playcanvas_flowers_lod0.ply}"
repeats="${2:-5}"
shift $(( $# > 2 ? 2 : $# )) || true
convert="$build/tools/rgs-convert"
[ -x "$convert" ] || { echo "bench_convert: build first ($convert missing)" >&2; exit 1; }
[ -f "$ply" ] || { echo "bench_convert: $ply: no such file" >&2; exit 1; }
command -v /usr/bin/time >/dev/null || { echo "bench_convert: needs GNU time (apt-get install time)" >&2; exit 1; }

# Other work on the machine shows up directly in the wall times: print the load so a noisy run is visible.
echo "load average before the runs: $(cut -d' ' -f1-3 /proc/loadavg) ($(nproc) CPUs)"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
"$convert" -q "$ply" "$out/warmup.rgs" "$@"

walls=(); rss=()
for i in $(seq 1 "$repeats"); do
  /usr/bin/time -f "%e %M" -o "$out/time.txt" "$convert" -q "$ply" "$out/run.rgs" "$@"
  read -r wall kb < "$out/time.txt"
  walls+=("$wall"); rss+=("$kb")
  echo "run $i: wall ${wall} s, peak RSS $((kb / 1024)) MiB"
done

in_bytes=$(stat -c %s "$ply")
out_bytes=$(stat -c %s "$out/run.rgs")
median() { printf '%s\n' "$@" | sort -g | awk '{a[NR]=$1} END {print (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }
wall_med=$(median "${walls[@]}")
rss_med_kb=$(median "${rss[@]}")
awk -v in_b="$in_bytes" -v out_b="$out_bytes" -v wall="$wall_med" -v rss_kb="$rss_med_kb" \
    -v name="$(basename "$ply")" -v cpus="$(nproc)" -v opts="$*" 'BEGIN {
  mbps = in_b / 1e6 / wall
  rss = rss_kb * 1024
  budget = in_b + out_b + 64 * 1048576
  printf "\n| scene | input MB | output MB | wall s (median) | MB/s | peak RSS MiB | budget MiB | cores | options |\n"
  printf "|---|---|---|---|---|---|---|---|---|\n"
  printf "| %s | %.1f | %.1f | %.3f | %.0f | %.1f | %.1f | %d | %s |\n", name, in_b/1e6, out_b/1e6, wall, mbps,
         rss/1048576, budget/1048576, cpus, (opts == "" ? "defaults" : opts)
  printf "\nthroughput target >= 300 MB/s: %s; memory target: %s\n", (mbps >= 300 ? "met" : "NOT met"),
         (rss <= budget ? "met" : "NOT met")
}'
