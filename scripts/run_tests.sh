#!/usr/bin/env bash
# Installs dependencies, builds everything (the CUDA parts only where they can run, or when asked for:
# scripts/build.sh) and runs the whole test suite with CTest, one line per test as it finishes. Extra arguments
# are CMake arguments for the build. GPU tests print "skipped: no CUDA device" on machines without a GPU (and
# are not built there unless asked for), and tests on the real scenes that are not shipped ($RGS_DATA_DIR, default
# data/ in the checkout) "skipped: ..." when they are absent; CTest reports a test that skipped everything as
# "Skipped" (listed after its summary), not as passed.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${RGS_BUILD_DIR:-$root/build}"
"$root/scripts/install_deps.sh" tests
"$root/scripts/build.sh" -- -DRGS_BUILD_TESTS=ON -DRGS_BUILD_LAB=ON -DRGS_BUILD_SAMPLES=ON -DRGS_WITH_OPENIMAGEIO=ON \
  "$@"
mkdir -p "$build/Testing"
summary="$build/Testing/ctest_output.txt"
set +e
ctest --test-dir "$build" --output-on-failure --parallel "$(nproc)" 2>&1 | tee "$summary"
status=${PIPESTATUS[0]}
set -e
python3 "$root/scripts/check_doc_links.py" || status=1  # every link to a Markdown file and heading resolves
python3 "$root/scripts/check_function_length.py" || status=1  # no function over 150 lines (product, lab/, python/)
python3 "$root/scripts/line_budget.py" --check || status=1  # the product's lines within their ceiling
# Why tests skipped (no GPU, no real scenes, ...): the reasons of the skipped tests and of the skipped
# parts of passing ones, counted, from the output CTest keeps.
log="$build/Testing/Temporary/LastTest.log"
if [ -f "$log" ] && grep -q "skipped: " "$log"; then
  echo; echo "Reasons for skipped tests and skipped parts of passing tests:"
  grep -ho "skipped: .*" "$log" | sort | uniq -c | sed 's/^/  /'
fi
# CTest's summary line last, with the number of skipped tests before it.
echo; echo "$(grep -c '(Skipped)$' "$summary" || true) tests skipped"
grep -E '^[0-9]+% tests passed' "$summary" | tail -1 || true
exit "$status"
