#!/usr/bin/env python3
"""PlayCanvas splat-transform reads what rgs-convert writes as SOG: a bundled .sog, a SOG folder and a streamed
SOG (lod-meta.json), each turned into a PLY by splat-transform and compared with the PLY our own reader makes of
the same output. The same Gaussians must come back: positions within 1e-5 scene units, log scales, SH and
quaternion components within 1e-4, activated opacities within 1e-4 (both sides decode the same codes; the
margins cover float32 rounding of different formulas); the streamed SOG's level 0 must have the scene's count.

splat-transform is found as $RGS_SPLAT_TRANSFORM, else under .splat_transform/node_modules/.bin in the checkout
(git-ignored: `npm install --prefix .splat_transform @playcanvas/splat-transform@3.7`), else on PATH; without
it the test prints "skipped: ..." and exits 77 (CI has no network).

Usage: test_sog_splat_transform.py RGS_CONVERT SCENE.ply SOURCE_DIR WORK_DIR
"""
import math
import os
import shutil
import subprocess
import sys

from splat_transform_util import NOT_FOUND, find_splat_transform, read_ply


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({r.returncode}):\n{r.stdout}\n{r.stderr}")


def compare(ours_path, theirs_path, what):
    n_ours, ours = read_ply(ours_path)
    n_theirs, theirs = read_ply(theirs_path)
    assert n_ours == n_theirs, f"{what}: {n_ours} Gaussians from our reader, {n_theirs} from splat-transform"
    worst = {}

    def track(kind, a, b):
        worst[kind] = max(worst.get(kind, 0.0), abs(a - b))

    for i in range(n_ours):
        for a in ("x", "y", "z"):
            track("position", ours[a][i], theirs[a][i])
        for a in ("scale_0", "scale_1", "scale_2"):
            track("log scale", ours[a][i], theirs[a][i])
        q1 = [ours["rot_%d" % c][i] for c in range(4)]
        q2 = [theirs["rot_%d" % c][i] for c in range(4)]
        n1, n2 = math.sqrt(sum(v * v for v in q1)), math.sqrt(sum(v * v for v in q2))
        sign = 1.0 if sum(a * b for a, b in zip(q1, q2)) >= 0 else -1.0
        for a, b in zip(q1, q2):
            track("rotation", a / n1, sign * b / n2)
        sig = lambda v: 1.0 / (1.0 + math.exp(-max(-60.0, min(60.0, v))))
        track("opacity", sig(ours["opacity"][i]), sig(theirs["opacity"][i]))
        for name in ours:
            if name.startswith("f_"):
                track("SH", ours[name][i], theirs[name][i])
    print(f"{what}: {n_ours} Gaussians; largest differences " +
          ", ".join(f"{k} {v:.3g}" for k, v in sorted(worst.items())))
    bounds = {"position": 1e-5, "log scale": 1e-4, "rotation": 1e-4, "opacity": 1e-4, "SH": 1e-4}
    for kind, bound in bounds.items():
        assert worst.get(kind, 0.0) <= bound, f"{what}: {kind} differs by {worst[kind]} > {bound}"
    return n_ours


def main():
    convert, scene, source_dir, work = sys.argv[1:5]
    tool = find_splat_transform(source_dir)
    if tool is None:
        print(NOT_FOUND)
        return 77
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(os.path.join(work, "folder"))
    os.makedirs(os.path.join(work, "streamed"))
    outputs = {"bundle": os.path.join(work, "scene.sog"),
               "folder": os.path.join(work, "folder", "meta.json"),
               "streamed": os.path.join(work, "streamed", "lod-meta.json")}
    for what, out in outputs.items():
        run([convert, "-q", scene, out] + (["--lod-levels", "auto"] if what == "streamed" else []))
        ours, theirs = os.path.join(work, what + "_ours.ply"), os.path.join(work, what + "_theirs.ply")
        run([convert, "-q", out, ours])
        run([tool, "-w", out, theirs])
        n = compare(ours, theirs, what)
        if what == "streamed":
            assert n == read_ply(os.path.join(work, "bundle_ours.ply"))[0]
    return 0


if __name__ == "__main__":
    sys.exit(main())
