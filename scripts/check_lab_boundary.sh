#!/usr/bin/env bash
# Checks that the lab (lab/, RGS_BUILD_LAB) stays outside the product: configures two build folders that differ
# only in RGS_BUILD_LAB (OFF and ON), builds the product libraries in each (rgs_format, rgs_converter,
# rgs_runtime, rgs_api, rgs_audit; rgs_kernels with CUDA, rgs_view when the viewer is built) and compares every
# object file of theirs byte for byte. A difference means that building the lab changes the product.
# Usage: scripts/check_lab_boundary.sh [CMAKE_ARGS...]   e.g. scripts/check_lab_boundary.sh -DRGS_WITH_CUDA=OFF
#   The folders are ${RGS_BUILD_DIR:-build-lab}-off and -on; the arguments go to both. Built through ccache (as
#   .ci/run does), the second tree's objects come from the cache exactly when their compiler inputs equal the
#   first's, which is what this check asks; any difference in flags, defines or headers compiles them anew.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
base="${RGS_BUILD_DIR:-$root/build-lab}"
libs=(format converter runtime kernels api audit view)
for side in off on; do
  flag=OFF
  [ $side = on ] && flag=ON
  echo "check_lab_boundary: configuring $base-$side (RGS_BUILD_LAB=$flag)"
  cmake -S "$root" -B "$base-$side" -G Ninja -DCMAKE_BUILD_TYPE=Release --log-level=WARNING -DRGS_BUILD_TESTS=ON \
    -DRGS_BUILD_SAMPLES=OFF -DRGS_BUILD_PYTHON=OFF -DRGS_INSTALL=OFF "$@" -DRGS_BUILD_LAB=$flag >/dev/null
  targets=()
  for lib in "${libs[@]}"; do
    if [ -d "$base-$side/$lib/CMakeFiles/rgs_$lib.dir" ]; then targets+=("rgs_$lib"); fi
  done
  echo "check_lab_boundary: building ${targets[*]}"
  cmake --build "$base-$side" --parallel "$(nproc)" --target "${targets[@]}" >/dev/null
done
status=0
compared=0
for lib in "${libs[@]}"; do
  dir="$lib/CMakeFiles/rgs_$lib.dir"
  [ -d "$base-off/$dir" ] || [ -d "$base-on/$dir" ] || continue
  off_list="$(cd "$base-off" && find "$dir" -name '*.o' | sort)"
  on_list="$(cd "$base-on" && find "$dir" -name '*.o' | sort)"
  if [ "$off_list" != "$on_list" ]; then
    echo "check_lab_boundary: rgs_$lib has other object files with the lab:" >&2
    diff <(echo "$off_list") <(echo "$on_list") >&2 || true
    status=1
    continue
  fi
  while IFS= read -r object; do
    [ -n "$object" ] || continue
    compared=$((compared + 1))
    if ! cmp -s "$base-off/$object" "$base-on/$object"; then
      echo "check_lab_boundary: $object differs with the lab" >&2
      status=1
    fi
  done <<<"$off_list"
done
if [ $status -ne 0 ]; then
  echo "check_lab_boundary: FAILED: the product's objects change when the lab is built" >&2
  exit 1
fi
echo "check_lab_boundary: ok, $compared product object files identical with and without the lab"
