#!/usr/bin/env python3
"""Draws the per-stage roofline of an rgs-bench JSON report (rgs-bench ... --json bench.json).

Usage: scripts/plot_roofline.py BENCH.json OUT.png [--resolution 3840x2160] [--mode faithful --mode roofgs]
                                [--title TEXT]

Log-log axes: arithmetic intensity (FLOP per byte) against achieved GFLOP/s. The roofs are the peaks the
same run measured (device_peaks: the device-to-device copy for the memory roof, the FP32 FMA loop for the
compute roof), meeting at the ridge point. One point per (mode, resolution, stage): colour = mode, marker =
stage, filled for the first resolution and hollow for the others; every point is labelled. Bytes and FLOPs
come from the analytic model of docs/lab/ROOFLINE.md (upper bounds), times from the run's stage medians.

Stages without FP32 work (sort, ranges) have intensity 0, which a log axis cannot show: they are drawn at the
left edge of the plot, at the height where their achieved bandwidth meets the memory roof's slope, so their
distance below the memory roof is their share of the bandwidth peak; their labels say "no FLOPs".

Runs on a host with python3 and matplotlib (Debian: python3-matplotlib); no GPU needed.
"""

import argparse
import json
import math
import sys

PROG = "plot_roofline.py"
STAGES = ["preprocess", "sort", "ranges", "render"]
MARKERS = {"preprocess": "o", "sort": "s", "ranges": "^", "render": "D"}


def fail(message):
    print(f"{PROG}: error: {message}", file=sys.stderr)
    sys.exit(1)


def number(obj, key, where):
    """obj[key] as a finite float, or a clear error naming where it was expected."""
    if not isinstance(obj, dict) or key not in obj:
        fail(f"{where}: missing '{key}'")
    value = obj[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        fail(f"{where}: '{key}' is {value!r}, not a finite number")
    return float(value)


def load_report(path):
    try:
        with open(path, "r", encoding="utf-8") as f:
            report = json.load(f)
    except OSError as e:
        fail(f"cannot read {path}: {e.strerror or e}")
    except json.JSONDecodeError as e:
        fail(f"{path} is not JSON: {e}")
    if not isinstance(report, dict) or report.get("tool") != "rgs-bench":
        fail(f"{path} is not an rgs-bench report (no \"tool\": \"rgs-bench\")")
    if "device_peaks" not in report:
        fail(f"{path} has no 'device_peaks': it was written by an rgs-bench without the roofline")
    peaks = report["device_peaks"]
    memory = number(peaks.get("memory", {}), "gbps", f"{path}: device_peaks.memory")
    compute = number(peaks.get("compute", {}), "gflops", f"{path}: device_peaks.compute")
    if memory <= 0 or compute <= 0:
        fail(f"{path}: device peaks must be positive (memory {memory} GB/s, compute {compute} GFLOP/s)")
    results = report.get("results")
    if not isinstance(results, list) or not results:
        fail(f"{path}: no results")
    points = []
    for i, run in enumerate(results):
        where = f"{path}: results[{i}]"
        if not isinstance(run, dict) or "roofline" not in run:
            fail(f"{where} has no 'roofline'")
        mode = run.get("mode", "?")
        resolution = run.get("resolution", "?")
        stages = run["roofline"].get("stages") if isinstance(run["roofline"], dict) else None
        if not isinstance(stages, dict):
            fail(f"{where}: roofline.stages missing")
        for stage in STAGES:
            s = stages.get(stage)
            if not isinstance(s, dict):
                fail(f"{where}: roofline.stages.{stage} missing")
            w = f"{where}.roofline.stages.{stage}"
            points.append({
                "mode": mode,
                "resolution": resolution,
                "stage": stage,
                "intensity": number(s, "flop_per_byte", w),
                "gflops": number(s, "gflops", w),
                "gbps": number(s, "gbps", w),
            })
    return report, memory, compute, points


def main():
    parser = argparse.ArgumentParser(prog=PROG, description="Roofline plot of an rgs-bench JSON report.")
    parser.add_argument("json", help="rgs-bench --json output")
    parser.add_argument("png", help="image to write (PNG; .pdf and .svg also work)")
    parser.add_argument("--resolution", action="append", help="only this resolution (repeatable), e.g. 3840x2160")
    parser.add_argument("--mode", action="append", help="only this mode (repeatable)")
    parser.add_argument("--title", help="plot title (default: scene, device, date)")
    args = parser.parse_args()

    report, memory, compute, points = load_report(args.json)
    if args.resolution:
        points = [p for p in points if p["resolution"] in args.resolution]
    if args.mode:
        points = [p for p in points if p["mode"] in args.mode]
    if not points:
        fail(f"{args.json}: no results match the --resolution/--mode filters")

    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.lines import Line2D
    except ImportError:
        fail(f"matplotlib is not available to {sys.executable}: install the Debian package python3-matplotlib "
             "(apt-get install -y python3-matplotlib, for /usr/bin/python3) or matplotlib from pip for this "
             "interpreter")

    ridge = compute / memory
    positive = [p["intensity"] for p in points if p["intensity"] > 0]
    x_lo = 10 ** math.floor(math.log10(min(positive + [ridge]) / 10))
    x_hi = 10 ** math.ceil(math.log10(max(positive + [ridge]) * 10))
    x_floor = x_lo * 1.5  # where stages without FLOPs are drawn
    for p in points:
        if p["intensity"] > 0:
            p["x"], p["y"], p["no_flops"] = p["intensity"], p["gflops"], False
        else:
            p["x"], p["y"], p["no_flops"] = x_floor, x_floor * p["gbps"], True
    ys = [p["y"] for p in points if p["y"] > 0]
    y_lo = 10 ** math.floor(math.log10(min(ys + [x_lo * memory]) / 2))
    y_hi = 10 ** math.ceil(math.log10(compute * 2))

    fig, ax = plt.subplots(figsize=(10, 7))
    xs = [x_lo, ridge, x_hi]
    ax.plot(xs, [min(compute, x * memory) for x in xs], color="black", linewidth=2)
    x_label = math.sqrt(x_lo * ridge)  # halfway up the memory roof (log scale), clear of the left edge
    ax.text(x_label, x_label * memory * 1.3, f"memory {memory:,.0f} GB/s", ha="right", fontsize=9)
    ax.text(x_hi / 1.2, compute * 1.1, f"FP32 {compute / 1000:,.1f} TFLOP/s", ha="right", fontsize=9)
    ax.axvline(ridge, color="grey", linestyle=":", linewidth=1)
    ax.text(ridge * 1.05, y_lo * 1.5, f"ridge {ridge:.1f} FLOP/B", fontsize=8, color="grey")
    if any(p["no_flops"] for p in points):
        ax.axvline(x_floor, color="lightgrey", linestyle="--", linewidth=1)

    modes = list(dict.fromkeys(p["mode"] for p in points))
    resolutions = list(dict.fromkeys(p["resolution"] for p in points))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    colour = {m: colours[i % len(colours)] for i, m in enumerate(modes)}
    crowded = {}  # labels already placed near a spot, so that coinciding points get stacked labels
    for p in points:
        if p["y"] <= 0:
            continue  # an untimed stage (0 ms) has no rate to show
        filled = p["resolution"] == resolutions[0]
        ax.scatter(p["x"], p["y"], marker=MARKERS[p["stage"]], s=55, zorder=3,
                   facecolors=colour[p["mode"]] if filled else "none", edgecolors=colour[p["mode"]])
        label = f"{p['stage']} {p['mode']}" + (f" {p['resolution']}" if len(resolutions) > 1 else "")
        if p["no_flops"]:
            label += " (no FLOPs)"
        spot = (round(math.log10(p["x"]), 1), round(math.log10(p["y"]), 1))
        above = crowded.get(spot, 0)
        crowded[spot] = above + 1
        ax.annotate(label, (p["x"], p["y"]), textcoords="offset points", xytext=(5, 3 - 7 * above), fontsize=6)

    handles = [Line2D([], [], color=colour[m], marker="o", linestyle="", label=m) for m in modes]
    handles += [Line2D([], [], color="black", marker=MARKERS[s], linestyle="", markerfacecolor="none", label=s)
                for s in STAGES]
    if len(resolutions) > 1:
        handles += [Line2D([], [], color="black", marker="o", linestyle="",
                           markerfacecolor="black" if i == 0 else "none", label=r) for i, r in enumerate(resolutions)]
    ax.legend(handles=handles, loc="lower right", fontsize=8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(x_lo, x_hi)
    ax.set_ylim(y_lo, y_hi)
    ax.set_xlabel("arithmetic intensity (FLOP / byte, analytic model)")
    ax.set_ylabel("achieved GFLOP/s (stage median time)")
    scene = report.get("scene", {})
    device = report.get("device", {})
    title = args.title or "{} ({:,} Gaussians) on {}, {}".format(
        str(scene.get("path", "?")).split("/")[-1], int(scene.get("gaussians", 0)), device.get("name", "?"),
        report.get("date", "?"))
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", linewidth=0.3)
    try:
        fig.savefig(args.png, dpi=150, bbox_inches="tight")
    except (OSError, ValueError) as e:
        fail(f"cannot write {args.png}: {e}")
    print(f"{args.png}: {len(points)} points, memory roof {memory:,.1f} GB/s, compute roof {compute:,.0f} GFLOP/s, "
          f"ridge {ridge:.2f} FLOP/B")


if __name__ == "__main__":
    main()
