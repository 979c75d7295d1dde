#!/usr/bin/env python3
"""The quality cards of docs/AUDITS.md: per format, what it costs in bytes and what it loses, measured render
against render, on every scene audited by scripts/audit_formats.sh; and the archive profile's rate-distortion
curves with every format as a point, one panel per scene.

    scripts/quality_cards.py --measure out --doc docs/AUDITS.md --plot docs/images/rate_distortion.png \\
        taebak=out/taebak_a.audit.json,out/taebak_b.audit.json      # the one command of docs/AUDITS.md
    scripts/quality_cards.py [--doc docs/AUDITS.md] [--plot docs/images/rate_distortion.png] \\
        flowers=out/flowers/mipnerf360_flowers_c3dgs.audit.json guitar=out/guitar/guitar.audit.json ...

With --measure OUT_DIR it first runs scripts/audit_formats.sh on the scenes of the cards that a development host
audits on its CPU (flowers, daffodils, guitar, biker: the real scenes under $RGS_DATA_DIR and the bundled guitar,
each with its views; SCENES below), into OUT_DIR/<scene>/, and takes their JSONs; a scene whose JSON is already
there is not audited again (delete it to measure anew). --dry-run prints those commands instead. Each argument is
NAME=JSON: a scene's name in the tables and the rgs-audit JSON (schema "rgs-audit", version 3 or 4) that
audit_formats.sh wrote for it, or several JSONs joined by commas (runs of one scene on the same views; taebak's
come from `scripts/gpu_check.sh .device_data OUT cards` on a GPU host). The measured scenes come first, then the
arguments in their order. Candidates labelled SERIES@POINT (archive@40, archive@spz) are the points of
a curve. With --doc the tables replace what lies between the markers <!-- quality-cards:begin --> and
<!-- quality-cards:end --> of that file, else they are printed. Needs python3-matplotlib for --plot.
Exit status: 0 ok, 1 a file that cannot be read or has no markers, or an audit that failed, 2 usage.
"""
import argparse
import json
import math
import os
import shlex
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# The scenes --measure audits: name, source, rgs-audit camera options, extra candidates, environment. "$DATA" is
# $RGS_DATA_DIR (the real scenes that are not shipped), "$ROOT" this checkout. daffodils' SOG is left out
# (SPLAT_TRANSFORM=/bin/false): splat-transform's k-means does not finish on its 542,104 Gaussians in reasonable time.
ORBIT = ["--orbit", "4", "--width", "480", "--height", "270"]
SCENES = [
    ("flowers", "$DATA/mipnerf360_flowers_c3dgs.ply",
     ["--cameras", "$DATA/mipnerf360_flowers_cameras.json", "--every", "4", "--width", "960"], [], {}),
    ("daffodils", "$DATA/playcanvas_flowers_lod0.ply", ORBIT, [], {"SPLAT_TRANSFORM": "/bin/false"}),
    ("guitar", "$ROOT/samples/guitar.ply", ORBIT, ["$DATA/guitar.compressed.ply"], {}),
    ("biker", "$DATA/biker.ply", ORBIT, ["$DATA/biker.spz"], {}),
]

BEGIN, END = "<!-- quality-cards:begin -->", "<!-- quality-cards:end -->"
# Formats in the order of the cards; a label not here follows them in the order first met.
ORDER = ["runtime", "int8dc", "zstd", "archive", "spz", "sog", "compressed.ply", "glb"]
WHAT = {
    "runtime": ".rgs default (DC residual, mapped as is)",
    "int8dc": ".rgs `--sh-dc-bits 8` (the paper's INT8 DC)",
    "zstd": ".rgs `--zstd all` (lossless)",
    "archive": ".rgs `--profile archive`, default settings",
    "spz": "SPZ v4, `rgs-convert --to spz` (the spz library's settings)",
    "sog": "SOG, splat-transform 3.7 (CPU path)",
    "compressed.ply": "PlayCanvas compressed PLY, splat-transform 3.7",
    "glb": "glTF KHR_gaussian_splatting (`--to glb`, float32)",
}


def value(v):
    return math.inf if v == "inf" else -math.inf if v == "-inf" else float(v)


def db(v):
    v = value(v)
    return "inf" if math.isinf(v) else f"{v:.2f}"


def read_audit(path):
    with open(path, encoding="utf-8") as f:
        doc = json.load(f)
    if doc.get("schema") != "rgs-audit" or doc.get("schema_version") not in (3, 4):
        raise ValueError(f"{path}: not an rgs-audit JSON of schema version 3 or 4")
    return doc


def load(arg):
    """NAME=JSON[,JSON...]: runs on the same source and views (a long audit split over several runs) are merged,
    a label measured twice taken from the first run that has it."""
    name, sep, paths = arg.partition("=")
    if not sep or not name or not paths:
        raise SystemExit(f"quality_cards.py: {arg}: expected NAME=JSON[,JSON...]")
    paths = paths.split(",")
    doc = read_audit(paths[0])
    for path in paths[1:]:
        more = read_audit(path)
        same = (more["source"]["gaussians"] == doc["source"]["gaussians"] and
                [(v["width"], v["height"]) for v in more["views"]] == [(v["width"], v["height"]) for v in doc["views"]])
        if not same:
            raise ValueError(f"{path}: another source or other views than {paths[0]}")
        labels = {c["label"] for c in doc["candidates"]}
        doc["candidates"] += [c for c in more["candidates"] if c["label"] not in labels]
    return name, doc


def by_label(doc):
    return {c["label"]: c for c in doc["candidates"]}


def views_text(doc):
    first = doc["views"][0]
    return f"{len(doc['views'])} views at {first['width']}x{first['height']}, {doc['backend']}"


def cards(scenes):
    labels = [l for l in ORDER if any(l in by_label(d) for _, d in scenes)]
    for _, d in scenes:
        labels += [c["label"] for c in d["candidates"] if c["label"] not in labels and "@" not in c["label"]]
    out = ["| format | " + " | ".join(f"{n} B/G | {n} dB" for n, _ in scenes) + " |",
           "|---|" + "---:|---:|" * len(scenes)]
    for label in labels:
        row = [WHAT.get(label, label)]
        for _, d in scenes:
            c = by_label(d).get(label)
            row += ([f"{c['bytes_per_gaussian']:.1f}", f"{db(c['psnr_db']['mean'])} / {db(c['psnr_db']['min'])}"]
                    if c else ["", ""])
        out.append("| " + " | ".join(row) + " |")
    out.append("")
    out.append("Scenes: " + "; ".join(f"{n}: {d['source']['gaussians']:,} Gaussians, SH degree "
                                      f"{d['source']['sh_degree']}, {views_text(d)}" for n, d in scenes) + ".")
    return out


def curve_table(scenes):
    out = ["| scene | point | target dB | bytes | B/G | PSNR mean / min dB | vs SPZ v4 bytes |", "|---|---|---:|---:|---:|---:|---:|"]
    for name, d in scenes:
        cands = by_label(d)
        spz = cands.get("spz")
        points = sorted((c for c in d["candidates"] if c["label"].startswith("archive@")), key=lambda c: c["bytes"])
        for c in points:
            point = c["label"].split("@", 1)[1]
            target = f"{value(spz['psnr_db']['mean']):.2f} (SPZ's)" if point == "spz" and spz else point
            ratio = f"{c['bytes'] / spz['bytes']:.2f}x" if spz else ""
            out.append(f"| {name} | {c['label']} | {target} | {c['bytes']:,} | {c['bytes_per_gaussian']:.2f} | "
                       f"{db(c['psnr_db']['mean'])} / {db(c['psnr_db']['min'])} | {ratio} |")
    return out


def plot(scenes, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cols = min(3, len(scenes))
    rows = (len(scenes) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 4.2 * rows), squeeze=False)
    for ax, (name, d) in zip(axes.flat, scenes):
        curve = sorted((c["bytes_per_gaussian"], value(c["psnr_db"]["mean"]), value(c["psnr_db"]["min"]))
                       for c in d["candidates"] if c["label"].startswith("archive@"))
        if curve:
            x, mean, low = zip(*curve)
            ax.plot(x, mean, "-s", color="tab:blue", markersize=4, label="archive, --target-psnr: mean")
            ax.plot(x, low, ":", color="tab:blue", label="worst view")
        for k, c in enumerate(c for c in d["candidates"] if "@" not in c["label"]):
            mean = value(c["psnr_db"]["mean"])
            if not math.isfinite(mean) or mean > 100:
                continue  # lossless: off the chart (the cards give it)
            ax.plot([c["bytes_per_gaussian"]], [mean], "o", color=f"C{(k + 1) % 10}")
            ax.annotate(c["label"], (c["bytes_per_gaussian"], mean), textcoords="offset points", xytext=(5, 3),
                        fontsize=7)
        ax.set_xscale("log")
        ax.set_title(f"{name} ({d['source']['gaussians']:,} Gaussians, SH {d['source']['sh_degree']})", fontsize=9)
        ax.set_xlabel("bytes per Gaussian", fontsize=8)
        ax.set_ylabel("PSNR against the source's render (dB)", fontsize=8)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7, loc="lower right")
    for ax in list(axes.flat)[len(scenes):]:
        ax.axis("off")
    fig.tight_layout()
    tmp = path + ".tmp.png"
    fig.savefig(tmp, dpi=90)
    os.replace(tmp, path)


def measure(out_dir, dry_run):
    """Runs audit_formats.sh on each scene of SCENES whose JSON is not in OUT_DIR yet; returns NAME=JSON arguments."""
    data = os.environ.get("RGS_DATA_DIR", "")
    if not data or not os.path.isdir(data):
        raise ValueError("--measure: set RGS_DATA_DIR to the folder of the real scenes (flowers, daffodils, biker)")
    args = []
    for name, source, views, extra, env in SCENES:
        expand = lambda v: v.replace("$DATA", data).replace("$ROOT", ROOT)  # noqa: E731
        source, views, extra = expand(source), [expand(v) for v in views], [expand(v) for v in extra]
        scene_dir = os.path.join(out_dir, name)
        stem = os.path.basename(source).split(".", 1)[0]
        result = os.path.join(scene_dir, stem + ".audit.json")
        args.append(f"{name}={result}")
        command = [os.path.join(ROOT, "scripts", "audit_formats.sh"), source, scene_dir] + views
        command += ["--"] + extra if extra else []
        shown = " ".join(f"{k}={shlex.quote(v)}" for k, v in env.items()) + " " * bool(env) + shlex.join(command)
        if dry_run:
            print(shown)
            continue
        if os.path.exists(result):
            sys.stderr.write(f"quality_cards.py: {name}: {result} exists, not audited again\n")
            continue
        sys.stderr.write(f"quality_cards.py: {name}: {shown}\n")
        if subprocess.run(command, env={**os.environ, **env}).returncode != 0:
            raise ValueError(f"{name}: audit_formats.sh failed (above: why)")
    return args


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="*", metavar="NAME=JSON[,JSON...]")
    ap.add_argument("--measure", metavar="OUT_DIR", help="audit the scenes of SCENES into OUT_DIR first")
    ap.add_argument("--dry-run", action="store_true", help="with --measure: print its commands and stop")
    ap.add_argument("--doc", help="Markdown file whose quality-card markers are replaced")
    ap.add_argument("--plot", help="PNG of the rate-distortion panels")
    args = ap.parse_args(argv[1:])
    if not args.scenes and not args.measure:
        ap.error("no scenes: give NAME=JSON arguments, --measure OUT_DIR, or both")
    if args.dry_run and not args.measure:
        ap.error("--dry-run goes with --measure")
    try:
        measured = measure(args.measure, args.dry_run) if args.measure else []
        if args.dry_run:
            return 0
        scenes = [load(a) for a in measured + args.scenes]
        names = [n for n, _ in scenes]
        if len(set(names)) != len(names):
            raise ValueError(f"a scene named twice: {names}")
        text = "\n".join(cards(scenes) + [""] + curve_table(scenes)) + "\n"
        if args.plot:
            plot(scenes, args.plot)
        if not args.doc:
            sys.stdout.write(text)
            return 0
        with open(args.doc, encoding="utf-8") as f:
            doc = f.read()
        if BEGIN not in doc or END not in doc:
            raise ValueError(f"{args.doc}: no {BEGIN} ... {END} markers")
        head, rest = doc.split(BEGIN, 1)
        tail = rest.split(END, 1)[1]
        tmp = args.doc + ".tmp"
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(head + BEGIN + "\n" + text + END + tail)
        os.replace(tmp, args.doc)
        return 0
    except (OSError, ValueError, KeyError) as e:
        sys.stderr.write(f"quality_cards.py: {e}\n")
        return 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
