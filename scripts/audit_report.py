#!/usr/bin/env python3
"""Renders an rgs-audit JSON (schema "rgs-audit", version 2) and its worst-view images into one self-contained
HTML file: plots as inline SVG drawn by matplotlib, images as base64 PNG, no network access needed to open it.

    scripts/audit_report.py result.json report.html

rgs-audit calls it after each audit that writes a report (--report); on a host without python3-matplotlib
(the GPU host), run it, or `rgs-audit --report-from result.json --report report.html`, where it is installed.
Needs python3-matplotlib (Debian) and NumPy. Exit status: 0 ok, 1 failure (message on stderr).
"""
import base64
import html
import io
import json
import math
import os
import sys

try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
except ImportError as e:  # the caller prints how to make the HTML elsewhere
    sys.stderr.write(f"audit_report.py: needs python3-matplotlib and numpy ({e})\n")
    sys.exit(1)

SUPPORTED_SCHEMA = 2


def esc(v):
    return html.escape(str(v))


def num(v, digits=2):
    if isinstance(v, str):
        return v  # "inf"
    if v is None:
        return "–"
    return f"{v:.{digits}f}"


def as_float(v):
    if v == "inf":
        return math.inf
    if v == "-inf":
        return -math.inf
    return float(v)


def group(n):
    return f"{int(n):,}"


def read_netpbm(path):
    """Binary PPM (P6) or PGM (P5), maxval 255, as an [H, W, C] uint8 array."""
    with open(path, "rb") as f:
        data = f.read()
    fields, pos = [], 0
    while len(fields) < 4:
        while data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b"#":
            pos = data.index(b"\n", pos) + 1
            continue
        end = pos
        while not data[end:end + 1].isspace():
            end += 1
        fields.append(data[pos:end])
        pos = end
    pos += 1  # one whitespace byte after maxval
    magic, w, h, maxval = fields[0], int(fields[1]), int(fields[2]), int(fields[3])
    if magic not in (b"P5", b"P6") or maxval != 255:
        raise ValueError(f"{path}: not a binary 8-bit PPM/PGM")
    c = 3 if magic == b"P6" else 1
    return np.frombuffer(data, dtype=np.uint8, count=w * h * c, offset=pos).reshape(h, w, c)


def png_data_uri(rgb_or_grey, cmap=None):
    buf = io.BytesIO()
    img = rgb_or_grey
    if img.shape[2] == 1:
        plt.imsave(buf, img[:, :, 0], cmap=cmap or "gray", vmin=0, vmax=255, format="png")
    else:
        plt.imsave(buf, img, format="png")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def svg_of(fig):
    buf = io.StringIO()
    fig.savefig(buf, format="svg", bbox_inches="tight")
    plt.close(fig)
    text = buf.getvalue()
    return text[text.index("<svg"):]  # drop the XML prolog and DOCTYPE: inline SVG in HTML5


def colour(i):
    return plt.rcParams["axes.prop_cycle"].by_key()["color"][i % 10]


def plot_views(doc):
    views = [v["name"] for v in doc["views"]]
    x = np.arange(len(views))
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(10, 5.2), sharex=True)
    for i, c in enumerate(doc["candidates"]):
        psnr = [as_float(v["psnr_db"]) for v in c["views"]]
        finite = [p if math.isfinite(p) else np.nan for p in psnr]
        marker = "o" if len(views) <= 40 else None
        ax1.plot(x, finite, marker=marker, ms=3, lw=1.2, color=colour(i), label=c["label"])
        ax2.plot(x, [v["ssim"] for v in c["views"]], marker=marker, ms=3, lw=1.2, color=colour(i), label=c["label"])
    gate = doc.get("gate")
    if gate:
        ax1.axhline(gate["min_psnr_db"], color="crimson", ls="--", lw=1, label=f"--min-psnr {gate['min_psnr_db']:g}")
    ax1.set_ylabel("PSNR (dB)")
    ax2.set_ylabel("SSIM")
    ax2.set_xlabel("view")
    if len(views) <= 30:
        ax2.set_xticks(x)
        ax2.set_xticklabels(views, rotation=60, ha="right", fontsize=7)
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3)
        ax.ticklabel_format(axis="y", useOffset=False)
    ax1.legend(fontsize=8, loc="best")
    ax1.set_title("Per-view quality against the source render")
    return svg_of(fig)


def plot_sizes(doc):
    cands = doc["candidates"]
    names = sorted({s["name"] for c in cands for s in c["sections"]}, key=lambda n: [
        "means", "rotations", "scales", "opacities", "sh", "metadata", "provenance"].index(n) if n in [
        "means", "rotations", "scales", "opacities", "sh", "metadata", "provenance"] else 99)
    labels = ["source"] + [c["label"] for c in cands]
    fig, ax = plt.subplots(figsize=(10, 0.55 * len(labels) + 1.4))
    y = np.arange(len(labels))
    src = doc["source"]
    ax.barh(0, src["bytes_per_gaussian"], color="0.6", label="whole file" if src["sections"] == [] else None)
    left = np.zeros(len(cands))
    for k, n in enumerate(names):
        vals = np.array([next((s["bytes_per_gaussian"] for s in c["sections"] if s["name"] == n), 0.0) for c in cands])
        if vals.sum() > 0:
            ax.barh(y[1:], vals, left=left, color=colour(k), label=n)
            left += vals
    rest = np.array([c["bytes_per_gaussian"] for c in cands]) - left
    ax.barh(y[1:], rest, left=left, color="0.8", label="rest of file")
    ax.set_yticks(y)
    ax.set_yticklabels(labels)
    ax.invert_yaxis()
    ax.set_xlabel("bytes per Gaussian")
    ax.legend(fontsize=8, ncol=4, loc="lower right")
    ax.grid(axis="x", alpha=0.3)
    ax.set_title("Size per Gaussian, by section")
    return svg_of(fig)


def plot_size_quality(doc):
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for i, c in enumerate(doc["candidates"]):
        mean, low = as_float(c["psnr_db"]["mean"]), as_float(c["psnr_db"]["min"])
        if not math.isfinite(mean):
            continue
        ax.errorbar([c["bytes_per_gaussian"]], [mean], yerr=[[mean - low], [0]], fmt="o", color=colour(i), capsize=4)
        ax.annotate(c["label"], (c["bytes_per_gaussian"], mean), textcoords="offset points", xytext=(6, 4), fontsize=8)
    ax.set_xlabel("bytes per Gaussian")
    ax.set_ylabel("PSNR (dB): mean, bar down to the worst view")
    ax.grid(alpha=0.3)
    ax.set_title("Size against quality")
    return svg_of(fig)


def stats_row(name, s, unit):
    return f"<tr><td>{esc(name)}</td><td>{s['max']:.3e}</td><td>{s['rms']:.3e}</td><td>{esc(unit)}</td></tr>"


def candidate_section(doc, i, c, base_dir):
    out = [f"<section class='cand'><h2>{esc(c['label'])} <small>{esc(c['path'])} ({esc(c['format'])})</small></h2>"]
    out.append(f"<p>{group(c['bytes'])} bytes, {c['bytes_per_gaussian']:.2f} B/Gaussian, ratio {c.get('ratio', 0):.2f}x "
               f"to the source; PSNR mean {num(c['psnr_db']['mean'])} dB, min {num(c['psnr_db']['min'])} dB "
               f"(view {esc(c['worst_view'])}); SSIM mean {c['ssim']['mean']:.5f}, min {c['ssim']['min']:.5f}; "
               f"max |d| {c['max_abs_diff']:.4f}.</p>")
    out.append("<div class='cols'>")
    if c["sections"]:
        out.append("<table><tr><th>section</th><th>codec</th><th>bytes</th><th>B/Gaussian</th></tr>")
        for s in c["sections"]:
            out.append(f"<tr><td>{esc(s['name'])}</td><td>{esc(s['codec'])}</td><td>{group(s['bytes'])}</td>"
                       f"<td>{s['bytes_per_gaussian']:.3f}</td></tr>")
        ov = c.get("header_table_padding_bytes", 0)
        out.append(f"<tr><td>header, table, padding</td><td></td><td>{group(ov)}</td>"
                   f"<td>{ov / max(c['gaussians'], 1):.3f}</td></tr></table>")
    e = c.get("errors")
    if e:
        out.append("<table><tr><th>attribute error</th><th>max</th><th>rms</th><th>unit</th></tr>")
        out.append(stats_row("position", e["position_scene_units"], "scene units"))
        out.append(stats_row("rotation", e["rotation_deg"], "degrees"))
        if "scale_of_largest_axis" in e:  # reports before it existed show the per-axis relative error
            out.append(stats_row("scale", e["scale_of_largest_axis"], "of the Gaussian's largest axis"))
        else:
            out.append(stats_row("scale", e["scale_relative"], "relative"))
        out.append(stats_row("opacity", e["opacity"], "absolute"))
        for d in e["sh"]:
            out.append(stats_row(f"SH degree {d['degree']}", d["error"], "absolute"))
            for ch in d["channels"]:
                note = ""
                if "scale" in ch:
                    note = f"scale {ch['scale']:.3e}, {group(ch['clipped'])} clipped"
                out.append(stats_row(f"  {ch['channel']}", ch["error"], note))
        out.append("</table>")
    else:
        out.append(f"<p>{esc(c.get('errors_note', 'no per-attribute errors'))}</p>")
    out.append("</div>")
    if c["worst_views"]:
        out.append("<h3>Worst views: source, candidate, difference</h3>")
        for w in c["worst_views"]:
            if "source_image" not in w:
                continue
            imgs = []
            for key, cap, cmap in (("source_image", "source", None), ("candidate_image", c["label"], None),
                                   ("diff_image", f"|d| max over RGB, 0 to {w['heat_scale']:.4f}", "inferno")):
                uri = png_data_uri(read_netpbm(os.path.join(base_dir, w[key])), cmap)
                imgs.append(f"<figure><img class='view' alt='{esc(cap)}' src='{uri}'><figcaption>{esc(cap)}</figcaption>"
                            "</figure>")
            out.append(f"<div class='worst'><p><b>{esc(w['name'])}</b>: PSNR {num(w['psnr_db'])} dB</p>"
                       f"<div class='row'>{''.join(imgs)}</div></div>")
    out.append("</section>")
    return "\n".join(out)


def views_table(doc):
    cands = doc["candidates"]
    head = "".join(f"<th>{esc(c['label'])} PSNR</th><th>SSIM</th><th>max |d|</th>" for c in cands)
    rows = []
    for k, v in enumerate(doc["views"]):
        cells = "".join(f"<td>{num(c['views'][k]['psnr_db'])}</td><td>{c['views'][k]['ssim']:.5f}</td>"
                        f"<td>{c['views'][k]['max_abs_diff']:.4f}</td>" for c in cands)
        rows.append(f"<tr><td>{esc(v['name'])}</td><td>{v['width']}x{v['height']}</td>{cells}</tr>")
    return (f"<details><summary>Per-view table ({len(doc['views'])} views)</summary><table>"
            f"<tr><th>view</th><th>size</th>{head}</tr>{''.join(rows)}</table></details>")


CSS = """
body{font:14px/1.4 system-ui,sans-serif;margin:24px auto;max-width:1400px;color:#222;padding:0 16px}
h1{font-size:22px}h2{font-size:18px;border-top:1px solid #ccc;padding-top:12px}h2 small{font-weight:normal;color:#666}
table{border-collapse:collapse;margin:8px 16px 8px 0;font-size:13px}td,th{border:1px solid #ddd;padding:2px 8px;
text-align:right}td:first-child,th:first-child{text-align:left;white-space:pre}.cols{display:flex;flex-wrap:wrap;
align-items:flex-start}.row{display:flex;gap:8px}figure{margin:0;flex:1}img.view{width:100%;image-rendering:auto;
border:1px solid #ccc}figcaption{font-size:12px;color:#555}.plot svg{max-width:100%;height:auto}
.gate-pass{color:#17702b}.gate-fail{color:#b00020}
"""

# Marks the page once every image has decoded and every plot is laid out; the report test reads it.
CHECK_JS = """
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.querySelectorAll('img'));
  var okImgs = imgs.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length;
  var plots = Array.prototype.slice.call(document.querySelectorAll('.plot svg'));
  var okPlots = plots.filter(function (s) { var r = s.getBoundingClientRect(); return r.width > 50 && r.height > 50; }).length;
  document.body.setAttribute('data-render-check',
    'images ' + okImgs + '/' + imgs.length + ' plots ' + okPlots + '/' + plots.length);
});
"""


def main(argv):
    if len(argv) != 3:
        sys.stderr.write("usage: audit_report.py RESULT.json REPORT.html\n")
        return 2
    json_path, html_path = argv[1], argv[2]
    with open(json_path, encoding="utf-8") as f:
        doc = json.load(f)
    if doc.get("schema") != "rgs-audit" or doc.get("schema_version") != SUPPORTED_SCHEMA:
        sys.stderr.write(f"audit_report.py: {json_path}: not an rgs-audit JSON of schema version {SUPPORTED_SCHEMA}\n")
        return 1
    base_dir = os.path.dirname(os.path.abspath(json_path))
    src = doc["source"]
    cands = doc["candidates"]
    parts = [f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>rgs-audit: {esc(src['label'])} "
             f"{esc(os.path.basename(src['path']))}</title><style>{CSS}</style><script>{CHECK_JS}</script></head><body>"]
    parts.append(f"<h1>rgs-audit: {esc(src['path'])}</h1>")
    first = doc["views"][0]
    gate = doc.get("gate")
    gate_html = ""
    if gate:
        cls = "gate-pass" if gate["passed"] else "gate-fail"
        gate_html = (f"; gate --min-psnr {gate['min_psnr_db']:g} dB: <b class='{cls}'>"
                     f"{'passed' if gate['passed'] else 'FAILED'}</b>")
    parts.append(f"<p>Source: {esc(src['format'])}, {group(src['gaussians'])} Gaussians (SH degree {src['sh_degree']}), "
                 f"{group(src['bytes'])} bytes ({src['bytes_per_gaussian']:.1f} B/Gaussian). {len(doc['views'])} views "
                 f"({first['width']}x{first['height']} first), {len(cands)} candidate(s); backend "
                 f"<b>{esc(doc['backend'])}</b> ({esc(doc['device'])}), {esc(doc['renderer'])}; "
                 f"{doc['time_seconds']['total']:.1f} s{gate_html}. rgs-audit {esc(doc.get('tool_version', ''))}.</p>")
    parts.append("<table><tr><th>candidate</th><th>format</th><th>bytes</th><th>B/Gaussian</th><th>ratio</th>"
                 "<th>PSNR mean</th><th>PSNR min</th><th>SSIM mean</th><th>SSIM min</th><th>max |d|</th></tr>")
    for c in cands:
        parts.append(f"<tr><td>{esc(c['label'])}</td><td>{esc(c['format'])}</td><td>{group(c['bytes'])}</td>"
                     f"<td>{c['bytes_per_gaussian']:.2f}</td><td>{c.get('ratio', 0):.2f}x</td>"
                     f"<td>{num(c['psnr_db']['mean'])}</td><td>{num(c['psnr_db']['min'])}</td>"
                     f"<td>{c['ssim']['mean']:.5f}</td><td>{c['ssim']['min']:.5f}</td><td>{c['max_abs_diff']:.4f}</td></tr>")
    parts.append("</table>")
    if len(cands) > 1:
        parts.append(f"<div class='plot'>{plot_size_quality(doc)}</div>")
    parts.append(f"<div class='plot'>{plot_views(doc)}</div>")
    parts.append(views_table(doc))
    parts.append(f"<div class='plot'>{plot_sizes(doc)}</div>")
    for i, c in enumerate(cands):
        parts.append(candidate_section(doc, i, c, base_dir))
    parts.append(f"<p><small>PSNR: {esc(doc['metrics']['psnr'])}. SSIM: {esc(doc['metrics']['ssim'])}. "
                 f"max |d|: {esc(doc['metrics']['max_abs_diff'])}. Command: <code>{esc(doc.get('command', ''))}</code>"
                 "</small></p></body></html>\n")
    text = "\n".join(parts)
    tmp = html_path + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
    os.replace(tmp, html_path)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv))
    except (OSError, ValueError, KeyError) as e:
        sys.stderr.write(f"audit_report.py: {e}\n")
        sys.exit(1)
