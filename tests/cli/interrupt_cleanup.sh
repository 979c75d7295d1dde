#!/usr/bin/env bash
# Interrupts and kills of rgs-convert: SIGTERM / SIGINT while an output is being written exit 143 / 130 and
# leave no temporary and no output; SIGKILL leaves at most one "<name>.<pid>.rgs-partial" per output, which the
# next run removes (and says so). Usage: interrupt_cleanup.sh <rgs-convert> <sample.ply> <work dir>
set -u
# Job control: without it bash starts background commands with SIGINT ignored, and the tools keep a signal
# they inherit as ignored.
set -m
convert=$1 sample=$2 work=$3
rm -rf "$work" && mkdir -p "$work" && cd "$work" || exit 1
fail() { echo "FAIL: $*"; ls -la "$work"; exit 1; }

# A large input: the sample's vertices repeated K times, so that writing the restored PLY takes a while.
copies=24
header_end=$(grep -abo 'end_header' "$sample" | head -n 1 | cut -d: -f1)
header_bytes=$((header_end + 11))
vertices=$(head -c "$header_bytes" "$sample" | sed -n 's/^element vertex \([0-9]*\)$/\1/p')
[ -n "$vertices" ] || fail "no vertex count in $sample"
{
  head -c "$header_bytes" "$sample" | sed "s/^element vertex $vertices\$/element vertex $((vertices * copies))/"
  for _ in $(seq "$copies"); do tail -c +$((header_bytes + 1)) "$sample"; done
} > big.ply
"$convert" -q big.ply big.rgs || fail "cannot convert big.ply"
rm -f big.ply

partials() { ls out.ply.*.rgs-partial out.json.*.rgs-partial 2>/dev/null; }
# Everything in the directory but the input: whatever a run left, whatever its name.
leftovers() { ls -A | grep -v -x -e big.rgs -e next.log; }

# Starts the .rgs -> PLY conversion, waits until its output is being written, sends signal $1, checks the
# exit code $2 and that nothing is left.
interrupt_while_writing() {
  local signal=$1 expected=$2 seen=0
  rm -f out.ply out.json
  "$convert" -q big.rgs out.ply --json out.json &
  local pid=$!
  for _ in $(seq 2000); do
    if [ -n "$(partials)" ]; then seen=1; break; fi
    kill -0 "$pid" 2>/dev/null || break
    sleep 0.005
  done
  kill "-$signal" "$pid" 2>/dev/null
  wait "$pid"
  local rc=$?
  [ "$seen" = 1 ] || fail "SIG$signal: no out.ply.<pid>.rgs-partial appeared while writing (exit $rc)"
  [ "$rc" = "$expected" ] || fail "SIG$signal: expected exit $expected, got $rc"
  [ -z "$(leftovers)" ] || fail "SIG$signal left files behind: $(leftovers)"
  echo "ok: SIG$signal while writing -> exit $rc, no temporary, no output"
}
interrupt_while_writing TERM 143
interrupt_while_writing INT 130

# SIGKILL: no handler runs. At most one temporary per output remains, and the next run removes it.
"$convert" -q big.rgs out.ply &
pid=$!
for _ in $(seq 2000); do
  [ -n "$(partials)" ] && break
  sleep 0.005
done
kill -KILL "$pid" 2>/dev/null
wait "$pid" 2>/dev/null
left=$(partials | wc -l)
[ "$left" -le 1 ] || fail "SIGKILL left $left temporaries"
[ ! -e out.ply ] || fail "SIGKILL left an output"
if [ "$left" = 1 ]; then
  stale=$(partials)
  case "$stale" in out.ply."$pid".rgs-partial) ;; *) fail "unexpected temporary name $stale" ;; esac
  "$convert" big.rgs out.ply > next.log 2>&1 || fail "the next run failed: $(cat next.log)"
  grep -q "rgs-convert: removed .*$stale, left by an interrupted run (process $pid no longer exists)" next.log ||
    fail "the next run did not report the removal: $(cat next.log)"
  [ ! -e "$stale" ] || fail "the next run left $stale"
  echo "ok: SIGKILL left $stale, removed by the next run"
else
  echo "note: SIGKILL arrived before the temporary existed"
fi
rm -rf "$work"
echo "PASS"
