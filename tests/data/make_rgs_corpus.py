#!/usr/bin/env python3
"""Generates the .rgs test corpus from format/SPEC.md alone (python3 stdlib, no numpy, no zstd module).

  tests/data/v1.0/small_sh3.rgs        golden: 21 Gaussians, SH degree 3, linear scales, codec none
  tests/data/v1.0/small_sh0_zstd.rgs   golden: 64 Gaussians, SH degree 0, log scales, every section zstd
  tests/data/v1.0/forward_compat.rgs   a "1.7" file with an optional flag and unknown sections that a
                                       1.0 reader must open (SPEC §6)
  tests/data/v1.2/small_sh0_dc_residual.rgs  golden: small_sh0_zstd's scene with the sh_dc_residual section
                                       (SPEC §4.8), codec none
  tests/data/v1.3/small_sh1_lod.rgs    golden: a level-of-detail file (SPEC §4.9): 24 Gaussians, SH degree 1,
                                       linear scales, sh_dc_residual, 2 chunks x 3 levels (level 0: 8 + 6
                                       Gaussians), codec none, stamped 1.3 with required flag bit 1
  tests/data/bad/*.rgs                 files that must fail with a named StatusCode, listed with their
                                       defects in tests/format/bad_rgs_corpus.md (bad/lod_*.rgs: damaged
                                       copies of small_sh1_lod.rgs)

This is a second, independent implementation of the spec: its own XXH64, its own little-endian
writer, and zstd frames made of raw and RLE blocks (RFC 8878 §3.1.1.2), which any zstd decoder must
accept. The C++ tests check that the library reproduces small_sh3.rgs, small_sh0_dc_residual.rgs and
small_sh1_lod.rgs byte for byte from the same scenes (and, for the last, the same level-of-detail index).

  python3 tests/data/make_rgs_corpus.py           # (re)write the corpus
  python3 tests/data/make_rgs_corpus.py --check   # exit 1 if the files on disk differ from the generator
"""

import os
import struct
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
GOLDEN_DIR = os.path.join(HERE, "v1.0")
GOLDEN_DIR_1_2 = os.path.join(HERE, "v1.2")
GOLDEN_DIR_1_3 = os.path.join(HERE, "v1.3")
BAD_DIR = os.path.join(HERE, "bad")
MANIFEST = os.path.join(HERE, os.pardir, "format", "bad_rgs_corpus.md")

# ---------------------------------------------------------------------------------------------------
# XXH64 (https://github.com/Cyan4973/xxHash/blob/dev/doc/xxhash_spec.md), seed 0.
M64 = (1 << 64) - 1
P1, P2, P3, P4, P5 = (0x9E3779B185EBCA87, 0xC2B2AE3D27D4EB4F, 0x165667B19E3779F9, 0x85EBCA77C2B2AE63,
                      0x27D4EB2F165667C5)


def _rotl(x, r):
    return ((x << r) | (x >> (64 - r))) & M64


def _round(acc, lane):
    acc = (acc + lane * P2) & M64
    return (_rotl(acc, 31) * P1) & M64


def _merge(acc, val):
    acc ^= _round(0, val)
    return (acc * P1 + P4) & M64


def xxh64(data, seed=0):
    n = len(data)
    i = 0
    if n >= 32:
        v = [(seed + P1 + P2) & M64, (seed + P2) & M64, seed, (seed - P1) & M64]
        while i + 32 <= n:
            for j in range(4):
                v[j] = _round(v[j], struct.unpack_from("<Q", data, i + 8 * j)[0])
            i += 32
        h = (_rotl(v[0], 1) + _rotl(v[1], 7) + _rotl(v[2], 12) + _rotl(v[3], 18)) & M64
        for j in range(4):
            h = _merge(h, v[j])
    else:
        h = (seed + P5) & M64
    h = (h + n) & M64
    while i + 8 <= n:
        h ^= _round(0, struct.unpack_from("<Q", data, i)[0])
        h = (_rotl(h, 27) * P1 + P4) & M64
        i += 8
    if i + 4 <= n:
        h ^= (struct.unpack_from("<I", data, i)[0] * P1) & M64
        h = (_rotl(h, 23) * P2 + P3) & M64
        i += 4
    while i < n:
        h ^= (data[i] * P5) & M64
        h = (_rotl(h, 11) * P1) & M64
        i += 1
    h ^= h >> 33
    h = (h * P2) & M64
    h ^= h >> 29
    h = (h * P3) & M64
    h ^= h >> 32
    return h


assert xxh64(b"") == 0xEF46DB3751D8E999
assert xxh64(b"a") == 0xD24EC4F1A98C6E5B
assert xxh64(b"abc") == 0x44BC2CF5AD770999

# ---------------------------------------------------------------------------------------------------
# zstd frames of raw and RLE blocks (RFC 8878): content size, content checksum, window <= 2^27.
MAX_WINDOW = 1 << 27


def zstd_frame(content, window_log=None):
    """window_log forces a Window_Descriptor (no single segment) with that log2 window size."""
    n = len(content)
    if n < 256:
        fcs_flag, fcs = 0, struct.pack("<B", n)
    elif n < 65536 + 256:
        fcs_flag, fcs = 1, struct.pack("<H", n - 256)
    elif n < (1 << 32):
        fcs_flag, fcs = 2, struct.pack("<I", n)
    else:
        fcs_flag, fcs = 3, struct.pack("<Q", n)
    if window_log is not None:
        if fcs_flag == 0:
            fcs_flag, fcs = 1, struct.pack("<H", n - 256) if n >= 256 else None
            assert fcs is not None, "a windowed frame needs a 2-byte or larger content size field"
        descriptor = (fcs_flag << 6) | (1 << 2)
        out = bytearray(struct.pack("<I", 0xFD2FB528) + bytes([descriptor, (window_log - 10) << 3]) + fcs)
    elif n <= MAX_WINDOW:
        # Single segment (the window is the content size), content checksum, no dictionary.
        descriptor = (fcs_flag << 6) | (1 << 5) | (1 << 2)
        out = bytearray(struct.pack("<I", 0xFD2FB528) + bytes([descriptor]) + fcs)
    else:
        # SPEC §3.1 caps the window at 2^27: Window_Descriptor exponent 17, mantissa 0.
        descriptor = (fcs_flag << 6) | (1 << 2)
        out = bytearray(struct.pack("<I", 0xFD2FB528) + bytes([descriptor, 17 << 3]) + fcs)
    # Split into runs: 32+ equal bytes become an RLE block, the rest raw blocks of at most 128 KiB.
    blocks = []
    i = 0
    raw_start = 0
    while i < n:
        j = i
        while j < n and content[j] == content[i] and j - i < 128 * 1024:
            j += 1
        if j - i >= 32:
            if raw_start < i:
                blocks.append(("raw", raw_start, i))
            blocks.append(("rle", i, j))
            raw_start = j
        i = j
    if raw_start < n or not blocks:
        blocks.append(("raw", raw_start, n))
    for index, (kind, a, b) in enumerate(blocks):
        while kind == "raw" and b - a > 128 * 1024:  # never for the small corpus; kept for correctness
            blocks.insert(index, ("raw", a, a + 128 * 1024))
            a += 128 * 1024
    for index, (kind, a, b) in enumerate(blocks):
        last = 1 if index == len(blocks) - 1 else 0
        block_type = 0 if kind == "raw" else 1
        header = last | (block_type << 1) | ((b - a) << 3)
        out += struct.pack("<I", header)[:3]
        out += content[a:b] if kind == "raw" else content[a:a + 1]
    out += struct.pack("<I", xxh64(bytes(content)) & 0xFFFFFFFF)
    return bytes(out)


# ---------------------------------------------------------------------------------------------------
# The container (SPEC §2-§4).
MAGIC = bytes([0x89, 0x52, 0x47, 0x53, 0x0D, 0x0A, 0x1A, 0x0A])
HEADER_SIZE = 64
ENTRY_SIZE = 64
ALIGN = 256
METADATA_SIZE = 128
ID_METADATA, ID_PROVENANCE, ID_MEANS, ID_ROTATIONS, ID_SCALES, ID_OPACITIES, ID_SH = 1, 2, 16, 17, 18, 19, 20
ID_SH_DC_RESIDUAL = 21
ID_LOD = 22
REQUIRED_FLAG_LOD = 1 << 1  # SPEC §2.2
CODEC_NONE, CODEC_ZSTD = 0, 1
T_BYTES, T_I8, T_F16, T_F32 = 0, 1, 2, 3


def align_up(x):
    return (x + ALIGN - 1) // ALIGN * ALIGN


def encode_metadata(m):
    out = struct.pack("<I5B7x", m["sh_degree"], 1, 1, m["scale_encoding"], 1, 1)
    out += struct.pack("<3f", *m["aabb_min"]) + struct.pack("<3f", *m["aabb_max"])
    out += struct.pack("<3f", *m["sphere_center"]) + struct.pack("<f", m["sphere_radius"])
    out += struct.pack("<If", 8, 100.0)
    for row in m["sh_scales"]:
        out += struct.pack("<3f", *row)
    out += bytes(16)
    assert len(out) == METADATA_SIZE
    return out


def encode_provenance(pairs):
    out = struct.pack("<I", len(pairs))
    for key, value in pairs:
        k, v = key.encode("utf-8"), value.encode("utf-8")
        out += struct.pack("<I", len(k)) + k + struct.pack("<I", len(v)) + v
    return out


def container(sections, gaussian_count, minor=0, optional_flags=0, required_flags=0):
    """sections: list of dicts id, codec, type, components, count, raw (bytes), stored (bytes)."""
    table_end = HEADER_SIZE + ENTRY_SIZE * len(sections)
    offsets = []
    end = table_end
    for s in sections:
        offset = align_up(end)
        offsets.append(offset)
        end = offset + len(s["stored"])
    file_size = end
    out = bytearray(file_size)
    table = bytearray()
    for s, offset in zip(sections, offsets):
        out[offset:offset + len(s["stored"])] = s["stored"]
        table += struct.pack("<IHHII", s["id"], s["codec"], s["type"], s["components"], 0)
        table += struct.pack("<QQQQQQ", s["count"], offset, len(s["stored"]), s.get("raw_size", len(s["raw"])),
                             xxh64(bytes(s["stored"])), 0)
    header = MAGIC + struct.pack("<HHIIIQII", 1, minor, HEADER_SIZE, required_flags, optional_flags, gaussian_count,
                                 len(sections), 0)
    header += struct.pack("<QQ", HEADER_SIZE, file_size)
    out[HEADER_SIZE:table_end] = table
    out[0:56] = header
    struct.pack_into("<Q", out, 56, xxh64(bytes(header) + bytes(table)))
    return bytes(out)


def scene_sections(scene, codec):
    n = scene["count"]
    k = (scene["metadata"]["sh_degree"] + 1) ** 2

    def section(sid, etype, components, count, raw):
        stored = zstd_frame(raw) if codec == CODEC_ZSTD else raw
        return {"id": sid, "codec": codec, "type": etype, "components": components, "count": count, "raw": raw,
                "stored": stored}

    meta = encode_metadata(scene["metadata"])
    prov = encode_provenance(scene["provenance"])
    sections = [
        section(ID_METADATA, T_BYTES, 1, len(meta), meta),
        section(ID_PROVENANCE, T_BYTES, 1, len(prov), prov),
        section(ID_MEANS, T_F32, 3, n, struct.pack("<%df" % (3 * n), *scene["means"])),
        section(ID_ROTATIONS, T_F16, 4, n, struct.pack("<%dH" % (4 * n), *scene["rotations"])),
        section(ID_SCALES, T_F16, 3, n, struct.pack("<%dH" % (3 * n), *scene["scales"])),
        section(ID_OPACITIES, T_F16, 1, n, struct.pack("<%dH" % n, *scene["opacities"])),
        section(ID_SH, T_I8, 3 * k, n, struct.pack("<%db" % (3 * k * n), *scene["sh"])),
    ]
    if "sh_dc_residual" in scene:
        sections.append(section(ID_SH_DC_RESIDUAL, T_I8, 3, n, struct.pack("<%db" % (3 * n), *scene["sh_dc_residual"])))
    if "lod" in scene:
        # SPEC §4.9: the index itself may take any codec, but this corpus stores it raw like the C++ writer.
        raw = encode_lod(scene)
        sections.append({"id": ID_LOD, "codec": CODEC_NONE, "type": T_BYTES, "components": 1, "count": len(raw),
                         "raw": raw, "stored": raw})
    return sections


# ---------------------------------------------------------------------------------------------------
# The level-of-detail index (SPEC §4.9).
LOD_HEAD, LOD_CHUNK, LOD_RECORD = 16, 16, 24


def lod_ranges(lod):
    """(level, chunk, first, count) of each level record in record (level-major) order."""
    out = []
    first = 0
    for level, row in enumerate(lod["counts"]):
        for chunk, count in enumerate(row):
            out.append((level, chunk, first, count))
            first += count
    return out


def range_checksum(scene, first, count):
    """XXH64 of the range's means, rotations, scales, opacities, sh and sh_dc_residual bytes, one stream."""
    k3 = 3 * (scene["metadata"]["sh_degree"] + 1) ** 2
    a, b = first, first + count
    stream = struct.pack("<%df" % (3 * count), *scene["means"][3 * a:3 * b])
    stream += struct.pack("<%dH" % (4 * count), *scene["rotations"][4 * a:4 * b])
    stream += struct.pack("<%dH" % (3 * count), *scene["scales"][3 * a:3 * b])
    stream += struct.pack("<%dH" % count, *scene["opacities"][a:b])
    stream += struct.pack("<%db" % (k3 * count), *scene["sh"][k3 * a:k3 * b])
    if "sh_dc_residual" in scene:
        stream += struct.pack("<%db" % (3 * count), *scene["sh_dc_residual"][3 * a:3 * b])
    return xxh64(stream)


def encode_lod(scene):
    """The raw bytes of the lod section: head, chunk records, level records with their range checksums."""
    lod = scene["lod"]
    chunks, levels = len(lod["chunks"]), len(lod["counts"])
    out = struct.pack("<IIQ", chunks, levels, 0)
    for center, radius in lod["chunks"]:
        out += struct.pack("<4f", center[0], center[1], center[2], radius)
    for level, chunk, first, count in lod_ranges(lod):
        out += struct.pack("<QfIQ", count, lod["errors"][level][chunk], 0, range_checksum(scene, first, count))
    assert len(out) == LOD_HEAD + LOD_CHUNK * chunks + LOD_RECORD * levels * chunks
    return out


# ---------------------------------------------------------------------------------------------------
# Scenes. tests/format/test_scenes.h builds the same ones in C++; keep the two in step.
QUATS = [(0x3C00, 0, 0, 0), (0, 0x3C00, 0, 0), (0x3800, 0x3800, 0x3800, 0x3800), (0x3800, 0xB800, 0x3800, 0xB800)]


def small_sh3():
    n, degree = 21, 3
    k = (degree + 1) ** 2
    scene = {"count": n, "means": [], "rotations": [], "scales": [], "opacities": [], "sh": []}
    for i in range(n):
        scene["means"] += [(i % 7) * 0.5 - 1.5, (i % 5) * 0.25 - 0.5, i * 0.125 + 2.0]
        scene["rotations"] += QUATS[i % 4]
        for a in range(3):
            if (i, a) == (5, 2):
                bits = 0x0000  # a linear scale that underflowed FP16
            elif (i, a) == (6, 0):
                bits = 0x0001  # the smallest subnormal
            else:
                bits = 0x1C00 + ((i * 3 + a) * 97) % 0x1000
            scene["scales"].append(bits)
        scene["opacities"].append(0x3C00 if i == n - 1 else (i * 421) % 0x3C01)
        for kk in range(k):
            for c in range(3):
                scene["sh"].append((i * 31 + kk * 7 + c * 3) % 255 - 127)
    scene["metadata"] = {
        "sh_degree": degree, "scale_encoding": 1,
        "aabb_min": (-1.5, -0.5, 2.0), "aabb_max": (1.5, 0.5, 4.5),
        "sphere_center": (0.0, 0.0, 3.25), "sphere_radius": 2.125,
        "sh_scales": [[(c + 1) * 2.0 ** -(d + 3) if d <= degree else 0.0 for c in range(3)] for d in range(4)],
    }
    scene["provenance"] = [("source", "synthetic small_sh3 (tests/data/make_rgs_corpus.py)"),
                           ("converter", "make_rgs_corpus.py 1.0"),
                           ("options", "sh_degree=3 scale_encoding=linear codec=none"),
                           ("utf8", "Gau\u00dfian \u2713")]
    return scene


def small_sh0_zstd():
    n, degree = 64, 0
    scene = {"count": n, "means": [], "rotations": [], "scales": [], "opacities": [], "sh": []}
    for i in range(n):
        scene["means"] += [(i % 8) * 0.5 - 2.0, (i // 8) * 0.5 - 2.0, 1.0 + (i % 3) * 0.25]
        scene["rotations"] += QUATS[(i // 3) % 4]
        for a in range(3):
            scene["scales"].append(0xC000 + ((i * 3 + a) * 53) % 0x800 if i < 32 else 0x0000)  # log scale
        scene["opacities"].append(0x3800 + i * 8)
        for c in range(3):
            scene["sh"].append((i * 13 + c * 5) % 255 - 127)
    scene["metadata"] = {
        "sh_degree": degree, "scale_encoding": 2,
        "aabb_min": (-2.0, -2.0, 1.0), "aabb_max": (1.5, 1.5, 1.5),
        "sphere_center": (-0.25, -0.25, 1.25), "sphere_radius": 2.5,
        "sh_scales": [[(c + 1) * 0.125 if d == 0 else 0.0 for c in range(3)] for d in range(4)],
    }
    scene["provenance"] = [("source", "synthetic small_sh0_zstd (tests/data/make_rgs_corpus.py)"),
                           ("options", "sh_degree=0 scale_encoding=log codec=zstd (raw and RLE blocks)")]
    return scene


def small_sh0_dc_residual():
    """small_sh0_zstd's Gaussians with a DC residual of every i8 value (SPEC §4.8), stored raw."""
    scene = small_sh0_zstd()
    n = scene["count"]
    scene["sh_dc_residual"] = [(i * 3 + c) * 4 % 256 - 128 + (i % 4) for i in range(n) for c in range(3)]
    scene["provenance"] = [("source", "synthetic small_sh0_dc_residual (tests/data/make_rgs_corpus.py)"),
                           ("options", "sh_degree=0 scale_encoding=log codec=none sh_dc_residual")]
    return scene


def f16(bits):
    return struct.unpack("<e", struct.pack("<H", bits))[0]


def small_sh1_lod():
    """A level-of-detail scene (SPEC §4.9): 2 chunks x 3 levels, level-major. Chunk c is the sphere of radius 1
    around (2c - 1, 0, 2); level 0 holds 8 and 6 Gaussians, level 1 4 and 3, level 2 2 and 1 (N = 24, N0 = 14),
    the coarser levels with larger scales. Errors 0, then 0.125 / 0.25, then 0.5 / 0.75. Means are multiples of
    1/8 (exact in f32); every Gaussian's |mean - centre| + 3 max(scale) stays under 0.9 of its chunk's radius.
    tests/format/test_format_golden.cpp make_small_sh1_lod() builds the same scene and index in C++; keep them in
    step."""
    degree = 1
    k = (degree + 1) ** 2
    chunks = [((-1.0, 0.0, 2.0), 1.0), ((1.0, 0.0, 2.0), 1.0)]
    counts = [[8, 6], [4, 3], [2, 1]]
    errors = [[0.0, 0.0], [0.125, 0.25], [0.5, 0.75]]
    scene = {"means": [], "rotations": [], "scales": [], "opacities": [], "sh": [], "sh_dc_residual": [],
             "lod": {"chunks": chunks, "counts": counts, "errors": errors}}
    i = 0
    for level, chunk, first, count in lod_ranges(scene["lod"]):
        assert first == i
        center, radius = chunks[chunk]
        for j in range(count):
            offset = (((j * 3 + level) % 7 - 3) * 0.125, ((j * 2 + chunk) % 5 - 2) * 0.125,
                      ((j + 2 * level) % 3 - 1) * 0.25)
            mean = [center[a] + offset[a] for a in range(3)]
            scene["means"] += mean
            scene["rotations"] += QUATS[(i + level) % 4]
            scales = []
            for a in range(3):
                if (i, a) == (3, 1):
                    bits = 0x0000  # a linear scale that underflowed FP16
                elif level == 0:
                    bits = 0x2000 + ((i * 3 + a) * 37) % 0x0C00  # 2^-7 .. 2^-4
                else:
                    bits = 0x2C00 + (level - 1) * 0x0200 + ((i * 3 + a) * 29) % 0x0200  # 2^-4 .. 2^-3
                scales.append(bits)
            scene["scales"] += scales
            # SPEC §4.9: the 3-sigma extent lies inside the chunk's sphere, with a margin.
            reach = sum((mean[a] - center[a]) ** 2 for a in range(3)) ** 0.5 + 3 * max(f16(b) for b in scales)
            assert reach <= 0.9 * radius, (i, reach)
            scene["opacities"].append(0x3C00 if i == 0 else (i * 677) % 0x3C01)
            for kk in range(k):
                for c in range(3):
                    scene["sh"].append((i * 37 + kk * 11 + c * 5) % 255 - 127)
            for c in range(3):
                scene["sh_dc_residual"].append((i * 3 + c) * 11 % 256 - 128)
            i += 1
    scene["count"] = i
    xs, ys, zs = scene["means"][0::3], scene["means"][1::3], scene["means"][2::3]
    sphere_center = (0.0, 0.0, 2.0)
    far = max(sum((m[a] - sphere_center[a]) ** 2 for a in range(3)) ** 0.5 for m in zip(xs, ys, zs))
    scene["metadata"] = {
        "sh_degree": degree, "scale_encoding": 1,
        "aabb_min": (min(xs), min(ys), min(zs)), "aabb_max": (max(xs), max(ys), max(zs)),
        "sphere_center": sphere_center, "sphere_radius": -(-far * 8 // 1) / 8,  # rounded up to 1/8
        "sh_scales": [[(c + 1) * 2.0 ** -(d + 3) if d <= degree else 0.0 for c in range(3)] for d in range(4)],
    }
    assert scene["metadata"]["aabb_min"] == (-1.375, -0.25, 1.75)
    assert scene["metadata"]["aabb_max"] == (1.375, 0.25, 2.25)
    assert scene["metadata"]["sphere_radius"] == 1.5
    scene["provenance"] = [("source", "synthetic small_sh1_lod (tests/data/make_rgs_corpus.py)"),
                           ("options", "sh_degree=1 scale_encoding=linear codec=none sh_dc_residual lod=2x3")]
    return scene


def lod_file(scene, sections=None, minor=3, required_flags=REQUIRED_FLAG_LOD):
    return container(scene_sections(scene, CODEC_NONE) if sections is None else sections, scene["count"],
                     minor=minor, required_flags=required_flags)


# ---------------------------------------------------------------------------------------------------
# Patching helpers for the must-fail corpus.


def entry(i):
    return HEADER_SIZE + ENTRY_SIZE * i


def section_count(b):
    return struct.unpack_from("<I", b, 32)[0]


def fix_header(b):
    n = section_count(b)
    table_end = min(len(b), HEADER_SIZE + ENTRY_SIZE * n)
    struct.pack_into("<Q", b, 56, xxh64(bytes(b[0:56]) + bytes(b[HEADER_SIZE:table_end])))
    return b


def fix_section(b, i):
    offset, stored = struct.unpack_from("<QQ", b, entry(i) + 24)
    struct.pack_into("<Q", b, entry(i) + 48, xxh64(bytes(b[offset:offset + stored])))
    return fix_header(b)


def section_offset(b, i):
    return struct.unpack_from("<Q", b, entry(i) + 24)[0]


def put(b, fmt, offset, *values):
    struct.pack_into(fmt, b, offset, *values)
    return b


def bad_cases(g3, gz):
    """(name, expected StatusCode, stage, bytes, why). stage: 'open' fails at RgsFile::open (and so in
    validate); 'validate' opens fine and fails only in validate()."""
    cases = []

    def case(name, code, stage, data, why):
        cases.append((name, code, stage, bytes(data), why))

    def c3():
        return bytearray(g3)

    def cz():
        return bytearray(gz)

    META, PROV, MEANS, ROT, SCALES, OPAC, SH = range(7)
    # §5.1 header
    b = c3(); b[1] = ord("r")
    case("bad_magic", "kNotRgsFile", "open", b, "magic byte 1 is 'r'")
    case("empty", "kNotRgsFile", "open", b"", "zero bytes")
    case("ply_text", "kNotRgsFile", "open", b"ply\nformat binary_little_endian 1.0\nelement vertex 0\nend_header\n",
         "a PLY header")
    case("truncated_header", "kCorruptData", "open", g3[:40], "40 bytes: the magic, then the header ends")
    b = put(c3(), "<H", 8, 2); fix_header(b)
    case("future_major", "kUnsupportedVersion", "open", b, "major version 2")
    b = put(c3(), "<H", 8, 0); fix_header(b)
    case("major_zero", "kUnsupportedVersion", "open", b, "major version 0 (never released)")
    b = put(c3(), "<I", 16, 0x100); fix_header(b)
    case("unknown_required_flag", "kUnsupportedFeature", "open", b, "required flag bit 8")
    b = put(c3(), "<I", 12, 72); fix_header(b)
    case("header_size_mismatch", "kCorruptData", "open", b, "header_size 72")
    b = put(c3(), "<I", 36, 1); fix_header(b)
    case("header_reserved_nonzero", "kCorruptData", "open", b, "header bytes 36..39 = 1")
    b = put(c3(), "<Q", 40, 128); fix_header(b)
    case("table_offset_mismatch", "kCorruptData", "open", b, "table_offset 128")
    case("truncated", "kCorruptData", "open", g3[:-100], "last 100 bytes cut")
    case("trailing_bytes", "kCorruptData", "open", g3 + bytes(16), "16 bytes appended, file_size unchanged")
    b = bytearray(g3 + bytes(16)); put(b, "<Q", 48, len(b)); fix_header(b)
    case("trailing_after_last_section", "kCorruptData", "open", b, "16 bytes appended, file_size updated")
    b = put(c3(), "<I", 32, 65); fix_header(b)
    case("too_many_sections", "kLimitExceeded", "open", b, "section_count 65 > max_sections 64")
    count = (len(g3) - HEADER_SIZE) // ENTRY_SIZE + 1
    assert count <= 64
    b = put(c3(), "<I", 32, count)
    case("table_past_eof", "kCorruptData", "open", b, "section_count %d: the table runs past EOF" % count)
    b = c3(); b[56] ^= 0x01
    case("header_checksum", "kChecksumMismatch", "open", b, "checksum field bit flipped")
    b = put(c3(), "<Q", 24, 20)
    case("header_checksum_count", "kChecksumMismatch", "open", b, "gaussian_count 20, checksum not updated")
    b = put(c3(), "<Q", 24, 1 << 40); fix_header(b)
    case("gaussian_count_over_limit", "kLimitExceeded", "open", b, "gaussian_count 2^40 > max_gaussians 2^28")
    # §5.2 section table and placement
    b = put(c3(), "<I", entry(MEANS) + 12, 1); fix_header(b)
    case("table_reserved_nonzero", "kCorruptData", "open", b, "means entry reserved u32 = 1")
    b = put(c3(), "<I", entry(PROV), ID_MEANS); fix_header(b)
    case("duplicate_section", "kCorruptData", "open", b, "provenance entry relabelled as means")
    b = put(c3(), "<I", entry(OPAC), 0x7000); fix_header(b)
    case("missing_required_section", "kCorruptData", "open", b, "opacities entry relabelled as unknown id 0x7000")
    b = put(c3(), "<Q", entry(MEANS) + 24, section_offset(g3, MEANS) + 4); fix_header(b)
    case("misaligned_section", "kCorruptData", "open", b, "means offset + 4")
    b = put(c3(), "<Q", entry(ROT) + 24, section_offset(g3, MEANS)); fix_header(b)
    case("overlapping_sections", "kCorruptData", "open", b, "rotations offset = means offset")
    b = put(c3(), "<Q", entry(SH) + 24, section_offset(g3, SH) + ALIGN); fix_header(b)
    case("section_gap", "kCorruptData", "open", b, "sh offset + 256")
    sh_stored = struct.unpack_from("<Q", g3, entry(SH) + 32)[0]
    b = put(c3(), "<Q", entry(SH) + 32, sh_stored + ALIGN); fix_header(b)
    case("section_past_eof", "kCorruptData", "open", b, "sh stored_size + 256")
    b = c3(); b[section_offset(g3, META) + METADATA_SIZE] = 0x5A
    case("padding_nonzero", "kCorruptData", "open", b, "padding byte after the metadata record = 0x5a")
    # §5.3 entry rules
    rot_raw = struct.unpack_from("<Q", g3, entry(ROT) + 40)[0]
    b = put(c3(), "<Q", entry(ROT) + 40, rot_raw + 8); fix_header(b)
    case("raw_size_mismatch", "kCorruptData", "open", b, "rotations raw_size + 8, element_count unchanged")
    b = put(c3(), "<Q", entry(META) + 32, METADATA_SIZE - 4); fix_header(b)
    case("stored_size_mismatch", "kCorruptData", "open", b, "codec none, metadata stored_size 124 != raw 128")
    b = put(c3(), "<Q", 24, 20); fix_header(b)
    case("element_count_mismatch", "kCorruptData", "open", b, "gaussian_count 20, sections hold 21")
    b = put(c3(), "<HHI", entry(MEANS) + 4, CODEC_NONE, T_F16, 6); fix_header(b)
    case("wrong_element_type", "kCorruptData", "open", b, "means declared f16 x 6 (same 12 bytes per element)")
    b = put(c3(), "<H", entry(ROT) + 4, 7); fix_header(b)
    case("unknown_codec", "kUnsupportedFeature", "open", b, "rotations codec 7")
    # §5.3 metadata and provenance (section checksums updated so the content check fires)
    mo = section_offset(g3, META)
    b = c3(); b[mo + 6] = 9; fix_section(b, META)
    case("unknown_scale_encoding", "kUnsupportedFeature", "open", b, "metadata scale encoding 9")
    b = c3(); b[mo + 120] = 1; fix_section(b, META)
    case("metadata_reserved_nonzero", "kCorruptData", "open", b, "metadata reserved byte 120 = 1")
    b = put(c3(), "<I", mo + 56, 7); fix_section(b, META)
    case("metadata_bad_quantization", "kCorruptData", "open", b, "SH quantization bits 7")
    b = put(c3(), "<I", mo, 2); put(b, "<3f", mo + 64 + 36, 0.0, 0.0, 0.0); fix_section(b, META)
    case("sh_degree_mismatch", "kCorruptData", "open", b, "metadata SH degree 2, sh section has 48 components")
    b = put(c3(), "<I", mo, 4); fix_section(b, META)
    case("sh_degree_unsupported", "kUnsupportedFeature", "open", b, "metadata SH degree 4")
    b = put(c3(), "<f", mo + 52, float("nan")); fix_section(b, META)
    case("metadata_nan_radius", "kCorruptData", "open", b, "bounding sphere radius NaN")
    b = c3(); b[mo + 20] ^= 0x01
    case("metadata_checksum", "kChecksumMismatch", "open", b, "metadata byte flipped, checksum not updated")
    po = section_offset(g3, PROV)
    b = put(c3(), "<I", po + 4, 0xFFFF); fix_section(b, PROV)
    case("provenance_overrun", "kCorruptData", "open", b, "first provenance key length 65535")
    b = put(c3(), "<I", po, 1 << 30); fix_section(b, PROV)
    case("provenance_count_overrun", "kCorruptData", "open", b, "provenance count 2^30")
    # §5.4 payloads: open succeeds, validate() fails
    b = c3(); b[section_offset(g3, MEANS) + 3 * 12 + 1] ^= 0x01
    case("section_checksum", "kChecksumMismatch", "validate", b, "means byte flipped, checksum not updated")
    b = put(c3(), "<f", section_offset(g3, MEANS) + 5 * 12 + 4, float("nan")); fix_section(b, MEANS)
    case("nan_mean", "kCorruptData", "validate", b, "Gaussian 5 mean.y NaN")
    b = put(c3(), "<f", section_offset(g3, MEANS) + 8, 100.0); fix_section(b, MEANS)
    case("mean_outside_bounds", "kCorruptData", "validate", b, "Gaussian 0 mean.z 100, outside the AABB")
    b = put(c3(), "<4H", section_offset(g3, ROT) + 2 * 8, 0, 0, 0x8000, 0); fix_section(b, ROT)
    case("zero_rotation", "kCorruptData", "validate", b, "Gaussian 2 quaternion (0, 0, -0, 0)")
    b = put(c3(), "<H", section_offset(g3, SCALES) + 1 * 6, 0xB000); fix_section(b, SCALES)
    case("negative_linear_scale", "kCorruptData", "validate", b, "Gaussian 1 linear scale -0.125")
    b = put(c3(), "<H", section_offset(g3, OPAC) + 4 * 2, 0x3C01); fix_section(b, OPAC)
    case("opacity_above_one", "kCorruptData", "validate", b, "Gaussian 4 opacity 1.000977")
    b = c3(); b[section_offset(g3, SH) + 7] = 0x80; fix_section(b, SH)
    case("sh_minus_128", "kCorruptData", "validate", b, "SH value -128 outside [-127, 127]")
    # §5.3/§5.4 zstd frames (from the zstd golden; section order is the same)
    zo = section_offset(gz, MEANS)
    z_stored = struct.unpack_from("<Q", gz, entry(MEANS) + 32)[0]
    b = cz(); b[zo + 4] &= ~0x04; fix_section(b, MEANS)
    case("zstd_no_checksum_flag", "kCorruptData", "open", b, "means frame descriptor without the checksum flag")
    b = cz(); b[zo + 6] ^= 0x01; fix_section(b, MEANS)
    case("zstd_content_size", "kCorruptData", "open", b, "means frame content size != raw_size")
    b = cz(); b[zo] ^= 0xFF; fix_section(b, MEANS)
    case("zstd_bad_magic", "kCorruptData", "open", b, "means frame magic damaged")
    # The first block header follows the 4-byte magic, the descriptor and a 2-byte content size (384).
    b = cz(); b[zo + 7] |= 0x06; fix_section(b, MEANS)
    case("zstd_reserved_block", "kCorruptData", "validate", b, "first means block has the reserved type 3")
    b = cz(); b[zo + 10 + 12 * 2] ^= 0x01; fix_section(b, MEANS)
    case("zstd_content_checksum", "kChecksumMismatch", "validate", b,
         "one means byte changed inside a raw block; XXH64 updated, zstd content checksum not")
    b = cz(); b[zo + z_stored - 1] ^= 0x55; fix_section(b, MEANS)
    case("zstd_checksum_field", "kChecksumMismatch", "validate", b, "zstd content checksum field damaged")
    sections = scene_sections(small_sh0_zstd(), CODEC_ZSTD)
    sections[MEANS]["stored"] = zstd_frame(sections[MEANS]["raw"], window_log=28)
    case("zstd_window_too_large", "kCorruptData", "open", container(sections, 64),
         "means frame declares a 2^28-byte window (limit 2^27)")
    # §4.8 the DC residual
    sd = small_sh0_dc_residual()
    case("dc_residual_in_1_1", "kCorruptData", "open", container(scene_sections(sd, CODEC_NONE), 64, minor=1),
         "an sh_dc_residual section in a version 1.1 file")
    sections = scene_sections(sd, CODEC_NONE)
    sections[-1].update(components=1, count=192)
    case("dc_residual_components", "kCorruptData", "open", container(sections, 64, minor=2),
         "sh_dc_residual is i8 x 1 (192 elements), not i8 x 3")
    sections = scene_sections(sd, CODEC_NONE)
    sections[-1].update(count=63, raw=sections[-1]["raw"][:189], stored=sections[-1]["stored"][:189])
    case("dc_residual_count", "kCorruptData", "open", container(sections, 64, minor=2),
         "sh_dc_residual holds 63 elements for 64 Gaussians")
    return cases


def lod_bad_cases(scene):
    """(name, code, stage, bytes, why) of damaged copies of small_sh1_lod.rgs (SPEC §4.9). Each is rebuilt by
    container(), so the section and header checksums match and the named check is the one that fires."""
    cases = []
    golden = lod_file(scene)
    C, L = len(scene["lod"]["chunks"]), len(scene["lod"]["counts"])
    LOD, OPAC, SH = 8, 5, 6  # table indices: metadata, provenance, means, rotations, scales, opacities, sh,
    #                          sh_dc_residual, lod

    def case(name, code, stage, data, why):
        cases.append((name, code, stage, bytes(data), why))

    def record(level, chunk):
        return LOD_HEAD + LOD_CHUNK * C + LOD_RECORD * (level * C + chunk)

    def with_lod(raw):
        """The golden file's sections with the lod section's raw bytes replaced."""
        sections = scene_sections(scene, CODEC_NONE)
        sections[LOD].update(count=len(raw), raw=bytes(raw), stored=bytes(raw))
        return sections

    def patched(fmt, offset, *values):
        raw = bytearray(encode_lod(scene))
        struct.pack_into(fmt, raw, offset, *values)
        return lod_file(scene, with_lod(raw))

    # §5.3 #26 presence, flag and version gate
    case("lod_without_flag", "kCorruptData", "open", lod_file(scene, required_flags=0),
         "§5.3 #26: a lod section, required flag bit 1 clear")
    no_lod = scene_sections(scene, CODEC_NONE)[:LOD]
    case("lod_flag_without_section", "kCorruptData", "open", lod_file(scene, no_lod),
         "§5.3 #26: required flag bit 1 set, no lod section")
    case("lod_in_1_2", "kCorruptData", "open", lod_file(scene, minor=2),
         "§5.3 #26: a lod section and flag bit 1 in a file stamped 1.2 (kMinVersionForLod is 1.3)")
    sections = scene_sections(scene, CODEC_NONE)
    sections[OPAC].update(codec=CODEC_ZSTD, stored=zstd_frame(sections[OPAC]["raw"]))
    case("lod_zstd_section", "kCorruptData", "open", lod_file(scene, sections),
         "§5.3 #26: the opacities section is a (valid) zstd frame in a level-of-detail file")
    # §5.3 #24 the entry's layout
    sections = scene_sections(scene, CODEC_NONE)
    sections[LOD].update(type=T_I8)
    case("lod_element_type", "kCorruptData", "open", lod_file(scene, sections),
         "§5.3 #24: lod declared i8 x 1, not bytes x 1")
    # §5.3 #26 the index's size, reserved bytes and structure
    raw = encode_lod(scene) + bytes(8)
    case("lod_raw_size", "kCorruptData", "open", lod_file(scene, with_lod(raw)),
         "§5.3 #26: 8 zero bytes appended to the lod section: %d bytes, 16 + 16C + 24LC = %d"
         % (len(raw), len(raw) - 8))
    case("lod_head_reserved", "kCorruptData", "open", patched("<Q", 8, 1), "§5.3 #26: lod head reserved u64 = 1")
    case("lod_record_reserved", "kCorruptData", "open", patched("<I", record(1, 0) + 12, 1),
         "§5.3 #26: reserved u32 of the record of chunk 0 level 1 = 1")
    n = scene["count"]
    raw = struct.pack("<IIQ", n + 1, 1, 0) + bytes(LOD_CHUNK * (n + 1) + LOD_RECORD * (n + 1))
    case("lod_chunks_over_n", "kCorruptData", "open", lod_file(scene, with_lod(raw)),
         "§5.3 #26: C = %d > N = %d (L = 1, raw size %d to match)" % (n + 1, n, len(raw)))
    raw = struct.pack("<IIQ", C, 17, 0) + bytes(LOD_CHUNK * C + LOD_RECORD * 17 * C)
    case("lod_levels_17", "kCorruptData", "open", lod_file(scene, with_lod(raw)),
         "§5.3 #26: L = 17 > kMaxLodLevels (C = %d, raw size %d to match)" % (C, len(raw)))
    case("lod_nan_radius", "kCorruptData", "open", patched("<f", LOD_HEAD + LOD_CHUNK + 12, float("nan")),
         "§5.3 #26: chunk 1 radius NaN")
    case("lod_count_zero", "kCorruptData", "open", patched("<Q", record(2, 1), 0), "§5.3 #26: chunk 1 level 2 count 0")
    case("lod_tiling_short", "kCorruptData", "open", patched("<Q", record(2, 0), 1),
         "§5.3 #26: chunk 0 level 2 count 2 -> 1: the ranges cover %d of the %d Gaussians" % (n - 1, n))
    case("lod_tiling_over", "kCorruptData", "open", patched("<Q", record(2, 1), 2),
         "§5.3 #26: chunk 1 level 2 count 1 -> 2: the last range runs past N = %d" % n)
    raw = bytearray(encode_lod(scene))
    struct.pack_into("<Q", raw, record(0, 0), 3)
    struct.pack_into("<Q", raw, record(1, 0), 9)
    case("lod_count_increasing", "kCorruptData", "open", lod_file(scene, with_lod(raw)),
         "§5.3 #26: chunk 0 counts 3, 9, 2 (level 1 holds more than level 0; the total is still N)")
    case("lod_level0_error", "kCorruptData", "open", patched("<f", record(0, 1) + 8, 0.125),
         "§5.3 #26: chunk 1 level 0 error 0.125, not 0")
    case("lod_error_decreasing", "kCorruptData", "open", patched("<f", record(2, 0) + 8, 0.0625),
         "§5.3 #26: chunk 0 errors 0, 0.125, 0.0625")
    # §5.4 the ranges, checked by validate() (and lod_range) only
    raw = bytearray(encode_lod(scene))
    checksum = struct.unpack_from("<Q", raw, record(1, 1) + 16)[0]
    case("lod_range_checksum", "kChecksumMismatch", "validate", patched("<Q", record(1, 1) + 16, checksum ^ 1),
         "§5.4: chunk 1 level 1 range checksum with bit 0 flipped (lod section checksum updated)")
    k3 = 3 * (scene["metadata"]["sh_degree"] + 1) ** 2
    b = bytearray(golden)
    at = section_offset(golden, SH) + 21 * k3 + 4  # Gaussian 21: chunk 0 level 2
    b[at] ^= 0x02
    assert b[at] != 0x80
    fix_section(b, SH)
    case("lod_range_data", "kChecksumMismatch", "validate", b,
         "§5.4: an sh byte of Gaussian 21 (chunk 0 level 2) changed; the sh section's checksum updated, "
         "the range's not")
    moved = dict(scene)
    moved["means"] = list(scene["means"])
    moved["means"][3 * 15:3 * 16] = [1.0, 0.0, 2.0]  # Gaussian 15 (chunk 0 level 1) at chunk 1's centre
    case("lod_outside_chunk", "kCorruptData", "validate", lod_file(moved),
         "§5.4: Gaussian 15 (chunk 0 level 1) moved to (1, 0, 2), inside the bounds but 2 from its chunk's centre "
         "(range checksum recomputed)")
    return cases


def forward_compat(scene):
    """A file a future 1.7 writer could produce: an optional flag, unknown sections before and after the
    known ones, one with an unknown codec and element type. A 1.0 reader must open and validate it."""
    sections = scene_sections(scene, CODEC_NONE)
    future = b"per-Gaussian future data " * 3
    sections.insert(2, {"id": 0x8001, "codec": CODEC_NONE, "type": T_BYTES, "components": 1, "count": len(future),
                        "raw": future, "stored": future})
    sections.append({"id": 0x8002, "codec": CODEC_ZSTD, "type": T_I8, "components": 2, "count": 8,
                     "raw": bytes(range(16)), "stored": zstd_frame(bytes(range(16)))})
    opaque = bytes([0xA5]) * 20
    sections.append({"id": 0x8003, "codec": 9, "type": 0x77, "components": 5, "count": 3, "raw": b"",
                     "raw_size": 1000, "stored": opaque})
    return container(sections, scene["count"], minor=7, optional_flags=0x1)


def build():
    s3 = small_sh3()
    sz = small_sh0_zstd()
    g3 = container(scene_sections(s3, CODEC_NONE), s3["count"])
    gz = container(scene_sections(sz, CODEC_ZSTD), sz["count"])
    sl = small_sh1_lod()
    files = {
        os.path.join(GOLDEN_DIR, "small_sh3.rgs"): g3,
        os.path.join(GOLDEN_DIR, "small_sh0_zstd.rgs"): gz,
        os.path.join(GOLDEN_DIR, "forward_compat.rgs"): forward_compat(s3),
        os.path.join(GOLDEN_DIR_1_2, "small_sh0_dc_residual.rgs"):
            container(scene_sections(small_sh0_dc_residual(), CODEC_NONE), sz["count"], minor=2),
        os.path.join(GOLDEN_DIR_1_3, "small_sh1_lod.rgs"): lod_file(sl),
    }
    readme = ["# Must-fail .rgs corpus (tests/data/bad/*.rgs)", "",
              "Generated by `tests/data/make_rgs_corpus.py` from the golden files in `tests/data/v1.0/` (`lod_*`:",
              "from `tests/data/v1.3/small_sh1_lod.rgs`); do not edit by hand. `test_format_bad_corpus.cpp` has one",
              "TEST_CASE per file asserting the code below. Stage `open`: RgsFile::open fails (and so does validate);",
              "`validate`: the file opens and only validate() finds the problem. The `lod_*` defects name the check of",
              "format/SPEC.md §5 that fires (#24, #26: §5.3; §5.4: validate's range checks).", "",
              "| file | expected | stage | defect |", "|---|---|---|---|"]
    for name, code, stage, data, why in bad_cases(g3, gz) + lod_bad_cases(sl):
        files[os.path.join(BAD_DIR, name + ".rgs")] = data
        readme.append("| %s.rgs | %s | %s | %s |" % (name, code, stage, why))
    files[os.path.normpath(MANIFEST)] = ("\n".join(readme) + "\n").encode("utf-8")
    return files


def main():
    check = "--check" in sys.argv[1:]
    files = build()
    stale = []
    for path, data in sorted(files.items()):
        on_disk = open(path, "rb").read() if os.path.exists(path) else None
        if on_disk == data:
            continue
        stale.append(path)
        if not check:
            os.makedirs(os.path.dirname(path), exist_ok=True)
            with open(path, "wb") as f:
                f.write(data)
    known = {os.path.basename(p) for p in files if os.path.dirname(p) == BAD_DIR}
    # bad/ also holds other libraries' corpora (*.ply); only .rgs files are this script's.
    extra = sorted(n for n in os.listdir(BAD_DIR)
                   if n.endswith(".rgs") and n not in known) if os.path.isdir(BAD_DIR) else []
    if check:
        for path in stale:
            print("stale: %s" % os.path.relpath(path, HERE))
        for name in extra:
            print("not generated: bad/%s" % name)
        return 1 if stale or extra else 0
    for path in stale:
        print("wrote %s (%d bytes)" % (os.path.relpath(path, HERE), len(files[path])))
    for name in extra:
        print("warning: bad/%s is not produced by this script" % name)
    return 0


if __name__ == "__main__":
    sys.exit(main())
