#!/usr/bin/env python3
"""Renders an rgs-audit JSON (schema "rgs-audit", version 4) and its worst-view images into one self-contained
HTML file: plots as inline SVG drawn by matplotlib, images as base64 PNG, the source/candidate slider as inline
JavaScript; no network access needed to open it.

The page opens with the verdict (the JSON's "verdict": each candidate's mean PSNR in the verdict's metric, the
foreground PSNR where the source has background, against the threshold, the whole frame's beside it, its worst
view and the bytes it saves); each candidate's heatmaps are drawn on its own "heat_scale" (a percentile of its
|d|) under its own colour bar, with the largest |d| written; the PSNR plots show the threshold on a y axis at
least MIN_PSNR_SPAN_DB wide.

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

SUPPORTED_SCHEMA = 4
# The PSNR axes span at least this many dB (threshold included), so that a fraction of a dB between views does
# not fill the plot.
MIN_PSNR_SPAN_DB = 10.0
HEAT_CMAP = "inferno"
# The size-against-quality plot stops here: higher means (lossless files, PSNR limited by float arithmetic) are
# drawn at this edge with their value written, so that they do not flatten the lossy candidates.
SIZE_QUALITY_TOP_DB = 100.0


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


def finite_or_nan(v):
    f = as_float(v) if v is not None else math.nan
    return f if math.isfinite(f) else np.nan


def psnr_limits(values, lines):
    """y limits (dB) holding every finite value and every line, at least MIN_PSNR_SPAN_DB wide."""
    pts = [v for v in list(values) + list(lines) if v is not None and math.isfinite(v)]
    if not pts:
        return 0.0, MIN_PSNR_SPAN_DB
    lo, hi = min(pts), max(pts)
    if hi - lo < MIN_PSNR_SPAN_DB:
        mid = (lo + hi) / 2
        lo, hi = mid - MIN_PSNR_SPAN_DB / 2, mid + MIN_PSNR_SPAN_DB / 2
    pad = 0.05 * (hi - lo)
    return lo - pad, hi + pad


def threshold_lines(ax, doc):
    """The verdict's threshold and the --min-psnr gate as horizontal lines; returns their values."""
    lines = []
    verdict = doc.get("verdict")
    what = metric_words(doc)
    if verdict:
        t = verdict["threshold_db"]
        ax.axhline(t, color="crimson", ls="-", lw=1.2, label=f"threshold {t:g} dB (mean, {what})")
        lines.append(t)
    gate = doc.get("gate")
    if gate:
        g = gate["min_psnr_db"]
        ax.axhline(g, color="crimson", ls=":", lw=1.2, label=f"--min-psnr {g:g} dB (each view, {what})")
        lines.append(g)
    return lines


def metric_words(doc):
    """What the verdict and the gate compare, in words."""
    return "foreground" if (doc.get("verdict") or {}).get("metric") == "foreground" else "whole frame"


def plot_views(doc):
    views = [v["name"] for v in doc["views"]]
    x = np.arange(len(views))
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(10, 5.2), sharex=True)
    shown = []
    for i, c in enumerate(doc["candidates"]):
        finite = [finite_or_nan(v["psnr_db"]) for v in c["views"]]
        marker = "o" if len(views) <= 40 else None
        ax1.plot(x, finite, marker=marker, ms=3, lw=1.2, color=colour(i), label=f"{c['label']} (whole frame)")
        shown += finite
        fg = [finite_or_nan(v.get("foreground_psnr_db")) for v in c["views"]]
        if any(math.isfinite(f) for f in fg):
            ax1.plot(x, fg, marker=marker, ms=3, lw=1.0, ls="--", color=colour(i), label=f"{c['label']} (foreground)")
            shown += fg
        ax2.plot(x, [v["ssim"] for v in c["views"]], marker=marker, ms=3, lw=1.2, color=colour(i), label=c["label"])
    ax1.set_ylim(*psnr_limits(shown, threshold_lines(ax1, doc)))
    ssim_low = min([v["ssim"] for c in doc["candidates"] for v in c["views"]] + [1.0])
    ax2.set_ylim(min(ssim_low, 0.99) - 0.0005, 1.0005)  # at least 0.01 wide, 1 at the top
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


def curve_name(label):
    """"archive@40" -> "archive": candidates labelled SERIES@POINT are drawn as one rate-distortion curve."""
    return label.split("@", 1)[0] if "@" in label else None


def plot_size_quality(doc):
    fig, ax = plt.subplots(figsize=(7, 4.5))
    shown = []
    curves = {}
    for i, c in enumerate(doc["candidates"]):
        mean, low = as_float(c["psnr_db"]["mean"]), as_float(c["psnr_db"]["min"])
        if not math.isfinite(mean) or c["bytes_per_gaussian"] <= 0:
            continue
        shown += [min(mean, SIZE_QUALITY_TOP_DB), min(low, SIZE_QUALITY_TOP_DB)]
        name = curve_name(c["label"])
        if name is not None:
            curves.setdefault(name, []).append((c["bytes_per_gaussian"], mean, low))
            continue
        if mean > SIZE_QUALITY_TOP_DB:  # near-lossless: drawn at the top edge, its value written
            ax.plot([c["bytes_per_gaussian"]], [SIZE_QUALITY_TOP_DB], "^", color=colour(i))
            ax.annotate(f"{c['label']} ({mean:.0f} dB)", (c["bytes_per_gaussian"], SIZE_QUALITY_TOP_DB),
                        textcoords="offset points", xytext=(6, -10), fontsize=8)
            continue
        ax.errorbar([c["bytes_per_gaussian"]], [mean], yerr=[[mean - low], [0]], fmt="o", color=colour(i), capsize=4)
        ax.annotate(c["label"], (c["bytes_per_gaussian"], mean), textcoords="offset points", xytext=(6, 4), fontsize=8)
    for k, (name, points) in enumerate(sorted(curves.items())):
        x, mean, low = (np.array(v) for v in zip(*sorted(points)))
        ax.plot(x, mean, "-s", color=colour(len(doc["candidates"]) + k), markersize=4, label=f"{name}: mean")
        ax.plot(x, low, ":", color=colour(len(doc["candidates"]) + k), label=f"{name}: worst view")
    ax.set_ylim(*psnr_limits(shown, threshold_lines(ax, doc)))
    sizes = [c["bytes_per_gaussian"] for c in doc["candidates"] if c["bytes_per_gaussian"] > 0]
    if sizes and max(sizes) > 8 * min(sizes):
        ax.set_xscale("log")
    if doc.get("verdict") or doc.get("gate") or curves:
        ax.legend(fontsize=8, loc="lower right")
    ax.set_xlabel("bytes per Gaussian")
    ax.set_ylabel("PSNR (dB): mean, bar down to the worst view")
    ax.grid(alpha=0.3, which="both")
    ax.set_title("Size against quality" + (": rate-distortion curves (labels SERIES@POINT) and points" if curves else ""))
    return svg_of(fig)


def colour_bar(scale, largest):
    """A candidate's colour bar, 0 to `scale` (|d|; larger values at the top colour, up to `largest`), as inline
    SVG."""
    fig, ax = plt.subplots(figsize=(6, 0.9))
    fig.colorbar(matplotlib.cm.ScalarMappable(norm=matplotlib.colors.Normalize(0, scale), cmap=HEAT_CMAP), cax=ax,
                 orientation="horizontal", extend="max" if largest > scale else "neither")
    ax.set_xlabel(f"|d|, max over R, G, B (clamped values); largest {largest:.4f}", fontsize=9)
    ax.tick_params(labelsize=8)
    return svg_of(fig)


def verdict_html(doc):
    """The page's first line: pass/fail per candidate against the threshold, worst view, bytes saved."""
    v = doc.get("verdict")
    if not v:
        return ("<div id='verdict' class='verdict'><b>No verdict</b>: this JSON was written before rgs-audit had "
                "one (run the audit again).</div>")
    t = v["threshold_db"]
    cands = doc["candidates"]
    passed = sum(1 for c in cands if c["verdict"]["passed"])
    metric = v.get("metric", "whole_frame")
    what = metric_words(doc)
    head = (f"<b class='{'gate-pass' if v['passed'] else 'gate-fail'}'>{'PASS' if v['passed'] else 'FAIL'}</b>: "
            f"{passed} of {len(cands)} candidate(s) have a mean {what} PSNR over the views of at least {t:g} dB")
    items = []
    for c in cands:
        cv = c["verdict"]
        ok = cv["passed"]
        saved = cv.get("bytes_saved")
        if saved is None:
            size = "no file size"
        elif saved >= 0:
            size = f"saves {group(saved)} bytes ({100 * cv['bytes_saved_fraction']:.0f}% of the source)"
        else:
            size = f"adds {group(-saved)} bytes ({-100 * cv['bytes_saved_fraction']:.0f}% of the source)"
        wv = cv["worst_view"]
        beside = (f" (whole frame {num(cv['whole_frame_psnr_mean_db'])} dB)" if metric == "foreground" else "")
        items.append(
            f"<li class='verdict-cand' data-label='{esc(c['label'])}' data-passed='{str(ok).lower()}' "
            f"data-metric='{esc(metric)}' data-psnr-mean='{esc(num(cv['psnr_mean_db']))}' "
            f"data-worst-view='{esc(wv['name'])}' data-worst-psnr='{esc(num(wv['psnr_db']))}'>"
            f"<b class='{'gate-pass' if ok else 'gate-fail'}'>{'PASS' if ok else 'FAIL'}</b> {esc(c['label'])}: "
            f"mean {what} PSNR {num(cv['psnr_mean_db'])} dB {'&ge;' if ok else '&lt;'} {t:g} dB{beside}; worst "
            f"view {esc(wv['name'])} {num(wv['psnr_db'])} dB; {size}</li>")
    why = (" The foreground PSNR decides: the black background raises the whole-frame PSNR (below)."
           if metric == "foreground" else "")
    return (f"<div id='verdict' class='verdict' data-passed='{str(v['passed']).lower()}' data-threshold='{t:g}' "
            f"data-metric='{esc(metric)}'>{head} (rgs-audit --threshold).{why}<ul>{''.join(items)}</ul></div>")


def background_note(doc):
    """Why the whole-frame PSNR is inflated by the black background, with this audit's numbers."""
    fractions = [v["foreground_fraction"] for c in doc["candidates"][:1] for v in c["views"]
                 if "foreground_fraction" in v]
    if not fractions or min(fractions) >= 1.0:
        return ""
    f = sum(fractions) / len(fractions)
    extra = 10 * math.log10(1 / f) if f > 0 else math.inf
    return (f"<p class='note'>The renders have a black background, equal in both images, and the scene covers "
            f"{100 * f:.0f}% of the frame on average: the background's zero errors dilute the whole-frame MSE, "
            f"raising its PSNR by 10&middot;log10(1/{f:.2f}) = {extra:.1f} dB for the same error on the scene, so "
            f"the foreground PSNR (over the pixels where the source render's alpha or colour is not background) "
            f"is the one to compare between scenes.</p>")


def stats_row(name, s, unit):
    return f"<tr><td>{esc(name)}</td><td>{s['max']:.3e}</td><td>{s['rms']:.3e}</td><td>{esc(unit)}</td></tr>"


def compare_widget(src_uri, cand_uri, label):
    """Source and candidate stacked; the slider moves the split (source left, candidate right), flip swaps
    between all source and all candidate. Driven by SLIDER_JS."""
    return ("<figure class='compare' data-split='50'><div class='stack'>"
            f"<img class='view under' alt='source' src='{src_uri}'>"
            f"<img class='view over' alt='{esc(label)}' src='{cand_uri}' style='clip-path: inset(0 0 0 50%)'>"
            "<div class='divider' style='left: 50%'></div></div>"
            "<div class='controls'><input type='range' class='slider' min='0' max='100' value='50' "
            f"aria-label='split between source and {esc(label)}'><button type='button' class='flip'>flip</button>"
            "</div>"
            f"<figcaption>left of the line: source, right: {esc(label)} (drag, or flip)</figcaption></figure>")


def candidate_section(doc, i, c, base_dir):
    out = [f"<section class='cand'><h2>{esc(c['label'])} <small>{esc(c['path'])} ({esc(c['format'])})</small></h2>"]
    fg = c.get("foreground_psnr_db") or {}
    fg_text = (f"foreground PSNR mean {num(fg.get('mean'))} dB, min {num(fg.get('min'))} dB; " if fg else "")
    out.append(f"<p>{group(c['bytes'])} bytes, {c['bytes_per_gaussian']:.2f} B/Gaussian, ratio {c.get('ratio', 0):.2f}x "
               f"to the source; PSNR mean {num(c['psnr_db']['mean'])} dB, min {num(c['psnr_db']['min'])} dB "
               f"(view {esc(c['worst_view'])}); {fg_text}SSIM mean {c['ssim']['mean']:.5f}, min {c['ssim']['min']:.5f}; "
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
        pairing = e.get("pairing")  # reports before it existed paired index by index
        if pairing and pairing["method"] == "content":
            text = (f"Gaussians paired by content: each with a source Gaussian within "
                    f"{pairing['position_tolerance_scene_units']:.3e} scene units")
        else:
            text = "Gaussians paired index by index (the source's Gaussians in its order)"
        if pairing and pairing["source_gaussians_unpaired"]:
            text += f"; {group(pairing['source_gaussians_unpaired'])} source Gaussians not in the candidate"
        out.append(f"<p>{esc(text)}.</p>")
    else:
        out.append(f"<p>{esc(c.get('errors_note', 'no per-attribute errors'))}</p>")
    out.append("</div>")
    if c["worst_views"]:
        out.append("<h3>Worst views: source against candidate, and the difference</h3>")
        scale = c.get("heat_scale")
        if scale is not None and any(w.get("diff_image") for w in c["worst_views"]):
            pct = doc.get("heat_scale_percentile", 99)
            top = (f"the top of the colour bar is {scale:.4f}, the {pct:g}th percentile of the non-zero |d| of "
                   f"these heatmaps; larger |d|, up to the largest, {c['max_abs_diff']:.4f}, take the top colour"
                   if scale > 0 else "this candidate does not differ from the source here, so its heatmaps are black")
            out.append(f"<p class='note'>Heatmaps of {esc(c['label'])} on its own scale: black is no difference; "
                       f"{top}. Compare candidates by the numbers, not by brightness.</p>"
                       f"<div class='colorbar' data-heat-scale='{scale!r}' data-max-abs-diff='{c['max_abs_diff']!r}'>"
                       f"{colour_bar(scale if scale > 0 else 1.0, c['max_abs_diff'])}</div>")
        per_view = {v["name"]: v for v in c["views"]}
        for w in c["worst_views"]:
            if "source_image" not in w:
                continue
            uri = {key: png_data_uri(read_netpbm(os.path.join(base_dir, w[key])), HEAT_CMAP if key == "diff_image"
                                     else None) for key in ("source_image", "candidate_image", "diff_image")}
            scale = w["heat_scale"]
            view_max = per_view[w["name"]]["max_abs_diff"]
            cap = (f"|d| max over RGB: largest here {view_max:.4f}; colour bar above: 0 to {scale:.4f}"
                   + (" and more" if view_max > scale else ""))
            heat = (f"<figure><img class='view heatmap' data-heat-scale='{scale!r}' data-max-abs-diff='{view_max!r}' "
                    f"alt='difference' src='{uri['diff_image']}'><figcaption>{esc(cap)}</figcaption></figure>")
            fg = per_view[w["name"]].get("foreground_psnr_db")
            fg_text = f", foreground {num(fg)} dB" if "foreground_psnr_db" in per_view[w["name"]] else ""
            out.append(f"<div class='worst'><p><b>{esc(w['name'])}</b>: PSNR {num(w['psnr_db'])} dB{fg_text}</p>"
                       f"<div class='row'>{compare_widget(uri['source_image'], uri['candidate_image'], c['label'])}"
                       f"{heat}</div></div>")
    out.append("</section>")
    return "\n".join(out)


def views_table(doc):
    cands = doc["candidates"]
    head = "".join(f"<th>{esc(c['label'])} PSNR</th><th>PSNR fg</th><th>SSIM</th><th>max |d|</th>" for c in cands)
    rows = []
    for k, v in enumerate(doc["views"]):
        cells = "".join(f"<td>{num(c['views'][k]['psnr_db'])}</td><td>{num(c['views'][k].get('foreground_psnr_db'))}</td>"
                        f"<td>{c['views'][k]['ssim']:.5f}</td><td>{c['views'][k]['max_abs_diff']:.4f}</td>"
                        for c in cands)
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
.verdict{font-size:16px;border:1px solid #ccc;padding:6px 12px;background:#fafafa}.verdict ul{margin:4px 0;
padding-left:20px}.note{color:#444;max-width:1000px}.colorbar svg{width:480px;height:auto}
.stack{position:relative;line-height:0}.stack img.over{position:absolute;left:0;top:0}.divider{position:absolute;
top:0;bottom:0;width:2px;margin-left:-1px;background:#0af;pointer-events:none}.controls{display:flex;gap:8px;
align-items:center}.controls input{flex:1}
"""

# The source/candidate comparison: the slider sets the split (percent of the width from the left at which the
# candidate begins), flip jumps between all candidate (0) and all source (100). Delegated, so no set-up is needed.
SLIDER_JS = """
function rgsSetSplit(box, v) {
  v = Math.max(0, Math.min(100, Number(v)));
  box.querySelector('img.over').style.clipPath = 'inset(0 0 0 ' + v + '%)';
  box.querySelector('.divider').style.left = v + '%';
  box.querySelector('input.slider').value = v;
  box.setAttribute('data-split', String(v));
}
document.addEventListener('input', function (e) {
  if (e.target.classList && e.target.classList.contains('slider')) rgsSetSplit(e.target.closest('.compare'), e.target.value);
});
document.addEventListener('click', function (e) {
  if (!e.target.classList || !e.target.classList.contains('flip')) return;
  var box = e.target.closest('.compare');
  rgsSetSplit(box, Number(box.getAttribute('data-split')) > 0 ? 0 : 100);
});
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
             f"{esc(os.path.basename(src['path']))}</title><style>{CSS}</style><script>{CHECK_JS}{SLIDER_JS}</script></head>"
             "<body>"]
    parts.append(verdict_html(doc))
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
                 "<th>PSNR mean</th><th>PSNR min</th><th>PSNR fg mean</th><th>PSNR fg min</th><th>SSIM mean</th>"
                 "<th>SSIM min</th><th>max |d|</th><th>load s</th><th>render s</th></tr>")
    for c in cands:
        fg = c.get("foreground_psnr_db") or {}
        load = f"{c['load_seconds']:.2f}" if c.get("load_seconds") else "–"
        render = f"{c['render_seconds']:.2f}" if "render_seconds" in c else "–"
        parts.append(f"<tr><td>{esc(c['label'])}</td><td>{esc(c['format'])}</td><td>{group(c['bytes'])}</td>"
                     f"<td>{c['bytes_per_gaussian']:.2f}</td><td>{c.get('ratio', 0):.2f}x</td>"
                     f"<td>{num(c['psnr_db']['mean'])}</td><td>{num(c['psnr_db']['min'])}</td>"
                     f"<td>{num(fg.get('mean'))}</td><td>{num(fg.get('min'))}</td>"
                     f"<td>{c['ssim']['mean']:.5f}</td><td>{c['ssim']['min']:.5f}</td><td>{c['max_abs_diff']:.4f}</td>"
                     f"<td>{load}</td><td>{render}</td></tr>")
    parts.append("</table>")
    parts.append(f"<p class='note'>PSNR fg: over the foreground. load s: reading and decoding the file (source "
                 f"{src.get('load_seconds', 0):.2f} s). render s: the candidate's renders, summed over the views "
                 f"({esc(doc['backend'])} backend{', until the device finished each' if doc['backend'] == 'cuda' else ''})."
                 "</p>")
    parts.append(background_note(doc))
    if len(cands) > 1:
        parts.append(f"<div class='plot'>{plot_size_quality(doc)}</div>")
    parts.append(f"<div class='plot'>{plot_views(doc)}</div>")
    parts.append(views_table(doc))
    parts.append(f"<div class='plot'>{plot_sizes(doc)}</div>")
    if any(w.get("diff_image") for c in cands for w in c["worst_views"]):
        parts.append("<h2>Differences</h2><p class='note'>Each candidate's heatmaps are on its own scale, under its "
                     "own colour bar, so that every candidate's structure shows (one shared scale topped by one "
                     "candidate's brightest pixel leaves the others black); the largest |d| is written beside each. "
                     "Heatmaps reduced for the page keep the largest |d| of each block.</p>")
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
