#!/usr/bin/env python3
"""Generates tests/data/bad/*.ply: small PLY files that rgs::converter::read_ply must reject (one of them reads
but rgs::converter::quantize must refuse it).

Every file holds a few real Gaussians taken from samples/guitar.ply (first vertices, INRIA SH0 layout)
with one defect each. The expected StatusCode of each file is listed in EXPECTED below and asserted by
tests/converter/test_ply_corpus.cpp. Output is deterministic: rerunning gives identical bytes.

    python3 tests/data/make_ply_corpus.py        # from the repository root (python3 stdlib only)
"""
import math
import os
import struct
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SAMPLE = os.path.join(ROOT, "samples", "guitar.ply")
OUT_DIR = os.path.join(ROOT, "tests", "data", "bad")
VERTICES = 8  # real vertices copied into each file

# file name -> (expected StatusCode, what is wrong)
EXPECTED = {
    "truncated.ply": ("kIoError", "header declares 8 vertices, data stops inside vertex 5"),
    "not_a_ply.ply": ("kCorruptData", "first line is not 'ply'"),
    "missing_format.ply": ("kCorruptData", "no 'format' line before the elements"),
    "vertex_count_too_large.ply": ("kIoError", "declares 1,000,000 vertices in a file of about 1 KB"),
    "unknown_property_type.ply": ("kUnsupportedFeature", "'property float128 x'"),
    "face_before_vertex.ply": ("kCorruptData", "a face element with 2 faces precedes the vertex element"),
    "list_in_vertex.ply": ("kUnsupportedFeature", "a list property inside the vertex element"),
    "missing_rot_3.ply": ("kUnsupportedFeature", "rot_3 is absent"),
    "f_rest_count_7.ply": ("kUnsupportedFeature", "7 f_rest properties (not 0, 9, 24 or 45)"),
    "bad_ascii_token.ply": ("kCorruptData", "ascii vertex 2 has the token '1.2.3'"),
    "nan_mean.ply": ("kCorruptData", "vertex 3 has x = NaN (accepted with kSanitize, dropping 1)"),
    "zero_quaternion.ply": ("kCorruptData", "vertex 6 has rot_0..3 = 0 (accepted with kSanitize, dropping 1)"),
    "means_span_overflow.ply": ("kInvalidArgument", "reads under both policies; vertices 0 and 1 at -3e38 and "
                                "+3e38 on each axis, whose bounding sphere overflows float32: quantize refuses"),
}


def read_sample():
    """Returns (property names, list of vertex dicts) of the first VERTICES vertices of the sample."""
    with open(SAMPLE, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    names = []
    for line in data[:end].decode("ascii").splitlines():
        parts = line.split()
        if parts[:1] == ["property"]:
            assert parts[1] == "float", line
            names.append(parts[2])
    stride = 4 * len(names)
    rows = []
    for i in range(VERTICES):
        values = struct.unpack_from("<%df" % len(names), data, end + i * stride)
        rows.append(dict(zip(names, values)))
    return names, rows


def header(names, count, fmt="binary_little_endian", before="", after_format="", types=None, extra=""):
    lines = ["ply"]
    if fmt is not None:
        lines.append("format %s 1.0" % fmt)
    lines.append("comment RoofGS must-fail corpus (tests/data/make_ply_corpus.py)")
    if after_format:
        lines.append(after_format)
    if before:
        lines.append(before)
    lines.append("element vertex %d" % count)
    for n in names:
        lines.append("property %s %s" % ((types or {}).get(n, "float"), n))
    if extra:
        lines.append(extra)
    lines.append("end_header")
    return ("\n".join(lines) + "\n").encode("ascii")


def binary_rows(names, rows):
    return b"".join(struct.pack("<%df" % len(names), *[r[n] for n in names]) for r in rows)


def ascii_value(v):
    if math.isnan(v):
        return "nan"
    return repr(float(v))


def write(name, content):
    assert len(content) < 4096, (name, len(content))
    with open(os.path.join(OUT_DIR, name), "wb") as f:
        f.write(content)


def main():
    names, rows = read_sample()
    os.makedirs(OUT_DIR, exist_ok=True)
    good = header(names, len(rows)) + binary_rows(names, rows)

    # Data stops in the middle of vertex 5 of 8.
    full = binary_rows(names, rows)
    write("truncated.ply", header(names, len(rows)) + full[: 5 * 4 * len(names) + 10])

    write("not_a_ply.ply", b"This is not a PLY file, just text that looks nothing like one.\n" + full[:256])

    write("missing_format.ply", header(names, len(rows), fmt=None) + full)

    write("vertex_count_too_large.ply", header(names, 1000000) + full)

    write("unknown_property_type.ply", header(names, len(rows), types={"x": "float128"}) + full)

    # A face element with two triangles declared (and stored) before the vertex element.
    faces = b"".join(struct.pack("<Biii", 3, a, a + 1, a + 2) for a in (0, 3))
    write("face_before_vertex.ply",
          header(names, len(rows), before="element face 2\nproperty list uchar int vertex_indices") + faces + full)

    # The vertex element ends with a list property; each vertex stores an empty list (count byte 0).
    listed = b"".join(struct.pack("<%df" % len(names), *[r[n] for n in names]) + b"\x00" for r in rows)
    write("list_in_vertex.ply", header(names, len(rows), extra="property list uchar float extra") + listed)

    no_rot3 = [n for n in names if n != "rot_3"]
    write("missing_rot_3.ply", header(no_rot3, len(rows)) + binary_rows(no_rot3, rows))

    rest7 = names[:9] + ["f_rest_%d" % r for r in range(7)] + names[9:]
    rows7 = [dict(r, **{"f_rest_%d" % k: 0.01 * (k + 1) * r["f_dc_0"] for k in range(7)}) for r in rows]
    write("f_rest_count_7.ply", header(rest7, len(rows)) + binary_rows(rest7, rows7))

    text = []
    for i, r in enumerate(rows):
        vals = [ascii_value(r[n]) for n in names]
        if i == 2:
            vals[1] = "1.2.3"
        text.append(" ".join(vals))
    write("bad_ascii_token.ply", header(names, len(rows), fmt="ascii") + ("\n".join(text) + "\n").encode("ascii"))

    nan_rows = [dict(r) for r in rows]
    nan_rows[3]["x"] = float("nan")
    write("nan_mean.ply", header(names, len(rows)) + binary_rows(names, nan_rows))

    zero_rows = [dict(r) for r in rows]
    for k in range(4):
        zero_rows[6]["rot_%d" % k] = 0.0
    write("zero_quaternion.ply", header(names, len(rows)) + binary_rows(names, zero_rows))

    far_rows = [dict(r) for r in rows]
    for axis in "xyz":
        far_rows[0][axis] = -3e38
        far_rows[1][axis] = 3e38
    write("means_span_overflow.ply", header(names, len(rows)) + binary_rows(names, far_rows))

    assert len(good) < 4096
    for name in sorted(EXPECTED):
        print("%-28s %-20s %s" % (name, EXPECTED[name][0], EXPECTED[name][1]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
