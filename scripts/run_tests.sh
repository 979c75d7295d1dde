#!/usr/bin/env bash
# Installs dependencies, builds everything (CUDA parts only when nvcc is found) and runs the whole test
# suite with CTest. GPU tests report "skipped: no CUDA device" on machines without a GPU. Tests on the
# real scenes that are not shipped look in $RGS_DATA_DIR (default ../shared/data) and are skipped
# visibly when it is absent.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${RGS_BUILD_DIR:-$root/build}"
"$root/scripts/install_deps.sh"
"$root/scripts/build.sh" "$@"
status=0
ctest --test-dir "$build" --output-on-failure --parallel "$(nproc)" || status=$?
# CTest hides the output of passing tests; list what was skipped (no GPU, no ../shared/data) so it is seen.
log="$build/Testing/Temporary/LastTest.log"
if [ -f "$log" ] && grep -q "skipped:" "$log"; then
  echo; echo "Skipped parts of passing tests:"
  grep -ho "skipped: .*" "$log" | sort | uniq -c | sed 's/^/  /'
fi
exit "$status"
