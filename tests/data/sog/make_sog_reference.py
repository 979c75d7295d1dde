#!/usr/bin/env python3
"""Documents and regenerates the PlayCanvas input references in tests/data/sog/ (python3 stdlib only).

Reference decodes come from PlayCanvas splat-transform 3.7.0, run once by hand (tests never call it):

    ST="npx -y @playcanvas/splat-transform@3.7.0"
    # a crop of the guitar scene (samples/guitar.ply; splat-transform filters in its own frame, x and y flipped)
    $ST -w samples/guitar.ply -S -0.292,1.1315,0.1756,0.15 /tmp/guitar_crop.ply        # 877 Gaussians
    $ST -w /tmp/guitar_crop.ply tests/data/sog/guitar_crop.sog                          # bundled SOG v2 (stored ZIP)
    $ST -w /tmp/guitar_crop.ply tests/data/sog/guitar_crop/meta.json                    # the same, unbundled
    $ST -w /tmp/guitar_crop.ply /tmp/lod/lod-meta.json                                  # streamed SOG, 1 level
    $ST -w /tmp/guitar_crop.ply tests/data/sog/guitar_crop.compressed.ply
    $ST -w tests/data/sog/guitar_crop.sog tests/data/sog/guitar_crop_sog_reference.ply
    $ST -w tests/data/sog/guitar_crop.compressed.ply tests/data/sog/guitar_crop_compressed_reference.ply
    # taebak (not shipped: only a sample of its decoded values is kept, see below)
    $ST -w $RGS_DATA_DIR/taebak_lod0_sog/lod-meta.json -L 0 /tmp/taebak_ref.ply

guitar_crop_sh3/ adds a synthetic 3-band SH palette to guitar_crop/ (make_sog_sh_fixture.cpp, whose header
says how to build and run it); `$ST -w tests/data/sog/guitar_crop_sh3/meta.json /tmp/sh3.ply` decodes it to the
values the test derives from the fixture's rule (checked when it was made: SH, means, scales and opacities
identical, rotations within 6e-8).

guitar_crop_v1_meta.json is a hand-written meta.json of the earlier unversioned layout (means.shape, per-channel
scales/sh0 mins and maxs, sh0's fourth channel the opacity logit) over guitar_crop's images;
guitar_crop_v1_reference.ply is `$ST -w <folder with it as meta.json and the images>/meta.json <out.ply>`.

The streamed (1 level) output's chunk 0_0 is byte-identical to guitar_crop/, so only its lod-meta.json is
kept, as guitar_crop_lod-meta.json with `filenames` pointing at guitar_crop/meta.json.

This script then makes, deterministically:
  guitar_crop_deflate.sog            guitar_crop.sog's entries re-packed with deflate (the reader's zlib path)
  taebak_lod0_reference_sample.ply   Gaussians SAMPLE_INDICES(N) of /tmp/taebak_ref.ply, same properties
and prints the whole-scene statistics that tests/converter/test_scene_reader.cpp asserts for taebak.

    python3 tests/data/sog/make_sog_reference.py [/tmp/taebak_ref.ply]
"""
import math
import os
import struct
import sys
import zipfile

HERE = os.path.dirname(os.path.abspath(__file__))


def sample_indices(n):
    """First 100, last 100 and 300 evenly spaced Gaussians (the test computes the same list)."""
    picked = set(range(min(100, n))) | set(range(max(0, n - 100), n)) | {k * n // 300 for k in range(300)}
    return sorted(picked)


def read_ply(path):
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    count = 0
    names = []
    for line in header:
        parts = line.split()
        if parts[:2] == ["element", "vertex"]:
            count = int(parts[2])
        elif parts and parts[0] == "property":
            assert parts[1] == "float", line
            names.append(parts[2])
    return header, names, count, data, end


def make_deflate_bundle():
    src = os.path.join(HERE, "guitar_crop.sog")
    dst = os.path.join(HERE, "guitar_crop_deflate.sog")
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for info in zin.infolist():
            out = zipfile.ZipInfo(info.filename, date_time=(2026, 11, 22, 0, 0, 0))
            out.compress_type = zipfile.ZIP_DEFLATED
            zout.writestr(out, zin.read(info.filename))


def make_taebak_sample(path):
    header, names, n, data, start = read_ply(path)
    stride = 4 * len(names)
    rows = sample_indices(n)
    out_header = "\n".join(line if not line.startswith("element vertex") else "element vertex %d" % len(rows)
                           for line in header) + "\n"
    with open(os.path.join(HERE, "taebak_lod0_reference_sample.ply"), "wb") as f:
        f.write(out_header.encode("ascii"))
        for i in rows:
            f.write(data[start + i * stride:start + (i + 1) * stride])
    # Whole-scene statistics in the cloud's conventions (linear scale, sigmoid opacity).
    col = {name: k for k, name in enumerate(names)}
    sums = {k: 0.0 for k in ("x", "y", "z", "scale", "opacity", "f_dc")}
    for values in struct.iter_unpack("<%df" % len(names), data[start:start + n * stride]):
        for axis in "xyz":
            sums[axis] += values[col[axis]]
        sums["scale"] += sum(math.exp(values[col["scale_%d" % a]]) for a in range(3)) / 3
        sums["opacity"] += 1 / (1 + math.exp(-values[col["opacity"]]))
        sums["f_dc"] += sum(values[col["f_dc_%d" % c]] for c in range(3)) / 3
    print("count", n)
    for k, v in sums.items():
        print("mean_%s %.9g" % (k, v / n))


if __name__ == "__main__":
    make_deflate_bundle()
    if len(sys.argv) > 1:
        make_taebak_sample(sys.argv[1])
