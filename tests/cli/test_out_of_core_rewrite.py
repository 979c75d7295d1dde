#!/usr/bin/env python3
"""The out-of-core build reads its PLY in several passes; another process rewrites the file while rgs-convert
runs. Every run must end in exit 0 with the output equal to the conversion of one of the two versions (the
rewrite came before the first pass or after the last), or in exit 1 with an error and no output: never a
signal, never a file mixed from both versions.

The input is the sample tiled four times; the rewrites alternate between: the same size with some means moved
far outside the scene's box, the same size with the means moved among the vertices (inside the box), the file
truncated to half, the file grown by vertices (another header), and a new file renamed over the input. Each is
applied in place (same inode) except the rename, after a random delay within the first 60 % of an undisturbed
run's time (the passes over the input come first). Exit 0 when every run ended so and at least one rewrite was
seen by a pass.

Usage: test_out_of_core_rewrite.py RGS_CONVERT SAMPLE.ply WORK_DIR [TRIALS]
"""
import os
import random
import shutil
import struct
import subprocess
import sys
import time

ARGS = ["--lod-levels", "auto", "--lod-chunk", "4096", "--memory-limit", "72MiB", "-q"]


def split_ply(data):
    """(header, vertex count, stride, offsets of x, y and z) of a binary little-endian PLY of float properties."""
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end]
    count, names = 0, []
    for line in header.decode("ascii").splitlines():
        parts = line.split()
        if parts[:2] == ["element", "vertex"]:
            count = int(parts[2])
        elif parts[:2] == ["property", "float"]:
            names.append(parts[2])
        elif parts and parts[0] == "property":
            raise SystemExit("unexpected property in '%s'" % line)
    return header, count, 4 * len(names), [4 * names.index(a) for a in ("x", "y", "z")]


def tiled(data, copies):
    header, count, stride, _ = split_ply(data)
    body = data[len(header):len(header) + count * stride]
    new_header = header.replace(b"element vertex %d\n" % count, b"element vertex %d\n" % (count * copies))
    return new_header + body * copies


def variants(data):
    """The versions the input is rewritten to, by name: (bytes, written in place or renamed over)."""
    header, count, stride, xyz = split_ply(data)
    h = len(header)
    outside = bytearray(data)
    for i in range(0, count, 7):  # every 7th mean 10^4 units away along x
        at = h + i * stride + xyz[0]
        (x,) = struct.unpack_from("<f", outside, at)
        struct.pack_into("<f", outside, at, x + 1e4)
    inside = bytearray(data)
    for i in range(count):  # vertex i takes the mean of vertex i + 1: every mean inside the box, others moved
        j = (i + 1) % count
        for off in xyz:
            inside[h + i * stride + off:h + i * stride + off + 4] = data[h + j * stride + off:h + j * stride + off + 4]
    grown = data.replace(b"element vertex %d\n" % count, b"element vertex %d\n" % (count + 5000))
    grown += data[h:h + 5000 * stride]
    return {
        "means_outside": (bytes(outside), "in place"),
        "means_inside": (bytes(inside), "in place"),
        "truncated": (data[:len(data) // 2], "in place"),
        "grown": (grown, "in place"),
        "renamed": (bytes(inside), "rename"),
    }


def convert(tool, src, dst):
    return subprocess.run([tool, src, dst] + ARGS, stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def read(path):
    with open(path, "rb") as f:
        return f.read()


def rewrite(path, new, how):
    if how == "rename":
        tmp = path + ".new"
        with open(tmp, "wb") as f:
            f.write(new)
        os.replace(tmp, path)
        return
    with open(path, "r+b") as f:  # the same inode, rewritten from its start
        f.write(new)
        f.truncate(len(new))


def main():
    if len(sys.argv) < 4:
        print(__doc__)
        return 2
    tool, sample, work = sys.argv[1], sys.argv[2], sys.argv[3]
    trials = int(sys.argv[4]) if len(sys.argv) > 4 else 40
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    original = tiled(read(sample), 4)
    versions = variants(original)
    src = os.path.join(work, "input.ply")
    out = os.path.join(work, "out.rgs")

    # The conversions of every version (None where it cannot be converted), and the run's time.
    expected = {}
    for name, (data, _) in list(versions.items()) + [("original", (original, None))]:
        with open(src, "wb") as f:
            f.write(data)
        started = time.monotonic()
        done = convert(tool, src, out)
        if name == "original":
            seconds = time.monotonic() - started
            if done.returncode != 0:
                print("FAIL: the original does not convert:", done.stderr.decode(errors="replace"))
                return 1
        expected[name] = read(out) if done.returncode == 0 else None
        if os.path.exists(out):
            os.remove(out)
    summary = subprocess.run([tool, src, out] + ARGS[:-1], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    if b"built out of core" not in summary.stdout:
        print("FAIL: the original is not converted out of core with", " ".join(ARGS[:-1]))
        return 1
    os.remove(out)

    rng = random.Random(1)
    names = list(versions)
    outcomes = {}
    failures = []
    for trial in range(trials):
        name = names[trial % len(names)]
        data, how = versions[name]
        if os.path.exists(src):
            os.remove(src)
        with open(src, "wb") as f:
            f.write(original)
        process = subprocess.Popen([tool, src, out] + ARGS, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        time.sleep(rng.uniform(0.0, 0.6 * seconds))
        rewrite(src, data, how)
        _, err = process.communicate()
        err = err.decode(errors="replace")
        rc = process.returncode
        changed = "changed during the passes of the out-of-core build" in err
        outcome = "signal %d" % -rc if rc < 0 else "exit %d%s" % (rc, " (changed)" if changed else "")
        outcomes[outcome] = outcomes.get(outcome, 0) + 1
        print("%s, %s: %s %s" % (name, how, outcome, err.strip()[:300]))
        written = os.path.exists(out)
        if rc == 0:
            got = read(out)
            if got != expected["original"] and got != expected[name]:
                failures.append("%s: exit 0 with a file equal to neither version" % name)
        elif rc == 1:
            if written:
                failures.append("%s: exit 1 but %s exists" % (name, out))
            if "rgs-convert: error: " not in err:
                failures.append("%s: exit 1 without an error message: %s" % (name, err))
        else:
            failures.append("%s: %s: %s" % (name, outcome, err.strip()))
        if written:
            os.remove(out)
    print("%d rewrites during a run: %s" % (trials, ", ".join("%d x %s" % (n, o) for o, n in sorted(outcomes.items()))))
    for f in failures:
        print("FAIL:", f)
    if failures:
        return 1
    if not any("changed" in o for o in outcomes):
        print("FAIL: no rewrite was seen by a pass (the runs are too short for the delays?)")
        return 1
    print("PASS")
    return 0


if __name__ == "__main__":
    sys.exit(main())
