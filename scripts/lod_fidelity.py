#!/usr/bin/env python3
"""How far a level-of-detail render is from the full detail, next to how far the full detail is from itself when
the camera moves by a fraction of a pixel (docs/LOD.md#what-it-costs).

    scripts/lod_fidelity.py SCENE_LOD.rgs --cameras cameras.json [--width 320] [--pixel-errors 0.5,1,2]
        [--shifts 0.25,0.5] [--work DIR] [--tools build/tools]

Renders with rgs-render on the CPU reference, each camera of the INRIA cameras.json as it is:
- the full detail (`--no-lod`), the reference of every row;
- the full detail with every camera moved sideways (along its own x axis) by s pixels at the depth of the scene's
  bounding-sphere centre, for each s of --shifts: what a sub-pixel change of viewpoint alone costs the PSNR;
- the levels chosen at each pixel error E of --pixel-errors, without a splat budget (`--splat-budget 0
  --pixel-error E`), with the splats a view draws.
Prints one Markdown table row per render: PSNR mean / min over the views (8-bit-free: float images clamped to
[0, 1]) and splats drawn. Needs NumPy. Exit status: 0 ok, 1 a failed render, 2 usage.
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

import numpy as np


def read_pfm(path):
    with open(path, "rb") as f:
        if f.readline().strip() != b"PF":
            raise ValueError(f"{path}: not a colour PFM")
        width, height = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    return np.clip(data.reshape(height, width, 3), 0.0, 1.0)


def psnr_views(reference_dir, candidate_dir):
    values = []
    for name in sorted(n for n in os.listdir(reference_dir) if n.endswith(".pfm")):
        a = read_pfm(os.path.join(reference_dir, name)).astype(np.float64)
        b = read_pfm(os.path.join(candidate_dir, name)).astype(np.float64)
        mse = float(np.mean((a - b) ** 2))
        values.append(float("inf") if mse == 0 else 10 * np.log10(1 / mse))
    return values


def render(tools, scene, cameras, width, out_dir, extra):
    cmd = [os.path.join(tools, "rgs-render"), scene, "-o", out_dir, "--cameras", cameras, "--width", str(width),
           "--pfm", "--format", "ppm", *extra]
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode != 0:
        sys.stderr.write(f"lod_fidelity.py: {' '.join(cmd)} failed:\n{run.stderr}")
        sys.exit(1)
    splats = [int(s.replace(",", "")) for s in re.findall(r"([\d,]+) splats", run.stderr)]
    return sum(splats) / len(splats) if splats else None


def scene_info(tools, scene):
    """The bounding sphere's centre and the full detail's Gaussian count, from rgs-info."""
    info = subprocess.run([os.path.join(tools, "rgs-info"), scene], capture_output=True, text=True, check=True).stdout
    centre = re.search(r"bounding sphere\s+centre \(([^)]*)\)", info)
    full = re.search(r"full detail ([\d,]+) Gaussians", info)
    if not centre or not full:
        sys.stderr.write(f"lod_fidelity.py: rgs-info {scene} shows no bounding sphere or no levels of detail\n")
        sys.exit(1)
    return np.array([float(v) for v in centre.group(1).split(",")]), int(full.group(1).replace(",", ""))


def shifted_cameras(cameras, centre, width, pixels):
    """Each camera moved along its x axis so that the sphere centre's depth moves by `pixels` at `width`."""
    out = []
    for cam in cameras:
        rotation = np.array(cam["rotation"], dtype=np.float64)  # camera to world: columns are the camera axes
        position = np.array(cam["position"], dtype=np.float64)
        depth = float((centre - position) @ rotation[:, 2])
        fx = cam["fx"] * width / cam["width"]
        moved = dict(cam)
        moved["position"] = list(position + pixels * depth / fx * rotation[:, 0])
        out.append(moved)
    return out


def row(label, values, splats):
    finite = [v for v in values if np.isfinite(v)]
    mean = np.mean(finite) if len(finite) == len(values) else float("inf")
    return f"| {label} | {mean:.2f} / {min(values):.2f} | {splats / 1e6:.2f}M |"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", help="level-of-detail .rgs (rgs-convert --lod-levels auto)")
    parser.add_argument("--cameras", required=True, help="INRIA cameras.json")
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--pixel-errors", default="0.5,1,2")
    parser.add_argument("--shifts", default="0.25,0.5")
    parser.add_argument("--work", help="directory for the renders (default: a temporary one)")
    parser.add_argument("--tools", default=os.path.join(os.path.dirname(__file__), "..", "build", "tools"))
    args = parser.parse_args()
    with open(args.cameras) as f:
        cameras = json.load(f)
    work = args.work or tempfile.mkdtemp(prefix="lod_fidelity.")
    os.makedirs(work, exist_ok=True)
    reference = os.path.join(work, "full")
    centre, full_splats = scene_info(args.tools, args.scene)
    render(args.tools, args.scene, args.cameras, args.width, reference, ["--no-lod"])
    print(f"{args.scene}, {len(cameras)} cameras of {args.cameras}, width {args.width}, CPU reference; "
          "PSNR against the full detail of the same camera")
    print()
    print("| render | PSNR mean / min dB | splats a view |")
    print("|---|---|---|")
    for shift in (float(s) for s in args.shifts.split(",") if s):
        path = os.path.join(work, f"cameras_shift{shift}.json")
        with open(path, "w") as f:
            json.dump(shifted_cameras(cameras, centre, args.width, shift), f)
        out = os.path.join(work, f"shift{shift}")
        render(args.tools, args.scene, path, args.width, out, ["--no-lod"])
        print(row(f"full detail, camera moved {shift:g} px", psnr_views(reference, out), full_splats))
    for error in (float(e) for e in args.pixel_errors.split(",") if e):
        out = os.path.join(work, f"error{error}")
        splats = render(args.tools, args.scene, args.cameras, args.width, out,
                        ["--splat-budget", "0", "--pixel-error", f"{error:g}"])
        print(row(f"levels at `--pixel-error {error:g}`", psnr_views(reference, out), splats))
    return 0


if __name__ == "__main__":
    sys.exit(main())
