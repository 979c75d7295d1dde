#!/usr/bin/env bash
# Installs the Debian packages RoofGS builds against (Debian 12 or newer). Idempotent: skips apt when
# everything is already installed. Uses sudo when not run as root.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config time
  libzstd-dev libxxhash-dev libdraco-dev libglm-dev
  libopenimageio-dev openimageio-tools
  doctest-dev nlohmann-json3-dev libcli11-dev libtbb-dev
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#packages[@]} packages present"
  exit 0
fi

sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
echo "install_deps: installing ${missing[*]}"
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
