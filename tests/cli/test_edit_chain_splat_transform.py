#!/usr/bin/env python3
"""The edit chain of rgs-convert against PlayCanvas splat-transform's actions: the same chains, run through both
tools on the shipped SH-3 scene (tests/data/guitar_sh3.ply, 8,000 Gaussians) to a PLY, must give the same
Gaussians, in the same order and the same count; and splat-transform's .ksplat reader must give the Gaussians
ours gives for each file of tests/data/ksplat and tests/fuzz/corpus/ksplat_read (SH degree 3 there).

Conventions (splat-transform 3.7.0, dist/index.mjs: processDataTable, Transform, convertToSpace). splat-transform
reads a PLY as raw columns with a pending transform Transform.PLY, a 180° turn about z into PlayCanvas's engine
frame, and composes every spatial action in that engine frame: `-t/-r/-s` left-multiply the pending transform,
and the PLY writer bakes it back into PLY space. Seen in the PLY's own axes (RoofGS's RDF), an action is therefore
conjugated by diag(-1, -1, 1):
- `-t X,Y,Z` is rgs-convert `--translate -X,-Y,Z`;
- `-r X,Y,Z` (Quat.setFromEulerAngles: R = Rz(Z)·Ry(Y)·Rx(X), rgs-convert's own order) is `--rotate -X,-Y,Z`;
- `-s S` is `--scale S`;
- `-V NAME,CMP,V` on x, y, z, rot_*, scale_* or f_rest_* first bakes the pending transform into the engine frame
  and compares there, so `-V x,gt,V` is `--filter 'x lt -V'` (y likewise, z unchanged); on opacity, scale_* and
  f_dc_* it compares the raw column with the value mapped back (logit, log, (v − 0.5)/C0), the activated value
  rgs-convert compares, up to rounding at the threshold (no Gaussian of the scene lies within 1e-5 of a chain's
  threshold or crop boundary: BOUNDARY_MARGINS);
- `-B` and `-S` take the box and sphere in the engine frame: `-B x0,y0,z0,x1,y1,z1` is `--crop-box
  -x1,-y1,z0,-x0,-y0,z1`, `-S x,y,z,r` is `--crop-sphere -x,-y,z,r` (its surface is outside, ours inside).
- `-N` drops a Gaussian with a non-finite value in any column except +inf opacity and -inf log scales, which
  rgs-convert's `--filter-nan` keeps too; it also drops -inf opacity (we keep it: opacity 0) and keeps zero-norm
  rotations (we drop them): the chain damages the scene only with NaN in columns both tools read.
Gaussians are matched by order (both tools keep the source's order). Tolerances, float precision: both tools
compute from the same float32 inputs by different formulas (float32 or float64, their own SH rotation matrices),
which measured differences of at most 2.4e-7; the bounds are positions 1e-5 · (1 + |x|) scene units, log scales
1e-5, quaternion components (normalized, sign aligned) 1e-5, opacity 1e-6 (activated), f_dc 1e-6 and f_rest 1e-5.
For .ksplat the two readers decode the same bytes, with the same bounds (f_rest 1e-6); a scale that float16
truncated to 0 has no log scale, written -17.33 by rgs-convert and -10 by splat-transform, and counts as equal.

splat-transform is found as $RGS_SPLAT_TRANSFORM, else under .splat_transform/node_modules/.bin in the checkout
(git-ignored: `npm install --prefix .splat_transform @playcanvas/splat-transform@3.7`), else on PATH; without
it the test prints "skipped: ..." and exits 77 (CI has no network).

Usage: test_edit_chain_splat_transform.py RGS_CONVERT SOURCE_DIR WORK_DIR
"""
import math
import os
import struct
import subprocess
import sys

from splat_transform_util import NOT_FOUND, find_splat_transform, read_ply


def write_damaged(src, dst, damage):
    """Copies the PLY `src` to `dst` with `damage` [(row, property, value)] written into its float rows."""
    with open(src, "rb") as f:
        data = bytearray(f.read())
    end = data.index(b"end_header\n") + len(b"end_header\n")
    names = [l.split()[2] for l in data[:end].decode("ascii").splitlines() if l.startswith("property float")]
    for row, name, value in damage:
        struct.pack_into("<f", data, end + 4 * (row * len(names) + names.index(name)), value)
    with open(dst, "wb") as f:
        f.write(data)


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({r.returncode}):\n{r.stdout}\n{r.stderr}")


def sigmoid(v):
    return 1.0 / (1.0 + math.exp(-max(-60.0, min(60.0, v))))


def compare(ours_path, theirs_path, what, tol):
    """Largest differences per attribute, Gaussians matched by order; fails beyond `tol` (kind -> bound)."""
    n_ours, ours = read_ply(ours_path)
    n_theirs, theirs = read_ply(theirs_path)
    assert n_ours == n_theirs, f"{what}: {n_ours} Gaussians from rgs-convert, {n_theirs} from splat-transform"
    assert n_ours > 0, f"{what}: no Gaussian left"
    worst = {}

    def track(kind, diff):
        worst[kind] = max(worst.get(kind, 0.0), diff)

    for i in range(n_ours):
        for a in ("x", "y", "z"):
            track("position", abs(ours[a][i] - theirs[a][i]) / (1 + abs(theirs[a][i])))
        for a in ("scale_0", "scale_1", "scale_2"):
            # A zero scale (a float16 .ksplat scale truncated to 0) has no log: rgs-convert writes -17.33,
            # splat-transform -10; both stand for a Gaussian flat along that axis.
            zero = ours[a][i] <= -17 and theirs[a][i] <= -10
            track("log scale", 0.0 if zero else abs(ours[a][i] - theirs[a][i]))
        q1 = [ours["rot_%d" % c][i] for c in range(4)]
        q2 = [theirs["rot_%d" % c][i] for c in range(4)]
        n1, n2 = math.sqrt(sum(v * v for v in q1)), math.sqrt(sum(v * v for v in q2))
        sign = 1.0 if sum(a * b for a, b in zip(q1, q2)) >= 0 else -1.0
        for a, b in zip(q1, q2):
            track("rotation", abs(a / n1 - sign * b / n2))
        track("opacity", abs(sigmoid(ours["opacity"][i]) - sigmoid(theirs["opacity"][i])))
        for name in ours:
            if name.startswith("f_dc"):
                track("f_dc", abs(ours[name][i] - theirs[name][i]))
            elif name.startswith("f_rest"):
                track("f_rest", abs(ours[name][i] - theirs[name][i]))
    print(f"{what}: {n_ours} Gaussians; " + ", ".join(f"{k} {v:.3g}" for k, v in sorted(worst.items())))
    for kind, bound in tol.items():
        assert worst.get(kind, 0.0) <= bound, f"{what}: {kind} differs by {worst[kind]:.3g} > {bound}"
    return n_ours


# (name, splat-transform actions, the same in rgs-convert's options)
CHAINS = [
    ("translate", ["-t", "0.5,-1,2"], ["--translate", "-0.5,1,2"]),
    ("rotate", ["-r", "30,-20,45"], ["--rotate", "-30,20,45"]),
    ("scale", ["-s", "1.5"], ["--scale", "1.5"]),
    ("filter opacity", ["-V", "opacity,gt,0.3"], ["--filter", "opacity gt 0.3"]),
    ("filter x after a turn", ["-r", "0,0,90", "-V", "x,gt,-3.95"], ["--rotate", "0,0,90", "--filter", "x lt 3.95"]),
    ("crop box", ["-B", "-1,3.8,-0.1,1,4.1,0.1"], ["--crop-box", "-1,-4.1,-0.1,1,-3.8,0.1"]),
    ("crop sphere", ["-S", "0.4,4.0,-0.05,0.16"], ["--crop-sphere", "-0.4,-4.0,-0.05,0.16"]),
    ("whole chain", ["-t", "0.5,-1,2", "-r", "30,-20,45", "-s", "1.5", "-V", "opacity,gt,0.3",
                     "-V", "scale_0,lt,0.02", "-B", "-10,-10,-10,10,10,10"],
     ["--translate", "-0.5,1,2", "--rotate", "-30,20,45", "--scale", "1.5", "--filter", "opacity gt 0.3",
      "--filter", "scale_0 lt 0.02", "--crop-box", "-10,-10,-10,10,10,10"]),
]
# Distance of every Gaussian of the source to each chain's filter boundary, in the boundary's units: a boundary is
# decided alike by both tools only when no Gaussian sits on it within their rounding (about 1e-7 relative).
BOUNDARY_MARGINS = {
    "filter opacity": lambda p, i: abs(sigmoid(p["opacity"][i]) - 0.3),
    "filter x after a turn": lambda p, i: abs(-p["y"][i] - 3.95),  # x after Rz(90°) is -y
    "crop box": lambda p, i: min(abs(p["y"][i] + 4.1), abs(p["y"][i] + 3.8), abs(p["z"][i] + 0.1),
                                 abs(p["z"][i] - 0.1)),
    "crop sphere": lambda p, i: abs(math.dist((p["x"][i], p["y"][i], p["z"][i]), (-0.4, -4.0, -0.05)) - 0.16),
    "whole chain": lambda p, i: min(abs(sigmoid(p["opacity"][i]) - 0.3), abs(1.5 * math.exp(p["scale_0"][i]) - 0.02)),
}
EDIT_TOL = {"position": 1e-5, "log scale": 1e-5, "rotation": 1e-5, "opacity": 1e-6, "f_dc": 1e-6, "f_rest": 1e-5}


def main():
    if len(sys.argv) != 4:
        raise SystemExit(__doc__)
    rgs_convert, source_dir, work = sys.argv[1:]
    splat_transform = find_splat_transform(source_dir)
    if splat_transform is None:
        print(NOT_FOUND)
        return 77
    os.makedirs(work, exist_ok=True)
    scene = os.path.join(source_dir, "tests", "data", "guitar_sh3.ply")
    n, props = read_ply(scene)
    for name, distance in BOUNDARY_MARGINS.items():
        closest = min(distance(props, i) for i in range(n))
        assert closest > 1e-5, f"{name}: a Gaussian lies {closest:.3g} from the filter's boundary"
    for name, theirs_args, ours_args in CHAINS:
        slug = name.replace(" ", "_")
        theirs, ours = os.path.join(work, slug + "_st.ply"), os.path.join(work, slug + "_rgs.ply")
        run([splat_transform, "-q", "-w", scene] + theirs_args + [theirs])
        run([rgs_convert, "-q", scene, ours] + ours_args)
        kept = compare(ours, theirs, name, EDIT_TOL)
        if name.startswith(("filter", "crop")):
            assert 0 < kept < 8000, f"{name}: kept {kept} of 8000, so the filter decided nothing"
    # --filter-nan: NaN in a position, a log scale, an SH value and a rotation of four Gaussians.
    damaged = os.path.join(work, "damaged.ply")
    write_damaged(scene, damaged, [(10, "x", math.nan), (20, "scale_1", math.nan), (30, "f_rest_7", math.nan),
                                   (40, "rot_2", math.nan)])
    run([splat_transform, "-q", "-w", damaged, "-N", "-t", "1,0,0", os.path.join(work, "nan_st.ply")])
    run([rgs_convert, "-q", damaged, os.path.join(work, "nan_rgs.ply"), "--filter-nan", "--translate", "-1,0,0"])
    assert compare(os.path.join(work, "nan_rgs.ply"), os.path.join(work, "nan_st.ply"), "filter-nan",
                   EDIT_TOL) == 7996
    # .ksplat: splat-transform's reader (an implementation independent of ours) against ours, file by file.
    # The fuzz seeds add SH degree 3, which GaussianSplats3D's PLY path never writes.
    ksplat_files = [os.path.join(d, f) for d in (os.path.join(source_dir, "tests", "data", "ksplat"),
                                                 os.path.join(source_dir, "tests", "fuzz", "corpus", "ksplat_read"))
                    for f in sorted(os.listdir(d)) if f.endswith(".ksplat")]
    assert len(ksplat_files) == 9, ksplat_files
    for path in ksplat_files:
        name = os.path.basename(path)
        theirs, ours = os.path.join(work, name + "_st.ply"), os.path.join(work, name + "_rgs.ply")
        run([splat_transform, "-q", "-w", path, theirs])
        run([rgs_convert, "-q", path, ours])
        compare(ours, theirs, name, KSPLAT_TOL)
    return 0


KSPLAT_TOL = {"position": 1e-5, "log scale": 1e-5, "rotation": 1e-5, "opacity": 1e-6, "f_dc": 1e-6,
              "f_rest": 1e-6}


if __name__ == "__main__":
    sys.exit(main())
