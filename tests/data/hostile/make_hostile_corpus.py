#!/usr/bin/env python3
"""Generates the hostile-scene corpus tests/data/hostile/ from the shipped real fixtures: scenes that name files
outside themselves, declare sizes their bytes cannot hold, expand far beyond their size, nest JSON deeply, or
loop their glTF node graph. tests/converter/test_hostile_scenes.cpp states what read_scene must do with each;
what git cannot hold (symbolic links, FIFOs, 70,000-deep JSON) that test builds at run time.

Sources: tests/data/sog/guitar_crop/ (877 Gaussians, splat-transform's SOG) and
tests/data/interop/guitar_256_splat_transform.glb (256 Gaussians). Only the standard library is used: the WebP
images of the expanding scenes are written here as lossless (VP8L) bitstreams whose five prefix codes each hold
one symbol, so every pixel costs zero bits; the zstd frames are RLE blocks (RFC 8878 3.1.1.2); the ZIP archives
are written field by field (PKWARE APPNOTE 4.3).

  gltf/        scene.gltf + scene.bin: the guitar_256 GLB split into JSON and buffer (valid, the base of the rest)
               bytelength_3gib.gltf       buffer byteLength 3 GiB, uri scene.bin (15,360 bytes)
               data_uri_bytelength_3gib.gltf  the same with the buffer in a data: URI
               no_bufferview_40m.gltf     accessors of 40M elements without bufferView (zeros that no byte holds)
               deep_extras_32.gltf        asset.extras nested 32 arrays deep (valid: must read)
               deep_extras_100.gltf       ... 100 deep
               deep_extensions_required_100.gltf, deep_accessor_type_100.gltf  nesting where messages quote JSON
               long_extension_name.gltf, long_accessor_type.gltf, long_version.gltf  10,000-character strings
               that the error names
               node_cycle.gltf (0 -> 1 -> 0), node_self_cycle.gltf (0 -> 0), node_dag_40.gltf (node i has children
               [i+1, i+1] for i < 40: 2^40 paths to node 40)
  gltf_escape/ one .gltf per spelling of a buffer uri that leaves the folder (the target of the relative ones is
               ../gltf/scene.bin, which exists): dotdot, nested_dotdot, pct_dotdot_lower (%2e%2e%2f),
               pct_dotdot_upper (%2E%2E%2F), pct_dots_only (%2e%2e/), absolute (/etc/passwd), pct_absolute
               (%2Fetc%2Fpasswd), file_scheme, http_scheme, long_dotdot ('../' + 5,000 characters)
  glb/         instanced_40m.glb   valid: one mesh of 88 primitives over the 256 Gaussians, drawn by 1,776 nodes
                                   (40,009,728 Gaussians in 75 KB)
               bytelength_3gib.glb buffer 0 declares 3 GiB, the BIN chunk holds 15,360 bytes
               deep_100.glb        JSON chunk nested 100 deep
  sog/         the crop's five WebP images, meta.json (valid; numbers at 5 significant digits) and variants read
               as <name>.json next to the images: escape_* (an image name leaving the folder, spelled as above),
               count_40m.json (count 40M over 877-pixel images), deep_32.json (valid), deep_100.json,
               long_name.json (a missing image named by 5,000 characters); and streamed-SOG lod-meta files over
               meta.json: lod.json (valid), lod_escape_*, lod_count_40m.json (40M Gaussians of
               count_40m.json), lod_deep_100.json, lod_long_name.json
  sog_no_images/count_40m.json   count 40M and no image files
  sog_solid_33m/ valid: 5,792 x 5,792 single-colour images, count 33,547,264 (about 5 KB)
  sog_bundle/  bundled .sog files: entry_deflate_1gib.sog (means_l.webp's deflated entry declares 1 GiB - 1
               bytes), entry_stored_1gib.sog (its stored entry declares 1 GiB - 1), solid_33m.sog (sog_solid_33m
               zipped), escape_dotdot.sog (meta.json names ../means_l.webp), deep_100.sog
  ksplat/      made from tests/data/ksplat/guitar_256_l1.ksplat (one section, one full bucket of 256 Gaussians,
               11 KB; its 4,096-byte header and section header alone, 5 KB, for the counts) and, for a partially
               filled bucket, guitar_sh3_1024_l1_sh2.ksplat (3 sections of 400, 400 and 224 Gaussians, 79 KB):
               count_4g.ksplat      every Gaussian count 2^32 - 1 (section 0 and the header, loaded and not)
               sections_4g.ksplat   2^32 - 1 sections (4 TiB of section headers)
               buckets_4g.ksplat    2^32 - 1 buckets, all full (48 GiB of bucket centres)
               bucket_size_4g.ksplat  the full bucket holds 2^32 - 1 Gaussians (the section's count stays 256)
               partial_4g.ksplat    section 0's partially filled bucket is 2^32 - 1 long (the count stays 400)
  spz/         v4_rle_16m.spz     valid: 16,777,216 Gaussians in RLE blocks (10 KB)
               v3_gzip_1m.spz     valid: 1,048,576 Gaussians of zero bytes, gzip (20 KB)
               v4_garbage_40m.spz 40M Gaussians, streams of zstd frames whose blocks are noise but whose sizes
                                  pass the 32768:1 bound

Output is deterministic: rerunning gives identical bytes (v3_gzip_1m.spz depends on zlib's deflate, which
has been stable for this input across versions); --check reports stale or extra files without writing.

    python3 tests/data/hostile/make_hostile_corpus.py [--check]
"""
import base64
import hashlib
import json
import os
import struct
import sys
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(HERE)))
SOG_DIR = os.path.join(ROOT, "tests", "data", "sog", "guitar_crop")
GLB = os.path.join(ROOT, "tests", "data", "interop", "guitar_256_splat_transform.glb")
SOG_IMAGES = ["means_l.webp", "means_u.webp", "quats.webp", "scales.webp", "sh0.webp"]
MILLION40 = 40000000
GIB = 1 << 30
KSPLAT_SMALL = os.path.join(ROOT, "tests", "data", "ksplat", "guitar_256_l1.ksplat")
KSPLAT_PARTIAL = os.path.join(ROOT, "tests", "data", "ksplat", "guitar_sh3_1024_l1_sh2.ksplat")


def read(path):
    with open(path, "rb") as f:
        return f.read()


def dumps(value):
    return json.dumps(value, separators=(",", ":")).encode("ascii")


def nested(depth, leaf="x"):
    """`depth` nested JSON arrays around `leaf`, as text."""
    return "[" * depth + json.dumps(leaf) + "]" * depth


def with_raw(doc, path, raw_json):
    """JSON text of `doc` with the member at `path` (list of keys) replaced by the text `raw_json`."""
    marker = "@@RAW@@"
    d = json.loads(json.dumps(doc))
    node = d
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = marker
    return dumps(d).replace(json.dumps(marker).encode("ascii"), raw_json.encode("ascii"))


# ---------------------------------------------------------------------------------------------------
# glTF

def split_glb():
    data = read(GLB)
    assert struct.unpack_from("<III", data, 0)[:2] == (0x46546C67, 2)
    json_len, json_type = struct.unpack_from("<II", data, 12)
    assert json_type == 0x4E4F534A
    doc = json.loads(data[20:20 + json_len])
    at = 20 + json_len
    bin_len, bin_type = struct.unpack_from("<II", data, at)
    assert bin_type == 0x004E4942
    return doc, data[at + 8:at + 8 + bin_len]


def glb(json_bytes, bin_bytes):
    json_bytes += b" " * (-len(json_bytes) % 4)
    bin_bytes += b"\0" * (-len(bin_bytes) % 4)
    body = struct.pack("<II", len(json_bytes), 0x4E4F534A) + json_bytes
    body += struct.pack("<II", len(bin_bytes), 0x004E4942) + bin_bytes
    return struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body


def gltf_scene(base, bin_bytes, uri="scene.bin", byte_length=None):
    """The GLB's document as a .gltf whose one buffer is `uri` (byteLength: the buffer's, unless given)."""
    d = json.loads(json.dumps(base))
    d["asset"]["generator"] = "tests/data/hostile/make_hostile_corpus.py from splat-transform 3.7.0's GLB"
    d["buffers"] = [{"byteLength": len(bin_bytes) if byte_length is None else byte_length, "uri": uri}]
    return d


def gltf_files():
    base, bin_bytes = split_glb()
    files = {}

    def scene(uri="scene.bin", byte_length=None):
        return gltf_scene(base, bin_bytes, uri, byte_length)

    files["gltf/scene.gltf"] = dumps(scene())
    files["gltf/scene.bin"] = bin_bytes
    files["gltf/bytelength_3gib.gltf"] = dumps(scene(byte_length=3 * GIB))
    files["gltf/data_uri_bytelength_3gib.gltf"] = dumps(
        scene(uri="data:application/octet-stream;base64," + base64.b64encode(bin_bytes[:96]).decode("ascii"),
              byte_length=3 * GIB))

    d = scene()
    for a in d["accessors"]:
        a.pop("bufferView")
        a.pop("byteOffset", None)
        a["count"] = MILLION40
        a.pop("min", None)
        a.pop("max", None)
    files["gltf/no_bufferview_40m.gltf"] = dumps(d)

    files["gltf/deep_extras_32.gltf"] = with_raw(scene(), ["asset", "extras"], nested(32))
    files["gltf/deep_extras_100.gltf"] = with_raw(scene(), ["asset", "extras"], nested(100))
    d = scene()
    d["extensionsRequired"] = ["KHR_gaussian_splatting", "@"]
    files["gltf/deep_extensions_required_100.gltf"] = with_raw(d, ["extensionsRequired"],
                                                               "[\"KHR_gaussian_splatting\"," + nested(99) + "]")
    files["gltf/deep_accessor_type_100.gltf"] = with_raw(scene(), ["accessors", 0, "type"], nested(100, "VEC3"))
    d = scene()
    d["extensionsRequired"] = ["KHR_gaussian_splatting", "X" * 10000]
    files["gltf/long_extension_name.gltf"] = dumps(d)
    d = scene()
    d["accessors"][0]["type"] = "T" * 10000
    files["gltf/long_accessor_type.gltf"] = dumps(d)
    d = scene()
    d["asset"]["version"] = "3" + "V" * 10000
    files["gltf/long_version.gltf"] = dumps(d)
    d = scene()
    d["meshes"][0]["primitives"][0]["extensions"]["KHR_gaussian_splatting"]["kernel"] = "K" * 10000
    files["gltf/long_kernel.gltf"] = dumps(d)

    d = scene()
    d["nodes"] = [{"children": [1]}, {"children": [0], "mesh": 0}]
    files["gltf/node_cycle.gltf"] = dumps(d)
    d = scene()
    d["nodes"] = [{"children": [0], "mesh": 0}]
    files["gltf/node_self_cycle.gltf"] = dumps(d)
    d = scene()
    d["nodes"] = [{"children": [i + 1, i + 1]} for i in range(40)] + [{"mesh": 0}]
    files["gltf/node_dag_40.gltf"] = dumps(d)

    escapes = {
        "dotdot": "../gltf/scene.bin",
        "nested_dotdot": "sub/../../gltf/scene.bin",
        "pct_dotdot_lower": "%2e%2e%2fgltf%2fscene.bin",
        "pct_dotdot_upper": "%2E%2E%2Fgltf%2Fscene.bin",
        "pct_dots_only": "%2e%2e/gltf/scene.bin",
        "absolute": "/etc/passwd",
        "pct_absolute": "%2Fetc%2Fpasswd",
        "file_scheme": "file:///etc/passwd",
        "http_scheme": "http://127.0.0.1/scene.bin",
        "long_dotdot": "../" + "A" * 5000 + "/scene.bin",
    }
    for name, uri in escapes.items():
        files["gltf_escape/%s.gltf" % name] = dumps(scene(uri=uri))

    # Instancing: 88 primitives of one mesh over the same accessors, drawn by 1,776 nodes.
    d = json.loads(json.dumps(base))
    d["asset"]["generator"] = "tests/data/hostile/make_hostile_corpus.py: instanced guitar_256"
    prim = d["meshes"][0]["primitives"][0]
    d["meshes"][0]["primitives"] = [prim] * 88
    d["nodes"] = [{"mesh": 0}] * 1776
    d["scenes"] = [{"nodes": list(range(1776))}]
    assert 88 * 1776 * 256 == 40009728
    files["glb/instanced_40m.glb"] = glb(dumps(d), bin_bytes)
    d = json.loads(json.dumps(base))
    d["buffers"][0]["byteLength"] = 3 * GIB
    files["glb/bytelength_3gib.glb"] = glb(dumps(d), bin_bytes)
    files["glb/deep_100.glb"] = glb(with_raw(base, ["asset", "extras"], nested(100)), bin_bytes)
    return files


# ---------------------------------------------------------------------------------------------------
# SOG

def compact_sog_meta(path):
    """A SOG meta.json (splat-transform's) with its numbers at 5 significant digits: its images stay valid for
    it, and it is less than half the size."""
    def rounded(v):
        if isinstance(v, float):
            return float("%.5g" % v)
        if isinstance(v, list):
            return [rounded(x) for x in v]
        if isinstance(v, dict):
            return {k: rounded(x) for k, x in v.items()}
        return v
    return rounded(json.loads(read(path)))


def sog_meta():
    """guitar_crop's meta.json, compacted."""
    meta = compact_sog_meta(os.path.join(SOG_DIR, "meta.json"))
    meta["asset"]["generator"] = "tests/data/hostile/make_hostile_corpus.py from splat-transform v3.7.0"
    return meta


def with_first_image(meta, name):
    m = json.loads(json.dumps(meta))
    m["means"]["files"][0] = name
    return m


def lod_meta(chunk, count):
    return {"version": 1, "asset": {"generator": "tests/data/hostile/make_hostile_corpus.py"}, "count": count,
            "counts": [count], "lodLevels": 1, "filenames": [chunk],
            "tree": {"bound": {"min": [0, 0, 0], "max": [1, 1, 1]},
                     "lods": {"0": {"file": 0, "offset": 0, "count": count}}}}


def bit_writer():
    bits = []

    def put(value, n):
        for i in range(n):
            bits.append((value >> i) & 1)

    def done():
        bits.extend([0] * (-len(bits) % 8))
        return bytes(sum(bits[i + j] << j for j in range(8)) for i in range(0, len(bits), 8))
    return put, done


def solid_webp(width, height, argb):
    """A lossless WebP of one colour (a, r, g, b bytes): five single-symbol prefix codes, zero bits per pixel."""
    put, done = bit_writer()
    put(width - 1, 14)
    put(height - 1, 14)
    put(1, 1)          # alpha_is_used
    put(0, 3)          # version
    put(0, 1)          # no transform
    put(0, 1)          # no colour cache
    put(0, 1)          # no meta prefix codes
    a, r, g, b = argb
    for symbol in (g, r, b, a, 0):  # green, red, blue, alpha, distance
        put(1, 1)      # simple code
        put(0, 1)      # one symbol
        put(1, 1)      # 8-bit symbol
        put(symbol, 8)
    data = b"\x2f" + done() + b"\0\0"
    chunk = b"VP8L" + struct.pack("<I", len(data)) + data + b"\0" * (len(data) & 1)
    return b"RIFF" + struct.pack("<I", 4 + len(chunk)) + b"WEBP" + chunk


SOLID_SIDE = 5792
SOLID_IMAGES = {  # a, r, g, b: any mean and code; the quaternion tag (alpha) 252 = w largest
    "means_l.webp": (255, 0, 0, 0), "means_u.webp": (255, 128, 128, 128), "quats.webp": (252, 128, 128, 128),
    "scales.webp": (255, 128, 128, 128), "sh0.webp": (200, 128, 128, 128)}


def solid_scene(meta):
    files = {name: solid_webp(SOLID_SIDE, SOLID_SIDE, argb) for name, argb in SOLID_IMAGES.items()}
    m = json.loads(json.dumps(meta))
    m["count"] = SOLID_SIDE * SOLID_SIDE
    files["meta.json"] = dumps(m)
    return files


def zip_archive(entries, comment=b""):
    """entries: [(name, data, method, declared_size or None)]. Fixed DOS time, no extra fields."""
    out = bytearray()
    central = bytearray()
    for name, data, method, declared in entries:
        stored = data if method == 0 else zlib.compress(data, 9)[2:-4]
        crc = zlib.crc32(data)
        size = len(data) if declared is None else declared
        name_b = name.encode("ascii")
        offset = len(out)
        out += struct.pack("<IHHHHHIIIHH", 0x04034b50, 20, 0, method, 0, 0x21, crc, len(stored), size,
                           len(name_b), 0) + name_b + stored
        central += struct.pack("<IHHHHHHIIIHHHHHII", 0x02014b50, 20, 20, 0, method, 0, 0x21, crc, len(stored), size,
                               len(name_b), 0, 0, 0, 0, 0, offset) + name_b
    end = struct.pack("<IHHHHIIH", 0x06054b50, 0, 0, len(entries), len(entries), len(central), len(out), len(comment))
    return bytes(out + central + end) + comment


def sog_files():
    files = {}
    meta = sog_meta()
    images = {name: read(os.path.join(SOG_DIR, name)) for name in SOG_IMAGES}
    for name, data in images.items():
        files["sog/" + name] = data
    files["sog/meta.json"] = dumps(meta)
    escapes = {
        "dotdot": "../../sog/guitar_crop/means_l.webp",
        "nested_dotdot": "sub/../../../sog/guitar_crop/means_l.webp",
        "pct_dotdot": "%2e%2e%2f%2e%2e%2fsog%2fguitar_crop%2fmeans_l.webp",
        "absolute": "/etc/passwd",
        "pct_absolute": "%2Fetc%2Fpasswd",
        "file_scheme": "file:///etc/passwd",
    }
    for name, target in escapes.items():
        files["sog/escape_%s.json" % name] = dumps(with_first_image(meta, target))
    m = json.loads(json.dumps(meta))
    m["count"] = MILLION40
    files["sog/count_40m.json"] = dumps(m)
    files["sog_no_images/count_40m.json"] = dumps(m)
    files["sog/deep_32.json"] = with_raw(meta, ["asset", "extras"], nested(32))
    files["sog/deep_100.json"] = with_raw(meta, ["asset", "extras"], nested(100))
    files["sog/long_name.json"] = dumps(with_first_image(meta, "A" * 5000 + ".webp"))

    files["sog/lod.json"] = dumps(lod_meta("meta.json", 877))
    lod_escapes = {
        "dotdot": "../../sog/guitar_crop/meta.json",
        "nested_dotdot": "sub/../../../sog/guitar_crop/meta.json",
        "pct_dotdot": "%2e%2e%2f%2e%2e%2fsog%2fguitar_crop%2fmeta.json",
        "absolute": "/etc/passwd",
        "pct_absolute": "%2Fetc%2Fpasswd",
        "file_scheme": "file:///etc/passwd",
    }
    for name, target in lod_escapes.items():
        files["sog/lod_escape_%s.json" % name] = dumps(lod_meta(target, 877))
    files["sog/lod_count_40m.json"] = dumps(lod_meta("count_40m.json", MILLION40))
    files["sog/lod_deep_100.json"] = with_raw(lod_meta("meta.json", 877), ["asset", "extras"], nested(100))
    files["sog/lod_long_name.json"] = dumps(lod_meta("B" * 5000 + "/meta.json", 877))

    solid = solid_scene(meta)
    for name, data in solid.items():
        files["sog_solid_33m/" + name] = data

    def bundle(meta_bytes, image_entries):
        return zip_archive([("meta.json", meta_bytes, 8, None)] + image_entries)
    real = [(name, images[name], 8, None) for name in SOG_IMAGES]
    files["sog_bundle/entry_deflate_1gib.sog"] = bundle(
        dumps(meta), [(n, d, m, GIB - 1 if n == "means_l.webp" else s) for n, d, m, s in real])
    files["sog_bundle/entry_stored_1gib.sog"] = bundle(
        dumps(meta), [(n, d, 0 if n == "means_l.webp" else m, GIB - 1 if n == "means_l.webp" else s)
                      for n, d, m, s in real])
    files["sog_bundle/solid_33m.sog"] = bundle(solid["meta.json"],
                                               [(n, solid[n], 0, None) for n in SOG_IMAGES])
    files["sog_bundle/escape_dotdot.sog"] = bundle(dumps(with_first_image(meta, "../means_l.webp")), real)
    files["sog_bundle/deep_100.sog"] = bundle(with_raw(meta, ["asset", "extras"], nested(100)), real)
    return files


# ---------------------------------------------------------------------------------------------------
# SPZ

ZSTD_MAGIC = 0xFD2FB528
ZSTD_BLOCK = 128 * 1024


def zstd_rle_frame(byte, n):
    """A frame of n copies of `byte`: content size declared, 128 KiB window, RLE blocks."""
    out = bytearray(struct.pack("<IBB", ZSTD_MAGIC, (2 << 6), (17 - 10) << 3) + struct.pack("<I", n))
    left = n
    while left > 0:
        size = min(left, ZSTD_BLOCK)
        left -= size
        header = (1 if left == 0 else 0) | (1 << 1) | (size << 3)
        out += struct.pack("<I", header)[:3] + bytes([byte])
    return bytes(out)


def noise(n, seed):
    out = bytearray()
    counter = 0
    while len(out) < n:
        out += hashlib.sha256(b"%s:%d" % (seed.encode("ascii"), counter)).digest()
        counter += 1
    return bytes(out[:n])


def zstd_noise_frame(total, seed):
    """`total` bytes: a frame without content size whose compressed blocks hold noise (parses, cannot decode)."""
    out = bytearray(struct.pack("<IBB", ZSTD_MAGIC, 0, (17 - 10) << 3))
    left = total - len(out)
    while left > 0:
        size = min(left - 3, ZSTD_BLOCK - 1)
        left -= size + 3
        header = (1 if left == 0 else 0) | (2 << 1) | (size << 3)
        out += struct.pack("<I", header)[:3] + noise(size, "%s:%d" % (seed, left))
    assert len(out) == total
    return bytes(out)


def spz_v4(n, streams):
    """SPZ v4, SH degree 0, 12 fractional bits; `streams` are the five compressed streams with raw sizes."""
    header = struct.pack("<IIIBBBBI", 0x5053474E, 4, n, 0, 12, 0, len(streams), 32) + b"\0" * 12
    toc = b"".join(struct.pack("<QQ", len(data), raw) for data, raw in streams)
    return header + toc + b"".join(data for data, _ in streams)


def spz_files():
    files = {}
    per_point = [9, 1, 3, 3, 4]  # positions, alphas, colours, scales, rotations (smallest three)
    n = 1 << 24
    files["spz/v4_rle_16m.spz"] = spz_v4(n, [(zstd_rle_frame(0, n * b), n * b) for b in per_point])
    n = MILLION40
    files["spz/v4_garbage_40m.spz"] = spz_v4(
        n, [(zstd_noise_frame(-(-n * b // 32768), "stream%d" % i), n * b) for i, b in enumerate(per_point)])
    n = 1 << 20
    legacy = struct.pack("<IIIBBBB", 0x5053474E, 3, n, 0, 12, 0, 0) + bytes(n * sum(per_point))
    gz = zlib.compressobj(9, zlib.DEFLATED, 16 + 15)
    data = bytearray(gz.compress(legacy) + gz.flush())
    data[4:8] = b"\0\0\0\0"  # MTIME 0
    data[9] = 255            # OS unknown
    files["spz/v3_gzip_1m.spz"] = bytes(data)
    return files


def ksplat_files():
    """GaussianSplats3D .ksplat (SplatBuffer 0.1): header u32 counts at 4 (sections), 8 (loaded), 12 (Gaussians),
    16 (loaded); section headers of 1024 bytes from byte 4096: u32 loaded at 0, count at 4, bucket size at 8,
    buckets at 12, full buckets at 32, partially filled at 36."""
    small, partial = read(KSPLAT_SMALL), read(KSPLAT_PARTIAL)
    head = small[:4096 + 1024]
    big = 0xFFFFFFFF

    def with_u32(data, fields):
        data = bytearray(data)
        for offset in fields:
            struct.pack_into("<I", data, offset, big)
        return bytes(data)

    s0 = 4096
    partial0 = 4096 + 3 * 1024  # section 0's first partially filled bucket length
    return {
        "ksplat/count_4g.ksplat": with_u32(head, [12, 16, s0, s0 + 4]),
        "ksplat/sections_4g.ksplat": with_u32(head, [4, 8]),
        "ksplat/buckets_4g.ksplat": with_u32(small, [s0 + 12, s0 + 32]),
        "ksplat/bucket_size_4g.ksplat": with_u32(small, [s0 + 8]),
        "ksplat/partial_4g.ksplat": with_u32(partial, [partial0]),
    }


def build():
    files = {}
    for part in (gltf_files(), sog_files(), spz_files(), ksplat_files()):
        files.update(part)
    return {os.path.join(HERE, *name.split("/")): data for name, data in files.items()}


def main():
    check = "--check" in sys.argv[1:]
    files = build()
    total = sum(len(d) for d in files.values())
    assert total < 1 << 20, total
    stale = []
    for path, data in sorted(files.items()):
        if os.path.exists(path) and read(path) == data:
            continue
        stale.append(path)
        if not check:
            os.makedirs(os.path.dirname(path), exist_ok=True)
            with open(path, "wb") as f:
                f.write(data)
    extra = []
    for folder, dirs, names in os.walk(HERE):
        dirs[:] = [d for d in dirs if d != "__pycache__"]
        for name in names:
            path = os.path.join(folder, name)
            if path not in files and not name.endswith(".py"):
                extra.append(path)
    for path in stale:
        print("%s %s (%d bytes)" % ("stale:" if check else "wrote", os.path.relpath(path, ROOT), len(files[path])))
    for path in extra:
        print("not generated: %s" % os.path.relpath(path, ROOT))
    return 1 if check and (stale or extra) else 0


if __name__ == "__main__":
    sys.exit(main())
