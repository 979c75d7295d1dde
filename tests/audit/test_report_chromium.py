#!/usr/bin/env python3
"""The HTML report in a real browser: runs rgs-audit (CPU backend) on the bundled guitar against two conversions
of it (.rgs and SPZ), opens the report in headless Chromium and checks from the DOM after load: the page's
render check (every <img> decoded, every plot laid out); the verdict line, against the JSON, on the foreground
PSNR (guitar has a black background), for a threshold every candidate passes, for one only the better
candidate passes, and for one between a candidate's foreground and whole-frame means (it fails; on the whole
frame it would pass), with the --min-psnr gate's exit status on the same metric; one colour bar per candidate,
each heatmap on its candidate's scale with its largest |d| written, and the .rgs heatmap not black (decoded from
the page); the source/candidate slider and flip (driven by a script added to a copy of the page). Then
screenshots it, checking that the screenshot is not blank, and screenshots the heatmaps of the .rgs candidate
(heatmaps.png in WORK_DIR). The first run names the report's own
JSON with --json, the second names it through a symbolic link: both must write it once.

    test_report_chromium.py RGS_AUDIT RGS_CONVERT GUITAR_PLY WORK_DIR

Exit status: 0 passed, 1 failed, 77 skipped (no chromium, or no python3-matplotlib for the report script),
with a "skipped: ..." line.
"""
import base64
import html.parser
import io
import json
import math
import os
import re
import shutil
import subprocess
import sys

SKIP = 77


def skip(why):
    print(f"skipped: {why}")
    sys.exit(SKIP)


def fail(why):
    print(f"FAILED: {why}")
    sys.exit(1)


class Elements(html.parser.HTMLParser):
    """Start tags of a DOM dump with their attributes, and the text inside the element of id 'verdict'."""

    def __init__(self):
        super().__init__()
        self.tags = []  # (tag, {attr: value})
        self.verdict_text = ""
        self._depth = 0  # > 0 inside #verdict

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.tags.append((tag, a))
        if self._depth or a.get("id") == "verdict":
            self._depth += 1

    def handle_endtag(self, tag):
        if self._depth:
            self._depth -= 1

    def handle_data(self, data):
        if self._depth:
            self.verdict_text += data

    def with_class(self, cls):
        return [a for _, a in self.tags if cls in (a.get("class") or "").split()]


def dump_dom(common, path, extra_script=None):
    """The DOM of `path` after load (with `extra_script` appended to a copy of it first)."""
    if extra_script:
        with open(path, encoding="utf-8") as f:
            text = f.read()
        path = path.replace(".html", "_scripted.html")
        with open(path, "w", encoding="utf-8") as f:
            f.write(text.replace("</body>", f"<script>{extra_script}</script></body>"))
    dom = subprocess.run(common + ["--virtual-time-budget=10000", "--dump-dom", "file://" + os.path.abspath(path)],
                         capture_output=True, text=True, timeout=120).stdout
    parsed = Elements()
    parsed.feed(dom)
    return dom, parsed


def fg_mean(c):
    m = c["foreground_psnr_db"]["mean"]
    return math.inf if m == "inf" else m


def check_verdict(parsed, doc, threshold, where):
    """The verdict line against the JSON, on the foreground PSNR: overall and per candidate pass/fail, worst view
    (lowest foreground PSNR), its PSNR."""
    box = [a for _, a in parsed.tags if a.get("id") == "verdict"]
    if len(box) != 1:
        fail(f"{where}: {len(box)} elements of id 'verdict', expected 1")
    body = next(k for k, (t, _) in enumerate(parsed.tags) if t == "body")
    if parsed.tags[body + 1][1].get("id") != "verdict":
        fail(f"{where}: the verdict is not the first thing on the page")
    cands = doc["candidates"]
    if doc["verdict"].get("metric") != "foreground" or box[0].get("data-metric") != "foreground":
        fail(f"{where}: the verdict is on {doc['verdict'].get('metric')!r} / {box[0].get('data-metric')!r}, expected "
             "the foreground PSNR (guitar has a black background)")
    expect_all = all(fg_mean(c) >= threshold for c in cands)
    if box[0].get("data-passed") != str(expect_all).lower() or float(box[0].get("data-threshold")) != threshold:
        fail(f"{where}: verdict {box[0]} for threshold {threshold}, expected passed={expect_all}")
    word = "PASS" if expect_all else "FAIL"
    if not parsed.verdict_text.strip().startswith(word):
        fail(f"{where}: the verdict line reads {parsed.verdict_text.strip()[:80]!r}, expected {word} first")
    items = parsed.with_class("verdict-cand")
    if len(items) != len(cands):
        fail(f"{where}: {len(items)} candidates in the verdict, expected {len(cands)}")
    for item, c in zip(items, cands):
        passed = fg_mean(c) >= threshold
        worst = min(c["views"], key=lambda v: v["foreground_psnr_db"])
        if (item.get("data-label") != c["label"] or item.get("data-passed") != str(passed).lower()
                or item.get("data-metric") != "foreground"
                or abs(float(item.get("data-psnr-mean")) - fg_mean(c)) > 0.006
                or item.get("data-worst-view") != worst["name"]
                or abs(float(item.get("data-worst-psnr")) - worst["foreground_psnr_db"]) > 0.006):
            fail(f"{where}: verdict of {c['label']} is {item}, expected passed={passed} at foreground mean "
                 f"{fg_mean(c):.2f} dB, worst {worst['name']} at {worst['foreground_psnr_db']:.2f} dB")
    return expect_all


# Drives the first slider and its flip button as a reader would and records what the page did.
SLIDER_TEST = """
window.addEventListener('load', function () {
  var box = document.querySelector('.compare');
  var slider = box.querySelector('input.slider'), over = box.querySelector('img.over');
  var out = [];
  slider.value = 25;
  slider.dispatchEvent(new Event('input', {bubbles: true}));
  out.push(box.getAttribute('data-split') + ':' + over.style.clipPath);
  box.querySelector('button.flip').click();
  out.push(box.getAttribute('data-split') + ':' + over.style.clipPath);
  box.querySelector('button.flip').click();
  out.push(box.getAttribute('data-split') + ':' + slider.value);
  document.body.setAttribute('data-slider-test', out.join('|'));
});
"""


# Keeps the "Differences" heading and note and the first candidate's section without its tables.
HEATMAPS_ONLY = """
(function () {
  var keep = [];
  document.querySelectorAll('h2').forEach(function (h) { if (h.textContent === 'Differences') keep.push(h, h.nextElementSibling); });
  var cand = document.querySelector('section.cand');
  keep.push(cand);
  Array.prototype.slice.call(document.body.children).forEach(function (e) {
    if (keep.indexOf(e) < 0 && e.tagName !== 'SCRIPT') e.remove();
  });
  cand.querySelectorAll('.cols, section.cand > p').forEach(function (e) { e.remove(); });
  document.body.style.margin = '8px auto';
})();
"""


def main():
    rgs_audit, rgs_convert, guitar, work = sys.argv[1:5]
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if not chromium:
        skip("chromium not installed (Debian package chromium)")
    try:
        import matplotlib  # noqa: F401  (the report script needs it, under the same interpreter)
        import matplotlib.image as mpimg
        import numpy as np
    except ImportError:
        skip(f"python3-matplotlib not importable by {sys.executable}")
    os.makedirs(work, exist_ok=True)
    rgs = os.path.join(work, "guitar.rgs")
    spz = os.path.join(work, "guitar.spz")
    subprocess.run([rgs_convert, "-q", guitar, rgs], check=True)
    subprocess.run([rgs_convert, "-q", "--to", "spz", guitar, spz], check=True)
    env = dict(os.environ, RGS_PYTHON=sys.executable)
    common = [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars"]

    def audit(report, json_path, threshold, min_psnr=30.0, exit_code=0):
        for old in (report, report.replace(".html", ".json")):  # json_path may be a link to the latter
            if os.path.lexists(old):
                os.remove(old)
        run = subprocess.run([rgs_audit, guitar, rgs, spz, "--label", "rgs", "--label", "spz", "--orbit", "3",
                              "--width", "240", "--height", "135", "--backend", "cpu", "--report", report,
                              "--json", json_path, "--threshold", repr(threshold), "--min-psnr", repr(min_psnr), "-q"],
                             env=env, capture_output=True, text=True)
        if run.returncode != exit_code or not os.path.exists(report):
            fail(f"rgs-audit exit {run.returncode}, expected {exit_code}: {run.stderr}")
        with open(report.replace(".html", ".json"), encoding="utf-8") as f:
            return json.load(f)

    # The report's own JSON named by --json: written once, and the report reads it.
    report = os.path.join(work, "report.html")
    doc = audit(report, os.path.join(work, "report.json"), 30.0)
    with open(report, encoding="utf-8") as f:
        text = f.read()
    if re.search(r"(src|href)=['\"]https?:", text):
        fail("the report refers to the network")
    dom, parsed = dump_dom(common, report)
    if not check_verdict(parsed, doc, 30.0, "threshold 30 dB"):
        fail("threshold 30 dB: guitar's conversions are above 60 dB, the verdict must pass")

    # A threshold between the two candidates' foreground means: the better one passes, the report fails; --json is
    # a symbolic link to the report's JSON.
    means = [fg_mean(c) for c in doc["candidates"]]
    mid = round((means[0] + means[1]) / 2, 2)
    report2 = os.path.join(work, "report2.html")
    link = os.path.join(work, "report2_link.json")
    if os.path.lexists(link):
        os.remove(link)
    os.symlink("report2.json", link)
    doc2 = audit(report2, link, mid)
    if not os.path.islink(link) or doc2["verdict"]["threshold_db"] != mid:
        fail("--json through a symbolic link to the report's JSON: the link was replaced or not written")
    _, parsed2 = dump_dom(common, report2)
    if check_verdict(parsed2, doc2, mid, f"threshold {mid} dB"):
        fail(f"threshold {mid} dB between the candidates' means {means}: the verdict must fail")
    if [c["verdict"]["passed"] for c in doc2["candidates"]] != [m >= mid for m in means]:
        fail(f"threshold {mid} dB: JSON verdicts {[c['verdict'] for c in doc2['candidates']]}, means {means}")

    # A threshold between the SPZ's foreground and whole-frame means: the verdict fails (the whole frame would
    # pass it), and a --min-psnr between its foreground and whole-frame minimum exits 3 (the whole frame passes).
    spz_doc = doc["candidates"][1]
    between = round((fg_mean(spz_doc) + spz_doc["psnr_db"]["mean"]) / 2, 2)
    fg_min = min(v["foreground_psnr_db"] for v in spz_doc["views"])
    gate = round((fg_min + spz_doc["psnr_db"]["min"]) / 2, 2)
    if not (fg_mean(spz_doc) < between < spz_doc["psnr_db"]["mean"] and fg_min < gate < spz_doc["psnr_db"]["min"]):
        fail(f"SPZ: foreground {fg_mean(spz_doc)} / min {fg_min}, whole frame {spz_doc['psnr_db']}: no room between")
    report3 = os.path.join(work, "report3.html")
    doc3 = audit(report3, os.path.join(work, "report3.json"), between, min_psnr=gate, exit_code=3)
    _, parsed3 = dump_dom(common, report3)
    if check_verdict(parsed3, doc3, between, f"threshold {between} dB") or doc3["candidates"][1]["verdict"]["passed"]:
        fail(f"threshold {between} dB between the SPZ's foreground and whole-frame means: the verdict must fail")
    if doc3["gate"]["passed"] or doc3["gate"].get("metric") != "foreground":
        fail(f"--min-psnr {gate} dB between the SPZ's foreground and whole-frame minimum: gate {doc3['gate']}")

    # One colour bar per candidate; each heatmap on its candidate's scale, with its largest |d| written.
    bars = parsed.with_class("colorbar")
    heats = parsed.with_class("heatmap")
    cands = doc["candidates"]
    if len(bars) != len(cands):
        fail(f"{len(bars)} colour bars, expected one per candidate ({len(cands)})")
    if len(heats) != 6:
        fail(f"{len(heats)} heatmaps, expected 6")
    for k, (bar, c) in enumerate(zip(bars, cands)):
        scale = float(bar["data-heat-scale"])
        if scale != c["heat_scale"] or not 0 < scale <= c["max_abs_diff"] or \
                float(bar["data-max-abs-diff"]) != c["max_abs_diff"]:
            fail(f"colour bar of {c['label']}: {bar}, JSON heat_scale {c['heat_scale']}, max |d| {c['max_abs_diff']}")
        per_view = {v["name"]: v["max_abs_diff"] for v in c["views"]}
        for h, w in zip(heats[3 * k:3 * k + 3], c["worst_views"]):
            if float(h["data-heat-scale"]) != scale or float(h["data-max-abs-diff"]) != per_view[w["name"]]:
                fail(f"heatmap of {c['label']} {w['name']}: {h.get('data-heat-scale')} / {h.get('data-max-abs-diff')}, "
                     f"expected scale {scale}, largest |d| {per_view[w['name']]}")
            if f"largest here {per_view[w['name']]:.4f}" not in dom:
                fail(f"heatmap of {c['label']} {w['name']}: its largest |d| is not written")
    if cands[0]["heat_scale"] >= cands[1]["max_abs_diff"] or cands[0]["max_abs_diff"] >= cands[1]["max_abs_diff"]:
        fail(f"the .rgs's scale {cands[0]['heat_scale']} is not below the SPZ's largest |d|: one shared scale "
             "would not be told apart")
    # The .rgs heatmaps as the page shows them, decoded: of the pixels that differ at all (brighter than the colour
    # map's black), a share must be bright (a channel above 0.35, inferno above about 0.15 of its scale). On the
    # SPZ's largest |d|, ten times the .rgs's, none would be.
    differ = bright = 0
    for h in heats[:3]:
        img = mpimg.imread(io.BytesIO(base64.b64decode(h["src"].split(",", 1)[1])), format="png")[:, :, :3]
        top = img.max(axis=2)
        differ += int((top > 0.03).sum())
        bright += int((top > 0.35).sum())
    lit = bright / max(differ, 1)
    if differ == 0 or lit < 0.01:
        fail(f".rgs heatmaps: {bright} bright pixels of {differ} that differ ({lit:.2%}): they look black")

    # The slider and flip, driven in a copy of the page.
    _, scripted = dump_dom(common, report, SLIDER_TEST)
    body = [a for t, a in scripted.tags if t == "body"][0]
    got = body.get("data-slider-test", "")
    steps = got.split("|")
    if len(steps) != 3 or not steps[0].startswith("25:inset(") or "25%" not in steps[0] or \
            not steps[1].startswith("0:") or steps[2] != "100:100":
        fail(f"slider and flip: {got!r}, expected split 25 (clip at 25%), then 0, then 100")

    m = re.search(r'data-render-check="images (\d+)/(\d+) plots (\d+)/(\d+)"', dom)
    if not m:
        fail("the page's render check did not run (no data-render-check in the DOM)")
    ok_img, n_img, ok_plot, n_plot = map(int, m.groups())
    # 2 candidates x 3 worst views x (source, candidate, difference); plots: size/quality, per view, sizes.
    if n_img != 18 or ok_img != n_img:
        fail(f"images rendered {ok_img}/{n_img}, expected 18/18")
    if n_plot != 3 or ok_plot != n_plot:
        fail(f"plots rendered {ok_plot}/{n_plot}, expected 3/3")
    shot = os.path.join(work, "report.png")
    subprocess.run(common + ["--window-size=1400,2600", f"--screenshot={shot}", "file://" + os.path.abspath(report)],
                   capture_output=True, timeout=120)
    if not os.path.exists(shot):
        fail("chromium wrote no screenshot")
    img = mpimg.imread(shot)[:, :, :3]
    colours = len(np.unique((img * 255).astype(np.uint8).reshape(-1, 3), axis=0))
    dark = float((img.mean(axis=2) < 0.2).mean())  # the renders have black backgrounds
    if colours < 500 or dark < 0.02:
        fail(f"the screenshot looks blank ({colours} colours, {dark:.1%} dark pixels)")
    # The .rgs candidate's heatmaps alone (a copy of the page keeping its "Differences" note, its colour bar and
    # worst views), for a reader to look at: docs/images/audit_heatmaps.png is one.
    with open(report, encoding="utf-8") as f:
        text = f.read()
    heat_page = os.path.join(work, "report_heatmaps.html")
    with open(heat_page, "w", encoding="utf-8") as f:
        f.write(text.replace("</body>", "<script>" + HEATMAPS_ONLY + "</script></body>"))
    heat_shot = os.path.join(work, "heatmaps.png")
    subprocess.run(common + ["--window-size=1400,820", f"--screenshot={heat_shot}", "file://" + heat_page],
                   capture_output=True, timeout=120)
    if not os.path.exists(heat_shot):
        fail("chromium wrote no screenshot of the heatmaps")
    print(f"report rendered: images {ok_img}/{n_img}, plots {ok_plot}/{n_plot}; verdicts at 30 and {mid} dB "
          f"and {between} dB as expected, gate {gate} dB exits 3; colour bars at "
          f"{[float(b['data-heat-scale']) for b in bars]}, .rgs heatmap lit {lit:.1%}; slider {got}; screenshot {shot}: "
          f"{colours} colours, {dark:.1%} dark")
    return 0


if __name__ == "__main__":
    sys.exit(main())
