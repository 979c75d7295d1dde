#!/usr/bin/env python3
"""Generates the fuzz seed corpora tests/fuzz/corpus/<target>/ from real data: the first Gaussians of
samples/guitar.ply (the only scene the project may ship, $RGS_DATA_DIR/SOURCES.md).

  rgs_read/    small .rgs files: guitar crops quantized as the converter does (SPEC §4), codec none and zstd,
               linear and log scales, SH degree 0, 1 and 3, and an empty scene. guitar has SH degree 0; the
               higher-degree crops take their f_rest values from the f_dc values of the following Gaussians.
               Scenes that leave the archive's quantizers nothing to span: a flat axis (scale_2 of one log-scale
               in every Gaussian, as 2D-Gaussian and surfel exports write it: -inf, -30, -20; -3.3), one
               Gaussian, and one Gaussian repeated.
  ply_read/    small PLY crops: INRIA layout binary little- and big-endian, ascii, another property order with
               double means, SH degree 3 (f_rest as above), and a face element after the vertices; flat, one-
               Gaussian and repeated-Gaussian crops as for rgs_read.
  ksplat_read/ small GaussianSplats3D .ksplat files (SplatBuffer 0.1, laid out as converter/include/rgs/converter/
               ksplat_reader.h describes): 16 Gaussians at level 0 (float32), 24 at level 1 (float16, positions as
               16-bit bucket offsets) with SH degree 1 in two sections of full and partially filled buckets of 8,
               12 at level 2 (8-bit SH) with SH degree 3; f_rest as for rgs_read.
  render_cpu/  inputs of fuzz_render_cpu.cpp: a camera looking at a guitar crop, with the RoofGS switches off,
               all on, and with SH degree 1.
  sog_meta/    the meta.json files of tests/data/sog's guitar crop (v2 with SH 0 and 3, the unversioned layout),
               compacted, for fuzz_sog_meta.cpp, which reads them next to guitar_crop_sh3's images.
  sog_folder/  inputs of fuzz_sog_folder.cpp: a change to one image of the folder (none, removed, a symbolic link
               out of the folder, a FIFO, a folder, moved into sub/) and those meta.json files; one names
               ../means_l.webp, one names means_l.webp under three spellings.
  gltf_json/   inputs of fuzz_gltf_json.cpp: the guitar_256 GLB of tests/data/interop as a .gltf over its buffer
               (tests/data/hostile/gltf/), with two transformed nodes, self-contained (16 Gaussians in a data:
               URI), with buffer uris leaving the folder (../scene.bin, %2e%2e%2fcanary.bin), a node cycle and
               JSON nested 100 deep.
  zip/         inputs of fuzz_zip.cpp: guitar_crop_sh3 as a bundled .sog (stored), guitar_crop deflated with
               an archive comment, and guitar_crop with a meta.json that inflates past the ratio limit.
  camera_json/ inputs of fuzz_camera_json.cpp: loader options and an INRIA cameras.json of a ring of cameras
               around the guitar crop (guitar has no cameras of its own).

The .rgs container is written by tests/data/make_rgs_corpus.py (the independent SPEC implementation that
writes the golden files); glTF documents, compacted SOG metas and ZIP archives by
tests/data/hostile/make_hostile_corpus.py. Output is deterministic: rerunning gives identical bytes;
--check reports stale files without writing.

    python3 tests/fuzz/make_fuzz_corpus.py [--check]      # python3 stdlib only
"""
import base64
import json
import math
import os
import struct
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
SAMPLE = os.path.join(ROOT, "samples", "guitar.ply")
OUT = os.path.join(HERE, "corpus")
sys.path.insert(0, os.path.join(ROOT, "tests", "data"))
import make_rgs_corpus as rgs  # noqa: E402  (container, xxh64, zstd_frame)
sys.path.insert(0, os.path.join(ROOT, "tests", "data", "hostile"))
import make_hostile_corpus as hostile  # noqa: E402  (glTF documents, compact SOG metas, ZIP archives)

INRIA = ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2", "opacity",
         "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]


def read_guitar(n):
    """The first n vertices of the sample as dicts of property name -> float."""
    with open(SAMPLE, "rb") as f:
        data = f.read(1 << 16)
    end = data.index(b"end_header\n") + len(b"end_header\n")
    names = [line.split()[2] for line in data[:end].decode("ascii").splitlines() if line.startswith("property")]
    assert names == INRIA, names
    stride = 4 * len(names)
    return [dict(zip(names, struct.unpack_from("<%df" % len(names), data, end + i * stride))) for i in range(n)]


def with_sh(rows, degree):
    """Adds f_rest_* for `degree`: coefficient k of channel c of Gaussian i is f_dc_c of Gaussian i + k."""
    k = (degree + 1) ** 2
    out = []
    for i, r in enumerate(rows):
        r = dict(r)
        for c in range(3):
            for j in range(1, k):
                r["f_rest_%d" % (c * (k - 1) + j - 1)] = 0.25 * rows[(i + j) % len(rows)]["f_dc_%d" % c]
        out.append(r)
    return out


def f32(v):
    return struct.unpack("<f", struct.pack("<f", v))[0]


def half_bits(v):
    return struct.unpack("<H", struct.pack("<e", v))[0]


def round_half_away(x):
    return int(math.floor(abs(x) + 0.5)) * (1 if x >= 0 else -1)


def quantize(rows, degree, log_scales):
    """The runtime profile (SPEC §4) of float rows, as make_rgs_corpus.scene_sections expects it."""
    k = (degree + 1) ** 2
    n = len(rows)
    scene = {"count": n, "means": [], "rotations": [], "scales": [], "opacities": [], "sh": []}
    coeffs = []  # [i][k][c]
    for r in rows:
        scene["means"] += [r["x"], r["y"], r["z"]]
        q = [r["rot_%d" % j] for j in range(4)]
        norm = math.sqrt(sum(v * v for v in q))
        scene["rotations"] += [half_bits(v / norm) for v in q]
        for a in range(3):
            s = r["scale_%d" % a]
            scene["scales"].append(half_bits(s if log_scales else math.exp(s)))
        scene["opacities"].append(half_bits(1.0 / (1.0 + math.exp(-r["opacity"]))))
        c = [[r["f_dc_%d" % ch] for ch in range(3)]]
        for j in range(1, k):
            c.append([r["f_rest_%d" % (ch * (k - 1) + j - 1)] for ch in range(3)])
        coeffs.append(c)
    sh_scales = [[0.0] * 3 for _ in range(4)]
    for j in range(k):
        d = 0 if j == 0 else 1 if j < 4 else 2 if j < 9 else 3
        for ch in range(3):
            sh_scales[d][ch] = max(sh_scales[d][ch], max((abs(c[j][ch]) for c in coeffs), default=0.0))
    sh_scales = [[f32(v / 127.0) for v in row] for row in sh_scales]
    for c in coeffs:
        for j in range(k):
            d = 0 if j == 0 else 1 if j < 4 else 2 if j < 9 else 3
            for ch in range(3):
                s = sh_scales[d][ch]
                scene["sh"].append(max(-127, min(127, round_half_away(c[j][ch] / s))) if s > 0 else 0)
    means = [scene["means"][i * 3:i * 3 + 3] for i in range(n)]
    lo = [min((m[a] for m in means), default=0.0) for a in range(3)]
    hi = [max((m[a] for m in means), default=0.0) for a in range(3)]
    centre = [f32((lo[a] + hi[a]) / 2) for a in range(3)]
    radius = max((math.sqrt(sum((m[a] - centre[a]) ** 2 for a in range(3))) for m in means), default=0.0)
    radius32 = f32(radius)
    if radius32 < radius:  # round up, as the converter does
        radius32 = struct.unpack("<f", struct.pack("<I", struct.unpack("<I", struct.pack("<f", radius32))[0] + 1))[0]
    scene["metadata"] = {"sh_degree": degree, "scale_encoding": 2 if log_scales else 1,
                         "aabb_min": lo, "aabb_max": hi, "sphere_center": centre, "sphere_radius": radius32,
                         "sh_scales": sh_scales}
    scene["provenance"] = [("source", "samples/guitar.ply, first %d Gaussians" % n),
                           ("generator", "tests/fuzz/make_fuzz_corpus.py")]
    return scene


def rgs_file(rows, degree, log_scales, codec):
    scene = quantize(rows, degree, log_scales)
    return rgs.container(rgs.scene_sections(scene, codec), scene["count"])


def ply_file(rows, names, fmt="binary_little_endian", types=None, tail=b"", extra_header=""):
    types = types or {}
    header = ["ply", "format %s 1.0" % fmt, "comment guitar crop (tests/fuzz/make_fuzz_corpus.py)",
              "element vertex %d" % len(rows)]
    header += ["property %s %s" % (types.get(n, "float"), n) for n in names]
    if extra_header:
        header.append(extra_header)
    header.append("end_header")
    out = ("\n".join(header) + "\n").encode("ascii")
    codes = {"float": "f", "double": "d", "uchar": "B"}
    if fmt == "ascii":
        for r in rows:
            out += (" ".join(repr(r[n]) for n in names) + "\n").encode("ascii")
    else:
        order = "<" if fmt == "binary_little_endian" else ">"
        for r in rows:
            out += b"".join(struct.pack(order + codes[types.get(n, "float")], r[n]) for n in names)
    return out + tail


def render_input(rows, switches, degree):
    """Bytes in the order fuzz_render_cpu.cpp reads them: camera 48 x 32 looking down +z at the crop."""
    scene = quantize(with_sh(rows, degree) if degree else rows, degree, log_scales=False)
    centre = scene["metadata"]["sphere_center"]
    dist = 3.0 * max(scene["metadata"]["sphere_radius"], 0.1)
    out = struct.pack("<B", switches | (degree << 6))
    out += struct.pack("<BB", 47, 31)                       # width 48, height 32
    out += struct.pack("<4h", 32767, 0, 0, 0)               # identity rotation
    out += struct.pack("<3f", -centre[0], -centre[1], dist - centre[2])
    out += struct.pack("<BBB", 16, 64, 0)                   # fx, fy about 1.05 widths and heights, near 0.2
    out += struct.pack("<B", 0)                             # linear scales
    for d in range(degree + 1):
        out += struct.pack("<3f", *scene["metadata"]["sh_scales"][d])
    k3 = 3 * (degree + 1) ** 2
    for i in range(scene["count"]):
        out += struct.pack("<3f", *scene["means"][i * 3:i * 3 + 3])
        out += struct.pack("<4H", *scene["rotations"][i * 4:i * 4 + 4])
        out += struct.pack("<3H", *scene["scales"][i * 3:i * 3 + 3])
        opacity = struct.unpack("<e", struct.pack("<H", scene["opacities"][i]))[0]
        out += struct.pack("<H", int(round(opacity * 65535)))
        out += struct.pack("<%db" % k3, *scene["sh"][i * k3:(i + 1) * k3])
    return out


def cameras_input(downscale, width, height, every_kth, count):
    """Bytes in the order fuzz_camera_json.cpp reads them: loader options, then an INRIA cameras.json of
    `count` cameras on a ring around the guitar crop (camera-to-world rotation rows, position, fx, fy)."""
    scene = quantize(read_guitar(64), 0, log_scales=False)
    c = scene["metadata"]["sphere_center"]
    r = 3.0 * scene["metadata"]["sphere_radius"]
    cams = []
    for i in range(count):
        a = 2 * math.pi * i / count
        forward = [-math.sin(a), 0.0, math.cos(a)]   # looks at the centre from -forward * r
        right = [math.cos(a), 0.0, math.sin(a)]
        down = [0.0, 1.0, 0.0]
        rows = [[right[j], down[j], forward[j]] for j in range(3)]  # columns are the camera axes
        pos = [c[j] - r * forward[j] for j in range(3)]
        cams.append('{"id": %d, "img_name": "guitar_%03d", "width": 640, "height": 480, "position": [%s], '
                    '"rotation": [%s], "fy": 500.0, "fx": 500.0}'
                    % (i, i, ", ".join(repr(v) for v in pos),
                       ", ".join("[" + ", ".join(repr(v) for v in row) + "]" for row in rows)))
    text = "[" + ",\n ".join(cams) + "]\n"
    return struct.pack("<dHHB", downscale, width, height, every_kth) + text.encode("ascii")


def ksplat_file(rows, level, degree, section_size, bucket_size):
    """A .ksplat of `rows` in sections of `section_size`, each cut into buckets of `bucket_size` in row order (the
    last partially filled), each bucket's centre the middle of its means' box and its block twice the largest
    offset; as GaussianSplats3D's SplatBuffer writes one, with its encodings (floor for 8-bit values)."""
    k = (degree + 1) ** 2
    rest = [] if degree == 0 else [(band, c, m) for band in range(1, degree + 1) for c in range(3)
                                   for m in range(2 * band + 1)]
    values = [r["f_rest_%d" % (c * (k - 1) + band * band + m - 1)] for r in rows for band, c, m in rest]
    lo, hi = (min(values), max(values)) if values else (-1.5, 1.5)
    half = lambda v: struct.pack("<H", half_bits(v))
    sections = [rows[i:i + section_size] for i in range(0, len(rows), section_size)]
    headers, bodies = b"", b""
    for sec in sections:
        buckets = [sec[i:i + bucket_size] for i in range(0, len(sec), bucket_size)] if level else [sec]
        full = [b for b in buckets if len(b) == bucket_size] if level else []
        partial = [b for b in buckets if len(b) != bucket_size] if level else []
        centres, records = b"", b""
        block = 0.0
        for b in full + partial:
            centre = [(min(r[a] for r in b) + max(r[a] for r in b)) / 2 for a in "xyz"]
            block = max([block] + [2.0001 * abs(r[a] - centre[i]) for r in b for i, a in enumerate("xyz")])
            centres += struct.pack("<3f", *centre)
        block = f32(block or 1.0)
        for bi, b in enumerate(full + partial if level else buckets):
            centre = struct.unpack_from("<3f", centres, 12 * bi) if level else None
            for r in b:
                q = [r["rot_%d" % i] for i in range(4)]
                n = math.sqrt(sum(v * v for v in q))
                scales = [math.exp(r["scale_%d" % i]) for i in range(3)]
                if level == 0:
                    rec = struct.pack("<3f3f4f", r["x"], r["y"], r["z"], *scales, *[v / n for v in q])
                else:
                    rec = b"".join(struct.pack("<H", min(65535, max(0, round((r[a] - centre[i]) * 32767 / (block / 2))
                                                                   + 32767))) for i, a in enumerate("xyz"))
                    rec += b"".join(half(v) for v in scales) + b"".join(half(v / n) for v in q)
                rec += bytes(min(255, max(0, math.floor((0.5 + 0.28209479177387814 * r["f_dc_%d" % c]) * 255)))
                             for c in range(3))
                rec += bytes([min(255, math.floor(255 / (1 + math.exp(-r["opacity"]))))])
                for band, c, m in rest:
                    v = r["f_rest_%d" % (c * (k - 1) + band * band + m - 1)]
                    rec += (struct.pack("<f", v) if level == 0 else half(v) if level == 1 else
                            bytes([min(255, max(0, math.floor((v - lo) / (hi - lo) * 255)))]))
                records += rec
        body = b"".join(struct.pack("<I", len(b)) for b in partial) + (centres if level else b"") + records
        h = struct.pack("<4IfH2x4I", len(sec), len(sec), bucket_size if level else 0, len(full + partial) if level
                        else 0, block if level else 0.0, 12 if level else 0, 32767 if level else 0, len(body),
                        len(full), len(partial)) + struct.pack("<H", degree)
        headers += h + bytes(1024 - len(h))
        bodies += body
    head = struct.pack("<BBxxIIIIH2x3fff", 0, 1, len(sections), len(sections), len(rows), len(rows), level,
                       0.0, 0.0, 0.0, lo, hi)
    return head + bytes(4096 - len(head)) + headers + bodies


def flat(rows, log_scale):
    """`rows` with scale_2 = log_scale in every Gaussian (a flat axis)."""
    return [dict(r, scale_2=log_scale) for r in rows]


def build():
    g64 = read_guitar(64)
    files = {}

    def add(target, name, data, limit=8192):
        assert len(data) <= limit, (name, len(data))
        files[os.path.join(OUT, target, name)] = data

    add("rgs_read", "guitar64_sh0_linear.rgs", rgs_file(g64, 0, False, rgs.CODEC_NONE))
    add("rgs_read", "guitar64_sh0_log_zstd.rgs", rgs_file(g64, 0, True, rgs.CODEC_ZSTD))
    add("rgs_read", "guitar24_sh1_log.rgs", rgs_file(with_sh(g64[:24], 1), 1, True, rgs.CODEC_NONE))
    add("rgs_read", "guitar12_sh3_linear_zstd.rgs", rgs_file(with_sh(g64[:12], 3), 3, False, rgs.CODEC_ZSTD))
    add("rgs_read", "guitar0_empty.rgs", rgs_file([], 0, False, rgs.CODEC_NONE))
    add("rgs_read", "guitar16_flat_inf_linear.rgs", rgs_file(flat(g64[:16], -math.inf), 0, False, rgs.CODEC_NONE))
    add("rgs_read", "guitar16_flat_30_log.rgs", rgs_file(flat(g64[:16], -30.0), 0, True, rgs.CODEC_NONE))
    add("rgs_read", "guitar16_flat_3p3_linear.rgs", rgs_file(flat(g64[:16], -3.3), 0, False, rgs.CODEC_NONE))
    add("rgs_read", "guitar1_sh1_log.rgs", rgs_file(with_sh(g64[:1], 1), 1, True, rgs.CODEC_NONE))
    add("rgs_read", "guitar16_repeated_linear.rgs", rgs_file(g64[:1] * 16, 0, False, rgs.CODEC_NONE))

    sh3 = INRIA[:9] + ["f_rest_%d" % i for i in range(45)] + INRIA[9:]
    splat_transform_order = ["x", "y", "z", "rot_0", "rot_1", "rot_2", "rot_3", "scale_0", "scale_1", "scale_2",
                             "opacity", "f_dc_0", "f_dc_1", "f_dc_2"]
    add("ply_read", "guitar32_le.ply", ply_file(g64[:32], INRIA))
    add("ply_read", "guitar16_be.ply", ply_file(g64[:16], INRIA, fmt="binary_big_endian"))
    add("ply_read", "guitar8_ascii.ply", ply_file(g64[:8], INRIA, fmt="ascii"))
    add("ply_read", "guitar16_reordered_double.ply",
        ply_file(g64[:16], splat_transform_order, types={"x": "double", "y": "double", "z": "double"}))
    add("ply_read", "guitar6_sh3.ply", ply_file(with_sh(g64[:6], 3), sh3))
    add("ply_read", "guitar16_flat_inf.ply", ply_file(flat(g64[:16], -math.inf), INRIA))
    add("ply_read", "guitar16_flat_20.ply", ply_file(flat(g64[:16], -20.0), INRIA))
    add("ply_read", "guitar16_flat_3p3.ply", ply_file(flat(g64[:16], -3.3), INRIA))
    add("ply_read", "guitar1.ply", ply_file(g64[:1], INRIA))
    add("ply_read", "guitar16_repeated.ply", ply_file(g64[:1] * 16, INRIA))
    face = b"".join(struct.pack("<Biii", 3, i, i + 1, i + 2) for i in range(2))
    add("ply_read", "guitar8_le_face.ply",
        ply_file(g64[:8], INRIA, tail=face, extra_header="element face 2\nproperty list uchar int vertex_indices"))

    add("sog_meta", "guitar_crop_v2.json", sog_meta("guitar_crop/meta.json"))
    add("sog_meta", "guitar_crop_sh3_v2.json", sog_meta("guitar_crop_sh3/meta.json"))
    add("sog_meta", "guitar_crop_v1.json", sog_meta("guitar_crop_v1_meta.json"))

    # fuzz_sog_folder: [change][image slot] + meta.json (the slots of fuzz_sog_folder.cpp's kImages).
    sh0 = sog_meta("guitar_crop/meta.json")
    add("sog_folder", "keep_sh3.bin", bytes([0, 0]) + sog_meta("guitar_crop_sh3/meta.json"))
    add("sog_folder", "removed_quats.bin", bytes([1, 2]) + sh0)
    add("sog_folder", "symlink_means_l.bin", bytes([2, 0]) + sh0)
    add("sog_folder", "fifo_means_u.bin", bytes([3, 1]) + sh0)
    add("sog_folder", "folder_scales.bin", bytes([4, 3]) + sh0)
    add("sog_folder", "moved_sh0.bin", bytes([5, 4]) + sh0.replace(b'"sh0.webp"', b'"sub/sh0.webp"'))
    add("sog_folder", "escape_dotdot.bin", bytes([0, 0]) + sh0.replace(b'"means_l.webp"', b'"../means_l.webp"'))
    # One file under several names (spellings of one path): its bytes count once towards the ratio limit.
    add("sog_folder", "one_image_many_names.bin", bytes([0, 0]) + sh0.replace(b'"means_u.webp"', b'"./means_l.webp"')
        .replace(b'"scales.webp"', b'".//means_l.webp"'))

    base, bin_bytes = hostile.split_glb()
    add("gltf_json", "guitar256.gltf", hostile.dumps(hostile.gltf_scene(base, bin_bytes)))
    doc = hostile.gltf_scene(base, bin_bytes)
    doc["nodes"] = [{"mesh": 0, "translation": [1.0, 0.0, -2.0]},
                    {"children": [2], "scale": [2.0, 2.0, 2.0], "rotation": [0.0, 0.0, 0.0, 1.0]},
                    {"mesh": 0, "translation": [0.0, 0.5, 0.0]}]
    doc["scenes"] = [{"nodes": [0, 1]}]
    add("gltf_json", "guitar256_two_nodes.gltf", hostile.dumps(doc))
    add("gltf_json", "guitar16_data_uri.gltf", hostile.dumps(gltf_data_uri(base, bin_bytes, 16)))
    for name, uri in (("escape_dotdot", "../scene.bin"), ("escape_pct", "%2e%2e%2fcanary.bin")):
        add("gltf_json", "guitar256_%s.gltf" % name, hostile.dumps(hostile.gltf_scene(base, bin_bytes, uri)))
    doc = hostile.gltf_scene(base, bin_bytes)
    doc["nodes"] = [{"children": [1]}, {"children": [0], "mesh": 0}]
    add("gltf_json", "guitar256_node_cycle.gltf", hostile.dumps(doc))
    add("gltf_json", "guitar256_deep_extras_100.gltf",
        hostile.with_raw(hostile.gltf_scene(base, bin_bytes), ["asset", "extras"], hostile.nested(100)))

    sog = os.path.join(ROOT, "tests", "data", "sog")
    sh3_dir = os.path.join(sog, "guitar_crop_sh3")
    sh3_images = sorted(n for n in os.listdir(sh3_dir) if n.endswith(".webp"))
    add("zip", "guitar_crop_sh3_stored.sog", hostile.zip_archive(
        [("meta.json", sog_meta("guitar_crop_sh3/meta.json"), 0, None)] +
        [(n, hostile.read(os.path.join(sh3_dir, n)), 0, None) for n in sh3_images]), limit=32768)
    add("zip", "guitar_crop_deflate_comment.sog", hostile.zip_archive(
        [("meta.json", sh0, 8, None)] +
        [(n, hostile.read(os.path.join(sog, "guitar_crop", n)), 8, None) for n in hostile.SOG_IMAGES],
        comment=b"tests/fuzz/make_fuzz_corpus.py"), limit=32768)
    # meta.json padded with 9 MiB of spaces, deflated: an entry past the ratio limit of the archive.
    add("zip", "meta_inflating_9mib.sog", hostile.zip_archive(
        [("meta.json", sh0 + b" " * (9 << 20), 8, None)] +
        [(n, hostile.read(os.path.join(sog, "guitar_crop", n)), 0, None) for n in hostile.SOG_IMAGES]), limit=65536)

    add("ksplat_read", "guitar16_l0_sh0.ksplat", ksplat_file(g64[:16], 0, 0, 16, 256))
    add("ksplat_read", "guitar24_l1_sh1_2sections.ksplat", ksplat_file(with_sh(g64[:24], 1), 1, 1, 12, 8))
    add("ksplat_read", "guitar12_l2_sh3.ksplat", ksplat_file(with_sh(g64[:12], 3), 2, 3, 12, 256))

    add("render_cpu", "guitar32_baseline.bin", render_input(g64[:32], 0x00, 0))
    add("render_cpu", "guitar32_roofgs_all.bin", render_input(g64[:32], 0x1f, 0))
    add("render_cpu", "guitar16_sh1_key32.bin", render_input(g64[:16], 0x01, 1))
    add("camera_json", "guitar_ring3.bin", cameras_input(1.0, 0, 0, 0, 3))
    add("camera_json", "guitar_ring4_downscale8_every2.bin", cameras_input(8.0, 0, 0, 1, 4))
    add("camera_json", "guitar_ring2_width64.bin", cameras_input(1.0, 64, 0, 0, 2))
    return files


def sog_meta(name):
    """A meta.json of tests/data/sog (splat-transform's, for the guitar crop) in compact JSON with its numbers
    at 5 significant digits, so that it fits the seed size limit; the images it names stay valid for it."""
    return hostile.dumps(hostile.compact_sog_meta(os.path.join(ROOT, "tests", "data", "sog", name)))


def gltf_data_uri(base, bin_bytes, n):
    """The GLB's document, self-contained: its first n Gaussians in one data: URI buffer."""
    doc = json.loads(json.dumps(base))
    data = b""
    for view in doc["bufferViews"]:
        elem = view["byteLength"] // 256
        chunk = bin_bytes[view["byteOffset"]:view["byteOffset"] + elem * n]
        view["byteOffset"] = len(data)
        view["byteLength"] = len(chunk)
        data += chunk
    for accessor in doc["accessors"]:
        accessor["count"] = n
        accessor.pop("min", None)
        accessor.pop("max", None)
    doc["asset"]["generator"] = "tests/fuzz/make_fuzz_corpus.py from splat-transform 3.7.0's GLB"
    doc["buffers"] = [{"byteLength": len(data),
                       "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode("ascii")}]
    return doc


def main():
    check = "--check" in sys.argv[1:]
    files = build()
    stale = []
    for path, data in sorted(files.items()):
        if os.path.exists(path) and open(path, "rb").read() == data:
            continue
        stale.append(path)
        if not check:
            os.makedirs(os.path.dirname(path), exist_ok=True)
            with open(path, "wb") as f:
                f.write(data)
    for path in stale:
        print("%s %s (%d bytes)" % ("stale:" if check else "wrote", os.path.relpath(path, ROOT), len(files[path])))
    return 1 if check and stale else 0


if __name__ == "__main__":
    sys.exit(main())
