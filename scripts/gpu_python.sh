#!/usr/bin/env bash
# GPU host: compiles the roofgs Python module for the host's own Python against the libraries staged by
# scripts/stage_gpu.sh (.device_data/py), then runs the Python tests (tests/python; the GPU cases need a
# device and PyTorch for DLPack) with it. Writes the pytest log to OUT_DIR when given.
# Usage: scripts/gpu_python.sh STAGE_DIR [OUT_DIR]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
stage="$(cd "$1" && pwd)"
if [ -f "$stage/py.tar.xz" ]; then tar -C "$stage" -xJf "$stage/py.tar.xz"; fi
py="$stage/py"
out="${2:-}"
package="$py/package"
mkdir -p "$package"
python_include="$(python3 -c 'import sysconfig; print(sysconfig.get_paths()["include"])')"
suffix="$(python3 -c 'import sysconfig; print(sysconfig.get_config_var("EXT_SUFFIX"))')"
includes=()
for lib in audit api format converter runtime kernels view; do includes+=(-I"$root/$lib/include"); done
# roofgs.view() when the staged libraries hold the viewer (stage_gpu.sh marks it).
viewer=()
if [ -f "$py/with_viewer" ]; then viewer=(-DRGS_WITH_VIEWER=1); fi
# The module's sources, as python/CMakeLists.txt lists them.
sources=()
for name in roofgs_module py_arguments py_arrays py_audit py_cameras py_conversion py_images py_rasterization \
  py_scenes py_viewer; do
  sources+=("$root/python/src/$name.cpp")
done
c++ -O2 -std=c++17 -shared -fPIC -fvisibility=hidden "${viewer[@]}" -I"$py/include" -I"$python_include" "${includes[@]}" \
  "${sources[@]}" -o "$package/roofgs$suffix" -L"$py" -lroofgs_core -Wl,-rpath,"$py"
echo "gpu_python: built $package/roofgs$suffix for $(python3 --version)"
log="${out:+$out/pytest.log}"
PYTHONPATH="$package" RGS_SOURCE_DIR="$root" python3 -m pytest -v -rs -p no:cacheprovider "$root/tests/python" \
  2>&1 | tee ${log:+"$log"}
