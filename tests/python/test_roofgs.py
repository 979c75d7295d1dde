# The roofgs module: conversion, loading, cameras in every convention, CPU renders as NumPy arrays, errors
# with codes, audits as dicts; GPU renders through DLPack (skipped visibly without a device).
import math
import pathlib
import re
import subprocess
import sys
import warnings

import numpy as np
import pytest

from conftest import SOURCE_DIR, roofgs


def test_convert_reports_sizes_and_errors(guitar_rgs, tmp_path):
    report = roofgs.convert(str(SOURCE_DIR / "samples" / "guitar.ply"), str(tmp_path / "g.rgs"),
                            scale_encoding="log", zstd=["sh"])
    assert report["input"]["format"] == "ply" and report["output"]["format"] == "rgs"
    assert report["output"]["bytes"] < report["input"]["bytes"]
    assert report["errors"]["position"]["max"] == 0.0
    back = roofgs.convert(guitar_rgs, str(tmp_path / "back.ply"))
    assert back["input"]["format"] == "rgs" and back["output"]["format"] == "ply"
    assert back["gaussians"] == 90854 and "errors" not in back
    assert not report["input"]["compact"] and not back["input"]["compact"]
    # An archive .rgs is a compact input, and its errors are those of the decoded archive: Draco moves means.
    archive = roofgs.convert(str(SOURCE_DIR / "samples" / "guitar.ply"), str(tmp_path / "a.rgs"), profile="archive")
    assert 0 < archive["errors"]["position"]["max"] < 1e-3
    assert roofgs.convert(str(tmp_path / "a.rgs"), str(tmp_path / "a.ply"))["input"]["compact"]


def test_convert_report_is_rgs_convert_json(tmp_path):
    """convert()'s dict is rgs-convert --json's report (api::convert_report_json): the same keys and values."""
    import json
    import os
    import subprocess
    tool = os.environ.get("RGS_CONVERT")
    if not tool:
        pytest.skip("rgs-convert not built (RGS_CONVERT unset)")
    src = str(SOURCE_DIR / "samples" / "guitar.ply")
    for name, options in (("g.rgs", ["--profile", "archive"]), ("g.spz", [])):
        dst = str(tmp_path / name)
        report = roofgs.convert(src, dst, profile="archive" if options else None)
        subprocess.run([tool, src, dst, *options, "--json", str(tmp_path / "cli.json"), "-q"], check=True)
        cli = json.loads((tmp_path / "cli.json").read_text())
        assert set(report.pop("seconds")) == set(cli.pop("seconds")) == {"read", "quantize", "lod", "write", "total"}
        assert report == cli, name


# The first bytes of each output format.
SIGNATURES = {"rgs": b"\x89RGS\r\n\x1a\n", "ply": b"ply\n", "spz": b"NGSP", "glb": b"glTF", "sog": b"PK\x03\x04"}
DATA = SOURCE_DIR / "tests" / "data"
INPUTS = {
    "ply": DATA / "interop" / "guitar_256.ply",
    "rgs": DATA / "v1.0" / "small_sh3.rgs",
    "compressed_ply": DATA / "sog" / "guitar_crop.compressed.ply",
    "sog": DATA / "sog" / "guitar_crop_sh3" / "meta.json",
    "sog_bundle": DATA / "sog" / "guitar_crop.sog",
    "sog_lod": DATA / "sog" / "guitar_crop_lod-meta.json",
    "spz": DATA / "interop" / "guitar_256_splat_transform_v4.spz",
    "glb": DATA / "interop" / "guitar_256_splat_transform.glb",
    "splat": DATA / "interop" / "guitar_256_splat_transform.splat",
    "ksplat": DATA / "ksplat" / "guitar_sh3_1024_l1_sh2.ksplat",
}


@pytest.mark.parametrize("output", sorted(SIGNATURES))
@pytest.mark.parametrize("input_format", sorted(INPUTS))
def test_convert_writes_the_format_dst_names(input_format, output, tmp_path):
    src = INPUTS[input_format]
    dst = tmp_path / ("out." + output)
    report = roofgs.convert(str(src), str(dst))
    assert report["input"]["format"] == input_format
    assert report["output"]["format"] == output
    assert dst.read_bytes()[:len(SIGNATURES[output])] == SIGNATURES[output]
    assert report["output"]["bytes"] == dst.stat().st_size
    back = roofgs.load(str(dst), device="cpu", quantize_other_formats=False)
    assert back.info["gaussians"] == report["gaussians"] > 0


def test_convert_writes_sog_folders_and_streamed_sog(tmp_path):
    src = str(SOURCE_DIR / "tests" / "data" / "guitar_sh3.ply")
    folder = roofgs.convert(src, str(tmp_path / "meta.json"))
    assert folder["output"]["format"] == "sog" and (tmp_path / "shN_labels.webp").is_file()
    (tmp_path / "lod").mkdir()
    streamed = roofgs.convert(src, str(tmp_path / "lod" / "lod-meta.json"), lod_levels="auto")
    assert streamed["output"]["description"] == "PlayCanvas streamed SOG"
    assert (tmp_path / "lod" / "0_0" / "meta.json").is_file()
    for path in (tmp_path / "meta.json", tmp_path / "lod" / "lod-meta.json"):
        back = roofgs.load(str(path), device="cpu", quantize_other_formats=False)
        assert back.info["gaussians"] == folder["gaussians"] == 8000


def test_convert_options_match_the_tool(tmp_path):
    src = str(INPUTS["sog"])
    # `to` decides for any other extension; a name saying another of the four formats is refused.
    report = roofgs.convert(src, str(tmp_path / "scene.bin"), to="spz", sh_degree=1)
    assert report["output"]["format"] == "spz" and report["sh_degree"] == 1
    assert any("reduced to 1" in note for note in report["input"]["notes"])
    with pytest.raises(roofgs.Error) as e:
        roofgs.convert(src, str(tmp_path / "scene.rgs"), to="glb")
    assert e.value.code_name == "kInvalidArgument" and "the name says rgs" in str(e.value)
    archive = roofgs.convert(src, str(tmp_path / "a.rgs"), profile="archive")
    runtime = roofgs.convert(src, str(tmp_path / "r.rgs"))
    assert archive["output"]["bytes"] < runtime["output"]["bytes"]
    assert "archive" in archive["output"]["description"]
    # The SPZ axes: the frame chosen is noted on writing and on reading.
    ply = str(INPUTS["ply"])
    for frame in ("rub", "as-stored"):
        out = roofgs.convert(ply, str(tmp_path / (frame + ".spz")), spz_frame=frame)
        assert any("frame:" in note and (frame == "rub") == ("RUB" in note) for note in out["output"]["notes"])
        scene = roofgs.load(str(tmp_path / (frame + ".spz")), device="cpu", quantize_other_formats=False,
                            spz_frame=frame)
        assert any(note.startswith("SPZ axes read as " + ("RUB" if frame == "rub" else "stored"))
                   for note in scene.info["notes"])
    with pytest.raises(roofgs.Error):
        roofgs.convert(ply, str(tmp_path / "x.spz"), spz_frame="flu")
    # One audit compares SPZ files of both conventions: the frame is given per file.
    rub, stored = tmp_path / "rub.spz", tmp_path / "as-stored.spz"
    per_file = roofgs.audit(ply, [str(rub), str(stored)], orbit=2, width=96, height=54, device="cpu",
                            spz_frame={stored: "as-stored"})
    one_frame = roofgs.audit(ply, [str(rub), str(stored)], orbit=2, width=96, height=54, device="cpu")
    psnr = lambda report, i: report["candidates"][i]["psnr_mean_db"]
    assert psnr(per_file, 0) == psnr(one_frame, 0) and psnr(per_file, 1) == pytest.approx(psnr(per_file, 0), abs=1e-6)
    assert psnr(one_frame, 1) < psnr(per_file, 1) - 10  # read in the other frame: upside down
    with pytest.raises(roofgs.Error):
        roofgs.load(str(stored), device="cpu", spz_frame={stored: "flu"})


def test_errors_carry_codes(tmp_path):
    with pytest.raises(roofgs.Error) as e:
        roofgs.load(str(tmp_path / "missing.rgs"), device="cpu")
    assert e.value.code_name == "kIoError" and e.value.code == 1
    assert isinstance(e.value, RuntimeError)
    with pytest.raises(roofgs.Error) as e:
        roofgs.load(str(SOURCE_DIR / "tests" / "data" / "bad" / "section_checksum.rgs"), device="cpu")
    assert e.value.code_name == "kChecksumMismatch"
    with pytest.raises(roofgs.Error) as e:
        roofgs.load(str(SOURCE_DIR / "samples" / "guitar.ply"), device="tpu")
    assert e.value.code_name == "kInvalidArgument"
    with pytest.raises(roofgs.Error) as e:
        roofgs.convert(str(SOURCE_DIR / "samples" / "guitar.ply"), str(tmp_path / "x.rgs"), zstd=["colours"])
    assert e.value.code_name == "kInvalidArgument" and "colours" in str(e.value)


def test_cameras_in_every_convention():
    # INRIA: identity orientation at (1, 2, 3); the point 10 units ahead lands on the centre pixel.
    c = roofgs.camera_from_inria(np.eye(3), [1, 2, 3], 100, 100, 200, 100)
    assert c.project([1, 2, 13]) == pytest.approx((99.5, 49.5, 10))
    # COLMAP: 90 degrees about z, principal point as given (corner origin).
    s = math.sqrt(0.5)
    c = roofgs.camera_from_colmap([s, 0, 0, s], [0, 0, 4], 50, 60, 30, 20, 64, 48)
    assert c.project([1, 0, 0]) == pytest.approx((29.5, 34.5, 4))
    # OpenCV: pixel centres at integers, u = fx x/z + cx.
    K = [[500, 0, 319.5], [0, 400, 239.5], [0, 0, 1]]
    c = roofgs.camera_from_opencv(K, np.eye(3), [0, 0, 2], 640, 480)
    assert c.project([0.2, -0.1, 0]) == pytest.approx((369.5, 219.5, 2))
    # OpenGL: eye at (0, 0, 5), perspective(90 deg, aspect 2); world (1, 1, 0) -> window (110, 60 from the
    # bottom) -> pixel (109.5, 39.5) counted from the top.
    view = np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, -5], [0, 0, 0, 1]], dtype=float)
    proj = np.array([[0.5, 0, 0, 0], [0, 1, 0, 0], [0, 0, -100.1 / 99.9, -20 / 99.9], [0, 0, -1, 0]])
    c = roofgs.camera_from_opengl(view, proj, 200, 100)
    assert c.project([1, 1, 0]) == pytest.approx((109.5, 39.5, 5))
    vk = proj.copy()
    vk[1, 1] = -1
    c = roofgs.camera_from_vulkan(view, vk, 200, 100)
    assert c.project([1, 1, 0]) == pytest.approx((109.5, 39.5, 5))
    with pytest.raises(roofgs.Error) as e:
        roofgs.camera_from_opengl(view, vk, 200, 100)
    assert e.value.code_name == "kInvalidArgument"


def test_cpu_render_returns_numpy(guitar_rgs):
    scene = roofgs.load(guitar_rgs, device="cpu")
    assert len(scene) == 90854
    info = scene.info
    assert info["device"] == "cpu" and info["source_is_rgs"]
    camera = scene.orbit_cameras(1, 64, 36)[0]
    rgba = scene.render(camera)
    assert rgba.shape == (36, 64, 4) and rgba.dtype == np.float32
    assert rgba[..., 3].max() > 0.5
    rgba8, depth = scene.render(camera, preset="faithful", format="rgba8", depth=True, width=32, height=18)
    assert rgba8.shape == (18, 32, 4) and rgba8.dtype == np.uint8
    assert depth.shape == (18, 32) and depth.dtype == np.float32 and depth.max() > 0
    half = scene.render(camera, preset="paper", format="rgba16f")
    assert half.dtype == np.float16
    # The same preset gives the same frame in every format (8-bit: the 3DGS rounding rule).
    fastest32 = scene.render(camera, format="rgba32f")
    fastest8 = scene.render(camera, format="rgba8")
    expected8 = np.floor(np.clip(fastest32, 0, 1) * 255 + 0.5).astype(np.uint8)
    assert np.array_equal(fastest8, expected8)
    with pytest.raises(roofgs.Error) as e:
        scene.render(camera, preset="slowest")
    assert e.value.code_name == "kInvalidArgument"
    # The GPU's scratch budget means nothing to the CPU renderer: the same frame; nor does settling, which waits
    # for a GPU level-of-detail scene's levels.
    assert np.array_equal(scene.render(camera, scratch_budget=1), rgba)
    assert np.array_equal(scene.render(camera, settle=True), rgba)


def test_load_level_of_detail_keywords():
    """load()'s level-of-detail keywords on the golden v1.3 file (2 chunks x 3 levels, 14 Gaussians at full
    detail, 3 in the coarsest levels): the full detail on request, a splat budget kept, frame_stats counting."""
    path = DATA / "v1.3" / "small_sh1_lod.rgs"
    full = roofgs.load(path, device="cpu", lod=False)
    assert len(full) == 14 and not full.info["lod"]["active"]
    assert full.info["lod"]["chunks"] == 2 and full.info["lod"]["levels"] == 3
    assert full.frame_stats is None
    camera = full.orbit_cameras(1, 64, 36)[0]
    reference = full.render(camera)
    assert full.frame_stats["gaussians"] == 14 and full.frame_stats["lod"]["splats"] == 0
    # No budget and no error allowed: level 0 of every chunk, the full detail itself.
    exact = roofgs.load(path, device="cpu", splat_budget=0, pixel_error=0.0)
    lod = exact.info["lod"]
    assert lod["active"] and lod["stored_gaussians"] == 24 and lod["splat_budget"] == 0 and lod["pool_bytes"] == 0
    assert np.array_equal(exact.render(camera), reference)
    stats = exact.frame_stats
    assert stats["lod"]["splats"] == 14 and stats["lod"]["chunks_drawn"] == 2 and stats["lod"]["chunks_culled"] == 0
    assert stats["lod"]["bytes_streamed"] == 0 and stats["lod"]["chunks_not_resident"] == 0
    # A budget of the coarsest levels: at most 3 Gaussians drawn, another image.
    small = roofgs.load(path, device="cpu", splat_budget=3, pixel_error=1.0)
    image = small.render(camera)
    assert small.frame_stats["lod"]["splats"] <= 3 and small.frame_stats["lod"]["chunks_coarsened"] > 0
    assert small.frame_stats["gaussians"] == small.frame_stats["lod"]["splats"]
    assert not np.array_equal(image, reference)
    # Bad values name the setting; a memory budget means nothing to the CPU, nor a budget to a file without levels.
    with pytest.raises(ValueError, match=r"^load\(\): pixel_error must be a finite number in 0\.\.1000, got -1$"):
        roofgs.load(path, device="cpu", pixel_error=-1.0)
    with pytest.raises(ValueError, match=r"^load\(\): stream_bytes must be an integer in 1\.\.\d+, got 0$"):
        roofgs.load(path, device="cpu", stream_bytes=0)
    assert roofgs.load(path, device="cpu", stream_bytes=1 << 16).info["lod"]["stream_bytes_per_frame"] == 1 << 16
    noted = roofgs.load(path, device="cpu", memory_budget=1 << 20)
    assert any("memory budget not used on the CPU" in n for n in noted.info["notes"])
    plain = roofgs.load(INPUTS["rgs"], device="cpu", splat_budget=1000)
    assert not plain.info["lod"]["active"]
    assert any("level-of-detail budgets not used" in n for n in plain.info["notes"])


def test_paths_devices_sizes_and_reprs(guitar_rgs, tmp_path):
    """Paths as os.PathLike; device="auto" (the default) loads on the CPU when no device answers, said once,
    and "cuda" then raises an error naming the fix; one image side keeps the aspect ratio."""
    rgs = pathlib.Path(guitar_rgs)
    report = roofgs.convert(SOURCE_DIR / "samples" / "guitar.ply", tmp_path / "g.spz")
    assert report["output"]["format"] == "spz" and (tmp_path / "g.spz").stat().st_size == report["output"]["bytes"]
    scene = roofgs.load(rgs, device="cpu")
    assert repr(scene).startswith("<roofgs.Scene 90854 Gaussians, SH degree 0, ")
    camera = scene.orbit_cameras(1, 64, 36)[0]
    assert scene.render(camera, width=32).shape == (18, 32, 4)
    assert scene.render(camera, height=9).shape == (9, 16, 4)
    assert roofgs.built_with_cuda or not roofgs.has_cuda
    if not roofgs.has_cuda:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # said once per process: see the test below
            auto = roofgs.load(rgs)
        assert auto.device == "cpu"
        with pytest.raises(roofgs.Error) as e:
            roofgs.load(rgs, device="cuda")
        assert e.value.code_name == "kUnsupportedFeature" and "device='cpu'" in str(e.value)
    else:
        assert roofgs.load(rgs).device == "cuda"


def test_no_cuda_device_is_said_once_per_process_in_plain_words():
    """device="auto" without a device warns once per process (not once per calling line), without CUDA's
    wording, which roofgs.cuda_status() keeps."""
    import subprocess
    import sys
    script = """
import warnings, roofgs
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("default")
    for line in range(3):
        roofgs.load(%r)
    roofgs.load(%r)
    roofgs.load(%r)
    roofgs.load(%r)
print(len(caught))
for w in caught:
    print(w.category.__name__, w.message)
""" % ((str(GUITAR),) * 4)
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    lines = run.stdout.splitlines()
    status = roofgs.cuda_status()
    assert set(status) == {"built_with_cuda", "available", "reason"}
    assert status["built_with_cuda"] == roofgs.built_with_cuda
    if status["available"]:
        assert lines == ["0"] and status["reason"] == ""
        return
    assert lines == ["1", "RuntimeWarning roofgs: no usable CUDA device: rendering on the CPU reference "
                          "(roofgs.cuda_status() says why)"], run.stdout
    assert status["reason"] and status["reason"] not in lines[1]


def test_audit_takes_one_path_and_gives_the_verdict(tmp_path):
    """audit() takes a single candidate path (str or os.PathLike) as well as a list, and carries rgs-audit
    --json's verdict per candidate and for the run."""
    ply = SOURCE_DIR / "samples" / "guitar.ply"
    roofgs.convert(ply, tmp_path / "g.rgs")
    args = dict(orbit=1, width=48, height=27, device="cpu")
    for candidate in (str(tmp_path / "g.rgs"), tmp_path / "g.rgs"):
        report = roofgs.audit(str(ply), candidate, **args)
        assert len(report["candidates"]) == 1 and report["candidates"][0]["path"].endswith("g.rgs")
    c = report["candidates"][0]
    v = c["verdict"]
    assert set(v) == {"passed", "metric", "psnr_mean_db", "whole_frame_psnr_mean_db", "foreground_psnr_mean_db",
                      "worst_view", "bytes_saved", "bytes_saved_fraction"}
    # guitar has a background: the verdict is on the foreground PSNR, the whole frame's beside it.
    assert v["metric"] == "foreground" and v["passed"] is True
    assert v["psnr_mean_db"] == v["foreground_psnr_mean_db"] < v["whole_frame_psnr_mean_db"] == c["psnr_mean_db"]
    assert v["bytes_saved"] == report["source"]["bytes"] - c["bytes"] and 0.3 < v["bytes_saved_fraction"] < 1
    assert report["verdict"] == {
        "threshold_db": 40.0, "passed": True,
        "criterion": "mean PSNR over the views (each candidate's verdict metric) >= threshold_db"}
    strict = roofgs.audit(ply, [tmp_path / "g.rgs"], threshold=1000.0, **args)
    assert strict["verdict"]["passed"] is False and strict["candidates"][0]["verdict"]["passed"] is False
    # No cameras and no orbit: rgs-audit's default views, said in views_note (no cameras.json beside samples/).
    guessed = roofgs.audit(ply, tmp_path / "g.rgs", width=64, height=36, device="cpu")
    assert "guessed" in guessed["views_note"] and guessed["views"] > 1 and "views_note" not in report


def test_an_unknown_convert_option_lists_every_option(tmp_path):
    """The TypeError of an unknown keyword names every option convert() and save() take."""
    src = str(SOURCE_DIR / "samples" / "guitar.ply")
    for call, name, count in ((lambda **k: roofgs.convert(src, str(tmp_path / "x.rgs"), **k), "convert", 31),
                              (lambda **k: roofgs.save(str(tmp_path / "x.rgs"), *read_ply_arrays(GUITAR), **k), "save",
                               30)):
        with pytest.raises(TypeError, match="bogus") as e:
            call(bogus=1)
        listed = str(e.value).split("the options are ")[1].split(", ")
        assert listed == _signature_keywords(getattr(roofgs, name)) and len(listed) == count
    with pytest.raises(TypeError, match="unexpected keyword argument 'bogus'; the options are to, sh_degree"):
        roofgs._convert(src, str(tmp_path / "x.rgs"), bogus=1)


def test_camera_project_takes_a_named_point():
    camera = roofgs.camera_from_opencv([[100, 0, 32], [0, 100, 18], [0, 0, 1]], np.eye(3), [0, 0, 0], 64, 36)
    x, y, z = camera.project(point=[0.0, 0.0, 2.0])
    assert (x, y, z) == (32.0, 18.0, 2.0)  # OpenCV K: pixel centres at integers, as project()
    assert "project(self: roofgs.Camera, point:" in roofgs.Camera.project.__doc__


def test_module_docstring_names_every_format_it_reads():
    import os
    import subprocess
    tool = os.environ.get("RGS_CONVERT")
    if not tool:
        pytest.skip("skipped: rgs-convert not built (RGS_CONVERT unset)")
    help_text = " ".join(subprocess.run([tool, "--help"], capture_output=True, text=True, check=True).stdout.split())
    formats = re.search(r"converter::read_scene detects \((.*?)\)", help_text).group(1).split(", ")
    assert len(formats) >= 7
    for name in formats + [".rgs"]:
        assert name in roofgs.__doc__, name


def test_audit_takes_any_format(tmp_path):
    """audit() is rgs-audit's measurement: renders against the source on the same views, any formats."""
    ply = SOURCE_DIR / "samples" / "guitar.ply"
    roofgs.convert(ply, tmp_path / "g.spz")
    roofgs.convert(ply, tmp_path / "g.rgs")
    report = roofgs.audit(ply, [tmp_path / "g.spz", tmp_path / "g.rgs"], orbit=2, width=96, height=54, device="cpu")
    assert report["views"] == 2 and report["source"]["gaussians"] == 90854
    spz, rgs = report["candidates"]
    assert spz["format"] != "rgs" and spz["sections"] == [] and 0 < spz["errors"]["position"]["max"] < 0.01
    assert len(rgs["sections"]) >= 5 and 30 < rgs["bytes_per_gaussian"] < 60
    assert rgs["errors"]["opacity"]["max"] < 1e-3
    # The .rgs renders closer to the source than the SPZ, and both well above noise.
    assert rgs["psnr_min_db"] > spz["psnr_min_db"] > 25
    assert 0 < spz["ssim_min"] <= rgs["ssim_min"] <= 1


def test_embedding_doc_python_example(guitar_rgs, tmp_path, monkeypatch):
    """Runs the Python example of docs/EMBEDDING.md as written (with its scene path pointed at the sample)."""
    text = (SOURCE_DIR / "docs" / "EMBEDDING.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert blocks, "docs/EMBEDDING.md has no python example"
    monkeypatch.chdir(tmp_path)
    pathlib.Path("scene.rgs").write_bytes(pathlib.Path(guitar_rgs).read_bytes())
    namespace = {"DEVICE": "cuda" if roofgs.has_cuda and _cuda_ok() else "cpu"}
    exec(compile(blocks[0].replace('device="cuda"', 'device=DEVICE'), "EMBEDDING.md", "exec"), namespace)
    # Upright and the C++ example's view: its OpenCV camera (identity rotation, eye 3 radii before the centre)
    # renders the same image on the CPU reference.
    scene = roofgs.load("scene.rgs", device="cpu")
    center, radius = np.array(scene.info["sphere_center"]), scene.info["sphere_radius"]
    opencv = roofgs.camera_from_opencv([[500, 0, 319.5], [0, 500, 179.5], [0, 0, 1]], np.eye(3),
                                       -center + [0, 0, 3 * radius], 640, 360)
    difference = np.abs(np.asarray(namespace["pixels"]).astype(int) - scene.render(opencv, format="rgba8"))
    if namespace["DEVICE"] == "cpu":
        assert difference.max() <= 1
    else:  # the GPU's fastest preset blends in binary16 (docs/RENDERER.md): close, not equal
        assert difference.mean() < 1.0


def test_embedding_doc_gsplat_example(guitar_rgs, cuda, tmp_path, monkeypatch):
    """Runs the torch example of docs/EMBEDDING.md as written: its first view is the C++ example's."""
    torch = pytest.importorskip("torch")
    blocks = re.findall(r"```python\n(.*?)```", (SOURCE_DIR / "docs" / "EMBEDDING.md").read_text(), re.S)
    assert len(blocks) >= 2, "docs/EMBEDDING.md has no torch example"
    monkeypatch.chdir(tmp_path)
    pathlib.Path("scene.rgs").write_bytes(pathlib.Path(guitar_rgs).read_bytes())
    namespace = {}
    exec(compile(blocks[1], "EMBEDDING.md", "exec"), namespace)
    colors, alphas = namespace["colors"], namespace["alphas"]
    assert isinstance(colors, torch.Tensor) and colors.is_cuda and tuple(colors.shape) == (2, 360, 640, 3)
    scene = roofgs.load("scene.rgs", device="cpu")
    center, radius = np.array(scene.info["sphere_center"]), scene.info["sphere_radius"]
    opencv = roofgs.camera_from_opencv([[500, 0, 319.5], [0, 500, 179.5], [0, 0, 1]], np.eye(3),
                                       -center + [0, 0, 3 * radius], 640, 360)
    rgba = scene.render(opencv)
    assert _psnr(colors[0].cpu().numpy(), rgba[..., :3]) > 50 and _psnr(alphas[0, ..., 0].cpu().numpy(), rgba[..., 3]) > 50


def test_readme_python_example(tmp_path, monkeypatch):
    """Runs the Python example of the README as written, on the bundled sample."""
    blocks = re.findall(r"```python\n(.*?)```", (SOURCE_DIR / "README.md").read_text(), re.S)
    assert blocks, "README.md has no python example"
    monkeypatch.chdir(tmp_path)
    pathlib.Path("scene.ply").write_bytes((SOURCE_DIR / "samples" / "guitar.ply").read_bytes())
    namespace = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # "no CUDA device" on a machine without one
        exec(compile(blocks[0], "README.md", "exec"), namespace)
    assert namespace["report"]["gaussians"] == 90854
    image = np.asarray(namespace["rgba"])  # a NumPy array on the CPU, a DeviceImage on the GPU
    assert image.shape == (720, 1280, 4) and image.dtype == np.uint8 and image[..., 3].max() > 128


def _cuda_ok():
    from conftest import cuda_available
    return cuda_available()[0]


def test_gpu_render_dlpack(guitar_rgs, cuda):
    torch = pytest.importorskip("torch")
    scene = roofgs.load(guitar_rgs, device="cuda")
    info = scene.info
    assert not info["has_fp32"]
    assert info["memory_bytes"] <= 1.1 * info["runtime_section_bytes"]
    camera = scene.orbit_cameras(1, 320, 180)[0]
    stream = torch.cuda.Stream()
    image = scene.render(camera, stream=stream.cuda_stream)
    assert image.shape == [180, 320, 4] and image.dtype == "float32"
    with torch.cuda.stream(stream):
        t = torch.from_dlpack(image)  # no copy: the tensor views the renderer's output
    assert t.data_ptr() == image.data_ptr and t.is_cuda and tuple(t.shape) == (180, 320, 4)
    with pytest.raises(TypeError, match=r"^__dlpack__\(\): stream must be an int, got str$"):
        image.__dlpack__(stream="default")
    cpu_scene = roofgs.load(guitar_rgs, device="cpu")
    ref = cpu_scene.render(camera)
    mse = float(((t.cpu().numpy().astype(np.float64) - ref) ** 2).mean())
    assert mse == 0 or 10 * math.log10(1 / mse) > 50
    with pytest.raises(roofgs.Error) as e:
        scene.render(camera, preset="faithful")
    assert e.value.code_name == "kInvalidArgument"
    both = roofgs.load(guitar_rgs, device="cuda", presets=["fastest", "faithful"])
    rgba8 = both.render(camera, preset="faithful", format="rgba8").numpy()
    assert rgba8.dtype == np.uint8 and rgba8.shape == (180, 320, 4)
    # A scratch budget renders in groups of tile rows, the same frame; one below the scene's own buffers is refused.
    whole = scene.render(camera).numpy()
    assert np.array_equal(scene.render(camera, scratch_budget=64 << 20).numpy(), whole)
    with pytest.raises(roofgs.Error) as e:
        scene.render(camera, scratch_budget=1 << 20)
    assert e.value.code_name == "kLimitExceeded"


def test_type_stubs_name_every_public_object():
    """python/roofgs.pyi, installed with the module, declares exactly its public names."""
    stubs = (SOURCE_DIR / "python" / "roofgs.pyi").read_text()
    declared = set(re.findall(r"^(?:def|class) (\w+)", stubs, re.M)) | set(re.findall(r"^(\w+):", stubs, re.M))
    public = {name for name in dir(roofgs) if not name.startswith("_")}
    assert public == {name for name in declared if not name.startswith("_")}


def read_ply_arrays(path):
    """A 3DGS binary PLY's Gaussians as roofgs.save()'s arrays (activated: exp scales, sigmoid opacities)."""
    data = pathlib.Path(path).read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    names = re.findall(rb"property float (\w+)", data[:end])
    rows = np.frombuffer(data[end:], dtype=np.dtype([(n.decode(), "<f4") for n in names]))
    col = lambda *keys: np.stack([rows[k] for k in keys], axis=1).astype(np.float32)
    rest = sorted((n.decode() for n in names if n.startswith(b"f_rest_")), key=lambda n: int(n[7:]))
    k = 1 + len(rest) // 3
    sh = np.zeros((len(rows), k, 3), np.float32)
    sh[:, 0] = col("f_dc_0", "f_dc_1", "f_dc_2")
    for c in range(3):  # PLY f_rest: channel-major; the arrays: coefficient-major
        for j in range(k - 1):
            sh[:, 1 + j, c] = rows[rest[c * (k - 1) + j]]
    return (col("x", "y", "z"), col("rot_0", "rot_1", "rot_2", "rot_3"), np.exp(col("scale_0", "scale_1", "scale_2")),
            1 / (1 + np.exp(-rows["opacity"].astype(np.float32))), sh)


GUITAR = SOURCE_DIR / "samples" / "guitar.ply"


def test_from_arrays_renders_what_the_file_renders(tmp_path):
    arrays = read_ply_arrays(GUITAR)
    from_file = roofgs.load(GUITAR, device="cpu", quantize_other_formats=False)
    from_arrays = roofgs.Scene.from_arrays(*arrays, device="cpu")
    assert len(from_arrays) == len(from_file) == 90854
    camera = from_file.orbit_cameras(2, 96, 54)[1]
    # Equal up to float32 rounding: NumPy's exp and sigmoid above against the PLY reader's expf.
    for preset in ("fastest", "faithful"):
        assert np.allclose(from_arrays.render(camera, preset=preset), from_file.render(camera, preset=preset),
                           rtol=0, atol=1e-6)
    # arrays() gives back what from_arrays() takes (quaternions normalized again: within a float32 ulp).
    back = from_file.arrays()
    assert [a.shape for a in back] == [(90854, 3), (90854, 4), (90854, 3), (90854,), (90854, 1, 3)]
    assert np.allclose(roofgs.Scene.from_arrays(*back, device="cpu").render(camera), from_file.render(camera),
                       rtol=0, atol=1e-6)


@pytest.mark.parametrize("output", sorted(SIGNATURES))
def test_save_writes_every_format(output, tmp_path):
    means, quats, scales, opacities, sh = read_ply_arrays(GUITAR)
    path = tmp_path / ("g." + output)
    report = roofgs.save(path, means[:500], quats[:500], scales[:500], opacities[:500], sh[:500])
    assert report["input"]["format"] == "arrays" and report["output"]["format"] == output
    assert path.read_bytes()[:len(SIGNATURES[output])] == SIGNATURES[output]
    back = roofgs.load(path, device="cpu", quantize_other_formats=False)
    assert len(back) == 500
    if output == "ply":  # lossless: the same frame as the arrays themselves
        camera = back.orbit_cameras(1, 64, 36)[0]
        direct = roofgs.Scene.from_arrays(means[:500], quats[:500], scales[:500], opacities[:500], sh[:500], device="cpu")
        assert np.allclose(back.render(camera), direct.render(camera), atol=1e-6)


def test_save_and_convert_fit_a_target(tmp_path):
    # Rate control through api::convert: the arrays themselves are the source (no scratch file), and the report
    # says what the fit reached; a target needs a .rgs output.
    scene = roofgs.load(GUITAR, device="cpu", quantize_other_formats=False)
    report = roofgs.save(tmp_path / "g30.rgs", *scene.arrays(), target_psnr=30, orbit=2, width=96)
    fit = report["rate_control"]
    assert fit["psnr_mean_db"] >= 30 and fit["views"] == 2 and fit["width"] == 96
    assert report["output"]["bytes"] == (tmp_path / "g30.rgs").stat().st_size
    report = roofgs.convert(GUITAR, tmp_path / "g_bytes.rgs", target_bytes=300000, orbit=2, width=96)
    assert report["output"]["bytes"] <= 300000 and report["rate_control"]["psnr_mean_db"] > 30
    with pytest.raises(Exception, match="archive profile of a .rgs output"):
        roofgs.convert(GUITAR, tmp_path / "g.ply", target_psnr=30)
    assert not (tmp_path / "g.ply").exists()


def test_arrays_follow_the_value_rules():
    means, quats, scales, opacities, sh = (a[:100].copy() for a in read_ply_arrays(GUITAR))
    with pytest.raises(roofgs.Error) as e:
        roofgs.Scene.from_arrays(means, quats, -scales, opacities, sh, device="cpu")
    assert e.value.code_name == "kInvalidArgument" and "exp() them first" in str(e.value)
    with pytest.raises(roofgs.Error) as e:
        roofgs.Scene.from_arrays(means, quats, scales, opacities * 2 + 1, sh, device="cpu")
    assert "sigmoid() them first" in str(e.value)
    means[7, 1] = np.nan
    with pytest.raises(roofgs.Error) as e:
        roofgs.Scene.from_arrays(means, quats, scales, opacities, sh, device="cpu")
    assert e.value.code_name == "kCorruptData"
    assert len(roofgs.Scene.from_arrays(means, quats, scales, opacities, sh, device="cpu", sanitize=True)) == 99
    with pytest.raises(roofgs.Error):
        roofgs.Scene.from_arrays(means[:, :2], quats, scales, opacities, sh, device="cpu")


def gsplat_cameras(cameras):
    """gsplat's viewmats [C, 4, 4] (world-to-camera) and Ks [C, 3, 3] of roofgs cameras."""
    viewmats = np.zeros((len(cameras), 4, 4), np.float32)
    Ks = np.zeros((len(cameras), 3, 3), np.float32)
    for i, c in enumerate(cameras):
        viewmats[i, :3, :3], viewmats[i, :3, 3], viewmats[i, 3, 3] = c.rotation, c.translation, 1
        Ks[i] = [[c.fx, 0, c.cx], [0, c.fy, c.cy], [0, 0, 1]]
    return viewmats, Ks


def test_rasterization_is_gsplats_call_on_the_cpu_reference():
    """gsplat's conventions (world-to-camera viewmats, K with pixel centres at half-integers, activated
    values, RGB colours) give the CPU reference's frame of the same camera, bit for bit."""
    means, quats, scales, opacities, sh = read_ply_arrays(GUITAR)
    scene = roofgs.Scene.from_arrays(means, quats, scales, opacities, sh, device="cpu")
    cameras = scene.orbit_cameras(2, 80, 48)
    viewmats, Ks = gsplat_cameras(cameras)
    colors, alphas, meta = roofgs.rasterization(means, quats, scales, opacities, sh, viewmats, Ks, 80, 48,
                                                sh_degree=0, near_plane=0.2, render_mode="RGB+ED", device="cpu")
    assert colors.shape == (2, 48, 80, 4) and alphas.shape == (2, 48, 80, 1) and meta["n_cameras"] == 2
    for i, c in enumerate(cameras):
        rgba, depth = scene.render(c, depth=True)
        assert np.array_equal(colors[i, ..., :3], rgba[..., :3])
        assert np.array_equal(alphas[i, ..., 0], rgba[..., 3])
        assert np.array_equal(colors[i, ..., 3], depth)
    # RGB colours instead of SH: the DC term that renders them.
    rgb = np.clip(0.5 + 0.28209479177387814 * sh[:, 0], 0, None)
    colors_rgb, _, _ = roofgs.rasterization(means, quats, scales, opacities, rgb, viewmats[:1], Ks[:1], 80, 48,
                                            near_plane=0.2, device="cpu")
    assert np.allclose(colors_rgb[0], colors[0, ..., :3], atol=1e-5)
    with pytest.raises(ValueError, match="absgrad"):
        roofgs.rasterization(means, quats, scales, opacities, rgb, viewmats, Ks, 80, 48, absgrad=True)


def _small_gsplat_call(count=2, width=40, height=24):
    """A small rasterization() call on the guitar: its arrays (sh [N, 1, 3], sh_degree=0) and views."""
    means, quats, scales, opacities, sh = read_ply_arrays(GUITAR)
    cameras = roofgs.Scene.from_arrays(means, quats, scales, opacities, sh, device="cpu").orbit_cameras(count, width,
                                                                                                      height)
    viewmats, Ks = gsplat_cameras(cameras)
    return [means, quats, scales, opacities, sh, viewmats, Ks, width, height]


# gsplat.rasterization's options after `height` and their defaults (gsplat 1.5); rolling_shutter's default is
# gsplat's RollingShutterType.GLOBAL, which is not importable here.
GSPLAT_DEFAULTS = dict(near_plane=0.01, far_plane=1e10, radius_clip=0.0, eps2d=0.3, sh_degree=None, packed=True,
                       tile_size=16, backgrounds=None, render_mode="RGB", sparse_grad=False, absgrad=False,
                       rasterize_mode="classic", channel_chunk=32, distributed=False, camera_model="pinhole",
                       segmented=False, covars=None, with_ut=False, with_eval3d=False, radial_coeffs=None,
                       tangential_coeffs=None, thin_prism_coeffs=None, ftheta_coeffs=None, viewmats_rs=None)


def test_rasterization_takes_every_gsplat_option_at_its_default():
    """Each gsplat option, at its default, renders the same image; packed, channel_chunk and segmented at any
    value; any other non-default value raises ValueError naming the option."""
    import inspect
    args = _small_gsplat_call()
    parameters = inspect.signature(roofgs.rasterization).parameters
    assert list(parameters)[9:9 + len(GSPLAT_DEFAULTS) + 1] == [*list(GSPLAT_DEFAULTS)[:-1], "rolling_shutter",
                                                               "viewmats_rs"]
    assert _stub_positional("rasterization") == list(parameters)[:len(_stub_positional("rasterization"))]
    base, _, _ = roofgs.rasterization(*args, sh_degree=0, device="cpu")
    options = dict(GSPLAT_DEFAULTS, sh_degree=0)
    for name, value in options.items():
        colors, _, _ = roofgs.rasterization(*args, **{"sh_degree": 0, name: value}, device="cpu")
        assert np.array_equal(colors, base), name
    every, _, _ = roofgs.rasterization(*args, **options, device="cpu")
    assert np.array_equal(every, base)

    class Global:  # gsplat's RollingShutterType.GLOBAL, by name
        name = "GLOBAL"

    any_value = dict(packed=False, channel_chunk=4, segmented=True, far_plane=1e12, rolling_shutter=Global())
    colors, _, _ = roofgs.rasterization(*args, sh_degree=0, device="cpu", **any_value)
    assert np.array_equal(colors, base)
    refused = dict(far_plane=100.0, radius_clip=1.0, eps2d=0.1, tile_size=8, sparse_grad=True, absgrad=True,
                   rasterize_mode="mip", distributed=True, camera_model="fisheye", covars=np.eye(3),
                   with_ut=True, with_eval3d=True, radial_coeffs=np.zeros((2, 6)), tangential_coeffs=np.zeros((2, 2)),
                   thin_prism_coeffs=np.zeros((2, 4)), ftheta_coeffs=object(), rolling_shutter="ROLLING_TOP_TO_BOTTOM",
                   viewmats_rs=args[5])
    for name, value in refused.items():
        with pytest.raises(ValueError, match="; " + name + "=.* is not supported"):
            roofgs.rasterization(*args, **{name: value}, sh_degree=0, device="cpu")
    with pytest.raises(TypeError, match="bogus"):
        roofgs.rasterization(*args, bogus=1)


def test_rasterization_antialiased_scales_opacity_by_the_2d_filters_compensation():
    """rasterize_mode="antialiased" (gsplat's Mip-Splatting mode): a Gaussian's peak alpha is its opacity times
    sqrt(det S / det(S + 0.3 I)) of its projected covariance S, here (fx s / z)^2 I on the optical axis; NumPy and,
    when torch is importable, torch CPU tensors."""
    fx, z, opacity, side = 100.0, 10.0, 0.9, 41
    viewmats = np.eye(4, dtype=np.float32)[None]
    Ks = np.array([[[fx, 0, side / 2], [0, fx, side / 2], [0, 0, 1]]], np.float32)  # centre pixel 20 at 20.5
    quats = np.array([[1, 0, 0, 0]], np.float32)
    colors = np.ones((1, 3), np.float32)
    arrays = []
    for scale in (0.004, 0.01, 0.05, 0.5):
        sigma = fx * scale / z
        factor = sigma * sigma / (sigma * sigma + 0.3)
        means = np.array([[0, 0, z]], np.float32)
        scales = np.full((1, 3), scale, np.float32)
        opacities = np.array([opacity], np.float32)
        arrays.append((means, quats, scales, opacities, colors))
        alphas = {}
        for mode in ("classic", "antialiased"):
            _, a, _ = roofgs.rasterization(means, quats, scales, opacities, colors, viewmats, Ks, side, side,
                                           rasterize_mode=mode, preset="faithful", device="cpu")
            alphas[mode] = float(a[0, 20, 20, 0])
        assert alphas["classic"] == pytest.approx(opacity, rel=1e-5), sigma
        assert alphas["antialiased"] == pytest.approx(opacity * factor, rel=1e-4), sigma
    try:
        import torch
    except ImportError:
        print("skipped: torch CPU tensors (no torch)")
        return
    means, quats_, scales, opacities, colors_ = (torch.from_numpy(a) for a in arrays[2])
    _, a, _ = roofgs.rasterization(means, quats_, scales, opacities, colors_, torch.from_numpy(viewmats),
                                   torch.from_numpy(Ks), side, side, rasterize_mode="antialiased",
                                   preset="faithful", device="cpu")
    sigma = fx * 0.05 / z
    assert isinstance(a, torch.Tensor)
    assert float(a[0, 20, 20, 0]) == pytest.approx(opacity * sigma * sigma / (sigma * sigma + 0.3), rel=1e-4)


def test_rasterization_keeps_gsplats_leading_batch_dimensions():
    """means[None] and viewmats[None] render as without the batch; a batch of 2 renders each element, and the
    outputs carry the batch dimensions as gsplat's do."""
    means, quats, scales, opacities, sh, viewmats, Ks, w, h = _small_gsplat_call(count=3)
    gaussians = (means, quats, scales, opacities, sh)
    base, base_alphas, _ = roofgs.rasterization(*gaussians, viewmats, Ks, w, h, sh_degree=0, device="cpu")
    colors, alphas, meta = roofgs.rasterization(*(a[None] for a in gaussians), viewmats[None], Ks[None], w, h,
                                                sh_degree=0, device="cpu")
    assert colors.shape == (1, 3, h, w, 3) and alphas.shape == (1, 3, h, w, 1) and meta["batch_dims"] == [1]
    assert np.array_equal(colors[0], base) and np.array_equal(alphas[0], base_alphas)
    # [2, 1] batch: element (1, 0) has the Gaussians shifted away and other views.
    shifted = means + np.float32(1000)
    batch = lambda a, b: np.stack([a, b])[:, None]
    colors, alphas, meta = roofgs.rasterization(batch(means, shifted), *(batch(a, a) for a in gaussians[1:]),
                                                batch(viewmats[:2], viewmats[1:]), batch(Ks[:2], Ks[1:]), w, h,
                                                sh_degree=0, backgrounds=np.ones((2, 1, 2, 3), np.float32),
                                                device="cpu")
    assert colors.shape == (2, 1, 2, h, w, 3) and meta["n_cameras"] == 4 and len(meta["pairs"]) == 4
    assert np.array_equal(alphas[0, 0], base_alphas[:2]) and alphas[0, 0].max() > 0.5
    assert alphas[1, 0].max() == 0 and np.all(colors[1, 0] == 1)  # nothing in view: the background
    # Nested lists, with and without a batch dimension.
    few = [a[:300] for a in gaussians]
    listed, _, _ = roofgs.rasterization(*(a.tolist() for a in few), viewmats.tolist(), Ks.tolist(), w, h,
                                        sh_degree=0, device="cpu")
    batched, _, _ = roofgs.rasterization(*([a.tolist()] for a in few), [viewmats.tolist()], [Ks.tolist()], w, h,
                                         sh_degree=0, device="cpu")
    direct, _, _ = roofgs.rasterization(*few, viewmats, Ks, w, h, sh_degree=0, device="cpu")
    assert np.array_equal(listed, direct) and np.array_equal(batched[0], direct) and direct.max() > 0
    with pytest.raises(ValueError, match="viewmats: expected the leading batch dimensions"):
        roofgs.rasterization(*(a[None] for a in gaussians), viewmats, Ks, w, h, sh_degree=0, device="cpu")


def _fake_torch():
    """A stand-in for torch with what rasterization()'s array-type dispatch uses: Tensor, from_numpy, stack."""
    import types
    fake = types.ModuleType("torch")

    class Tensor(np.ndarray):
        pass

    fake.Tensor = Tensor
    fake.from_numpy = lambda a: a.view(Tensor)
    fake.stack = lambda parts, dim=0: np.stack(parts, axis=dim).view(Tensor)
    return fake


def test_rasterization_returns_the_callers_array_type(monkeypatch):
    """Host tensors in, the same tensor type out (here a stand-in torch; torch itself where installed); NumPy
    in, NumPy out; with and without batch dimensions."""
    args = _small_gsplat_call(count=1)
    base, _, _ = roofgs.rasterization(*args, sh_degree=0, device="cpu")
    assert type(base) is np.ndarray
    fake = _fake_torch()
    monkeypatch.setitem(__import__("sys").modules, "torch", fake)
    tensors = [fake.from_numpy(a) if isinstance(a, np.ndarray) else a for a in args]
    colors, alphas, _ = roofgs.rasterization(*tensors, sh_degree=0, device="cpu")
    assert type(colors) is fake.Tensor and type(alphas) is fake.Tensor and np.array_equal(colors, base)
    batched = [a[None] for a in tensors[:7]] + args[7:]
    colors, alphas, _ = roofgs.rasterization(*batched, sh_degree=0, device="cpu")
    assert type(colors) is fake.Tensor and colors.shape == (1,) + base.shape and np.array_equal(colors[0], base)


def test_rasterization_of_torch_cpu_tensors_returns_torch_cpu_tensors():
    torch = pytest.importorskip("torch", reason="skipped: torch is not installed")
    args = _small_gsplat_call(count=1)
    base, _, _ = roofgs.rasterization(*args, sh_degree=0, device="cpu")
    tensors = [torch.from_numpy(a) if isinstance(a, np.ndarray) else a for a in args]
    colors, alphas, _ = roofgs.rasterization(*tensors, sh_degree=0, device="cpu")
    assert isinstance(colors, torch.Tensor) and colors.device.type == "cpu" and colors.dtype == torch.float32
    image = colors.clamp(0, 1).permute(0, 3, 1, 2).cpu()  # a gsplat user's next line
    assert image.shape == (1, 3, args[8], args[7]) and np.array_equal(colors.numpy(), base)
    colors, _, _ = roofgs.rasterization(*(t[None] for t in tensors[:7]), *args[7:], sh_degree=0, device="cpu")
    assert isinstance(colors, torch.Tensor) and np.array_equal(colors[0].numpy(), base)


def test_arrays_and_rasterization_on_the_gpu(cuda):
    """from_arrays and rasterization on CUDA agree with the CPU reference (faithful: the same 3DGS rules;
    fastest within the GPU's binary16 blending, PSNR > 50 dB), and torch tensors are taken as they are."""
    torch = pytest.importorskip("torch")
    means, quats, scales, opacities, sh = read_ply_arrays(GUITAR)
    cpu = roofgs.Scene.from_arrays(means, quats, scales, opacities, sh, device="cpu")
    gpu = roofgs.Scene.from_arrays(*(torch.from_numpy(a).cuda() for a in (means, quats, scales, opacities, sh)),
                                   device="cuda")
    camera = cpu.orbit_cameras(1, 160, 90)[0]
    for preset in ("faithful", "fastest"):
        mse = float(np.mean((np.asarray(gpu.render(camera, preset=preset)) - cpu.render(camera, preset=preset)) ** 2))
        assert mse == 0 or 10 * math.log10(1 / mse) > 50, preset
    viewmat = np.eye(4, dtype=np.float32)[None]
    viewmat[0, :3, :3], viewmat[0, :3, 3] = camera.rotation, camera.translation
    K = np.array([[[camera.fx, 0, camera.cx], [0, camera.fy, camera.cy], [0, 0, 1]]], np.float32)
    args = (means, quats, scales, opacities, sh, viewmat, K, 160, 90)
    on_gpu, alphas_gpu, _ = roofgs.rasterization(*args, sh_degree=0, near_plane=0.2, preset="faithful", device="cuda")
    on_cpu, alphas_cpu, _ = roofgs.rasterization(*args, sh_degree=0, near_plane=0.2, preset="faithful", device="cpu")
    assert np.abs(on_gpu - on_cpu).max() < 1e-3 and np.abs(alphas_gpu - alphas_cpu).max() < 1e-3


def _psnr(a, b):
    mse = float(np.mean((np.asarray(a, np.float64) - np.asarray(b, np.float64)) ** 2))
    return math.inf if mse == 0 else 10 * math.log10(1 / mse)


def test_rasterization_of_cuda_tensors_stays_on_the_device(cuda):
    """torch CUDA tensors in (imported on their device, no host copy), torch CUDA tensors out on that device:
    the frames of the CPU reference (faithful within 1e-3, fastest within the GPU's binary16 blending, PSNR
    > 50 dB) and of the same arrays uploaded from host memory; a second call reuses the upload, and one after
    an in-place change of the means renders the change."""
    torch = pytest.importorskip("torch")
    means, quats, scales, opacities, sh = read_ply_arrays(GUITAR)
    cpu = roofgs.Scene.from_arrays(means, quats, scales, opacities, sh, device="cpu")
    viewmats, Ks = gsplat_cameras(cpu.orbit_cameras(2, 160, 90))
    device = torch.device("cuda", 0)
    tensors = [torch.from_numpy(a).to(device) for a in (means, quats, scales, opacities, sh)]
    views = (torch.from_numpy(viewmats).to(device), torch.from_numpy(Ks).to(device))
    options = dict(sh_degree=0, near_plane=0.2, render_mode="RGB+ED")
    for preset in ("faithful", "fastest"):
        colors, alphas, meta = roofgs.rasterization(*tensors, *views, 160, 90, preset=preset, **options)
        assert isinstance(colors, torch.Tensor) and isinstance(alphas, torch.Tensor)
        assert colors.device == device and alphas.device == device and colors.dtype == torch.float32
        assert tuple(colors.shape) == (2, 90, 160, 4) and tuple(alphas.shape) == (2, 90, 160, 1)
        assert meta["n_cameras"] == 2 and len(meta["pairs"]) == 2 and min(meta["pairs"]) > 0
        ref_colors, ref_alphas, _ = roofgs.rasterization(means, quats, scales, opacities, sh, viewmats, Ks, 160, 90,
                                                         preset=preset, device="cpu", **options)
        host_colors, host_alphas, _ = roofgs.rasterization(means, quats, scales, opacities, sh, viewmats, Ks, 160,
                                                           90, preset=preset, device="cuda", **options)
        got, got_alphas = colors.cpu().numpy(), alphas.cpu().numpy()
        # The device import gives the host path's scene bit for bit, hence its frame.
        assert np.array_equal(got, host_colors) and np.array_equal(got_alphas, host_alphas), preset
        covered = ref_alphas[..., 0] > 0.01
        depth_error = np.abs(got[..., 3] - ref_colors[..., 3])[covered] / ref_colors[..., 3][covered]
        if preset == "faithful":
            assert np.abs(got[..., :3] - ref_colors[..., :3]).max() < 1e-3
            assert np.abs(got_alphas - ref_alphas).max() < 1e-3
            assert depth_error.max() < 1e-3
        else:
            assert _psnr(got[..., :3], ref_colors[..., :3]) > 50 and _psnr(got_alphas, ref_alphas) > 50
            assert np.median(depth_error) < 1e-2
    # The same tensors again: the upload is reused and the frame is the same.
    first, _, meta = roofgs.rasterization(*tensors, *views, 160, 90, render_mode="RGB", sh_degree=0, near_plane=0.2)
    again, _, meta_again = roofgs.rasterization(*tensors, *views, 160, 90, render_mode="RGB", sh_degree=0,
                                                near_plane=0.2)
    assert not meta_again["uploaded"] and torch.equal(first, again)
    # An in-place change bumps the tensor's version: the next call uploads the moved Gaussians.
    shift = 0.25 * cpu.info["sphere_radius"]
    tensors[0][:, 0] += shift
    moved, moved_alphas, meta_moved = roofgs.rasterization(*tensors, *views, 160, 90, render_mode="RGB",
                                                           sh_degree=0, near_plane=0.2)
    assert meta_moved["uploaded"] and not torch.equal(moved, again)
    shifted = tensors[0].cpu().numpy()
    assert np.allclose(shifted[:, 0], means[:, 0] + shift, rtol=1e-6, atol=1e-6)
    ref, ref_alphas, _ = roofgs.rasterization(shifted, quats, scales, opacities, sh, viewmats, Ks, 160, 90,
                                              sh_degree=0, near_plane=0.2, device="cpu")
    assert _psnr(moved.cpu().numpy(), ref) > 50 and _psnr(moved_alphas.cpu().numpy(), ref_alphas) > 50
    _, _, meta_off = roofgs.rasterization(*tensors, *views, 160, 90, sh_degree=0, near_plane=0.2, cache=False)
    assert meta_off["uploaded"]


def test_cuda_tensor_colours_and_sh_degrees(cuda):
    """RGB colours [N, 3] and SH [N, K, 3] rendered at a lower sh_degree, converted on the device: the host
    path's frames of the same arrays; half-precision and non-contiguous tensors are converted by torch."""
    torch = pytest.importorskip("torch")
    scene = roofgs.load(DATA / "guitar_sh3.ply", device="cpu", quantize_other_formats=False)
    means, quats, scales, opacities, sh = scene.arrays()
    viewmats, Ks = gsplat_cameras(scene.orbit_cameras(1, 96, 64))
    on = lambda a: torch.from_numpy(np.ascontiguousarray(a)).cuda()
    for degree in (0, 1, 3):
        colors, alphas, meta = roofgs.rasterization(*map(on, (means, quats, scales, opacities, sh, viewmats, Ks)), 96,
                                                    64, sh_degree=degree, preset="faithful")
        host, host_alphas, _ = roofgs.rasterization(means, quats, scales, opacities, sh, viewmats, Ks, 96, 64,
                                                    sh_degree=degree, preset="faithful", device="cuda")
        assert np.array_equal(colors.cpu().numpy(), host) and np.array_equal(alphas.cpu().numpy(), host_alphas)
        assert host[..., :3].max() > 0.1
    rgb = np.clip(0.5 + 0.28209479177387814 * sh[:, 0], 0, None)
    colors, _, _ = roofgs.rasterization(*map(on, (means, quats, scales, opacities, rgb, viewmats, Ks)), 96, 64,
                                        preset="faithful")
    host, _, _ = roofgs.rasterization(means, quats, scales, opacities, rgb, viewmats, Ks, 96, 64, preset="faithful",
                                      device="cuda")
    assert np.array_equal(colors.cpu().numpy(), host)
    # float16 means and a transposed (non-contiguous) view of the quaternions: converted on the device.
    quats_t = on(np.ascontiguousarray(quats.T)).t()
    assert not quats_t.is_contiguous()
    colors16, _, _ = roofgs.rasterization(on(means).half(), quats_t, on(scales), on(opacities), on(rgb), on(viewmats),
                                          on(Ks), 96, 64, preset="faithful")
    host16, _, _ = roofgs.rasterization(on(means).half().float().cpu().numpy(), quats, scales, opacities, rgb, viewmats,
                                        Ks, 96, 64, preset="faithful", device="cuda")
    assert np.array_equal(colors16.cpu().numpy(), host16)
    with pytest.raises(roofgs.Error, match="above 3"):
        roofgs.rasterization(*map(on, (means, quats, scales, opacities, sh, viewmats, Ks)), 96, 64, sh_degree=4)
    with pytest.raises(ValueError, match="partly on CUDA"):
        roofgs.rasterization(on(means), quats, scales, opacities, rgb, viewmats, Ks, 96, 64)


def test_from_arrays_of_cuda_tensors_follows_the_value_rules(cuda):
    """Scene.from_arrays on CUDA tensors checks on the device what a file's Gaussians are checked for, with the
    host path's errors, and sanitize=True drops on the device what the host path drops."""
    torch = pytest.importorskip("torch")
    means, quats, scales, opacities, sh = (a[:100].copy() for a in read_ply_arrays(GUITAR))
    on = lambda a: torch.from_numpy(a).cuda()
    scene = roofgs.Scene.from_arrays(*map(on, (means, quats, scales, opacities, sh)))
    assert scene.device == "cuda" and scene.info["description"] == "float Gaussians in device memory"
    with pytest.raises(roofgs.Error) as e:
        roofgs.Scene.from_arrays(*map(on, (means, quats, -scales, opacities, sh)))
    assert e.value.code_name == "kInvalidArgument" and "Gaussian 0 has a negative scale" in str(e.value)
    with pytest.raises(roofgs.Error) as e:
        roofgs.Scene.from_arrays(*map(on, (means, quats, scales, opacities * 2 + 1, sh)))
    assert "sigmoid() them first" in str(e.value)
    means[7, 1] = np.nan
    quats[11] = 0
    with pytest.raises(roofgs.Error) as e:
        roofgs.Scene.from_arrays(*map(on, (means, quats, scales, opacities, sh)))
    assert e.value.code_name == "kCorruptData"
    assert "1 Gaussians have non-finite values (1 values) and 1 have zero-norm quaternions (first: Gaussian 7)" in str(
        e.value)
    on_device = roofgs.Scene.from_arrays(*map(on, (means, quats, scales, opacities, sh)), sanitize=True)
    from_host = roofgs.Scene.from_arrays(means, quats, scales, opacities, sh, device="cuda", sanitize=True)
    assert len(on_device) == len(from_host) == 98
    assert on_device.info["sphere_center"] == from_host.info["sphere_center"]
    assert on_device.info["sphere_radius"] == from_host.info["sphere_radius"]
    camera = from_host.orbit_cameras(1, 64, 36)[0]
    for preset in ("faithful", "fastest"):
        assert np.array_equal(on_device.render(camera, preset=preset).numpy(),
                              from_host.render(camera, preset=preset).numpy())


# Options of rgs-convert that concern one command-line run, not a conversion: none of them is a keyword.
TOOL_ONLY_OPTIONS = {"help", "version", "json", "quiet"}
# rgs-convert's edits act in the order given: in Python they are one keyword, edits=[(name, value), ...].
EDIT_OPTIONS = {"translate", "rotate", "scale", "filter-nan", "filter", "crop-box", "crop-box-outside", "crop-sphere",
                "crop-sphere-outside", "decimate"}


def _signature_keywords(fn):
    import inspect
    return [p.name for p in inspect.signature(fn).parameters.values() if p.kind == p.KEYWORD_ONLY]


def _stub_keywords(name):
    import ast
    tree = ast.parse((SOURCE_DIR / "python" / "roofgs.pyi").read_text())
    fn = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == name)
    return [a.arg for a in fn.args.kwonlyargs]


def _stub_positional(name):
    import ast
    tree = ast.parse((SOURCE_DIR / "python" / "roofgs.pyi").read_text())
    fn = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == name)
    return [a.arg for a in fn.args.args]


def test_convert_and_save_take_every_option_of_rgs_convert():
    import os
    import subprocess
    tool = os.environ.get("RGS_CONVERT")
    if not tool:
        pytest.skip("rgs-convert not built (RGS_CONVERT unset)")
    help_text = subprocess.run([tool, "--help"], capture_output=True, text=True, check=True).stdout
    options = set(re.findall(r"--([a-z][a-z0-9-]*)", help_text)) - TOOL_ONLY_OPTIONS
    assert EDIT_OPTIONS <= options
    expected = {o.replace("-", "_") for o in options - EDIT_OPTIONS} | {"edits"}
    assert {"target_bytes", "lod_levels", "lod_chunk", "max_decompression_ratio"} <= expected
    # save()'s first parameter is the output's path: the tool's --path (a camera path) is camera_path there.
    # convert()'s input_edits: the tool's edits written after each input (save() has one input: `edits`).
    for name, keywords in (("convert", expected | {"input_edits"}), ("save", expected - {"path"} | {"camera_path"})):
        for where, names in (("roofgs." + name, _signature_keywords(getattr(roofgs, name))),
                             ("roofgs.pyi " + name, _stub_keywords(name))):
            assert set(names) == keywords, (where, sorted(keywords - set(names)), sorted(set(names) - keywords))


def test_edits_act_in_order_and_bad_ones_raise_value_error_naming_them(tmp_path):
    src = str(SOURCE_DIR / "samples" / "guitar.ply")
    report = roofgs.convert(src, str(tmp_path / "a.ply"), edits=[("translate", "1,0,0"), ("rotate", "0,0,90"),
                                                               ("filter", "opacity gt 0.5"), ("filter-nan", "")])
    assert report["gaussians"] == 31311
    assert "filter 'opacity gt 0.5' removed 59,543 Gaussians" in report["input"]["notes"]
    roofgs.convert(src, str(tmp_path / "b.ply"), edits=[("rotate", "0,0,90"), ("translate", "1,0,0"),
                                                       ("filter", "opacity gt 0.5"), ("filter-nan",)])
    assert (tmp_path / "a.ply").read_bytes() != (tmp_path / "b.ply").read_bytes()
    for edits, message in (([("rotate", "1,1,0,0")], r"edits\[0\]: rotate '1,1,0,0': .*a rotation that is not one"),
                           ([("scale", "2"), ("filter", "colour gt 1")], r"edits\[1\]: filter 'colour gt 1': unknown property"),
                           ([("crop-box", "1,2,3")], r"edits\[0\]: crop-box '1,2,3': takes 6 numbers, not 3"),
                           ([("spin", "1")], r"edits\[0\]: unknown edit 'spin'")):
        with pytest.raises(ValueError, match=message):
            roofgs.convert(src, str(tmp_path / "x.rgs"), edits=edits)
    with pytest.raises(TypeError, match=r"^convert\(\): edits must be a sequence of \(name, value\) pairs of str"):
        roofgs.convert(src, str(tmp_path / "x.rgs"), edits="rotate 0,0,90")


def test_convert_merges_a_list_of_inputs_and_decimates(tmp_path):
    sh0, sh3 = str(SOURCE_DIR / "samples" / "guitar.ply"), SOURCE_DIR / "tests" / "data" / "guitar_sh3.ply"
    report = roofgs.convert([sh0, sh3], str(tmp_path / "merged.rgs"))  # a str and an os.PathLike
    assert report["gaussians"] == 98854 and report["sh_degree"] == 3
    assert report["input"]["path"] == sh0 + " + " + str(sh3)
    report = roofgs.convert((sh0, sh3), str(tmp_path / "decimated.ply"), edits=[("decimate", "1000")])
    # 98,854 Gaussians in chunks of 64 make more chunks than 1,000: the chunks are built eight times larger, and
    # each step of the cut removes at most one chunk's Gaussians (docs/LOD.md#decimation).
    assert 1000 - 8 * 64 < report["gaussians"] <= 1000
    assert "decimate '1000' removed %s Gaussians" % format(98854 - report["gaussians"], ",") in report["input"]["notes"]
    with pytest.raises(ValueError, match=r"edits\[0\]: decimate '1.5': takes a count of Gaussians"):
        roofgs.convert(sh0, str(tmp_path / "x.rgs"), edits=[("decimate", "1.5")])
    roofgs.convert(sh3, str(tmp_path / "aa.rgs"), antialiased=True)
    with pytest.raises(roofgs.Error, match="aa.rgs is anti-aliased .* and .*guitar.ply is not"):
        roofgs.convert([str(tmp_path / "aa.rgs"), sh0], str(tmp_path / "mixed.rgs"))


def test_convert_input_edits_act_on_their_source_before_the_merge(tmp_path):
    sh0, sh3 = str(SOURCE_DIR / "samples" / "guitar.ply"), str(SOURCE_DIR / "tests" / "data" / "guitar_sh3.ply")
    # rgs-convert guitar.ply --filter 'opacity gt 0.5' guitar_sh3.ply merged.ply: the filter keeps 31,311 of guitar's
    # 90,854 Gaussians and every one of guitar_sh3's 8,000.
    report = roofgs.convert([sh0, sh3], str(tmp_path / "merged.ply"), input_edits=[[("filter", "opacity gt 0.5")]])
    assert report["gaussians"] == 31311 + 98854 - 90854
    same = roofgs.convert([sh0, sh3], str(tmp_path / "same.ply"), input_edits=[None, []],
                          edits=[("translate", "1,0,0")])
    assert same["gaussians"] == 98854
    with pytest.raises(ValueError, match=r"edits\[0\]: unknown edit 'spin'"):
        roofgs.convert([sh0, sh3], str(tmp_path / "x.ply"), input_edits=[[], [("spin", "1")]])
    with pytest.raises(roofgs.Error, match="the edits of 3 inputs for 2"):
        roofgs.convert([sh0, sh3], str(tmp_path / "x.ply"), input_edits=[[], [], []])


def test_option_values_out_of_range_raise_value_error(tmp_path):
    src = str(SOURCE_DIR / "samples" / "guitar.ply")
    for value in (-1, 2 ** 70, 0):
        with pytest.raises(ValueError, match="target_bytes must be an integer in 1..18446744073709551615"):
            roofgs.convert(src, str(tmp_path / "x.rgs"), target_bytes=value)
    for value in (True, 1.5, "1"):
        with pytest.raises(TypeError, match=r"^convert\(\): target_bytes must be an int, got "):
            roofgs.convert(src, str(tmp_path / "x.rgs"), target_bytes=value)
    with pytest.raises(ValueError, match="lod_levels must be"):
        roofgs.convert(src, str(tmp_path / "x.rgs"), lod_levels=17)
    with pytest.raises(ValueError, match="max_decompression_ratio must be an integer in 1..32768"):
        roofgs.convert(src, str(tmp_path / "x.rgs"), max_decompression_ratio=0)
    means, quats, scales, opacities, sh = (np.zeros((1, 3), np.float32), np.array([[1, 0, 0, 0]], np.float32),
                                           np.full((1, 3), 0.01, np.float32), np.full(1, 0.5, np.float32),
                                           np.zeros((1, 1, 3), np.float32))
    with pytest.raises(ValueError, match="zstd_level must be an integer in 1..22"):
        roofgs.save(str(tmp_path / "x.rgs"), means, quats, scales, opacities, sh, zstd_level=23)


def test_convert_takes_level_of_detail_and_read_limits(tmp_path):
    src = str(SOURCE_DIR / "samples" / "guitar.ply")
    report = roofgs.convert(src, str(tmp_path / "lod.rgs"), lod_levels="auto", lod_chunk=4096)
    scene = roofgs.load(str(tmp_path / "lod.rgs"), device="cpu")
    assert scene.info["lod"]["chunks"] > 4 and report["gaussians"] == 90854
    with pytest.raises(roofgs.Error) as e:
        roofgs.convert(src, str(tmp_path / "x.rgs"), max_gaussians=1000)
    assert e.value.code_name == "kLimitExceeded"


def test_an_array_too_large_to_copy_raises_memory_error(tmp_path):
    class TooLarge:
        def __array__(self, dtype=None, copy=None):
            raise MemoryError("Unable to allocate 1.00 TiB")

    ok = np.zeros((1, 3), np.float32)
    with pytest.raises(MemoryError):
        roofgs.save(str(tmp_path / "x.rgs"), TooLarge(), np.array([[1, 0, 0, 0]], np.float32), ok,
                    np.full(1, 0.5, np.float32), np.zeros((1, 1, 3), np.float32))


def test_python_m_roofgs_names_every_output_format_of_convert():
    listing = subprocess.run([sys.executable, str(SOURCE_DIR / "python" / "roofgs_main.py")], capture_output=True,
                             text=True, check=True).stdout
    convert = next(line for line in listing.splitlines() if line.strip().startswith("convert"))
    for name in (".rgs", "PLY", "SPZ", "GLB", "SOG"):
        assert name in convert
