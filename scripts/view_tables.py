#!/usr/bin/env python3
"""Markdown table of the viewer's figures from `rgs-view-bench --json` outputs (python3 standard library only).

    scripts/view_tables.py OUT/view_*.json                                        # print the table
    scripts/view_tables.py --update docs/BENCHMARKS.md --block view OUT/view_*.json   # replace it in place

One row per run (scripts/gpu_check.sh ... view leaves view_<name>.json under its OUT folder): the scene, the
views (a fly-through of its cameras, or a path around it), the frame size, the encoding (JPEG: whether the GPU or
the CPU encoded it) and views in flight; frames per second sustained; the latency from a view sent to its
frame received (median, p95, max); the median frame's bytes; and the server's medians of the frame's render
call (the front door's render, level-of-detail streaming included), its GPU stages, the read-back and the
encoding. Runs through rgs-view-bench's shaping relay (--shape-mbps) go in a second table: the link, the bandwidth
budget, frames per second, latency, Mbit/s received, the median frame, the quality and scale the budget chose
(medians) and the PSNR of the received frames against the lossless frames of their views (mean / min).
--update replaces the lines between the markers of the block, as scripts/bench_tables.py does. A file
that is not an rgs-view-bench report, or runs from different devices, is an error (exit 1).
"""
import argparse
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_tables import ShapeError, table, update  # noqa: E402


def load(path):
    try:
        with open(path, encoding="utf-8") as f:
            run = json.load(f)
    except (OSError, ValueError) as e:
        raise ShapeError(f"{path}: {e}") from None
    if not isinstance(run, dict) or run.get("tool") != "rgs-view-bench":
        raise ShapeError(f"{path}: not an rgs-view-bench report")
    for key in ("device", "scene", "width", "height", "encoding", "in_flight", "frames_per_second", "latency_ms",
                "bytes_per_frame", "server_median", "measured_frames"):
        if key not in run:
            raise ShapeError(f"{path}: no '{key}'")
    return run


def ms(v):
    return "–" if v is None else f"{v:.2f}"


def views(r):
    """The camera path: a fly-through of the scene's cameras, or a path or orbit around it."""
    if r.get("cameras") and r.get("fly"):
        return f"{r['fly']} through its cameras"
    return f"{r.get('views', '?')} {'on its cameras' if r.get('cameras') else 'on a path'}"


def encoding(r):
    """The encoding and quality, and for JPEG where it was encoded (the hello's encoder, when the report has it)."""
    text = f"{r['encoding']} q{r.get('quality', '')}".strip()
    if r["encoding"] == "jpeg" and r.get("encoder"):
        text += " (GPU)" if "nvJPEG" in r["encoder"] else " (CPU)"
    return text


def rows(runs):
    out = []
    for r in runs:
        s, lat = r["server_median"], r["latency_ms"]
        out.append([
            f"{r['scene']} ({r['gaussians'] / 1e6:.2f}M)" if r.get("gaussians") else r["scene"], views(r),
            f"{r['width']}×{r['height']}", encoding(r), str(r["in_flight"]),
            str(r["measured_frames"]), f"{r['frames_per_second']:.1f}",
            f"{lat['median']:.1f} / {lat['p95']:.1f} / {lat['max']:.1f}",
            f"{r['bytes_per_frame']['median'] / 1024:.0f} KiB",
            ms(s.get("render_call_ms")), ms(s.get("total_gpu_ms")), ms(s.get("readback_ms")), ms(s.get("encode_ms")),
            f"{s['splats'] / 1e6:.2f}M" if s.get("splats") else "–",
        ])
    return out


def shaped_rows(runs):
    out = []
    for r in runs:
        lat, sh, p = r["latency_ms"], r["shaping"], r.get("psnr_db") or {}
        out.append([
            f"{r['scene']} ({r['gaussians'] / 1e6:.2f}M)" if r.get("gaussians") else r["scene"], views(r),
            f"{r['width']}×{r['height']}", encoding(r), str(r["in_flight"]),
            f"{sh['mbps']:g} Mbit/s, {sh['rtt_ms']:g} ms", f"{r['max_mbps']:g}" if r.get("max_mbps") else "none",
            str(r["measured_frames"]), f"{r['frames_per_second']:.1f}",
            f"{lat['median']:.1f} / {lat['p95']:.1f} / {lat['max']:.1f}", ms(r.get("mbps")),
            f"{r['bytes_per_frame']['median'] / 1024:.0f} KiB",
            f"q{r['quality_median']:.0f}, {r['scale_median']:g}" if r.get("quality_median") is not None else "–",
            f"{ms(p.get('mean'))} / {ms(p.get('min'))} ({p.get('views', 0)})",
        ])
    return out


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("json", nargs="+", help="rgs-view-bench --json outputs")
    parser.add_argument("--update", metavar="FILE", help="replace the table between FILE's markers")
    parser.add_argument("--block", metavar="NAME", help="with --update: the markers of the block NAME")
    args = parser.parse_args(argv)
    try:
        runs = [load(p) for p in args.json]
        devices = {r["device"] for r in runs}
        if len(devices) != 1:
            raise ShapeError(f"runs from several devices: {sorted(devices)}")
        header = ["scene", "views", "frame", "encoding", "in flight", "frames", "frames/s", "latency ms median / p95 / max",
                  "frame bytes", "render call ms", "GPU stages ms", "read-back ms", "encode ms", "splats"]
        plain = [r for r in runs if not r.get("shaping")]
        shaped = [r for r in runs if r.get("shaping")]
        text = f"{devices.pop()}:\n\n" + "\n".join(table(header, rows(plain))) + "\n"
        if shaped:
            header = ["scene", "views", "frame", "encoding", "in flight", "link", "budget Mbit/s", "frames",
                      "frames/s", "latency ms median / p95 / max", "Mbit/s", "frame bytes", "quality, scale",
                      "PSNR dB vs lossless mean / min (views)"]
            text += "\nThrough rgs-view-bench's shaping relay:\n\n" + "\n".join(table(header, shaped_rows(shaped))) + "\n"
        if args.update:
            update(args.update, text, args.block)
            print(f"view_tables: updated {args.update} from {len(runs)} file(s)", file=sys.stderr)
        else:
            sys.stdout.write(text)
    except ShapeError as e:
        print(f"view_tables: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
