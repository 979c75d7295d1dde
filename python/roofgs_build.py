"""PEP 517 build backend of the roofgs Python module: the project's CMake build, packed as a wheel.

`python3 -m pip install .` (or `pip wheel .`) first asks for the metadata (prepare_metadata_for_build_wheel,
instant: pip then resolves NumPy before anything is compiled), then calls build_wheel(), which configures the
repository with CMake for the interpreter running it (Python_EXECUTABLE = sys.executable), builds the `roofgs`
module and the command-line tools, and writes a wheel holding the package roofgs/ (the module, loaded by
roofgs_loader.py as `roofgs` itself, `python -m roofgs` from roofgs_main.py, the type stubs), the tools
(rgs-convert, rgs-info, rgs-render, rgs-audit, and rgs-view when the viewer is built; pip puts them on the
environment's PATH) and the metadata. No build requirement is downloaded: CMake, a C++ compiler, pybind11 and
the libraries come from the system (scripts/install_deps.sh tests installs them).

What is built and why is said in one line when the build starts and again when it ends. pip shows a backend's
output only with -v, so these lines also go to the terminal pip runs in, when there is one, with the build's
progress; the whole output is in the build log (<build folder>/roofgs-build.log).

CUDA: the CUDA renderer is built when nvcc is found and this machine has a CUDA device (/dev/nvidia<N>), or
when asked for: RGS_WITH_CUDA=ON (or OFF) in the environment, `--config-settings=cmake.define.RGS_WITH_CUDA=ON`,
or -DRGS_WITH_CUDA=ON in CMAKE_ARGS. Without a device the module renders with the CPU reference.

Settings (environment variables, or `--config-settings KEY=VALUE` with the same names in lower case):
  RGS_PYTHON_BUILD_DIR  CMake build folder (default: build-python-<interpreter tag> in the repository), kept
                        between installs so that a second install rebuilds only what changed.
  RGS_WITH_CUDA         ON, OFF or AUTO (default AUTO: as above).
  CMAKE_ARGS            extra CMake arguments, e.g. "-DRGS_WITH_CUDA=OFF" for a CPU-only module.
  RGS_BUILD_PROGRESS    0 to keep the progress lines off the terminal (they stay in the build log).
  cmake.define.NAME     (config-settings only) -DNAME=VALUE, e.g. cmake.define.RGS_WITH_CUDA=ON.
"""
import base64
import glob
import hashlib
import os
import pathlib
import re
import shlex
import shutil
import subprocess
import sys
import sysconfig
import time
import zipfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
TOOLS = ["rgs-convert", "rgs-info", "rgs-render", "rgs-audit"]
VIEWER_TOOL = "rgs-view"


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


def _cmake_defines(config_settings):
    """-DNAME=VALUE for each `cmake.define.NAME=VALUE` config setting."""
    return [f"-D{key[len('cmake.define.'):]}={value}" for key, value in (config_settings or {}).items()
            if key.startswith("cmake.define.")]


class _Messages:
    """Progress lines: to stderr (pip shows it with -v), to the build log, and to pip's terminal when there is
    one (pip hides a backend's output otherwise)."""

    def __init__(self, config_settings, log_path=None):
        self.tty = None
        if _setting(config_settings, "RGS_BUILD_PROGRESS", "1") != "0":
            try:
                self.tty = open("/dev/tty", "w")
            except OSError:
                self.tty = None
        self.log = None
        if log_path:
            log_path.parent.mkdir(parents=True, exist_ok=True)
            self.log = open(log_path, "w")

    def say(self, line, terminal=True):
        print(line, file=sys.stderr, flush=True)
        if self.log:
            self.log.write(line + "\n")
            self.log.flush()
        if terminal and self.tty:
            # pip's spinner writes after the cursor: start each line on a fresh one and leave the end to it.
            self.tty.write("\n    " + line)
            self.tty.flush()

    def output(self, line):
        sys.stderr.write(line)
        if self.log:
            self.log.write(line)

    def close(self):
        for f in (self.tty, self.log):
            if f:
                f.close()


def _cuda_choice(config_settings, cmake_args):
    """(ON/OFF, reason): whether to build the CUDA renderer, and why, with how to change it."""
    explicit = None
    for arg in cmake_args:
        m = re.match(r"-DRGS_WITH_CUDA(?::BOOL)?=(\S+)", arg)
        if m:
            explicit = (m.group(1), f"{arg} given")
    if explicit is None:
        value = _setting(config_settings, "RGS_WITH_CUDA", "AUTO").upper()
        if value not in ("AUTO", ""):
            explicit = (value, f"RGS_WITH_CUDA={value} given")
    if explicit:
        on = explicit[0].upper() in ("ON", "1", "TRUE", "YES")
        return ("ON" if on else "OFF"), explicit[1]
    how_on = "to build it anyway: RGS_WITH_CUDA=ON pip install . (or --config-settings=cmake.define.RGS_WITH_CUDA=ON)"
    nvcc = shutil.which("nvcc") or next(iter(glob.glob("/usr/local/cuda/bin/nvcc")), None)
    devices = sorted(glob.glob("/dev/nvidia[0-9]*"))
    if not nvcc:
        return "OFF", "no CUDA compiler (nvcc) found; the CPU reference renders"
    if not devices:
        return "OFF", f"nvcc found ({nvcc}) but no CUDA device on this machine; the CPU reference renders; {how_on}"
    return "ON", (f"nvcc ({nvcc}) and a CUDA device ({devices[0]}) found; "
                  "CPU-only: RGS_WITH_CUDA=OFF pip install .")


def _run(args, messages, progress_prefix=None):
    """Runs a command with its output to stderr and the log; with `progress_prefix`, a terminal line every
    tenth of Ninja's [done/total] steps."""
    process = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1)
    shown = -1
    for line in process.stdout:
        messages.output(line)
        m = re.match(r"\[(\d+)/(\d+)\]", line)
        if progress_prefix and m and int(m.group(1)) > 0:  # [0/N]: Ninja's check of the build files
            tenth = 10 * int(m.group(1)) // int(m.group(2))
            if tenth > shown:
                shown = tenth
                messages.say(f"{progress_prefix} {10 * tenth}% ({m.group(1)}/{m.group(2)} steps)")
    if process.wait() != 0:
        messages.say(f"roofgs: {' '.join(args[:3])} ... failed (exit {process.returncode}); "
                     f"the output above and the build log say why")
        raise subprocess.CalledProcessError(process.returncode, args)


def _build(config_settings):
    """Configures and builds the roofgs module and the tools; returns (module path, [tool paths])."""
    started = time.monotonic()
    build = pathlib.Path(_setting(config_settings, "RGS_PYTHON_BUILD_DIR",
                                  str(ROOT / f"build-python-{sys.implementation.cache_tag}")))
    messages = _Messages(config_settings, build / "roofgs-build.log")
    try:
        extra = shlex.split(_setting(config_settings, "CMAKE_ARGS")) + _cmake_defines(config_settings)
        cuda, why = _cuda_choice(config_settings, extra)
        kind = "with the CUDA renderer" if cuda == "ON" else "CPU-only"
        messages.say(f"roofgs {_version()}: building the module and {', '.join(TOOLS)} for {sys.executable} "
                     f"({sys.version.split()[0]}), {kind}: {why}")
        messages.say(f"roofgs: build folder {build}, log {build / 'roofgs-build.log'}")
        args = ["cmake", "-S", str(ROOT), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
                f"-DPython_EXECUTABLE={sys.executable}", "-DRGS_BUILD_PYTHON=ON", "-DRGS_BUILD_TESTS=OFF",
                "-DRGS_BUILD_TOOLS=ON", "-DRGS_BUILD_SAMPLES=OFF", "-DRGS_INSTALL=OFF", f"-DRGS_WITH_CUDA={cuda}"]
        if shutil.which("ninja") and not (build / "CMakeCache.txt").exists():
            args += ["-G", "Ninja"]
        if not any(a.startswith("-DRGS_WITH_OPENIMAGEIO") for a in extra):
            # PNG/EXR in rgs-render and rgs-audit when OpenImageIO is installed; PPM/PFM without it.
            found = shutil.which("pkg-config") and subprocess.run(
                ["pkg-config", "--exists", "OpenImageIO"], check=False).returncode == 0
            args.append(f"-DRGS_WITH_OPENIMAGEIO={'ON' if found else 'OFF'}")
        args += [a for a in extra if not a.startswith("-DRGS_WITH_CUDA")]
        messages.say("roofgs: configuring with CMake")
        _run(args, messages)
        cache = (build / "CMakeCache.txt").read_text()
        viewer = re.search(r"^RGS_BUILD_VIEWER:BOOL=ON", cache, re.M) is not None
        tools = TOOLS + ([VIEWER_TOOL] if viewer else [])
        jobs = str(os.cpu_count() or 1)
        messages.say(f"roofgs: compiling with {jobs} jobs")
        _run(["cmake", "--build", str(build), "--target", "roofgs", *tools, "--parallel", jobs], messages,
             "roofgs: compiling")
        suffix = sysconfig.get_config_var("EXT_SUFFIX")
        module = build / "python" / "package" / f"roofgs{suffix}"
        if not module.exists():
            raise RuntimeError(f"roofgs: CMake built no {module.name} in {module.parent} (is python3-dev, or this "
                               f"interpreter's headers, and pybind11-dev installed? see the CMake output above)")
        tool_paths = [build / "tools" / t for t in tools]
        elapsed = time.monotonic() - started
        messages.say(f"roofgs: built {kind} in {int(elapsed) // 60}m{int(elapsed) % 60:02d}s: the module and "
                     f"{', '.join(tools)} (installed on the environment's PATH)")
        return module, tool_paths
    finally:
        messages.close()


def _metadata():
    return (f"Metadata-Version: 2.1\nName: roofgs\nVersion: {_version()}\n"
            "Summary: Convert, load and render 3D Gaussian Splatting scenes\n"
            "Requires-Python: >=3.9\nRequires-Dist: numpy\nLicense: MIT\n").encode()


def _record_line(name, data):
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{name},sha256={digest},{len(data)}"


def get_requires_for_build_wheel(config_settings=None):
    return []


def prepare_metadata_for_build_wheel(metadata_directory, config_settings=None):
    """Writes the wheel's .dist-info folder without building, so that pip resolves NumPy first."""
    dist_info = f"roofgs-{_version()}.dist-info"
    folder = pathlib.Path(metadata_directory) / dist_info
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "METADATA").write_bytes(_metadata())
    return dist_info


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    module, tools = _build(config_settings)
    version = _version()
    dist_info = f"roofgs-{version}.dist-info"
    # The package roofgs/: the compiled module, the loader that makes `import roofgs` give it, `python -m roofgs`
    # and the type stubs.
    files = {
        f"roofgs/{module.name}": (module.read_bytes(), 0o100755),
        "roofgs/__init__.py": ((ROOT / "python" / "roofgs_loader.py").read_bytes(), 0o100644),
        "roofgs/__main__.py": ((ROOT / "python" / "roofgs_main.py").read_bytes(), 0o100644),
        "roofgs/__init__.pyi": ((ROOT / "python" / "roofgs.pyi").read_bytes(), 0o100644),
    }
    # The .data/scripts files go to the environment's bin folder (the wheel format, PEP 427).
    for tool in tools:
        files[f"roofgs-{version}.data/scripts/{tool.name}"] = (tool.read_bytes(), 0o100755)
    files[f"{dist_info}/METADATA"] = (_metadata(), 0o100644)
    files[f"{dist_info}/WHEEL"] = ((f"Wheel-Version: 1.0\nGenerator: roofgs_build\nRoot-Is-Purelib: false\n"
                                    f"Tag: {_tag()}\n").encode(), 0o100644)
    record = [_record_line(name, data) for name, (data, _) in files.items()] + [f"{dist_info}/RECORD,,"]
    files[f"{dist_info}/RECORD"] = (("\n".join(record) + "\n").encode(), 0o100644)
    wheel = f"roofgs-{version}-{_tag()}.whl"
    with zipfile.ZipFile(pathlib.Path(wheel_directory) / wheel, "w", zipfile.ZIP_DEFLATED) as z:
        for name, (data, mode) in files.items():
            info = zipfile.ZipInfo(name, date_time=(2020, 1, 1, 0, 0, 0))
            info.external_attr = mode << 16  # file type and permissions: pip keeps the executable bit
            info.compress_type = zipfile.ZIP_DEFLATED
            z.writestr(info, data)
    return wheel
