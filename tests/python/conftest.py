# Shared fixtures of the roofgs module tests. The module is found through PYTHONPATH (CTest sets it to the
# build's python/package folder); RGS_SOURCE_DIR points at the repository. Tests that take the `cuda` fixture
# are marked `cuda` (CTest runs them as python.roofgs_cuda, the others as python.roofgs), and a run in which
# every test skipped exits 77, which CTest reports as skipped.
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


SKIP_EXIT_STATUS = 77
_outcomes = {"passed": 0, "skipped": 0}


def pytest_configure(config):
    config.addinivalue_line("markers", "cuda: needs a CUDA device (the cuda fixture)")


def pytest_collection_modifyitems(items):
    for item in items:
        if "cuda" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.cuda)


def pytest_runtest_logreport(report):
    if report.skipped:
        _outcomes["skipped"] += 1
    elif report.passed and report.when == "call":
        _outcomes["passed"] += 1


def pytest_sessionfinish(session, exitstatus):
    if exitstatus == 0 and _outcomes["skipped"] > 0 and _outcomes["passed"] == 0:
        session.exitstatus = SKIP_EXIT_STATUS
