#!/usr/bin/env bash
# Installs dependencies, builds everything (CUDA parts only when nvcc is found) and runs the whole test
# suite with CTest, one line per test as it finishes. Extra arguments are CMake arguments for the build. GPU
# tests report "skipped: no CUDA device" on machines without a GPU. Tests on the
# real scenes that are not shipped look in $RGS_DATA_DIR (default ../shared/data) and are skipped
# visibly when it is absent.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${RGS_BUILD_DIR:-$root/build}"
"$root/scripts/install_deps.sh" tests
# Explicit, so a build folder configured by run_sample.sh (tools only) gets the whole project.
"$root/scripts/build.sh" -- -DRGS_BUILD_TESTS=ON -DRGS_BUILD_SAMPLES=ON -DRGS_WITH_OPENIMAGEIO=ON "$@"
status=0
ctest --test-dir "$build" --output-on-failure --parallel "$(nproc)" || status=$?
# CTest hides the output of passing tests; list what was skipped (no GPU, no ../shared/data) so it is seen.
log="$build/Testing/Temporary/LastTest.log"
if [ -f "$log" ] && grep -q "skipped:" "$log"; then
  echo; echo "Skipped parts of passing tests:"
  grep -ho "skipped: .*" "$log" | sort | uniq -c | sed 's/^/  /'
fi
exit "$status"
