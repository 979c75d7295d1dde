#!/usr/bin/env python3
"""Markdown tables of the current GPU figures from `rgs-bench --json` outputs (python3 standard library only).

    scripts/bench_tables.py OUT/bench_*.json                              # print the tables
    scripts/bench_tables.py --update docs/BENCHMARKS.md OUT/bench_*.json  # replace them in place

Reads the JSON that lab/tools/rgs_bench.cpp writes (one file per rgs-bench run; scripts/gpu_check.sh ... bench
leaves bench_<name>.json under its OUT folder) and prints, for the mode given by --mode (default fastest, the
fastest preset):
  1. its median frame time and its speedup over --reference (default faithful, the 3DGS baseline) in the same run, a row per scene
     and a column per resolution;
  2. its per-stage medians for the frames --stages names (default: the largest non-replicated scene at
     3840x2160, or at its largest resolution), with the reference's total;
  3. the PSNR of its images against the reference's (mean / min over the views), where the runs had --quality;
  4. with --modes SCENE@RES, every mode of that frame (the ablation);
  5. where the runs had --floor, the true floor: what the image needs (the CPU reference's census) and each
     stage's time over the time that work takes at the measured roofs (docs/lab/ROOFLINE.md#the-true-floor).
With --ab the inputs are the runs of `scripts/gpu_check.sh ... ab` (ab_<scene>_<a|b><round>.json: side A is
the other build, B this one) and the output is one table of total medians per side and B's change over A.
With --floor-only the output is the floor tables (5.) alone. With --occlusion it is one table of the pairs behind
saturated tiles (docs/lab/OCCLUSION.md), a row per input run (its camera set named) and resolution. With --update FILE the output replaces the lines
between the markers
    <!-- bench_tables: begin ... -->
    <!-- bench_tables: end -->
of FILE (each on a line of its own, once); with --block NAME, between "<!-- bench_tables NAME: begin ... -->"
and "<!-- bench_tables NAME: end -->". Any JSON that does not have the shape rgs-bench writes, files from
different devices, or the same (scene, mode, resolution) twice is an error (exit 1); bad options exit 2.
"""

import argparse
import json
import math
import os
import re
import statistics
import sys
import tempfile

BEGIN_MARKER = "<!-- bench_tables: begin"
END_MARKER = "<!-- bench_tables: end -->"

# Short names of the project's scenes (file stem -> label); --name adds others.
SCENE_NAMES = {
    "taebak": "taebak",
    "playcanvas_flowers_lod0": "daffodils",
    "mipnerf360_flowers_c3dgs": "flowers",
}

STAGES = ("preprocess", "sort", "ranges", "render", "total")

# The keys rgs-bench writes (lab/tools/rgs_bench.cpp); anything else is a shape this script does not know.
TOP_KEYS = {"tool", "version", "date", "timestamp_utc", "device", "device_peaks", "scene", "cameras",
            "warmup_frames", "repetitions", "statistic", "results", "quality", "front_door", "floor_census"}
TOP_REQUIRED = {"tool", "date", "device", "scene", "statistic", "results"}
RESULT_KEYS = {"mode", "mode_description", "resolution", "views", "frames", "median_ms", "stages", "fps",
               "mean_pairs", "max_tile_groups", "roofline", "per_view", "floor", "view_total_ms"}
RESULT_REQUIRED = {"mode", "resolution", "views", "median_ms"}
QUALITY_KEYS = {"mode", "resolution", "psnr_mean_db", "psnr_min_db", "psnr8_mean_db", "psnr8_min_db", "ssim_mean",
                "max_abs_diff", "views"}


class ShapeError(Exception):
    """The input is not what rgs-bench writes, or the inputs do not fit together."""


def need(cond, where, what):
    if not cond:
        raise ShapeError(f"{where}: {what}")


def is_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def check_keys(obj, known, required, where):
    need(isinstance(obj, dict), where, f"expected an object, found {type(obj).__name__}")
    unknown = sorted(set(obj) - known)
    need(not unknown, where, f"unknown keys {unknown} (not a shape rgs-bench writes; update the script)")
    missing = sorted(required - set(obj))
    need(not missing, where, f"missing keys {missing}")


def load_run(path):
    """One rgs-bench JSON file, checked, as a dict of what the tables use."""
    try:
        with open(path, encoding="utf-8") as f:
            j = json.load(f)
    except OSError as e:
        raise ShapeError(f"{path}: {e.strerror}") from None
    except json.JSONDecodeError as e:
        raise ShapeError(f"{path}: not JSON ({e})") from None
    check_keys(j, TOP_KEYS, TOP_REQUIRED, path)
    need(j["tool"] == "rgs-bench", path, f"tool is {j['tool']!r}, not 'rgs-bench'")
    need(isinstance(j["date"], str) and re.fullmatch(r"\d{4}-\d{2}-\d{2}", j["date"]), path,
         f"date {j['date']!r} is not YYYY-MM-DD")
    need(isinstance(j["statistic"], str) and j["statistic"].startswith("median over views x repetitions"), path,
         f"statistic {j['statistic']!r}: not the median rgs-bench reports")
    dev = j["device"]
    need(isinstance(dev, dict), path + ": device", "expected an object")
    need(isinstance(dev.get("name"), str) and dev["name"], path + ": device.name", "missing")
    need(isinstance(dev.get("compute_capability"), str), path + ": device.compute_capability", "missing")
    need(isinstance(dev.get("multiprocessors"), int), path + ": device.multiprocessors", "missing")
    scene = j["scene"]
    need(isinstance(scene, dict), path + ": scene", "expected an object")
    need(isinstance(scene.get("path"), str) and scene["path"], path + ": scene.path", "missing")
    need(isinstance(scene.get("gaussians"), int) and scene["gaussians"] >= 0, path + ": scene.gaussians",
         "missing or not a count")
    replicate = scene.get("replicate", 1)
    need(isinstance(replicate, int) and replicate >= 1, path + ": scene.replicate", "not a count ≥ 1")

    results = j["results"]
    need(isinstance(results, list) and results, path + ": results", "expected a non-empty array")
    frames = []
    for i, r in enumerate(results):
        where = f"{path}: results[{i}]"
        check_keys(r, RESULT_KEYS, RESULT_REQUIRED, where)
        need(isinstance(r["mode"], str) and r["mode"], where + ".mode", "missing")
        need(isinstance(r["resolution"], str) and re.fullmatch(r"\d+x\d+|native", r["resolution"]),
             where + ".resolution", f"{r['resolution']!r} is neither WIDTHxHEIGHT nor 'native'")
        need(isinstance(r["views"], int) and r["views"] > 0, where + ".views", "not a positive count")
        med = r["median_ms"]
        check_keys(med, {s + "_ms" for s in STAGES}, {s + "_ms" for s in STAGES}, where + ".median_ms")
        for s in STAGES:
            v = med[s + "_ms"]
            need(is_number(v) and math.isfinite(v) and v >= 0, f"{where}.median_ms.{s}_ms",
                 f"{v!r} is not a time")
        floor = {}
        if "floor" in r:
            for s in STAGES[:-1]:
                v = r["floor"].get(s, {}).get("floor_ms")
                need(is_number(v) and v >= 0, f"{where}.floor.{s}.floor_ms", f"{v!r} is not a time")
                floor[s] = float(v)
        spread = r.get("view_total_ms")
        frames.append({"mode": r["mode"], "resolution": r["resolution"],
                       "ms": {s: float(med[s + "_ms"]) for s in STAGES}, "floor": floor,
                       "pairs": float(r["mean_pairs"]) if is_number(r.get("mean_pairs")) else None,
                       "spread": (float(spread["min"]), float(spread["max"])) if spread else None})

    quality = j.get("quality", [])
    need(isinstance(quality, list), path + ": quality", "expected an array")
    rows = []
    for i, q in enumerate(quality):
        where = f"{path}: quality[{i}]"
        check_keys(q, QUALITY_KEYS, QUALITY_KEYS, where)
        keys = ("psnr_mean_db", "psnr_min_db", "psnr8_mean_db", "psnr8_min_db")
        for key in keys:
            # nlohmann::json writes +inf (identical images) as null.
            need(q[key] is None or is_number(q[key]), f"{where}.{key}", f"{q[key]!r} is not a PSNR")
        rows.append({"mode": q["mode"], "resolution": q["resolution"],
                     "psnr": tuple(math.inf if q[key] is None else float(q[key]) for key in keys)})

    census = {}
    for i, c in enumerate(j.get("floor_census", [])):
        where = f"{path}: floor_census[{i}]"
        views = c.get("views")
        need(isinstance(views, list) and views, where + ".views", "expected a non-empty array")
        n = len(views)
        mean = lambda key, sub=None: sum(v[key] if sub is None else v[key][sub] for v in views) / n
        census[c["resolution"]] = {
            "blended_px": mean("blended") / mean("pixels"), "skipped_px": mean("skipped") / mean("pixels"),
            "contributing": mean("contributing"), "rect": mean("rect_pairs"),
            "p16": mean("blending_pairs", "16x16"), "p8": mean("blending_pairs", "8x8"),
            "p4": mean("blending_pairs", "4x4"), "reach16": mean("reaching_pairs", "16x16"),
            "hidden_rect": mean("hidden_rect_pairs") if all("hidden_rect_pairs" in v for v in views) else None,
            "hidden_reach": mean("hidden_reaching_pairs") if all("hidden_reaching_pairs" in v for v in views) else None,
            "saturated": mean("saturated_tiles") if all("saturated_tiles" in v for v in views) else None}

    stem = os.path.basename(scene["path"].rstrip("/"))
    stem = re.sub(r"\.(rgs|ply|spz|glb|gltf|splat|sog|json)$", "", stem)
    cams = j.get("cameras") if isinstance(j.get("cameras"), dict) else {}
    views = {"path": "camera path", "orbit": "orbit"}.get(cams.get("source"), "own cameras")
    return {"path": path, "date": j["date"], "stem": stem, "replicate": replicate,
            "views": f"{views} ({cams['views']})" if isinstance(cams.get("views"), int) else views,
            "gaussians": scene["gaussians"],
            "device": (dev["name"], dev["compute_capability"], dev["multiprocessors"]),
            "frames": frames, "quality": rows, "census": census}


def gaussian_label(n):
    if n >= 1_000_000:
        return f"{n / 1e6:.2f}M"
    if n >= 1_000:
        return f"{n / 1e3:.0f}k"
    return str(n)


def resolution_label(res):
    return res.replace("x", "×")


def resolution_order(res):
    if res == "native":
        return (1, 0)
    w, h = (int(v) for v in res.split("x"))
    return (0, w * h)


class Scene:
    def __init__(self, run, names):
        self.key = (run["stem"], run["replicate"])
        self.name = names.get(run["stem"], run["stem"])
        self.replicate = run["replicate"]
        self.gaussians = run["gaussians"]
        self.frames = {}   # (mode, resolution) -> stage ms
        self.pairs = {}    # (mode, resolution) -> mean pairs per frame (None where the JSON has none)
        self.modes = []    # in the order the runs list them
        self.quality = {}  # (mode, resolution) -> (mean, min)
        self.floor = {}    # (mode, resolution) -> stage floor ms
        self.census = {}   # resolution -> mean census counts per frame
        self.spread = {}   # (mode, resolution) -> (fastest view, slowest view) median totals

    @property
    def label(self):
        base = self.name if self.replicate == 1 else f"{self.name} ×{self.replicate}"
        return f"{base} ({gaussian_label(self.gaussians)})"

    def matches(self, text):
        norm = lambda s: s.replace("×", "x").replace(" ", "").lower()
        base = self.name if self.replicate == 1 else f"{self.name}x{self.replicate}"
        return norm(text) in (norm(base), norm(f"{self.key[0]}x{self.replicate}" if self.replicate > 1
                                                else self.key[0]))


def collect(runs, names):
    devices = {r["device"] for r in runs}
    if len(devices) > 1:
        listed = "; ".join(f"{d[0]} (sm {d[1]}, {d[2]} SMs)" for d in sorted(devices))
        raise ShapeError(f"the files come from different devices ({listed}): one table per device")
    scenes = {}
    for run in runs:
        key = (run["stem"], run["replicate"])
        scene = scenes.setdefault(key, Scene(run, names))
        need(scene.gaussians == run["gaussians"], run["path"],
             f"{scene.name} has {run['gaussians']} Gaussians here and {scene.gaussians} in another file")
        for f in run["frames"]:
            k = (f["mode"], f["resolution"])
            need(k not in scene.frames, run["path"], f"{scene.name} {k[0]} {k[1]} appears twice in the inputs")
            scene.frames[k] = f["ms"]
            scene.pairs[k] = f["pairs"]
            if f["floor"]:
                scene.floor[k] = f["floor"]
            if f["spread"]:
                scene.spread[k] = f["spread"]
            if f["mode"] not in scene.modes:
                scene.modes.append(f["mode"])
        scene.census.update(run["census"])
        for q in run["quality"]:
            k = (q["mode"], q["resolution"])
            need(k not in scene.quality, run["path"], f"quality of {scene.name} {k[0]} {k[1]} appears twice")
            scene.quality[k] = q["psnr"]
    ordered = sorted(scenes.values(), key=lambda s: (s.replicate > 1, -s.gaussians, s.name))
    return ordered, devices.pop(), sorted({r["date"] for r in runs})


def table(header, rows):
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return lines


def db(v):
    return "∞" if math.isinf(v) else f"{v:.2f}"


def find_frame(scenes, spec):
    m = re.fullmatch(r"(.+)@(\d+x\d+|native)", spec)
    if not m:
        raise ShapeError(f"frame {spec!r}: expected SCENE@WIDTHxHEIGHT, e.g. taebak@3840x2160")
    for s in scenes:
        if s.matches(m.group(1)):
            return s, m.group(2)
    raise ShapeError(f"frame {spec!r}: no scene {m.group(1)!r} in the inputs "
                     f"({', '.join(s.label for s in scenes)})")


def render(scenes, device, dates, mode, reference, stage_specs, mode_specs, floor_only=False):
    out = []
    when = dates[0] if len(dates) == 1 else f"{dates[0]} to {dates[-1]}"
    out.append(f"Device: {device[0]} (sm_{device[1].replace('.', '')}, {device[2]} SMs); `rgs-bench` runs of {when}.")
    out.append("Times in ms: medians over views × repetitions, CUDA events.")
    resolutions = sorted({res for s in scenes for (m, res) in s.frames if m == mode}, key=resolution_order)
    need(resolutions, "inputs", f"no run of mode {mode!r}")

    if floor_only:
        return "\n".join(floor_tables(scenes, resolutions, mode)[1:]) + "\n"
    out += ["", f"`{mode}` frame time and speedup over `{reference}` (same run):", ""]
    rows = []
    for s in scenes:
        cells = []
        for res in resolutions:
            ms = s.frames.get((mode, res))
            if ms is None:
                cells.append("–")
                continue
            base = s.frames.get((reference, res))
            speedup = f", {base['total'] / ms['total']:.2f}×" if base and ms["total"] > 0 else ""
            cells.append(f"{ms['total']:.3f} ms{speedup}")
        if any(c != "–" for c in cells):
            rows.append([s.label] + cells)
    out += table(["scene"] + [resolution_label(r) for r in resolutions], rows)

    if stage_specs is None:
        largest = [s for s in scenes if s.replicate == 1 and any(m == mode for (m, _) in s.frames)]
        need(largest, "inputs", f"no non-replicated scene ran {mode!r}; name the frames with --stages")
        s = largest[0]
        own = sorted((res for (m, res) in s.frames if m == mode), key=resolution_order)
        stage_frames = [(s, "3840x2160" if "3840x2160" in own else own[-1])]
    elif stage_specs == ["all"]:
        stage_frames = [(s, res) for s in scenes for res in resolutions if (mode, res) in s.frames]
    else:
        stage_frames = [find_frame(scenes, spec) for spec in stage_specs]
    rows = []
    for s, res in stage_frames:
        ms = s.frames.get((mode, res))
        need(ms is not None, "--stages", f"{s.label} has no {mode} run at {res}")
        base = s.frames.get((reference, res))
        rows.append([f"{s.label}, {resolution_label(res)}"] + [f"{ms[st]:.3f}" for st in STAGES] +
                    [f"{base['total']:.3f}" if base else "–"])
    out += ["", f"`{mode}` per stage (the stage medians need not add up to the total's), and `{reference}`'s total:",
            ""]
    out += table(["frame"] + list(STAGES) + [f"`{reference}` total"], rows)

    q_res = [r for r in resolutions if any((mode, r) in s.quality for s in scenes)]
    if q_res:
        rows = []
        for s in scenes:
            if not any((mode, r) in s.quality for r in q_res):
                continue
            cells = []
            for r in q_res:
                q = s.quality.get((mode, r))
                cells.append(f"{db(q[0])} / {db(q[1])}; 8-bit {db(q[2])} / {db(q[3])}" if q else "–")
            rows.append([s.label] + cells)
        out += ["", f"`{mode}` against `{reference}`'s image of the same views (`--quality`), PSNR mean / min over "
                "the views, dB, of the float images and of their 8-bit images (what a PNG or the viewer shows):", ""]
        out += table(["scene"] + [resolution_label(r) for r in q_res], rows)

    out += floor_tables(scenes, resolutions, mode)
    for spec in mode_specs:
        s, res = find_frame(scenes, spec)
        base = s.frames.get((reference, res))
        rows = []
        for m in s.modes:
            ms = s.frames.get((m, res))
            if ms is None:
                continue
            speedup = f"{base['total'] / ms['total']:.2f}×" if base and ms["total"] > 0 else "–"
            rows.append([f"`{m}`"] + [f"{ms[st]:.3f}" for st in STAGES] + [speedup])
        need(rows, "--modes", f"{s.label} has no run at {res}")
        out += ["", f"Every mode of {s.label} at {resolution_label(res)}, speedup over `{reference}`:", ""]
        out += table(["mode"] + list(STAGES) + ["speedup"], rows)
    return "\n".join(out) + "\n"


def floor_tables(scenes, resolutions, mode):
    """The census and the per-stage floor of the runs that had --floor (empty without)."""
    out = []
    floor_frames = [(s, res) for s in scenes for res in resolutions if (mode, res) in s.floor]
    if floor_frames:
        rows = []
        for s, res in floor_frames:
            c = s.census[res]
            rows.append([f"{s.label}, {resolution_label(res)}", f"{c['blended_px']:.1f}", f"{c['skipped_px']:.1f}",
                         f"{c['contributing'] / 1e6:.2f}M", f"{c['rect'] / 1e6:.2f}M", f"{c['reach16'] / 1e6:.2f}M",
                         f"{c['p16'] / 1e6:.2f}M", f"{c['p8'] / 1e6:.2f}M", f"{c['p4'] / 1e6:.2f}M"])
        out += ["", "What the image needs (`--floor`, mean per view): Gaussians blended and tested in vain per pixel, "
                "Gaussians that blend anywhere, pairs of the 3DGS rectangles, pairs reaching α ≥ 1/255 per 16×16 "
                "tile, pairs that blend per 16×16, 8×8 and 4×4 cell:", ""]
        out += table(["frame", "blended/px", "skipped/px", "contributing", "3DGS pairs", "reaching 16×16",
                      "blending 16×16", "8×8", "4×4"], rows)
        rows = []
        for s, res in floor_frames:
            ms, fl = s.frames[(mode, res)], s.floor[(mode, res)]
            total = sum(fl.values())
            cells = [f"{ms[st]:.3f} / {fl[st]:.3f}" for st in STAGES[:-1]]
            lo_hi = s.spread.get((mode, res))
            rows.append([f"{s.label}, {resolution_label(res)}"] + cells +
                        [f"{ms['total']:.3f} / {total:.3f} ({ms['total'] / total:.1f}×)" if total > 0 else "–",
                         f"{lo_hi[0]:.3f}–{lo_hi[1]:.3f}" if lo_hi else "–"])
        out += ["", f"`{mode}` per stage against the true floor, ms (measured / floor), and the spread of the views' "
                "median totals:", ""]
        out += table(["frame"] + list(STAGES[:-1]) + ["total (× floor)", "views min–max"], rows)
    return out


def occlusion_table(runs, names, mode):
    """Pairs behind saturated tiles (docs/lab/OCCLUSION.md), a row per run and resolution with --floor: the census's
    hidden pairs, the bounds of their share of the mode's pairs, and its sort + ranges scaled to the pairs left at
    the lower bound."""
    rows = []
    floor_frames = []
    for run in runs:
        scenes, _, _ = collect([run], names)
        floor_frames += [(run, s, res) for s in scenes for res in sorted(s.census, key=resolution_order)]
    for run, s, res in floor_frames:
        c, pairs = s.census[res], s.pairs.get((mode, res))
        if c["hidden_rect"] is None or not pairs:
            continue
        w, h = (int(v) for v in res.split("x"))
        tiles = -(-w // 16) * -(-h // 16)
        # The mode's pairs F hold the reaching pairs and lie within the 3DGS rectangles' pairs, so the hidden ones
        # among them are at least the hidden reaching pairs and at most those plus F's pairs that reach nowhere.
        low = c["hidden_reach"] / pairs
        high = min(c["hidden_rect"], c["hidden_reach"] + max(pairs - c["reach16"], 0)) / pairs
        ms = s.frames[(mode, res)]
        rows.append([f"{s.label}, {resolution_label(res)}", run["views"], f"{100 * c['saturated'] / tiles:.0f} %",
                     f"{100 * c['hidden_rect'] / c['rect']:.1f} %", f"{100 * c['hidden_reach'] / c['reach16']:.1f} %",
                     f"{pairs / 1e6:.2f}M", f"{100 * low:.1f}–{100 * high:.1f} %",
                     f"{ms['sort'] + ms['ranges']:.3f} → {(ms['sort'] + ms['ranges']) * (1 - low):.3f}"])
    if not rows:
        raise ShapeError("no run with --floor and the census's hidden pairs among the inputs")
    devices = {r["device"] for r in runs}
    dates = sorted({r["date"] for r in runs})
    out = [f"Device: {', '.join(f'{d[0]} (sm {d[1]}, {d[2]} SMs)' for d in sorted(devices))}; "
           f"{', '.join(dates)}. Mean per view:", ""]
    return out + table(["frame", "views", "saturated tiles", "hidden 3DGS", "hidden reaching", f"{mode} pairs",
                        "hidden share", "sort + ranges ms"], rows)


def ab_table(runs, names):
    """Total medians of A and B runs of the same frames, one row per scene and resolution with every mode's
    runs (A's, then B's) and B's change over A (median of the rounds, so that one slow run does not decide)."""
    totals = {}  # (scene label, resolution) -> {mode: {"a": [...], "b": [...]}}
    modes = []
    for run in runs:
        m = re.search(r"_([ab])\d+\.json$", run["path"])
        need(m is not None, run["path"], "an --ab input is named ..._a<N>.json or ..._b<N>.json")
        label = Scene(run, names).label
        for f in run["frames"]:
            if f["mode"] not in modes:
                modes.append(f["mode"])
            sides = totals.setdefault((label, f["resolution"]), {}).setdefault(f["mode"], {"a": [], "b": []})
            sides[m.group(1)].append(f["ms"]["total"])
    rows = []
    for (label, res), by_mode in sorted(totals.items()):
        cells = []
        for mode in modes:
            sides = by_mode.get(mode)
            if sides is None:
                cells += ["–", "–"]
                continue
            need(sides["a"] and sides["b"], label, f"{mode} {res} lacks an A or a B run")
            a, b = statistics.median(sides["a"]), statistics.median(sides["b"])
            cells += [" ".join(f"{v:.3f}" for v in sides["a"]) + " → " + " ".join(f"{v:.3f}" for v in sides["b"]),
                      f"{100 * (b / a - 1):+.1f} %"]
        rows.append([label, resolution_label(res)] + cells)
    header = ["scene", "resolution"]
    for mode in modes:
        header += [f"`{mode}` A → B total ms", "B vs A"]
    return table(header, rows)


def update(path, generated, block=None):
    try:
        with open(path, encoding="utf-8") as f:
            lines = f.read().split("\n")
    except OSError as e:
        raise ShapeError(f"{path}: {e.strerror}") from None
    begin_marker = BEGIN_MARKER if block is None else f"<!-- bench_tables {block}: begin"
    end_marker = END_MARKER if block is None else f"<!-- bench_tables {block}: end -->"
    begins = [i for i, l in enumerate(lines) if l.startswith(begin_marker)]
    ends = [i for i, l in enumerate(lines) if l == end_marker]
    need(len(begins) == 1 and len(ends) == 1 and begins[0] < ends[0], path,
         f"expected one line starting with {begin_marker!r} and, after it, one line {end_marker!r} "
         f"(found {len(begins)} and {len(ends)})")
    new = lines[:begins[0] + 1] + generated.rstrip("\n").split("\n") + lines[ends[0]:]
    directory = os.path.dirname(os.path.abspath(path))
    fd, temp = tempfile.mkstemp(prefix=os.path.basename(path) + ".", suffix=".partial", dir=directory)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write("\n".join(new))
        os.chmod(temp, os.stat(path).st_mode & 0o7777)
        os.replace(temp, path)
    except BaseException:
        os.unlink(temp)
        raise


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("json", nargs="+", help="rgs-bench --json outputs")
    parser.add_argument("--update", metavar="FILE", help="replace the tables between FILE's markers")
    parser.add_argument("--mode", default="fastest", help="mode the tables show (default: fastest)")
    parser.add_argument("--reference", default="faithful", help="mode of the speedups and PSNR (default: faithful)")
    parser.add_argument("--stages", action="append", metavar="SCENE@RES",
                        help="frame of the per-stage table (repeatable; 'all': every frame)")
    parser.add_argument("--modes", action="append", default=[], metavar="SCENE@RES",
                        help="also a table of every mode of this frame (repeatable)")
    parser.add_argument("--floor-only", action="store_true", help="only the true floor's tables (runs with --floor)")
    parser.add_argument("--block", metavar="NAME", help="with --update: the markers of the block NAME")
    parser.add_argument("--ab", action="store_true", help="A/B runs of gpu_check.sh ab: one comparison table")
    parser.add_argument("--occlusion", action="store_true",
                        help="runs with --floor: one table of the pairs behind saturated tiles, a row per run")
    parser.add_argument("--name", action="append", default=[], metavar="STEM=LABEL",
                        help="short name of a scene file (e.g. garden_30k=garden)")
    args = parser.parse_args(argv)
    names = dict(SCENE_NAMES)
    for item in args.name:
        stem, sep, label = item.partition("=")
        if not sep or not stem or not label:
            parser.error(f"--name {item!r}: expected STEM=LABEL")
        names[stem] = label
    if args.stages and "all" in args.stages and len(args.stages) > 1:
        parser.error("--stages all cannot be combined with other frames")
    try:
        runs = [load_run(p) for p in args.json]
        if args.ab:
            sys.stdout.write("\n".join(ab_table(runs, names)) + "\n")
            return 0
        if args.occlusion:
            text = "\n".join(occlusion_table(runs, names, args.mode)) + "\n"
            if args.update:
                update(args.update, text, args.block)
            else:
                sys.stdout.write(text)
            return 0
        scenes, device, dates = collect(runs, names)
        text = render(scenes, device, dates, args.mode, args.reference, args.stages, args.modes, args.floor_only)
        if args.update:
            update(args.update, text, args.block)
            print(f"bench_tables: updated {args.update} from {len(runs)} file(s)", file=sys.stderr)
        else:
            sys.stdout.write(text)
    except ShapeError as e:
        print(f"bench_tables: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
