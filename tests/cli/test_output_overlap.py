#!/usr/bin/env python3
"""Every output kind against every input kind, through every spelling of the same file: refused, and the input's
bytes unchanged; a failed or interrupted write leaves the earlier output as it was and nothing new. The outputs
are the sinks rgs-convert lists (its --to choices): one it lists and this test does not aim at fails it.

Usage: test_output_overlap.py RGS_CONVERT RGS_RENDER RGS_AUDIT SMALL_PLY SAMPLE_PLY WORK_DIR

The inputs are made from SMALL_PLY (a few hundred Gaussians) by rgs-convert itself, plus a .splat and a .gltf
with an external buffer written here: PLY (also one named like an image), .rgs, SPZ, GLB, glTF + .bin, .splat,
SOG bundle, SOG folder, streamed SOG. SAMPLE_PLY, larger, is what the interrupted writes convert. Each output is aimed at each file an input reads (its entry and the files it
names) through: the path as written, "./", "sub/..", "missing/.." (through a folder a sink creates), a symbolic link to the file, a symbolic link to its
folder, a hard link, and a case variant (a different file on a case-sensitive file system: then the only
requirement is that no input changes). Outputs: rgs-convert's .rgs, .ply, .spz, .glb, .sog, --json and the
streamed SOG (lod-meta.json, whose chunk files are what collides); rgs-render's images (a camera named after
the file); rgs-audit's report and saved renders.
"""
import hashlib
import os
import shutil
import signal
import struct
import subprocess
import sys
import time

CONVERT, RENDER, AUDIT, SMALL_PLY, SAMPLE_PLY, WORK = sys.argv[1:7]
failures = []
cases = 0


def run(args, timeout=120):
    return subprocess.run(args, capture_output=True, text=True, timeout=timeout)


def snapshot(folder):
    """{relative path: sha256 or 'dir' or 'link'} of everything below `folder`."""
    out = {}
    for root, dirs, files in os.walk(folder):
        for name in dirs + files:
            path = os.path.join(root, name)
            rel = os.path.relpath(path, folder)
            if os.path.islink(path):
                out[rel] = "link"
            elif os.path.isdir(path):
                out[rel] = "dir"
            else:
                with open(path, "rb") as f:
                    out[rel] = hashlib.sha256(f.read()).hexdigest()
    return out


def check(condition, what):
    if not condition:
        failures.append(what)
        print("FAIL:", what)


def make_splat(ply_path, out_path):
    """A .splat (antimatter15 layout: position, scale, RGBA, rotation; 32 bytes a Gaussian) of a binary PLY."""
    with open(ply_path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().splitlines()
    props = [line.split()[-1] for line in header if line.startswith("property")]
    count = int(next(line.split()[-1] for line in header if line.startswith("element vertex")))
    stride = 4 * len(props)
    with open(out_path, "wb") as out:
        for i in range(count):
            v = dict(zip(props, struct.unpack_from("<%df" % len(props), data, end + i * stride)))
            scale = [min(max(pow(2.718281828, v["scale_%d" % k]), 1e-6), 1e3) for k in range(3)]
            rgba = [max(0, min(255, int((0.5 + 0.28209479 * v["f_dc_%d" % k]) * 255))) for k in range(3)]
            rgba.append(int(255 / (1 + pow(2.718281828, -max(min(v["opacity"], 30), -30)))))
            q = [v["rot_%d" % k] for k in range(4)]
            n = max(sum(c * c for c in q) ** 0.5, 1e-12)
            rot = [max(0, min(255, int(c / n * 128 + 128))) for c in q]
            out.write(struct.pack("<3f3f4B4B", v["x"], v["y"], v["z"], *scale, *rgba, *rot))


def make_gltf(glb_path, gltf_path, bin_name):
    """The GLB's JSON as a .gltf whose buffer is the external file `bin_name` next to it."""
    with open(glb_path, "rb") as f:
        glb = f.read()
    json_len = struct.unpack_from("<I", glb, 12)[0]
    doc = glb[20:20 + json_len].decode().rstrip(" \0")
    bin_len = struct.unpack_from("<I", glb, 20 + json_len)[0]
    binary = glb[28 + json_len:28 + json_len + bin_len]
    import json
    j = json.loads(doc)
    j["buffers"][0]["uri"] = bin_name
    with open(gltf_path, "w") as f:
        json.dump(j, f)
    with open(os.path.join(os.path.dirname(gltf_path), bin_name), "wb") as f:
        f.write(binary)


def make_inputs(base):
    """Each input kind in its own folder below `base`: (name, entry path, files it reads)."""
    made = []

    def convert(src, dst, *extra):
        r = run([CONVERT, "-q", src, dst, *extra])
        if r.returncode != 0:
            sys.exit("cannot make %s: %s" % (dst, r.stderr))

    def folder(name):
        path = os.path.join(base, name)
        os.makedirs(path)
        return path

    d = folder("ply")
    shutil.copy(SMALL_PLY, os.path.join(d, "scene.ply"))
    made.append(("ply", os.path.join(d, "scene.ply"), ["scene.ply"]))
    d = folder("ply_named_png")  # named as rgs-render's images and rgs-audit's source renders are
    os.makedirs(os.path.join(d, "source"))
    shutil.copy(SMALL_PLY, os.path.join(d, "source", "view.png"))
    made.append(("ply named .png", os.path.join(d, "source", "view.png"), [os.path.join("source", "view.png")]))
    for kind, name in (("rgs", "scene.rgs"), ("spz", "scene.spz"), ("glb", "scene.glb"), ("sog", "scene.sog")):
        d = folder(kind)
        convert(SMALL_PLY, os.path.join(d, name))
        made.append((kind, os.path.join(d, name), [name]))
    d = folder("splat")
    make_splat(SMALL_PLY, os.path.join(d, "scene.splat"))
    made.append(("splat", os.path.join(d, "scene.splat"), ["scene.splat"]))
    d = folder("gltf")
    make_gltf(os.path.join(base, "glb", "scene.glb"), os.path.join(d, "scene.gltf"), "scene.bin")
    made.append(("gltf", os.path.join(d, "scene.gltf"), ["scene.gltf", "scene.bin"]))
    d = folder("sog_folder")
    os.makedirs(os.path.join(d, "0_0"))
    convert(SMALL_PLY, os.path.join(d, "0_0", "meta.json"))
    made.append(("sog_folder", os.path.join(d, "0_0", "meta.json"),
                 [os.path.join("0_0", n) for n in sorted(os.listdir(os.path.join(d, "0_0")))]))
    d = folder("streamed")
    convert(SMALL_PLY, os.path.join(d, "lod-meta.json"), "--lod-levels", "2", "--lod-chunk", "64")
    files = []
    for root, _, names in os.walk(d):
        files += [os.path.relpath(os.path.join(root, n), d) for n in names]
    made.append(("streamed", os.path.join(d, "lod-meta.json"), sorted(files)))
    return made


def spellings(path, scratch):
    """(label, another name of `path`) for each spelling. The links are made in `scratch`/source (the folder of
    rgs-audit's source renders when --save-renders is `scratch`), each named after `path` alone."""
    folder, name = os.path.split(path)
    os.makedirs(os.path.join(folder, "sub"), exist_ok=True)
    links = os.path.join(scratch, "source")
    os.makedirs(links, exist_ok=True)
    tag = hashlib.sha256(path.encode()).hexdigest()[:8]
    link = os.path.join(links, "link_%s_%s" % (tag, name))
    os.symlink(path, link)
    folder_link = os.path.join(links, "folder_%s" % tag)
    os.symlink(folder, folder_link)
    hard = os.path.join(links, "hard_%s_%s" % (tag, name))
    os.link(path, hard)
    return [("as written", path), ("./", os.path.join(folder, ".", name)),
            ("sub/..", os.path.join(folder, "sub", "..", name)),
            ("missing/..", os.path.join(folder, "missing_" + tag, "..", name)), ("symbolic link", link),
            ("linked folder", os.path.join(folder_link, name)), ("hard link", hard),
            ("case variant", os.path.join(folder, name.upper()))]


FORMAT_EXTENSIONS = (".rgs", ".ply", ".spz", ".glb", ".sog")


def convert_outputs(target):
    """rgs-convert output arguments that write `target`: every format through --to where its name chooses none,
    else the format its extension names; and --json."""
    ext = os.path.splitext(target)[1].lower()
    kinds = [ext[1:]] if ext in FORMAT_EXTENSIONS else [e[1:] for e in FORMAT_EXTENSIONS]
    return [(k, [target, "--to", k]) for k in kinds] + [("json", [os.path.join(WORK, "json_out.rgs"), "--json",
                                                                   target])]


def sinks_listed_by_the_tool():
    """The output formats rgs-convert's --help offers (its --to choices) must be those this test aims outputs with:
    a sink added to the tool and not here fails the test until its overlap cases are added."""
    global cases
    cases += 1
    r = run([CONVERT, "--help"])
    # "--to TEXT   Output format: rgs, ply (INRIA PLY), spz (SPZ v4), ... or sog (...); default: ..."
    line = next((line for line in r.stdout.splitlines() if line.strip().startswith("--to ")), "")
    names = line.split("Output format:", 1)[-1].split(";", 1)[0].replace(" or ", ", ").split(",")
    listed = ",".join(sorted(n.split()[0] for n in names if n.split()))
    covered = sorted(e[1:] for e in FORMAT_EXTENSIONS)
    check(listed.split(",") == covered,
          "rgs-convert --help lists the outputs {%s}; this test covers %s" % (listed, ", ".join(covered)))


def case_insensitive(folder):
    probe = os.path.join(folder, "case_probe")
    open(probe, "w").close()
    same = os.path.exists(os.path.join(folder, "CASE_PROBE"))
    os.remove(probe)
    return same


def expect_refused(label, args, root, input_files, may_succeed=False):
    """Runs `args`; the run must not be killed and must fail, leaving every file below `root` as it was (no byte
    changed, nothing added or removed). With `may_succeed` (a case variant on a case-sensitive file system,
    another file there) it may succeed, and then only the input files (relative to `root`) must be unchanged."""
    global cases
    cases += 1
    before = snapshot(root)
    r = run(args)
    after = snapshot(root)
    check(r.returncode >= 0, "%s: killed by signal %d" % (label, -r.returncode))
    if may_succeed and r.returncode == 0:
        changed = [f for f in input_files if before.get(f) != after.get(f)]
    else:
        check(r.returncode in (1, 2) and "is the input file" in r.stderr,
              "%s: exit %d, expected the refusal of an output that is an input; stderr: %s" %
              (label, r.returncode, r.stderr.strip()[-300:]))
        changed = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
    check(not changed, "%s: changed below %s: %s" % (label, root, changed[:6]))


def image_cameras(scratch, name):
    """A cameras.json of one 32 x 24 view named `name`."""
    cams = os.path.join(scratch, "cams_%s.json" % name)
    with open(cams, "w") as f:
        f.write('[{"id":0,"img_name":"%s","width":32,"height":24,"position":[0,0,-3],'
                '"rotation":[[1,0,0],[0,1,0],[0,0,1]],"fx":30,"fy":30}]' % name)
    return cams


def overlap_matrix(inputs, scratch):
    insensitive = case_insensitive(WORK)
    for kind, entry, files in inputs:
        nested = kind in ("sog_folder", "ply named .png")  # the entry is one folder down
        root = os.path.dirname(os.path.dirname(entry)) if nested else os.path.dirname(entry)
        for rel in files:
            # The entry through every spelling into every output; each other file the scene names through the
            # spellings that reach another folder or inode, into one output kind in turn.
            is_entry = os.path.join(root, rel) == entry
            for n, (label, target) in enumerate(spellings(os.path.join(root, rel), scratch)):
                if not is_entry and label not in ("as written", "symbolic link", "hard link"):
                    continue
                may = label == "case variant" and not insensitive
                what = "(%s of %s)" % (label, rel)
                outputs = convert_outputs(target)
                for out_kind, out_args in outputs if is_entry else [outputs[(n + len(rel)) % len(outputs)]]:
                    expect_refused("rgs-convert %s -> %s %s" % (kind, out_kind, what),
                                   [CONVERT, "-q", entry] + out_args, root, files, may)
                # rgs-audit's report (a second of start-up each: the entries as written, the PLY's spellings).
                if is_entry and (label == "as written" or kind == "ply"):
                    expect_refused("rgs-audit %s -> report %s" % (kind, what),
                                   [AUDIT, "-q", "--backend", "cpu", SMALL_PLY, entry, "--orbit", "1", "--width",
                                    "32", "--height", "24", "--report", target], root, files, may)
                stem, ext = os.path.splitext(os.path.basename(target))
                if ext.lower() not in (".png", ".ppm"):
                    continue
                # rgs-render and rgs-audit --save-renders name each image after its camera; rgs-audit puts the
                # source's in the folder "source" of --save-renders.
                cams = image_cameras(scratch, stem)
                expect_refused("rgs-render %s -> image %s" % (kind, what),
                               [RENDER, entry, "--cameras", cams, "-o", os.path.dirname(target), "--format",
                                ext[1:].lower()], root, files, may)
                if os.path.basename(os.path.dirname(target)) != "source":
                    continue
                expect_refused("rgs-audit %s -> saved renders %s" % (kind, what),
                               [AUDIT, "-q", "--backend", "cpu", entry, SMALL_PLY, "--cameras", cams, "--no-report",
                                "--save-renders",
                                os.path.dirname(os.path.dirname(target)), "--format", ext[1:].lower()], root, files,
                               may)


def streamed_sog_collisions(inputs, scratch):
    """A streamed SOG output whose chunk files are an input's files: found only once its levels are built."""
    by_kind = {kind: entry for kind, entry, _ in inputs}
    sog_folder_root = os.path.dirname(os.path.dirname(by_kind["sog_folder"]))
    streamed_root = os.path.dirname(by_kind["streamed"])
    linked = os.path.join(scratch, "streamed_link")
    os.symlink(streamed_root, linked)
    for label, src, dst, root in [
            ("SOG folder 0_0/ below the output", by_kind["sog_folder"],
             os.path.join(sog_folder_root, "lod-meta.json"), sog_folder_root),
            ("another streamed SOG's chunks", by_kind["streamed"], os.path.join(streamed_root, "LOD-META.json"),
             streamed_root),
            ("the chunks through a linked folder", by_kind["streamed"], os.path.join(linked, "LOD-META.json"),
             streamed_root),
            ("a chunk folder 0_0/ read as a SOG folder", os.path.join(streamed_root, "0_0", "meta.json"),
             os.path.join(streamed_root, "lod-meta.json"), streamed_root)]:
        expect_refused("rgs-convert streamed SOG out: %s" % label,
                       [CONVERT, "-q", src, dst, "--lod-levels", "2", "--lod-chunk", "64"], root, [])


def failed_write_keeps_older_output(scratch):
    """An older streamed SOG at the output; the new one fails once some chunk files are staged (the folder of
    its last level is taken by a file): the older scene is as it was, and nothing new is left."""
    out = os.path.join(scratch, "older")
    os.makedirs(out)
    r = run([CONVERT, "-q", SMALL_PLY, os.path.join(out, "lod-meta.json"), "--lod-levels", "2"])
    check(r.returncode == 0, "older streamed SOG: %s" % r.stderr)
    with open(os.path.join(out, "2_0"), "w") as f:
        f.write("in the way")
    global cases
    cases += 1
    before = snapshot(out)
    r = run([CONVERT, "-q", SMALL_PLY, os.path.join(out, "lod-meta.json"), "--lod-levels", "3"])
    check(r.returncode == 1, "failed streamed SOG write: exit %d (%s)" % (r.returncode, r.stderr.strip()))
    check("2_0" in r.stderr, "failed streamed SOG write names the folder: %s" % r.stderr.strip())
    check(snapshot(out) == before, "a failed streamed SOG write changed the older scene or left files: %s" %
          sorted(set(snapshot(out)) ^ set(before))[:6])


def partial_below(folder):
    for _, _, names in os.walk(folder):
        if any(n.endswith(".rgs-partial") for n in names):
            return True
    return False


def interrupted_write_keeps_older_output(scratch):
    """SIGTERM while a streamed SOG is written over an older one (once its first temporary appears, and at a few
    other moments): either the run finished (exit 0) or it ended by the signal, the older scene as it was and
    nothing new."""
    out = os.path.join(scratch, "interrupted")
    os.makedirs(out)
    older_args = [CONVERT, "-q", SMALL_PLY, os.path.join(out, "lod-meta.json"), "--lod-levels", "1"]
    r = run(older_args)
    check(r.returncode == 0, "older streamed SOG: %s" % r.stderr)
    older = snapshot(out)
    global cases
    while_writing = 0
    for delay in (None, None, 0.05, 0.3, 1.0):
        cases += 1
        p = subprocess.Popen([CONVERT, "-q", SAMPLE_PLY, os.path.join(out, "lod-meta.json"), "--lod-levels", "3",
                              "--lod-chunk", "4096"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        if delay is None:
            deadline = time.time() + 60
            while p.poll() is None and not partial_below(out) and time.time() < deadline:
                time.sleep(0.002)
            while_writing += partial_below(out)
        else:
            time.sleep(delay)
        p.send_signal(signal.SIGTERM)
        p.wait(timeout=120)
        if p.returncode == 0:  # finished before the signal: the next trial starts from the older scene again
            shutil.rmtree(out)
            os.makedirs(out)
            run(older_args)
            older = snapshot(out)
            continue
        # 143 from the tool's handler; -15 when the signal came before the handler was installed (a sanitized
        # tool starts slowly), which is as good while nothing was written.
        check(p.returncode in (143, -signal.SIGTERM),
              "SIGTERM (%s): exit %d" % (delay or "while writing", p.returncode))
        check(snapshot(out) == older, "SIGTERM (%s) changed the older scene or left files: %s" %
              (delay or "while writing", sorted(set(snapshot(out)) ^ set(older))[:6]))
    check(while_writing > 0, "no SIGTERM arrived while chunk files were staged: the interrupt was not tested")


def main():
    shutil.rmtree(WORK, ignore_errors=True)
    os.makedirs(WORK)
    scratch = os.path.join(WORK, "scratch")
    os.makedirs(scratch)
    inputs = make_inputs(os.path.join(WORK, "inputs"))
    for step in (sinks_listed_by_the_tool, lambda: overlap_matrix(inputs, scratch), lambda: streamed_sog_collisions(inputs, scratch),
                 lambda: failed_write_keeps_older_output(scratch), lambda: interrupted_write_keeps_older_output(scratch)):
        start, before = time.time(), cases
        step()
        print("%d cases in %.1f s" % (cases - before, time.time() - start))
    print("%d cases, %d failures" % (cases, len(failures)))
    if failures:
        sys.exit(1)
    print("PASS")


if __name__ == "__main__":
    main()
