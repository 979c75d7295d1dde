#!/usr/bin/env python3
"""scripts/lod_fidelity.py end to end on the CPU reference: the bundled guitar given levels of detail (chunks of
4,096 Gaussians), a spiral of 6 views at 160x120. Checks: the floor row's popping is 0 and the levels at pixel error 0
with no budget (level 0 everywhere: the full render bit for bit) score exactly the floor's PSNR and SSIM; a 300-splat
budget (the coarsest levels: a few hundred splats) scores more than 1 dB below the floor; the script's area
downsample of a known image gives its 2x2 means; the Markdown, JSON and plot are written, and --update-doc replaces only the marked
block and refuses a file without it.

    test_lod_fidelity.py RGS_CONVERT TOOLS_DIR GUITAR_PLY WORK_DIR

Exit status: 0 passed, 1 failed, 77 skipped (no NumPy).
"""
import importlib.util
import json
import os
import shutil
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(ROOT, "scripts", "lod_fidelity.py")


def fail(why):
    print(f"FAILED: {why}")
    sys.exit(1)


def run(*args, ok=True):
    r = subprocess.run([*args], capture_output=True, text=True)
    if ok and r.returncode != 0:
        fail(f"{' '.join(args)} exited {r.returncode}: {r.stderr[-2000:]}")
    return r


def main(argv):
    try:
        import numpy as np
    except ImportError:
        print("skipped: NumPy is not installed")
        return 77
    convert, tools, guitar, work = argv[1:5]
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    scene = os.path.join(work, "guitar_lod.rgs")
    run(convert, guitar, scene, "--lod-levels", "auto", "--lod-chunk", "4096")

    spec = importlib.util.spec_from_file_location("lod_fidelity", SCRIPT)
    lod_fidelity = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(lod_fidelity)
    image = np.arange(4 * 6 * 3, dtype=np.float64).reshape(4, 6, 3)
    down = lod_fidelity.area_downsample_2x(image)
    if down.shape != (2, 3, 3) or down[1, 2, 1] != np.mean(image[2:4, 4:6, 1]):
        fail(f"area downsample: {down.shape}, {down[1, 2, 1]}")

    out = os.path.join(work, "out")
    r = run(sys.executable, SCRIPT, scene, "--path", "6", "--width", "160", "--height", "120", "--budgets", "300",
            "--pixel-errors", "0,1", "--out", out, "--tools", tools, "--jobs", "1")
    with open(os.path.join(out, "lod_quality.json")) as f:
        rows = {row["render"]: row for row in json.load(f)["scenes"][0]["rows"]}
    floor, exact, tight = rows["full detail (floor)"], rows["levels, pixel error 0"], rows["levels, budget 300"]
    if floor["popping_8bit"] != 0 or floor["views"] != 6:
        fail(f"floor row: {floor}")
    if (exact["psnr_mean"], exact["ssim_mean"], exact["popping_8bit"]) != (floor["psnr_mean"], floor["ssim_mean"], 0):
        fail(f"pixel error 0 differs from the full render: {exact} against {floor}")
    if not (tight["splats"] < floor["splats"] / 100 and tight["psnr_mean"] < floor["psnr_mean"] - 1):
        fail(f"a 300-splat budget: {tight} against {floor}")
    if not (10 < floor["psnr_mean"] < 100 and 0 < floor["ssim_mean"] <= 1):
        fail(f"floor scores out of range: {floor}")
    for name in ("lod_quality.md", "lod_quality.json"):
        if not os.path.getsize(os.path.join(out, name)):
            fail(f"{name} is empty")
    if "| full detail (floor) |" not in r.stdout or "Rule: the default pixel error" not in r.stdout:
        fail(f"table or rule missing from the output:\n{r.stdout}")

    doc = os.path.join(work, "doc.md")
    with open(doc, "w") as f:
        f.write("before\n<!-- lod_fidelity -->\nold\n<!-- /lod_fidelity -->\nafter\n")
    run(sys.executable, SCRIPT, "--plot-from", os.path.join(out, "lod_quality.json"), "--out", out,
        "--update-doc", doc)
    with open(doc) as f:
        text = f.read()
    if not (text.startswith("before\n") and text.endswith("after\n") and "old" not in text
            and "| full detail (floor) |" in text):
        fail(f"--update-doc:\n{text}")
    bare = os.path.join(work, "bare.md")
    with open(bare, "w") as f:
        f.write("no markers\n")
    r = run(sys.executable, SCRIPT, "--plot-from", os.path.join(out, "lod_quality.json"), "--out", out,
            "--update-doc", bare, ok=False)
    if r.returncode != 1 or open(bare).read() != "no markers\n":
        fail(f"--update-doc without markers: exit {r.returncode}")
    print("passed")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
