#!/usr/bin/env bash
# One scene in every storage profile and output format, and the archive profile's rate-distortion curve, audited
# in one rgs-audit run (the source rendered once per view): PSNR/SSIM of each candidate's decode against the FP32
# render of the source, bytes per Gaussian from each file. Candidates (labels in the report):
#   runtime         .rgs default (mapped as is)        zstd      .rgs --zstd all (lossless)
#   int8dc          .rgs --sh-dc-bits 8 (the paper's INT8 DC term, without the DC residual)
#   archive         .rgs --profile archive (defaults)  spz       SPZ v4 by rgs-convert (the spz library's settings)
#   glb             KHR_gaussian_splatting GLB         ($RGS_FORMATS: which of these six; default all)
#   archive@T       .rgs --target-psnr T for each T of $RGS_CURVE_TARGETS (default "35 40 45 50 55 60 spz"):
#                   the curve; T = spz fits SPZ's mean PSNR on the same views, measured first
#   sog, compressed.ply   splat-transform's SOG (its CPU path) and compressed PLY, when $SPLAT_TRANSFORM (a
#                   command) is set or splat-transform is on PATH (npm install @playcanvas/splat-transform)
#   extra           any files given after -- (e.g. shipped files of other tools)
# The camera options go to rgs-audit and to the rate control of rgs-convert alike, so the fits are measured on
# the views of the audit. Writes OUT_DIR/<scene>.<candidate>.* and OUT_DIR/<scene>.audit.html/.json;
# scripts/quality_cards.py turns the JSONs of several scenes into the quality cards of docs/AUDITS.md.
# Usage: scripts/audit_formats.sh SOURCE OUT_DIR [rgs-audit camera options...] [-- EXTRA_CANDIDATE...]
#   e.g. scripts/audit_formats.sh flowers.ply out --cameras cameras.json --every 4 --width 960
# Tools from $RGS_TOOLS_DIR, else $RGS_BUILD_DIR/tools (default build/tools).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
tools="${RGS_TOOLS_DIR:-${RGS_BUILD_DIR:-$root/build}/tools}"
[ $# -ge 2 ] || { sed -n 2,21p "${BASH_SOURCE[0]}" >&2; exit 2; }
source="$1"
out="$2"
shift 2
audit_args=()   # to rgs-audit
camera_args=()  # to rgs-convert's rate control: the same, less the audit's own options
extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --) shift; extra=("$@"); break ;;
    --backend|--threads|--device) audit_args+=("$1" "$2"); shift 2; continue ;;
  esac
  audit_args+=("$1")
  camera_args+=("$1")
  shift
done
formats="${RGS_FORMATS-runtime int8dc zstd archive spz glb}"
targets="${RGS_CURVE_TARGETS-35 40 45 50 55 60 spz}"
splat_transform="${SPLAT_TRANSFORM:-$(command -v splat-transform || true)}"
mkdir -p "$out"
name="$(basename "$source")"
case "$name" in lod-meta.json|meta.json) name="$(basename "$(dirname "$source")")" ;; esac
name="${name%%.*}"
log() { echo "audit_formats: $*" >&2; }
since() { echo "$(( ($(date +%s%N) - $1) / 1000000 )) ms"; }
convert() {  # LABEL FILE ARGS...: one candidate, its conversion time on stderr
  local label="$1" file="$2" t0
  shift 2
  t0=$(date +%s%N)
  "$tools/rgs-convert" -q "$source" "$file" "$@"
  log "$label converted in $(since "$t0")"
}
candidates=()
labels=()
add() { candidates+=("$1"); labels+=(--label "$2"); }
has() { [[ " $1 " == *" $2 "* ]]; }  # LIST WORD
for kind in $formats; do
  case "$kind" in
    runtime) convert runtime "$out/$name.runtime.rgs" ;;
    int8dc) convert int8dc "$out/$name.int8dc.rgs" --sh-dc-bits 8 ;;
    zstd) convert zstd "$out/$name.zstd.rgs" --zstd all ;;
    archive) convert archive "$out/$name.archive.rgs" --profile archive ;;
    spz) convert spz "$out/$name.spz" --to spz; add "$out/$name.spz" spz; continue ;;
    glb) convert glb "$out/$name.glb" --to glb; add "$out/$name.glb" glb; continue ;;
    *) log "RGS_FORMATS: unknown format $kind"; exit 2 ;;
  esac
  add "$out/$name.$kind.rgs" "$kind"
done
if [ -n "$splat_transform" ]; then
  for kind in sog compressed.ply; do
    t0=$(date +%s%N)
    if $splat_transform -q -w -g cpu "$source" "$out/$name.st.$kind"; then
      log "splat-transform $kind written in $(since "$t0")"
      add "$out/$name.st.$kind" "$kind"
    else
      log "splat-transform $kind failed (above: why); left out"
    fi
  done
else
  log "no splat-transform (set SPLAT_TRANSFORM or put it on PATH): no SOG or compressed PLY candidate"
fi

# The curve: the rate control's fit at each target; at SPZ's own mean PSNR on these views for "spz".
for t in $targets; do
  db="$t"
  if [ "$t" = spz ]; then
    has "$formats" spz || convert spz "$out/$name.spz" --to spz
    t0=$(date +%s%N)
    db="$("$tools/rgs-audit" -q "$source" "$out/$name.spz" "${audit_args[@]}" --no-report --json - |
      python3 -c 'import json, sys; print("%.2f" % json.load(sys.stdin)["candidates"][0]["psnr_db"]["mean"])')"
    log "spz: mean PSNR $db dB on these views ($(since "$t0"))"
  fi
  t0=$(date +%s%N)
  if "$tools/rgs-convert" -q "$source" "$out/$name.archive@$t.rgs" --target-psnr "$db" "${camera_args[@]}" \
    --json "$out/$name.archive@$t.json"; then
    log "archive@$t ($db dB) fitted in $(since "$t0") ($(python3 -c 'import json, sys
r = json.load(open(sys.argv[1]))["rate_control"]
print("search: %d archives encoded in %.1f s, %d rendered in %.1f s" %
      (r["encodings"], r["encode_seconds"], r["renders"], r["render_seconds"]))' "$out/$name.archive@$t.json"))"
    add "$out/$name.archive@$t.rgs" "archive@$t"
  else
    log "archive@$t: no fit at $db dB (above: why); left out of the curve"
  fi
done
for f in "${extra[@]}"; do add "$f" "$(basename "$f")"; done
"$tools/rgs-audit" "$source" "${candidates[@]}" "${labels[@]}" "${audit_args[@]}" --report "$out/$name.audit.html"
