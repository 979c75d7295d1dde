#!/usr/bin/env python3
"""Every output format of rgs-convert, byte for byte as recorded: the SHA-256 of each file each conversion writes
(tests/data/golden_outputs.json), for the shipped scenes, in memory and (the level-of-detail .rgs of a PLY) out of
core. A change to a writer, a reader or a stage on the way that changes any output byte fails here; a change
meant to do so records the new hashes with --update, and its commit says why the bytes changed. --sanitized (a
build with the sanitizers) skips the out-of-core case: a sanitized tool already holds more than its memory limit.

Usage: test_golden_outputs.py RGS_CONVERT REPO_ROOT WORK_DIR [--update] [--sanitized]
"""
import hashlib
import json
import os
import shutil
import subprocess
import sys

CONVERT, ROOT, WORK = sys.argv[1:4]
UPDATE = "--update" in sys.argv[4:]
SANITIZED = "--sanitized" in sys.argv[4:]
GOLDEN = os.path.join(ROOT, "tests", "data", "golden_outputs.json")

# (input, relative to the repository) x (output name, extra options). The output name chooses the format.
INPUTS = ["samples/guitar.ply", "tests/data/guitar_sh3.ply", "tests/data/sog/guitar_crop.sog",
          "tests/data/sog/guitar_crop.compressed.ply", "tests/data/interop/guitar_256_splat_transform_v4.spz",
          "tests/data/interop/guitar_256_splat_transform.glb", "tests/data/interop/guitar_256_splat_transform.splat"]
OUTPUTS = [("runtime.rgs", []), ("archive.rgs", ["--profile", "archive"]), ("zstd.rgs", ["--zstd", "all"]),
           ("log_scale.rgs", ["--scale-encoding", "log", "--sh-dc-bits", "8"]),
           ("lod.rgs", ["--lod-levels", "auto", "--lod-chunk", "4096"]), ("out.ply", []), ("out.spz", []),
           ("out.glb", []), ("out.sog", []), ("folder/meta.json", []),
           ("streamed/lod-meta.json", ["--lod-levels", "auto", "--lod-chunk", "4096"])]
# The same level-of-detail .rgs built out of core: a memory limit below the in-memory estimate of guitar.ply.
OUT_OF_CORE = ("samples/guitar.ply", "lod_out_of_core.rgs",
               ["--lod-levels", "auto", "--lod-chunk", "4096", "--memory-limit", "72MiB"])


def sha256(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def convert(src, name, options, key, results, failures):
    out_dir = os.path.join(WORK, key.replace("/", "_"))
    shutil.rmtree(out_dir, ignore_errors=True)
    os.makedirs(os.path.dirname(os.path.join(out_dir, name)), exist_ok=True)
    r = subprocess.run([CONVERT, "-q", os.path.join(ROOT, src), os.path.join(out_dir, name), *options],
                       capture_output=True, text=True, timeout=600)
    if r.returncode != 0:
        failures.append("%s: exit %d: %s" % (key, r.returncode, r.stderr.strip()))
        return
    files = {}
    for folder, _, names in os.walk(out_dir):
        for n in names:
            path = os.path.join(folder, n)
            files[os.path.relpath(path, out_dir)] = sha256(path)
    results[key] = files


def main():
    shutil.rmtree(WORK, ignore_errors=True)
    os.makedirs(WORK)
    results, failures = {}, []
    for src in INPUTS:
        for name, options in OUTPUTS:
            convert(src, name, options, "%s -> %s" % (src, name), results, failures)
    src, name, options = OUT_OF_CORE
    out_of_core_key = "%s -> %s" % (src, name)
    if SANITIZED:
        print("skipped: %s (a sanitized tool holds more than its memory limit)" % out_of_core_key)
    else:
        convert(src, name, options, out_of_core_key, results, failures)
    if UPDATE:
        with open(GOLDEN, "w") as f:
            json.dump(results, f, indent=1, sort_keys=True)
            f.write("\n")
        print("recorded %d conversions in %s" % (len(results), GOLDEN))
    else:
        with open(GOLDEN) as f:
            golden = json.load(f)
        if SANITIZED:
            del golden[out_of_core_key]
        for key in sorted(set(golden) | set(results)):
            if golden.get(key) != results.get(key):
                failures.append("%s: files and hashes %s, recorded %s" % (key, results.get(key), golden.get(key)))
    # The out-of-core build writes the bytes of the build in memory.
    in_memory = results.get("samples/guitar.ply -> lod.rgs", {}).get("lod.rgs")
    out_of_core = results.get("samples/guitar.ply -> lod_out_of_core.rgs", {}).get("lod_out_of_core.rgs")
    if in_memory is None or (in_memory != out_of_core and not SANITIZED):
        failures.append("the out-of-core .rgs (%s) differs from the one built in memory (%s)" % (out_of_core, in_memory))
    for f in failures:
        print("FAIL:", f)
    print("%d conversions, %d failures" % (len(results), len(failures)))
    if failures:
        sys.exit(1)
    print("PASS")


if __name__ == "__main__":
    main()
