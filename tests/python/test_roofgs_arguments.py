# Arguments of every public function of the roofgs module: a value of the wrong type raises TypeError and a
# value outside the argument's rule (a size of 0, a number that is not finite, a negative device) ValueError,
# each saying "<function>(): <argument> must be <rule>, got <what was given>" before any work is done.
import json
import re
from types import SimpleNamespace

import numpy as np
import pytest

from conftest import SOURCE_DIR, roofgs

DATA = SOURCE_DIR / "tests" / "data"
SMALL = DATA / "v1.0" / "small_sh3.rgs"
NAN, INF = float("nan"), float("inf")


@pytest.fixture(scope="module")
def ctx(tmp_path_factory):
    scene = roofgs.load(SMALL, device="cpu")
    camera = scene.orbit_cameras(1, 32, 18)[0]
    viewmats = np.eye(4, dtype=np.float32)[None]
    viewmats[0, :3, :3], viewmats[0, :3, 3] = camera.rotation, camera.translation
    Ks = np.array([[[camera.fx, 0, camera.cx], [0, camera.fy, camera.cy], [0, 0, 1]]], np.float32)
    out = tmp_path_factory.mktemp("arguments")
    (out / "cameras.json").write_text(json.dumps([{"id": 0, "img_name": "front", "width": 64, "height": 36,
                                                   "position": [0, 0, -5], "rotation": np.eye(3).tolist(),
                                                   "fx": 50, "fy": 50}]))
    return SimpleNamespace(scene=scene, camera=camera, arrays=scene.arrays(), viewmats=viewmats, Ks=Ks, out=out)


# OpenGL matrices of a camera at (0, 0, 5) looking along -z (test_roofgs.py's), [row, column].
GL_VIEW = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, -5], [0, 0, 0, 1]]
GL_PROJECTION = [[0.5, 0, 0, 0], [0, 1, 0, 0], [0, 0, -100.1 / 99.9, -20 / 99.9], [0, 0, -1, 0]]
VK_PROJECTION = [row[:] for row in GL_PROJECTION]
VK_PROJECTION[1][1] = -1


def merged(defaults, overrides):
    return {**defaults, **overrides}


# Each public function called with valid arguments, any of which `kw` replaces.
CALLS = {
    "camera_from_inria": lambda c, **kw: roofgs.camera_from_inria(**merged(dict(
        rotation_c2w=np.eye(3), position=[0, 0, -5], fx=100, fy=100, width=64, height=36), kw)),
    "camera_from_colmap": lambda c, **kw: roofgs.camera_from_colmap(**merged(dict(
        qvec=[1, 0, 0, 0], tvec=[0, 0, 4], fx=50, fy=60, cx=30, cy=20, width=64, height=48), kw)),
    "camera_from_opencv": lambda c, **kw: roofgs.camera_from_opencv(**merged(dict(
        K=[[500, 0, 319.5], [0, 400, 239.5], [0, 0, 1]], R=np.eye(3), t=[0, 0, 2], width=640, height=480), kw)),
    "camera_from_opengl": lambda c, **kw: roofgs.camera_from_opengl(**merged(dict(
        view=GL_VIEW, projection=GL_PROJECTION, width=200, height=100), kw)),
    "camera_from_vulkan": lambda c, **kw: roofgs.camera_from_vulkan(**merged(dict(
        view=GL_VIEW, projection=VK_PROJECTION, width=200, height=100), kw)),
    "load_cameras": lambda c, **kw: roofgs.load_cameras(**merged(dict(path=c.out / "cameras.json"), kw)),
    "project": lambda c, **kw: c.camera.project(**merged(dict(point=[0, 0, 0]), kw)),
    "resized": lambda c, **kw: c.camera.resized(**merged(dict(width=16, height=9), kw)),
    "orbit_cameras": lambda c, **kw: c.scene.orbit_cameras(**merged(dict(count=2, width=16, height=9), kw)),
    "render": lambda c, **kw: c.scene.render(c.camera, **merged(dict(width=16), kw)),
    "from_arrays": lambda c, **kw: roofgs.Scene.from_arrays(*c.arrays, **merged(dict(device="cpu"), kw)),
    "load": lambda c, **kw: roofgs.load(**merged(dict(path=SMALL, device="cpu"), kw)),
    "convert": lambda c, **kw: roofgs.convert(**merged(dict(src=SMALL, dst=c.out / "convert.ply"), kw)),
    "save": lambda c, **kw: roofgs.save(**merged(dict(path=c.out / "save.ply"), kw), means=c.arrays[0],
                                        quats=c.arrays[1], scales=c.arrays[2], opacities=c.arrays[3],
                                        sh=c.arrays[4]),
    "rasterization": lambda c, **kw: roofgs.rasterization(
        *c.arrays, **merged(dict(viewmats=c.viewmats, Ks=c.Ks, width=16, height=9, sh_degree=3, device="cpu"), kw)),
    "audit": lambda c, **kw: roofgs.audit(**merged(dict(
        source=SMALL, candidates=SMALL, orbit=1, width=16, height=12, device="cpu"), kw)),
}

# (function, argument, bad values that raise ValueError, bad values that raise TypeError)
RULES = [
    ("camera_from_inria", "rotation_c2w", [np.full((3, 3), NAN), np.eye(2)], ["not a matrix"]),
    ("camera_from_inria", "position", [[0, 0, INF], [0, 0]], [None]),
    ("camera_from_inria", "fx", [NAN, 0, -100], ["100"]),
    ("camera_from_inria", "fy", [INF], [None]),
    ("camera_from_inria", "width", [0, -1, 40000], [64.0, True, "64"]),
    ("camera_from_inria", "height", [0], [None]),
    ("camera_from_inria", "near_plane", [NAN, 0, -0.2], ["0.2"]),
    ("camera_from_inria", "name", [], [5]),
    ("camera_from_colmap", "qvec", [[NAN, 0, 0, 0], [1, 0, 0]], []),
    ("camera_from_colmap", "tvec", [[0, NAN, 4]], []),
    ("camera_from_colmap", "fx", [0], ["50"]),
    ("camera_from_colmap", "fy", [NAN], []),
    ("camera_from_colmap", "cx", [NAN, INF], ["30"]),
    ("camera_from_colmap", "cy", [-INF], [[20]]),
    ("camera_from_colmap", "width", [0], ["64"]),
    ("camera_from_colmap", "height", [0], []),
    ("camera_from_colmap", "near_plane", [NAN], []),
    ("camera_from_colmap", "name", [], [1.5]),
    ("camera_from_opencv", "K", [[[NAN, 0, 0], [0, 1, 0], [0, 0, 1]], np.eye(4)], []),
    ("camera_from_opencv", "R", [np.eye(2)], []),
    ("camera_from_opencv", "t", [[0, 0, NAN]], []),
    ("camera_from_opencv", "width", [0], ["640"]),
    ("camera_from_opencv", "height", [-480], []),
    ("camera_from_opencv", "near_plane", [0], []),
    ("camera_from_opencv", "name", [], [None]),
    ("camera_from_opengl", "view", [np.full((4, 4), NAN), np.eye(3)], []),
    ("camera_from_opengl", "projection", [np.eye(3)], ["projection"]),
    ("camera_from_opengl", "width", [0], [200.0]),
    ("camera_from_opengl", "height", [0], []),
    ("camera_from_opengl", "near_plane", [INF], []),
    ("camera_from_opengl", "name", [], [0]),
    ("camera_from_vulkan", "view", [np.eye(2)], []),
    ("camera_from_vulkan", "projection", [np.full((4, 4), INF)], []),
    ("camera_from_vulkan", "width", [0], []),
    ("camera_from_vulkan", "height", [0], ["100"]),
    ("camera_from_vulkan", "near_plane", [-1], []),
    ("camera_from_vulkan", "name", [], [0]),
    ("load_cameras", "path", [], [5, None]),
    ("project", "point", [[0, 0, NAN], [1, 2]], ["xyz"]),
    ("resized", "width", [0, -1], ["16"]),
    ("resized", "height", [0, 2 ** 40], [9.0]),
    ("orbit_cameras", "count", [0, -1], ["2", 2.0]),
    ("orbit_cameras", "width", [0], [None]),
    ("orbit_cameras", "height", [0, 40000], []),
    ("render", "width", [0, -16], [16.0, "16"]),
    ("render", "height", [0], [True]),
    ("render", "background", [(NAN, 0, 0), (0, 0)], ["black"]),
    ("render", "preset", [], [5]),
    ("render", "format", [], [None]),
    ("render", "stream", [], ["default"]),
    ("render", "scratch_budget", [-1], [0.5]),
    ("from_arrays", "device", [], [5]),
    ("from_arrays", "name", [], [None]),
    ("load", "path", [], [5]),
    ("load", "device", [], [0]),
    ("load", "presets", [], ["fastest", [5]]),
    ("load", "cuda_device", [-1, 1024], ["x", 0.0, None]),
    ("load", "splat_budget", [-1], ["1"]),
    ("load", "pixel_error", [NAN, INF, -1, 1001], ["1"]),
    ("load", "memory_budget", [-1], [1.5]),
    ("load", "stream_bytes", [0, -1], ["1MiB"]),
    ("convert", "src", [], [5]),
    ("convert", "dst", [], [None]),
    ("convert", "to", [], [5]),
    ("convert", "zstd", [], ["sh"]),
    ("convert", "sh_degree", [-1, 4], ["3"]),
    ("convert", "sh_clip_percentile", [NAN, 0], ["99"]),
    ("convert", "position_error", [INF], []),
    ("convert", "target_psnr", [NAN], ["40"]),
    ("convert", "cameras", [], [5]),
    ("convert", "orbit", [0], [1.0]),
    ("convert", "width", [0, 10], ["960"]),
    ("convert", "height", [0], []),
    ("convert", "lod_levels", ["fast", 0], [2.0]),
    ("convert", "sanitize", [], ["yes"]),
    ("save", "path", [], [5]),
    ("save", "camera_path", [0], ["4"]),
    ("save", "width", [0], []),
    ("save", "zstd_level", [0], ["3"]),
    ("rasterization", "width", [0, -1], ["16", 16.0]),
    ("rasterization", "height", [0], [None]),
    ("rasterization", "near_plane", [NAN, 0], ["0.01"]),
    ("rasterization", "sh_degree", [-1], [1.5]),
    ("rasterization", "render_mode", ["RGBD"], [5]),
    ("rasterization", "preset", [], [5]),
    ("audit", "source", [], [5]),
    ("audit", "candidates", [], [5, [5]]),
    ("audit", "orbit", [0, -1], ["1"]),
    ("audit", "width", [0, 10, -16], ["16"]),
    ("audit", "height", [0], [12.0]),
    ("audit", "device", [], [None]),
    ("audit", "threshold", [NAN, INF, -INF, 1001], ["40"]),
]


def rule_cases():
    for function, argument, bad_values, wrong_types in RULES:
        for error, values in ((ValueError, bad_values), (TypeError, wrong_types)):
            for value in values:
                shown = repr(value) if not isinstance(value, np.ndarray) else "array" + str(value.shape)
                yield pytest.param(function, argument, value, error, id=f"{function}-{argument}={shown}")


def test_every_function_is_called_validly(ctx):
    """The valid calls the argument cases start from succeed: each case's error comes from its one bad value."""
    results = {function: call(ctx) for function, call in CALLS.items()}
    assert results["load_cameras"][0].name == "front" and results["resized"].width == 16
    assert results["render"].shape == (9, 16, 4) and results["audit"]["views"] == 1


@pytest.mark.parametrize("function, argument, value, error", list(rule_cases()))
def test_a_bad_argument_is_refused_naming_the_function_and_the_argument(ctx, function, argument, value, error):
    with pytest.raises(error, match="^" + re.escape(f"{function}(): {argument} must be ")) as e:
        CALLS[function](ctx, **{argument: value})
    assert type(e.value) is error  # not roofgs.Error, nor pybind11's list of signatures


def test_the_messages_say_the_rule_and_the_value(ctx):
    with pytest.raises(ValueError) as e:
        CALLS["audit"](ctx, threshold=NAN)
    assert str(e.value) == "audit(): threshold must be a finite number in -1000..1000, got nan"
    with pytest.raises(ValueError) as e:
        CALLS["audit"](ctx, width=0)
    assert str(e.value) == "audit(): width must be an integer in 11..32768, got 0"
    with pytest.raises(ValueError) as e:
        CALLS["load"](ctx, cuda_device=-1)
    assert str(e.value) == "load(): cuda_device must be an integer in 0..1023, got -1"
    with pytest.raises(TypeError) as e:
        CALLS["load"](ctx, cuda_device="x")
    assert str(e.value) == "load(): cuda_device must be an int, got str"
    with pytest.raises(ValueError) as e:
        CALLS["render"](ctx, width=0)
    assert str(e.value) == "render(): width must be an integer in 1..32768, got 0"
    with pytest.raises(ValueError) as e:
        CALLS["camera_from_opencv"](ctx, near_plane=0)
    assert str(e.value) == "camera_from_opencv(): near_plane must be a finite number > 0, got 0"
    with pytest.raises(TypeError) as e:
        CALLS["audit"](ctx, threshold="a")
    assert str(e.value) == "audit(): threshold must be a number, got str"


def test_numpy_scalars_and_integral_numbers_are_taken(ctx):
    """What pybind11 took before is still taken: NumPy integers for ints, ints and NumPy floats for numbers."""
    cameras = ctx.scene.orbit_cameras(np.int64(2), np.uint16(16), np.int32(9))
    assert len(cameras) == 2 and (cameras[0].width, cameras[0].height) == (16, 9)
    camera = roofgs.camera_from_inria(np.eye(3), [0, 0, -5], np.float32(100), 100, np.int64(64), 36,
                                      near_plane=np.float64(0.5))
    assert camera.fx == 100 and camera.near_plane == 0.5
    assert ctx.scene.render(ctx.camera, width=np.int64(8)).shape == (5, 8, 4)


def test_lod_chunk_needs_lod_levels(ctx):
    """As rgs-convert's --lod-chunk requires --lod-levels: a chunk size without levels is refused."""
    with pytest.raises(ValueError, match=r"^convert\(\): lod_chunk requires lod_levels"):
        CALLS["convert"](ctx, dst=ctx.out / "lod.rgs", lod_chunk=4096)
    with pytest.raises(ValueError, match=r"^save\(\): lod_chunk requires lod_levels"):
        CALLS["save"](ctx, path=ctx.out / "lod.rgs", lod_chunk=4096)
    assert not (ctx.out / "lod.rgs").exists()
    report = CALLS["convert"](ctx, dst=ctx.out / "lod.rgs", lod_chunk=4096, lod_levels=2)
    assert report["output"]["format"] == "rgs"


VIEW_RULES = [("cuda_device", [-1, 1024], ["x", 0.5]), ("port", [-1, 65536], ["8080"]),
              ("max_clients", [0, 65], [8.0]), ("height", [0, -600], ["600"])]


@pytest.mark.skipif(not hasattr(roofgs, "view"), reason="built without the viewer (RGS_BUILD_VIEWER)")
@pytest.mark.parametrize("argument, value, error", [
    pytest.param(argument, value, error, id=f"view-{argument}={value!r}")
    for argument, bad_values, wrong_types in VIEW_RULES
    for error, values in ((ValueError, bad_values), (TypeError, wrong_types)) for value in values])
def test_a_bad_view_argument_is_refused_before_the_server_starts(ctx, argument, value, error):
    with pytest.raises(error, match="^" + re.escape(f"view(): {argument} must be ")):
        server = roofgs.view(ctx.scene, device="cpu", **{argument: value})
        server.stop()  # reached only where the argument was not refused


def test_save_takes_camera_path(ctx):
    """save()'s camera_path is rgs-convert's --path (save's own `path` is the output): N views of a camera path."""
    report = CALLS["save"](ctx, path=ctx.out / "fit.rgs", target_psnr=30, camera_path=1, width=16)
    assert report["rate_control"]["views"] == 1
