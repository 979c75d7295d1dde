#!/usr/bin/env bash
# The roofgs Python package as a user installs it: a fresh virtual environment of Debian's python3 (with its
# NumPy and pytest), `python -m pip install .` of this checkout (the README's command; CPU-only here unless
# CMAKE_ARGS says otherwise, to keep CI short), the command-line tools it installs on the environment's PATH
# (rgs-convert converts and rgs-info reads a scene, also through `python -m roofgs`), then the Python tests against the installed module, run
# from outside the checkout. Then a second CPython, when one is found ($RGS_SECOND_PYTHON, else pyenv's newest
# 3.12 or 3.13), installs the module into its own environment and loads and renders a scene with it.
# Usage: scripts/check_python_package.sh [WORK_DIR]   (default build-python-check in the checkout)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
work="${1:-$root/build-python-check}"
mkdir -p "$work"
export CMAKE_ARGS="${CMAKE_ARGS:--DRGS_WITH_CUDA=OFF}"
unset PYTHONPATH

install() {  # install PYTHON VENV [pip options...]; CMake builds in $work-<venv name> (beside the checkout's
  local python="$1" venv="$2"  # other build folders, so that ccache's relative paths match theirs: .ci/run)
  shift 2
  rm -rf "$venv"
  "$python" -m venv "$@" "$venv"
  RGS_PYTHON_BUILD_DIR="$work-$(basename "$venv")" "$venv/bin/python" -m pip install --quiet --no-input \
    ${RGS_PIP_OPTIONS:-} "$root"
  echo "check_python_package: installed $("$venv/bin/python" -c 'import roofgs; print(roofgs.__file__)')"
}

install /usr/bin/python3 "$work/venv" --system-site-packages
# The command-line tools come with the module, on the environment's PATH.
tool="$(PATH="$work/venv/bin:$PATH" command -v rgs-convert || true)"
if [ "$tool" != "$work/venv/bin/rgs-convert" ]; then
  echo "check_python_package: rgs-convert is not on the environment's PATH (found: '${tool}')" >&2
  exit 1
fi
"$tool" "$root/samples/guitar.ply" "$work/guitar_cli.rgs" --quiet
"$work/venv/bin/rgs-info" "$work/guitar_cli.rgs" > /dev/null
echo "check_python_package: $("$tool" --version) on the environment's PATH"
# python -m roofgs lists the tools and runs them.
listing="$(cd "$work" && "$work/venv/bin/python" -m roofgs)"
grep -q "$work/venv/bin/rgs-convert" <<< "$listing"
described="$(cd "$work" && "$work/venv/bin/python" -m roofgs info "$work/guitar_cli.rgs")"
grep -q "gaussians *90,854" <<< "$described"
(cd "$work" && RGS_SOURCE_DIR="$root" "$work/venv/bin/python" -m pytest "$root/tests/python" -q -p no:cacheprovider)

second="${RGS_SECOND_PYTHON:-$(ls -d "$HOME"/.pyenv/versions/3.1[23]*/bin/python3 2>/dev/null | sort -V | tail -1)}"
if [ -z "$second" ] || ! "$second" -c 'import venv' 2>/dev/null; then
  echo "check_python_package: skipped: no second CPython (set RGS_SECOND_PYTHON to one with its headers)"
  exit 0
fi
# NumPy is not installed there (no download): --no-deps; loading and a CPU render to NumPy need it only for
# the image, so the check converts, loads and prints the scene.
RGS_PIP_OPTIONS=--no-deps install "$second" "$work/venv2"
(cd "$work" && "$work/venv2/bin/python" - "$root/samples/guitar.ply" "$work/guitar.rgs" <<'PY'
import sys
import roofgs
report = roofgs.convert(sys.argv[1], sys.argv[2])
scene = roofgs.load(sys.argv[2], device="cpu")
assert len(scene) == report["gaussians"] == 90854, scene
print(f"check_python_package: Python {sys.version.split()[0]}: {scene}")
PY
)
