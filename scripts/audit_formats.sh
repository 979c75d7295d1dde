#!/usr/bin/env bash
# The size/quality table of every storage profile and output format for one scene, in one rgs-audit run: the
# source is converted to each candidate below, then rendered once per view against all of them (PSNR/SSIM of
# each candidate's decode against the FP32 render of the source; bytes per Gaussian from each file).
#   runtime         .rgs default (mapped as is)       zstd      .rgs --zstd all (lossless)
#   int8dc          .rgs --sh-dc-bits 8 (the paper's INT8 DC term, without the DC residual)
#   archive         .rgs --profile archive            spz       SPZ v4 written by rgs-convert
#   glb             KHR_gaussian_splatting GLB        extra     any files given after -- (e.g. other tools' outputs)
# Usage: scripts/audit_formats.sh SOURCE OUT_DIR [rgs-audit camera options...] [-- EXTRA_CANDIDATE...]
#   e.g. scripts/audit_formats.sh flowers.ply out --cameras cameras.json --every 4 --width 960
# Tools from $RGS_TOOLS_DIR, else $RGS_BUILD_DIR/tools (default build/tools). Writes OUT_DIR/<scene>.<candidate>.* and OUT_DIR/<scene>.audit.html/.json.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
tools="${RGS_TOOLS_DIR:-${RGS_BUILD_DIR:-$root/build}/tools}"
[ $# -ge 2 ] || { sed -n 2,11p "${BASH_SOURCE[0]}" >&2; exit 2; }
source="$1"
out="$2"
shift 2
audit_args=()
extra=()
while [ $# -gt 0 ]; do
  if [ "$1" = "--" ]; then shift; extra=("$@"); break; fi
  audit_args+=("$1")
  shift
done
mkdir -p "$out"
name="$(basename "$source")"
name="${name%%.*}"
convert() {  # LABEL FILE ARGS...: one candidate, its conversion time on stderr
  local label="$1" file="$2"
  shift 2
  local t0=$(date +%s%N)
  "$tools/rgs-convert" -q "$source" "$file" "$@"
  echo "audit_formats: $label converted in $(( ($(date +%s%N) - t0) / 1000000 )) ms" >&2
}
convert runtime "$out/$name.runtime.rgs"
convert int8dc "$out/$name.int8dc.rgs" --sh-dc-bits 8
convert zstd "$out/$name.zstd.rgs" --zstd all
convert archive "$out/$name.archive.rgs" --profile archive
convert spz "$out/$name.spz" --to spz
convert glb "$out/$name.glb" --to glb
candidates=("$out/$name.runtime.rgs" "$out/$name.int8dc.rgs" "$out/$name.zstd.rgs" "$out/$name.archive.rgs" "$out/$name.spz" "$out/$name.glb")
labels=(--label runtime --label int8dc --label zstd --label archive --label spz --label glb)
for f in "${extra[@]}"; do
  candidates+=("$f")
  labels+=(--label "$(basename "$f")")
done
"$tools/rgs-audit" "$source" "${candidates[@]}" "${labels[@]}" "${audit_args[@]}" --report "$out/$name.audit.html"
