#!/usr/bin/env python3
"""Level-of-detail quality against splat budget and pixel error, scored as the field scores it: against the full
scene rendered 2x2 supersampled, with the plain full render's own score beside it as the aliasing floor
(docs/LOD.md#measuring-quality).

    scripts/lod_fidelity.py SCENE_LOD.rgs [SCENE_LOD.rgs ...] (--cameras cameras.json --fly N | --path N)
        [--width 320] [--height H] [--budgets 0,250000,1000000] [--pixel-errors 0.5,1,2,4]
        [--backend cpu|cuda] [--stream-bytes N] [--out DIR] [--update-doc docs/LOD.md] [--tools build/tools] [--jobs N]

For each scene, every view of the camera path is rendered by rgs-render:
- the reference: the full detail (`--no-lod`) at twice the width and height (the camera's fx, fy, cx, cy doubled),
  area-downsampled 2x2 (each output pixel the mean of its four sub-pixels), as lab::area_downsample_2x does;
- the floor: the plain full render at the width and height, scored against the reference;
- the budget sweep: the levels at each splat budget B of --budgets with `--pixel-error 0` (the budget alone chooses);
- the pixel-error sweep: the levels at each pixel error E of --pixel-errors with no budget (`--splat-budget 0`).
With --backend cuda the level-of-detail frames are the streamer's, each settled by rgs-render (streamed before it is
drawn, within --stream-bytes a request, passed to rgs-render), so each view draws its own selection.
Each render gets PSNR (clamped RGB, peak 1) and SSIM (11x11 Gaussian window, sigma 1.5, valid windows, the
definition of runtime::ssim_rgb) against the reference, mean and min over the views, and its popping: the mean over
consecutive views of mean |I_t - I_(t-1)| (clamped RGB, all pixels and channels, 8-bit levels) minus the same of the
plain full render.

Writes into --out (default lod_quality/): lod_quality.md (the tables and the rule below), lod_quality.json (every
figure) and lod_quality.png (PSNR against splats a view, one curve per scene with its floor; needs matplotlib,
else only a note). The rule: the default pixel error is the largest swept E whose mean PSNR is within 1 dB of the
floor's; the budget at which quality drops 3 dB is the smallest swept budget whose mean PSNR is within 3 dB of the
floor's above every swept budget that drops further. With --update-doc, the block between the markers
`<!-- lod_fidelity -->` and `<!-- /lod_fidelity -->` of that file is replaced by the tables, and the plot is
copied beside it.
Needs NumPy. Exit status: 0 ok, 1 a failed render or a missing marker, 2 usage.
"""
import argparse
import json
import multiprocessing
import os
import re
import shutil
import subprocess
import sys
import tempfile

import numpy as np

MARK_BEGIN, MARK_END = "<!-- lod_fidelity -->", "<!-- /lod_fidelity -->"


def read_pfm(path):
    with open(path, "rb") as f:
        if f.readline().strip() != b"PF":
            raise ValueError(f"{path}: not a colour PFM")
        width, height = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    # PFM stores the bottom row first.
    return data.reshape(height, width, 3)[::-1].astype(np.float64)


def area_downsample_2x(image):
    """[2H, 2W, C] -> [H, W, C]: each pixel the mean of its 2x2 block (lab::area_downsample_2x)."""
    h, w = image.shape[0] // 2, image.shape[1] // 2
    return image.reshape(h, 2, w, 2, -1).mean(axis=(1, 3))


def _ssim_window():
    g = np.exp(-(np.arange(-5, 6) ** 2) / (2 * 1.5 ** 2))
    return g / g.sum()


def _filter_valid(plane, g):
    rows = sum(g[k] * plane[:, k:plane.shape[1] - 10 + k] for k in range(11))
    return sum(g[k] * rows[k:rows.shape[0] - 10 + k, :] for k in range(11))


def ssim(a, b):
    """Mean SSIM of clamped [H, W, 3] images: runtime::ssim_rgb's definition, filtered in float32 (the mean SSIM
    agrees with the float64 definition to about 1e-5)."""
    g, total = _ssim_window().astype(np.float32), 0.0
    for c in range(3):
        x, y = a[..., c].astype(np.float32), b[..., c].astype(np.float32)
        mx, my = _filter_valid(x, g), _filter_valid(y, g)
        vx = _filter_valid(x * x, g) - mx * mx
        vy = _filter_valid(y * y, g) - my * my
        cxy = _filter_valid(x * y, g) - mx * my
        s = (2 * mx * my + 1e-4) * (2 * cxy + 9e-4) / ((mx * mx + my * my + 1e-4) * (vx + vy + 9e-4))
        total += float(s.mean(dtype=np.float64))
    return total / 3


def score_view(task):
    """PSNR, SSIM against the reference and the clamped image, of one view's PFM."""
    reference_path, candidate_path = task
    reference = np.load(reference_path)
    candidate = np.clip(np.nan_to_num(read_pfm(candidate_path)), 0.0, 1.0)
    mse = float(np.mean((reference - candidate) ** 2))
    psnr = float("inf") if mse == 0 else 10 * np.log10(1 / mse)
    return psnr, ssim(reference, candidate), candidate


def view_names(directory):
    return sorted(n for n in os.listdir(directory) if n.endswith(".pfm"))


class Renderer:
    def __init__(self, args):
        self.args = args

    def render(self, scene, out_dir, width, height, extra):
        a = self.args
        cameras = ["--cameras", a.cameras, "--fly", str(a.fly)] if a.cameras else ["--path", str(a.path)]
        cmd = [os.path.join(a.tools, "rgs-render"), scene, "-o", out_dir, *cameras, "--width", str(width),
               "--height", str(height), "--pfm", "--format", "ppm", "--backend", a.backend, *extra]
        run = subprocess.run(cmd, capture_output=True, text=True)
        if run.returncode != 0:
            sys.stderr.write(f"lod_fidelity.py: {' '.join(cmd)} failed:\n{run.stderr}")
            sys.exit(1)
        splats = [int(s.replace(",", "")) for s in re.findall(r"([\d,]+) splats", run.stderr)]
        return sum(splats) / len(splats) if splats else None


def full_detail_count(tools, scene):
    info = subprocess.run([os.path.join(tools, "rgs-info"), scene], capture_output=True, text=True, check=True).stdout
    full = re.search(r"full detail ([\d,]+) Gaussians", info)
    if not full:
        sys.stderr.write(f"lod_fidelity.py: rgs-info {scene} shows no levels of detail\n")
        sys.exit(1)
    return int(full.group(1).replace(",", ""))


def score_render(pool, references, out_dir, splats, label):
    names = view_names(out_dir)
    results = pool.map(score_view, [(references[n], os.path.join(out_dir, n)) for n in names])
    psnr = [r[0] for r in results]
    changes = [float(np.mean(np.abs(results[i][2] - results[i - 1][2]))) * 255 for i in range(1, len(results))]
    finite = [p for p in psnr if np.isfinite(p)]
    return {"render": label, "splats": splats, "views": len(names),
            "psnr_mean": float(np.mean(finite)) if len(finite) == len(psnr) else float("inf"),
            "psnr_min": float(min(psnr)), "ssim_mean": float(np.mean([r[1] for r in results])),
            "frame_change_8bit": float(np.mean(changes)) if changes else 0.0}


def sweep_scene(args, pool, scene, work):
    """Every render of one scene, scored; returns the scene's figures."""
    renderer, w, h = Renderer(args), args.width, args.height
    full = full_detail_count(args.tools, scene)
    ref_dir = os.path.join(work, "reference")
    renderer.render(scene, ref_dir, 2 * w, 2 * h, ["--no-lod"])
    references = {}
    for name in view_names(ref_dir):
        image = np.clip(np.nan_to_num(read_pfm(os.path.join(ref_dir, name))), 0.0, 1.0)
        references[name] = os.path.join(work, name + ".npy")
        np.save(references[name], area_downsample_2x(image))
        os.remove(os.path.join(ref_dir, name))
    rows = []

    def measure(label, extra, kind, value):
        out = os.path.join(work, f"render{len(rows)}")
        splats = renderer.render(scene, out, w, h, extra)
        row = score_render(pool, references, out, splats if splats is not None else full, label)
        row.update({"kind": kind, "value": value})
        rows.append(row)
        shutil.rmtree(out)

    measure("full detail (floor)", ["--no-lod"], "floor", None)
    stream = ["--stream-bytes", args.stream_bytes] if args.stream_bytes and args.backend == "cuda" else []
    for budget in (int(float(b)) for b in args.budgets.split(",") if b):
        measure(f"levels, budget {budget:,}", ["--splat-budget", str(budget), "--pixel-error", "0", *stream],
                "budget", budget)
    for error in (float(e) for e in args.pixel_errors.split(",") if e):
        measure(f"levels, pixel error {error:g}", ["--splat-budget", "0", "--pixel-error", f"{error:g}", *stream],
                "error", error)
    floor = rows[0]
    for r in rows:
        r["popping_8bit"] = r["frame_change_8bit"] - floor["frame_change_8bit"]
    return {"scene": scene, "full_detail": full, "rows": rows}


def rule(result):
    """The default pixel error (the largest within 1 dB of the floor) and the 3 dB budget (the smallest swept budget
    within 3 dB of the floor, above every swept budget that drops further; None when none drops 3 dB)."""
    floor = result["rows"][0]["psnr_mean"]
    errors = [r for r in result["rows"] if r["kind"] == "error" and r["psnr_mean"] >= floor - 1]
    budgets = sorted((r for r in result["rows"] if r["kind"] == "budget" and r["value"] > 0), key=lambda r: r["value"])
    dropped = [i for i, r in enumerate(budgets) if r["psnr_mean"] < floor - 3]
    budget_3db = None
    if dropped:
        budget_3db = budgets[dropped[-1] + 1]["value"] if dropped[-1] + 1 < len(budgets) else "every swept"
    return (max(errors, key=lambda r: r["value"])["value"] if errors else None), budget_3db


def markdown(results, args):
    path = f"`--cameras {os.path.basename(args.cameras)} --fly {args.fly}`" if args.cameras else f"`--path {args.path}`"
    lines = [f"{args.width}x{args.height}, {path}, `--backend {args.backend}`; PSNR and SSIM against the full detail "
             "rendered 2x2 supersampled; popping in 8-bit levels.", ""]
    for res in results:
        default_error, budget_3db = rule(res)
        lines += [f"**{os.path.basename(res['scene'])}** ({res['full_detail']:,} Gaussians at full detail)", "",
                  "| render | splats a view | PSNR mean / min dB | SSIM | popping |", "|---|---|---|---|---|"]
        for r in res["rows"]:
            lines.append(f"| {r['render']} | {r['splats']:,.0f} | {r['psnr_mean']:.2f} / {r['psnr_min']:.2f} | "
                         f"{r['ssim_mean']:.4f} | {r['popping_8bit']:+.3f} |")
        lines += ["", "Rule: the default pixel error is the largest swept one within 1 dB of the floor's PSNR: "
                  + (f"**{default_error:g} px**" if default_error is not None else "none of those swept") +
                  "; the budget under which PSNR drops more than 3 dB below the floor's: "
                  + (f"**{budget_3db:,} splats** (the smallest swept budget within 3 dB)" if isinstance(budget_3db, int)
                     else "every swept budget drops 3 dB" if budget_3db else "none of those swept drops 3 dB")
                  + ".", ""]
    return "\n".join(lines)


def plot(results, path):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return "matplotlib missing: no plot (rerun with --plot-from OUT/lod_quality.json where it is installed)"
    # PSNR against each scene's own floor, so scenes whose floors lie tens of dB apart share one axis, and the rule's
    # 1 dB is one line across them.
    fig, ax = plt.subplots(figsize=(10, 4.5))
    for i, res in enumerate(results):
        colour = f"C{i}"
        name = os.path.basename(res["scene"])
        floor = res["rows"][0]["psnr_mean"]
        curve = sorted((r["splats"], r["psnr_mean"] - floor) for r in res["rows"]
                       if r["kind"] == "budget" and r["value"] > 0)
        if curve:
            ax.plot([c[0] for c in curve], [c[1] for c in curve], "o-", color=colour, label=f"{name}: budget")
        errors = sorted((r["splats"], r["psnr_mean"] - floor, r["value"]) for r in res["rows"] if r["kind"] == "error")
        ax.plot([e[0] for e in errors], [e[1] for e in errors], "^:", color=colour, label=f"{name}: pixel error")
        for s, p, e in errors:
            ax.annotate(f"{e:g} px", (s, p), textcoords="offset points", xytext=(4, -10), fontsize=7)
    ax.axhline(0, color="black", linewidth=0.8, label="full render (floor)")
    ax.axhline(-1, color="grey", linestyle="--", linewidth=0.8, label="1 dB below the floor (the rule)")
    ax.set_xscale("log")
    ax.set_xlabel("splats a view")
    ax.set_ylabel("PSNR above the floor, dB")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return f"wrote {path}"


def update_doc(doc, table, png):
    with open(doc) as f:
        text = f.read()
    if MARK_BEGIN not in text or MARK_END not in text:
        sys.stderr.write(f"lod_fidelity.py: {doc} has no {MARK_BEGIN} ... {MARK_END} block\n")
        sys.exit(1)
    head, rest = text.split(MARK_BEGIN, 1)
    tail = rest.split(MARK_END, 1)[1]
    with open(doc, "w") as f:
        f.write(f"{head}{MARK_BEGIN}\n{table}\n![LOD quality](lod_quality.png)\n\n{MARK_END}{tail}")
    if os.path.exists(png):
        shutil.copy(png, os.path.join(os.path.dirname(doc), "lod_quality.png"))


def parse_args():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenes", nargs="*", help="level-of-detail .rgs files (rgs-convert --lod-levels auto)")
    parser.add_argument("--cameras", help="INRIA cameras.json, flown with --fly")
    parser.add_argument("--fly", type=int, default=16, help="views flown through --cameras")
    parser.add_argument("--path", type=int, default=16, help="without --cameras: views of the spiral around the scene")
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--height", type=int, default=180)
    parser.add_argument("--budgets", default="100000,300000,1000000,3000000")
    parser.add_argument("--pixel-errors", default="0.5,1,2,4")
    parser.add_argument("--backend", default="cpu", choices=["cpu", "cuda"])
    parser.add_argument("--stream-bytes", help="--backend cuda: rgs-render's --stream-bytes (e.g. 8GiB)")
    parser.add_argument("--out", default="lod_quality")
    parser.add_argument("--update-doc", help="Markdown file whose lod_fidelity block receives the tables")
    parser.add_argument("--plot-from", help="only redraw the plot (and --update-doc) from this lod_quality.json")
    parser.add_argument("--work", help="directory for the renders (default: a temporary one, removed)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count())
    parser.add_argument("--tools", default=os.path.join(os.path.dirname(__file__), "..", "build", "tools"))
    args = parser.parse_args()
    if not args.scenes and not args.plot_from:
        parser.error("give a scene or --plot-from")
    return args


def main():
    args = parse_args()
    os.makedirs(args.out, exist_ok=True)
    if args.plot_from:
        with open(args.plot_from) as f:
            saved = json.load(f)
        results, table = saved["scenes"], saved["markdown"]
    else:
        work = args.work or tempfile.mkdtemp(prefix="lod_fidelity.")
        results = []
        with multiprocessing.Pool(max(1, args.jobs)) as pool:
            for i, scene in enumerate(args.scenes):
                scene_work = os.path.join(work, f"scene{i}")
                os.makedirs(scene_work, exist_ok=True)
                results.append(sweep_scene(args, pool, scene, scene_work))
        if not args.work:
            shutil.rmtree(work)
        table = markdown(results, args)
        with open(os.path.join(args.out, "lod_quality.json"), "w") as f:
            json.dump({"scenes": results, "markdown": table}, f, indent=1)
        with open(os.path.join(args.out, "lod_quality.md"), "w") as f:
            f.write(table + "\n")
    png = os.path.join(args.out, "lod_quality.png")
    note = plot(results, png)
    print(table)
    print(note)
    if args.update_doc:
        update_doc(args.update_doc, table, png)
    return 0


if __name__ == "__main__":
    sys.exit(main())
