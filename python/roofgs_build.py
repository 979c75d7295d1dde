"""PEP 517 build backend of the roofgs Python module: the project's CMake build, packed as a wheel.

`python3 -m pip install .` (or `pip wheel .`) calls build_wheel(), which configures the repository with CMake
for the interpreter running it (Python_EXECUTABLE = sys.executable), builds the `roofgs` target and writes a
wheel holding the module, its type stubs and the metadata. No build requirement is downloaded: CMake, a C++
compiler, pybind11 and the libraries come from the system (scripts/install_deps.sh tests installs them).

Settings (environment variables, or `--config-settings KEY=VALUE` with the same names in lower case):
  RGS_PYTHON_BUILD_DIR  CMake build folder (default: build-python-<interpreter tag> in the repository), kept
                        between installs so that a second install rebuilds only what changed.
  CMAKE_ARGS            extra CMake arguments, e.g. "-DRGS_WITH_CUDA=OFF" for a CPU-only module.
"""
import base64
import hashlib
import os
import pathlib
import re
import shlex
import shutil
import subprocess
import sys
import sysconfig
import zipfile

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _version():
    text = (ROOT / "CMakeLists.txt").read_text()
    return re.search(r"project\(RoofGS VERSION ([0-9.]+)", text).group(1)


def _tag():
    impl = "cp" if sys.implementation.name == "cpython" else sys.implementation.name[:2]
    py = f"{impl}{sys.version_info.major}{sys.version_info.minor}"
    platform = sysconfig.get_platform().replace("-", "_").replace(".", "_")
    return f"{py}-{py}-{platform}"


def _setting(config_settings, name, default=""):
    value = (config_settings or {}).get(name.lower())
    return value if value is not None else os.environ.get(name, default)


def _build_module(config_settings):
    """Configures and builds the roofgs target; returns the built module's path."""
    build = pathlib.Path(_setting(config_settings, "RGS_PYTHON_BUILD_DIR",
                                  str(ROOT / f"build-python-{sys.implementation.cache_tag}")))
    args = ["cmake", "-S", str(ROOT), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
            f"-DPython_EXECUTABLE={sys.executable}", "-DRGS_BUILD_PYTHON=ON", "-DRGS_BUILD_TESTS=OFF",
            "-DRGS_BUILD_TOOLS=OFF", "-DRGS_BUILD_SAMPLES=OFF", "-DRGS_INSTALL=OFF"]
    if shutil.which("ninja") and not (build / "CMakeCache.txt").exists():
        args += ["-G", "Ninja"]
    args += shlex.split(_setting(config_settings, "CMAKE_ARGS"))
    subprocess.run(args, check=True, stdout=sys.stderr)
    cache = (build / "CMakeCache.txt").read_text()
    cuda = re.search(r"^RGS_WITH_CUDA:BOOL=(\w+)", cache, re.M)
    print(f"roofgs: building for {sys.executable} ({sys.version.split()[0]}), CUDA "
          f"{'on' if cuda and cuda.group(1) == 'ON' else 'off (CPU reference only)'}", file=sys.stderr)
    subprocess.run(["cmake", "--build", str(build), "--target", "roofgs", "--parallel", str(os.cpu_count() or 1)],
                   check=True, stdout=sys.stderr)
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    module = build / "python" / "package" / f"roofgs{suffix}"
    if not module.exists():
        raise RuntimeError(f"roofgs: CMake built no {module.name} in {module.parent} (is python3-dev, or this "
                           f"interpreter's headers, and pybind11-dev installed? see the CMake output above)")
    return module


def _record_line(name, data):
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{name},sha256={digest},{len(data)}"


def get_requires_for_build_wheel(config_settings=None):
    return []


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    module = _build_module(config_settings)
    version = _version()
    dist_info = f"roofgs-{version}.dist-info"
    files = {
        module.name: module.read_bytes(),
        "roofgs.pyi": (ROOT / "python" / "roofgs.pyi").read_bytes(),
        f"{dist_info}/METADATA": (f"Metadata-Version: 2.1\nName: roofgs\nVersion: {version}\n"
                                  "Summary: Convert, load and render 3D Gaussian Splatting scenes\n"
                                  "Requires-Python: >=3.9\nRequires-Dist: numpy\nLicense: MIT\n").encode(),
        f"{dist_info}/WHEEL": (f"Wheel-Version: 1.0\nGenerator: roofgs_build\nRoot-Is-Purelib: false\n"
                               f"Tag: {_tag()}\n").encode(),
    }
    record = [_record_line(name, data) for name, data in files.items()] + [f"{dist_info}/RECORD,,"]
    files[f"{dist_info}/RECORD"] = ("\n".join(record) + "\n").encode()
    wheel = f"roofgs-{version}-{_tag()}.whl"
    with zipfile.ZipFile(pathlib.Path(wheel_directory) / wheel, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in files.items():
            info = zipfile.ZipInfo(name, date_time=(2020, 1, 1, 0, 0, 0))
            info.external_attr = (0o755 if name == module.name else 0o644) << 16
            info.compress_type = zipfile.ZIP_DEFLATED
            z.writestr(info, data)
    return wheel
