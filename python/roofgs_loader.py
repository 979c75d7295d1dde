"""The installed `roofgs` package: loads the compiled module (roofgs<EXT_SUFFIX> in this folder) as `roofgs`.

A wheel installs the module inside this package so that `python -m roofgs` (roofgs_main.py, installed as
roofgs/__main__.py) can run the command-line tools installed with it. `import roofgs` gives the compiled module
itself, as a build tree's python/package folder does; it keeps this folder as its __path__ so that the
interpreter still finds roofgs.__main__.
"""
import importlib.machinery
import importlib.util
import pathlib
import sys


def _load_compiled_module():
    folder = pathlib.Path(__file__).resolve().parent
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        path = folder / f"roofgs{suffix}"
        if path.exists():
            loader = importlib.machinery.ExtensionFileLoader(__name__, str(path))
            spec = importlib.util.spec_from_file_location(__name__, str(path), loader=loader)
            module = importlib.util.module_from_spec(spec)
            loader.exec_module(module)
            module.__path__ = [str(folder)]
            return module
    raise ImportError(f"roofgs: no compiled module roofgs{importlib.machinery.EXTENSION_SUFFIXES[0]} in {folder} "
                      f"(reinstall with: python -m pip install --force-reinstall <RoofGS checkout>)")


sys.modules[__name__] = _load_compiled_module()
