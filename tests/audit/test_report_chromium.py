#!/usr/bin/env python3
"""The HTML report in a real browser: runs rgs-audit (CPU backend) on the bundled guitar against two conversions
of it (.rgs and SPZ), opens the report in headless Chromium and checks from the DOM after load: the page's
render check (every <img> decoded, every plot laid out); the verdict line, against the JSON, for a threshold
every candidate passes and for one only the better candidate passes; one colour bar, and every heatmap on its
scale, the audit's largest |d|; the source/candidate slider and flip (driven by a script added to a copy of the
page). Then screenshots it, checking that the screenshot is not blank. The first run names the report's own
JSON with --json, the second names it through a symbolic link: both must write it once.

    test_report_chromium.py RGS_AUDIT RGS_CONVERT GUITAR_PLY WORK_DIR

Exit status: 0 passed, 1 failed, 77 skipped (no chromium, or no python3-matplotlib for the report script),
with a "skipped: ..." line.
"""
import html.parser
import json
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


def check_verdict(parsed, doc, threshold, where):
    """The verdict line against the JSON: overall and per candidate pass/fail, worst view, its PSNR."""
    box = [a for _, a in parsed.tags if a.get("id") == "verdict"]
    if len(box) != 1:
        fail(f"{where}: {len(box)} elements of id 'verdict', expected 1")
    body = next(k for k, (t, _) in enumerate(parsed.tags) if t == "body")
    if parsed.tags[body + 1][1].get("id") != "verdict":
        fail(f"{where}: the verdict is not the first thing on the page")
    cands = doc["candidates"]
    expect_all = all(c["psnr_db"]["mean"] == "inf" or c["psnr_db"]["mean"] >= threshold for c in cands)
    if box[0].get("data-passed") != str(expect_all).lower() or float(box[0].get("data-threshold")) != threshold:
        fail(f"{where}: verdict {box[0]} for threshold {threshold}, expected passed={expect_all}")
    word = "PASS" if expect_all else "FAIL"
    if not parsed.verdict_text.strip().startswith(word):
        fail(f"{where}: the verdict line reads {parsed.verdict_text.strip()[:80]!r}, expected {word} first")
    items = parsed.with_class("verdict-cand")
    if len(items) != len(cands):
        fail(f"{where}: {len(items)} candidates in the verdict, expected {len(cands)}")
    for item, c in zip(items, cands):
        passed = c["psnr_db"]["mean"] >= threshold
        worst = next(v for v in c["views"] if v["name"] == c["worst_view"])
        if (item.get("data-label") != c["label"] or item.get("data-passed") != str(passed).lower()
                or item.get("data-worst-view") != c["worst_view"]
                or abs(float(item.get("data-worst-psnr")) - worst["psnr_db"]) > 0.006):
            fail(f"{where}: verdict of {c['label']} is {item}, expected passed={passed}, worst "
                 f"{c['worst_view']} at {worst['psnr_db']:.2f} dB")
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

    def audit(report, json_path, threshold):
        for old in (report, report.replace(".html", ".json")):  # json_path may be a link to the latter
            if os.path.lexists(old):
                os.remove(old)
        run = subprocess.run([rgs_audit, guitar, rgs, spz, "--label", "rgs", "--label", "spz", "--orbit", "3",
                              "--width", "240", "--height", "135", "--backend", "cpu", "--report", report,
                              "--json", json_path, "--threshold", repr(threshold), "--min-psnr", "30", "-q"],
                             env=env, capture_output=True, text=True)
        if run.returncode != 0 or not os.path.exists(report):
            fail(f"rgs-audit exit {run.returncode}: {run.stderr}")
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

    # A threshold between the two candidates' means: the better one passes, the report fails; --json is a
    # symbolic link to the report's JSON.
    means = [c["psnr_db"]["mean"] for c in doc["candidates"]]
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

    # One colour bar; every heatmap on its scale, the largest |d| of the audit.
    bars = parsed.with_class("colorbar")
    heat = [float(a["data-heat-scale"]) for a in parsed.with_class("heatmap")]
    largest = max(c["max_abs_diff"] for c in doc["candidates"])
    if len(bars) != 1:
        fail(f"{len(bars)} colour bars, expected 1")
    if len(heat) != 6 or len(set(heat)) != 1 or heat[0] != float(bars[0]["data-heat-scale"]) \
            or abs(heat[0] - largest) > 1e-7 or heat[0] != doc["heat_scale"]:
        fail(f"heatmap scales {heat}, colour bar {bars[0].get('data-heat-scale')}, largest |d| {largest}")
    if min(c["max_abs_diff"] for c in doc["candidates"]) >= largest:
        fail("the two candidates have the same largest |d|: the shared scale is not tested")

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
    print(f"report rendered: images {ok_img}/{n_img}, plots {ok_plot}/{n_plot}; verdicts at 30 and {mid} dB "
          f"as expected; one colour bar, 6 heatmaps at {heat[0]:.4f}; slider {got}; screenshot {shot}: "
          f"{colours} colours, {dark:.1%} dark")
    return 0


if __name__ == "__main__":
    sys.exit(main())
