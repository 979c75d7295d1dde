# Shared fixtures of the roofgs module tests. The module is found through PYTHONPATH (CTest sets it to the
# build's python/package folder); RGS_SOURCE_DIR points at the repository.
import os
import pathlib

import pytest

roofgs = pytest.importorskip("roofgs")

SOURCE_DIR = pathlib.Path(os.environ.get("RGS_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))


def cuda_available():
    """True when the module has CUDA and a device answers; the reason otherwise."""
    if not roofgs.has_cuda:
        return False, "this build of roofgs has no CUDA support"
    try:
        roofgs.load(str(SOURCE_DIR / "samples" / "guitar.ply"), device="cuda")
    except roofgs.Error as e:
        if e.code_name == "kUnsupportedFeature":
            return False, "no CUDA device (" + str(e) + ")"
        raise
    return True, ""


@pytest.fixture(scope="session")
def guitar_rgs(tmp_path_factory):
    path = tmp_path_factory.mktemp("rgs") / "guitar.rgs"
    report = roofgs.convert(str(SOURCE_DIR / "samples" / "guitar.ply"), str(path))
    assert report["gaussians"] == 90854
    return str(path)


@pytest.fixture(scope="session")
def cuda():
    ok, why = cuda_available()
    if not ok:
        pytest.skip("skipped: " + why)
    return True
