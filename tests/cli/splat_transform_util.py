"""What the splat-transform interop tests share: where splat-transform is installed, and a float PLY's vertices."""
import os
import shutil
import struct


# What a test prints, and then exits 77 (skipped), when find_splat_transform finds none.
NOT_FOUND = ("skipped: splat-transform not found (set RGS_SPLAT_TRANSFORM, or npm install --prefix "
             ".splat_transform @playcanvas/splat-transform@3.7 in the checkout)")


def find_splat_transform(source_dir):
    """splat-transform's command: $RGS_SPLAT_TRANSFORM, the checkout's .splat_transform (npm install
    --prefix .splat_transform @playcanvas/splat-transform), or the PATH's; None when none is found."""
    candidates = [os.environ.get("RGS_SPLAT_TRANSFORM", ""),
                  os.path.join(source_dir, ".splat_transform", "node_modules", ".bin", "splat-transform"),
                  shutil.which("splat-transform") or ""]
    for c in candidates:
        if c and os.path.isfile(c) and os.access(c, os.X_OK):
            return c
    return None


def read_ply(path):
    """(vertex count, {property name: values}) of a binary little-endian PLY of float properties only."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    count, names = 0, []
    for line in data[:end].decode("ascii").splitlines():
        parts = line.split()
        if parts[:2] == ["element", "vertex"]:
            count = int(parts[2])
        elif parts[:2] == ["property", "float"]:
            names.append(parts[2])
        elif parts and parts[0] == "property":
            raise SystemExit(f"{path}: unexpected property type in '{line}'")
    values = struct.unpack_from("<%df" % (count * len(names)), data, end)
    k = len(names)
    return count, {n: values[i::k] for i, n in enumerate(names)}
