#!/usr/bin/env bash
# Installs the Debian packages RoofGS needs (Debian 12 or newer), and nothing else.
# Usage: scripts/install_deps.sh [sample|tests]
#   sample  what rgs-convert and rgs-info need to build (the README's first command)
#   tests   everything the whole test suite needs (default): the render and audit tools' image I/O, doctest,
#           GLM (camera tests of the front door), python3 with pybind11, NumPy, pytest and venv (the roofgs module
#           and its pip install check), matplotlib (the scripts' plots), chromium and python3-websocket (the
#           audit report's test in a headless browser), clang's libFuzzer and sanitizers (scripts/run_fuzzers.sh),
#           ccache (CI's stages share the objects they compile alike: .ci/run), cloc (the line budgets:
#           scripts/line_budget.py)
# Idempotent: skips apt when everything is present. Uses sudo when not run as root. Waits (up to 10 minutes)
# for another apt or dpkg to release its lock, as happens right after a fresh machine boots.
set -euo pipefail

profile="${1:-tests}"
sample=(
  build-essential cmake ninja-build pkg-config
  libzstd-dev liblzma-dev libxxhash-dev zlib1g-dev libzip-dev libwebp-dev libdraco-dev nlohmann-json3-dev libcli11-dev
  libboost-dev libturbojpeg0-dev
)
tests=(
  "${sample[@]}"
  doctest-dev libopenimageio-dev libglm-dev
  python3 python3-dev python3-venv pybind11-dev python3-numpy python3-pytest python3-matplotlib time
  chromium python3-websocket
  clang libclang-rt-14-dev llvm ccache cloc
)
case "$profile" in
  sample) packages=("${sample[@]}") ;;
  tests) packages=("${tests[@]}") ;;
  *) echo "install_deps.sh: unknown profile '$profile' (expected sample or tests)" >&2; exit 2 ;;
esac

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#packages[@]} packages of '$profile' present"
  exit 0
fi

sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
lock_timeout=600
echo "install_deps: installing ${missing[*]}"
# apt-get update has no lock timeout of its own: retry while another apt holds the lists lock.
for attempt in $(seq 1 60); do
  if $sudo apt-get -o DPkg::Lock::Timeout="$lock_timeout" update -qq; then break; fi
  if [ "$attempt" -eq 60 ]; then echo "install_deps: apt-get update kept failing" >&2; exit 1; fi
  echo "install_deps: apt-get update failed (another apt running?); retrying in 10 s" >&2
  sleep 10
done
DEBIAN_FRONTEND=noninteractive $sudo apt-get -o DPkg::Lock::Timeout="$lock_timeout" install -y -qq \
  --no-install-recommends "${missing[@]}"
