#!/usr/bin/env python3
"""Tiles a binary little-endian 3DGS PLY into a grid of COPIES copies, written as one binary PLY, streaming.

Copy k of the grid (g × g × g, g the smallest whole number with g³ ≥ COPIES, filled x fastest) is the source
moved by k's grid cell times the source's extent (the longest side of its means' box) along x, y and z; every
other property is copied byte for byte. The source is read COPIES + 1 times (once for its box), a block of rows
at a time: memory stays a few MiB whatever the size of the output, which is written to OUTPUT.part and renamed
on success (removed on failure). Such a scene is for measuring conversions of scenes larger than memory
(docs/LOD.md#scenes-larger-than-memory); it is never committed.

Usage: scripts/make_big_scene.py SOURCE.ply OUTPUT.ply COPIES
  e.g. rgs-convert data/taebak_lod0_sog/lod-meta.json /tmp/taebak.ply
       scripts/make_big_scene.py /tmp/taebak.ply /tmp/taebak_x8.ply 8     # 33,994,288 Gaussians, 2.3 GB
Exit status: 0 on success, 1 on a bad source or a failed write, 2 on a usage error.
"""
import math
import os
import struct
import sys

try:  # NumPy moves a block's means in one step; without it every row is unpacked in Python (far slower)
    import numpy
except ImportError:
    numpy = None

PLY_TYPES = {"char": "b", "int8": "b", "uchar": "B", "uint8": "B", "short": "h", "int16": "h", "ushort": "H",
             "uint16": "H", "int": "i", "int32": "i", "uint": "I", "uint32": "I", "float": "f", "float32": "f",
             "double": "d", "float64": "d"}
BLOCK_ROWS = 65536


class SourceError(Exception):
    pass


def read_header(f):
    """The vertex count, the row's struct format, the byte offsets of x, y and z, and the header's end."""
    lines = []
    while True:
        line = f.readline()
        if not line:
            raise SourceError("no end_header")
        lines.append(line.decode("ascii", "replace").strip())
        if lines[-1] == "end_header":
            break
    if lines[0] != "ply" or "format binary_little_endian 1.0" not in lines:
        raise SourceError("not a binary little-endian PLY")
    count, fmt, names, in_vertex = None, "<", [], False
    for line in lines:
        words = line.split()
        if words[:1] == ["element"]:
            if in_vertex:
                raise SourceError("an element after vertex (only a PLY of vertices alone is tiled)")
            in_vertex = words[1] == "vertex"
            if not in_vertex:
                raise SourceError("element " + words[1] + " before vertex")
            count = int(words[2])
        elif words[:1] == ["property"] and in_vertex:
            if words[1] == "list" or words[1] not in PLY_TYPES:
                raise SourceError("vertex property type " + words[1] + " is not tiled")
            fmt += PLY_TYPES[words[1]]
            names.append(words[2])
    for axis in "xyz":
        if axis not in names or fmt[1 + names.index(axis)] != "f":
            raise SourceError("no float property " + axis)
    offsets = [struct.calcsize(fmt[:1 + names.index(axis)]) for axis in "xyz"]
    return count, struct.Struct(fmt), offsets, lines


def blocks(path, header_bytes, row_size, count):
    """The source's rows, BLOCK_ROWS at a time, as bytearrays."""
    with open(path, "rb") as f:
        f.seek(header_bytes)
        left = count
        while left:
            n = min(left, BLOCK_ROWS)
            data = f.read(n * row_size)
            if len(data) != n * row_size:
                raise SourceError("the file ends before its %d rows" % count)
            left -= n
            yield bytearray(data)


def means_view(block, row_size, offsets):
    """A NumPy view of `block`'s rows as records of their x, y and z."""
    dtype = numpy.dtype({"names": ["x", "y", "z"], "formats": ["<f4"] * 3, "offsets": offsets, "itemsize": row_size})
    return numpy.frombuffer(block, dtype=dtype)


def means_box(path, header_bytes, row, offsets, count):
    lo, hi = [math.inf] * 3, [-math.inf] * 3
    if numpy is not None:
        for block in blocks(path, header_bytes, row.size, count):
            view = means_view(block, row.size, offsets)
            for a, axis in enumerate("xyz"):
                lo[a] = min(lo[a], float(view[axis].min()))
                hi[a] = max(hi[a], float(view[axis].max()))
        return lo, hi
    xyz = struct.Struct("<3f") if offsets[1] == offsets[0] + 4 and offsets[2] == offsets[0] + 8 else None
    for block in blocks(path, header_bytes, row.size, count):
        for start in range(0, len(block), row.size):
            if xyz:
                p = xyz.unpack_from(block, start + offsets[0])
            else:
                p = [struct.unpack_from("<f", block, start + o)[0] for o in offsets]
            for a in range(3):
                if p[a] < lo[a]:
                    lo[a] = p[a]
                if p[a] > hi[a]:
                    hi[a] = p[a]
    return lo, hi


def shifted(block, row_size, offsets, shift):
    """`block` with every row's x, y, z moved by `shift` (in float32, as the rows hold them), in place."""
    if numpy is not None:
        view = means_view(block, row_size, offsets)
        for a, axis in enumerate("xyz"):
            view[axis] += numpy.float32(shift[a])
        return block
    floats = struct.Struct("<f")
    for start in range(0, len(block), row_size):
        for a in range(3):
            at = start + offsets[a]
            floats.pack_into(block, at, floats.unpack_from(block, at)[0] + shift[a])
    return block


def main(argv):
    if len(argv) != 4 or not argv[3].isdigit() or int(argv[3]) < 1:
        print(__doc__.split("\n\n")[-1].strip(), file=sys.stderr)
        return 2
    source, output, copies = argv[1], argv[2], int(argv[3])
    with open(source, "rb") as f:
        count, row, offsets, lines = read_header(f)
        header_bytes = f.tell()
    lo, hi = means_box(source, header_bytes, row, offsets, count)
    extent = max(h - l for h, l in zip(hi, lo))
    side = 1
    while side ** 3 < copies:
        side += 1
    header = [line if not line.startswith("element vertex") else "element vertex %d" % (count * copies)
              for line in lines]
    part = output + ".part"
    try:
        with open(part, "wb") as out:
            out.write(("\n".join(header) + "\n").encode("ascii"))
            for k in range(copies):
                cell = (k % side, (k // side) % side, k // (side * side))
                shift = [c * extent for c in cell]
                for block in blocks(source, header_bytes, row.size, count):
                    out.write(shifted(block, row.size, offsets, shift) if k else block)
                print("copy %d of %d written" % (k + 1, copies), file=sys.stderr)
        os.replace(part, output)
    except BaseException:
        if os.path.exists(part):
            os.remove(part)
        raise
    print("%s: %d Gaussians (%d copies of %s), %d bytes" % (output, count * copies, copies, source,
                                                           os.path.getsize(output)))
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv))
    except (SourceError, OSError, ValueError) as e:
        print("make_big_scene: error: %s" % e, file=sys.stderr)
        sys.exit(1)
