#!/usr/bin/env python3
"""The HTML report in a real browser: runs rgs-audit (CPU backend, no PATH, no Python named: the report needs no
other program) on the bundled guitar against two conversions of it (.rgs and SPZ), opens each report in headless
Chromium driven through the DevTools protocol and checks after load: no console error or uncaught exception; the
page's render check (every <img> decoded, every plot laid out); the verdict line, against the JSON, on the
foreground PSNR (guitar has a black background), for a threshold every candidate passes, for one only the better
candidate passes, and for one between a candidate's foreground and whole-frame means (it fails; on the whole
frame it would pass), with the --min-psnr gate's exit status on the same metric; the SVG figures: one point per
view per candidate in each series of the per-view plot, every PSNR point on one linear dB-to-pixel scale, the
threshold and gate lines, one bar per scene in the size chart with lengths in the ratio of the bytes per
Gaussian, one point per candidate in the size/quality chart; one colour bar per candidate, each heatmap on its
candidate's scale with its largest |d| written, and the .rgs heatmap not black (decoded by the page's canvas);
the source/candidate slider and flip, driven in the page. Then it screenshots the page, checks the screenshot is
not blank, and writes into WORK_DIR: report.png (the whole page), figure_size_quality.png, figure_views.png,
figure_sizes.png (each figure) and heatmaps.png (the .rgs candidate's colour bar and worst views). The first run
names the report's own JSON with --json, the second names it through a symbolic link: both must write it once.

    test_report_chromium.py RGS_AUDIT RGS_CONVERT GUITAR_PLY WORK_DIR

Exit status: 0 passed, 1 failed, 77 skipped (no chromium, or no python3-websocket), with a "skipped: ..." line.
"""
import base64
import html.parser
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import urllib.request

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


class Browser:
    """Headless Chromium and one page of it, driven through the DevTools protocol (python3-websocket)."""

    def __init__(self, chromium, profile):
        import websocket
        self.proc = subprocess.Popen([chromium, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                                      "--remote-debugging-port=0", f"--user-data-dir={profile}", "about:blank"],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        port_file = os.path.join(profile, "DevToolsActivePort")
        deadline = time.time() + 60
        while not (os.path.exists(port_file) and open(port_file).read().strip()):
            if time.time() > deadline or self.proc.poll() is not None:
                self.close()
                fail("chromium did not open its DevTools port")
            time.sleep(0.1)
        port = open(port_file).read().split()[0]
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=30) as r:
            page = next(t for t in json.load(r) if t["type"] == "page")
        self.ws = websocket.create_connection(page["webSocketDebuggerUrl"], timeout=120, suppress_origin=True)
        self.next_id = 0
        self.events = []
        for domain in ("Page", "Runtime", "Log"):
            self.call(f"{domain}.enable")

    def call(self, method, **params):
        self.next_id += 1
        self.ws.send(json.dumps({"id": self.next_id, "method": method, "params": params}))
        while True:
            msg = json.loads(self.ws.recv())
            if msg.get("id") == self.next_id:
                if "error" in msg:
                    fail(f"DevTools {method}: {msg['error']}")
                return msg.get("result", {})
            self.events.append(msg)

    def evaluate(self, expression):
        r = self.call("Runtime.evaluate", expression=expression, returnByValue=True, awaitPromise=True)
        if "exceptionDetails" in r:
            fail(f"script in the page failed: {r['exceptionDetails']}")
        return r["result"].get("value")

    def open(self, path, width=1400, height=1000):
        """Loads `path` at a window `width` wide; returns the console errors and uncaught exceptions."""
        self.events = []
        self.call("Emulation.setDeviceMetricsOverride", width=width, height=height, deviceScaleFactor=1, mobile=False)
        self.call("Page.navigate", url="file://" + os.path.abspath(path))
        deadline = time.time() + 120
        while not any(e.get("method") == "Page.loadEventFired" for e in self.events):
            if time.time() > deadline:
                fail(f"{path}: no load event")
            self.events.append(json.loads(self.ws.recv()))
        self.evaluate("new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")  # laid out
        errors = []
        for e in self.events:
            m, p = e.get("method"), e.get("params", {})
            if m == "Runtime.exceptionThrown":
                details = p["exceptionDetails"]
                errors.append(details.get("exception", {}).get("description") or details.get("text", "exception"))
            elif m == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert"):
                errors.append(" ".join(str(a.get("value", a.get("description"))) for a in p.get("args", [])))
            elif m == "Log.entryAdded" and p["entry"].get("level") == "error":
                errors.append(p["entry"].get("text", ""))
        return errors

    def screenshot(self, path, clip=None):
        """The page (or `clip` {x, y, width, height} in page pixels) as PNG into `path`; returns its data URI."""
        if clip is None:
            size = self.evaluate("[document.documentElement.scrollWidth, document.documentElement.scrollHeight]")
            clip = {"x": 0, "y": 0, "width": size[0], "height": size[1]}
        shot = self.call("Page.captureScreenshot", format="png", captureBeyondViewport=True,
                         clip=dict(clip, scale=1))["data"]
        with open(path, "wb") as f:
            f.write(base64.b64decode(shot))
        return "data:image/png;base64," + shot

    def close(self):
        if getattr(self, "ws", None):
            self.ws.close()
        self.proc.terminate()
        try:
            self.proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.proc.kill()


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


def load(browser, report, where):
    """Opens the report, fails on a console error; returns its DOM, parsed."""
    errors = browser.open(report)
    if errors:
        fail(f"{where}: console errors: {errors}")
    dom = browser.evaluate("document.documentElement.outerHTML")
    parsed = Elements()
    parsed.feed(dom)
    return dom, parsed


# The figures as the browser laid them out: per plot its series (points and their centres), bar rows and lines.
FIGURES = """
(() => {
  const centre = e => { const b = e.getBBox(); return [b.x + b.width / 2, b.y + b.height / 2]; };
  return Array.from(document.querySelectorAll('svg.rgs-plot')).map(svg => ({
    plot: svg.dataset.plot,
    box: [svg.getBoundingClientRect().width, svg.getBoundingClientRect().height],
    series: Array.from(svg.querySelectorAll('g.series')).map(g => ({
      kind: g.dataset.kind, label: g.dataset.label, panel: g.closest('g.panel').dataset.panel,
      points: Array.from(g.querySelectorAll('.pt')).map(centre)})),
    bars: Array.from(svg.querySelectorAll('g.bar-row')).map(g => ({
      label: g.dataset.label, segments: g.querySelectorAll('rect.bar').length,
      width: Array.from(g.querySelectorAll('rect.bar')).reduce((s, r) => s + r.getBBox().width, 0)})),
    lines: svg.querySelectorAll('.hline').length,
    legend: Array.from(svg.querySelectorAll('g.legend text')).map(t => t.textContent)}));
})()
"""


def check_figures(browser, doc, where):
    """The SVG figures against the JSON: points per series, their PSNR scale, lines, bars, size/quality points."""
    figures = browser.evaluate(FIGURES)
    by_plot = {}
    for f in figures:
        by_plot.setdefault(f["plot"], []).append(f)
        if f["box"][0] < 50 or f["box"][1] < 20:
            fail(f"{where}: figure {f['plot']} laid out at {f['box']}")
    cands, views = doc["candidates"], doc["views"]
    if sorted(by_plot) != ["colour-bar", "size_quality", "sizes", "views"] or len(by_plot["colour-bar"]) != len(cands):
        fail(f"{where}: figures {[f['plot'] for f in figures]}, expected size_quality, views, sizes and "
             f"{len(cands)} colour bars")
    per_view = by_plot["views"][0]
    expected = [(f"{c['label']} ({k.replace('_', ' ')})", k) for c in cands for k in ("whole_frame", "foreground")]
    expected += [(c["label"], "ssim") for c in cands]
    got = [(s["label"], s["kind"]) for s in per_view["series"]]
    if sorted(got) != sorted(expected):
        fail(f"{where}: per-view series {got}, expected {expected}")
    scale = []  # (dB, y) of every PSNR point
    for s in per_view["series"]:
        if len(s["points"]) != len(views):
            fail(f"{where}: series {s['label']} has {len(s['points'])} points, expected one per view ({len(views)})")
        c = next(c for c in cands if s["label"].startswith(c["label"]))
        key = {"whole_frame": "psnr_db", "foreground": "foreground_psnr_db"}.get(s["kind"])
        if key:
            scale += [(v[key], p[1]) for v, p in zip(c["views"], s["points"])]
        xs = [p[0] for p in s["points"]]
        if xs != sorted(xs) or len(set(xs)) != len(xs):
            fail(f"{where}: series {s['label']}: the views are not left to right: {xs}")
    (d0, y0), (d1, y1) = min(scale), max(scale)
    for d, y in scale:  # higher PSNR higher up, every point on the line through the extremes
        if abs(y0 + (d - d0) * (y1 - y0) / (d1 - d0) - y) > 0.6 or y1 >= y0:
            fail(f"{where}: the point of {d:.3f} dB is at y {y:.1f}, off the axis through {(d0, y0)} and {(d1, y1)}")
    threshold, gate = doc["verdict"]["threshold_db"], doc["gate"]["min_psnr_db"]
    for text in (f"threshold {threshold:g} dB (mean, foreground)", f"--min-psnr {gate:g} dB (each view, foreground)"):
        if text not in per_view["legend"]:
            fail(f"{where}: the per-view legend {per_view['legend']} lacks {text!r}")
    if per_view["lines"] != 2:
        fail(f"{where}: {per_view['lines']} horizontal lines in the per-view plot, expected the threshold and gate")
    bars = by_plot["sizes"][0]["bars"]
    labels = ["source"] + [c["label"] for c in cands]
    if [b["label"] for b in bars] != labels:
        fail(f"{where}: size bars {[b['label'] for b in bars]}, expected {labels}")
    sizes = [doc["source"]["bytes_per_gaussian"]] + [c["bytes_per_gaussian"] for c in cands]
    for b, size in zip(bars[1:], sizes[1:]):
        if abs(b["width"] / bars[0]["width"] - size / sizes[0]) > 0.01:
            fail(f"{where}: bar {b['label']} is {b['width']:.1f} px against the source's {bars[0]['width']:.1f}, "
                 f"expected the ratio {size / sizes[0]:.3f}")
    sections = len(cands[0]["sections"])
    if bars[1]["segments"] != sections + 1 or bars[2]["segments"] != 1:
        fail(f"{where}: .rgs bar of {bars[1]['segments']} segments (expected {sections} sections and the rest), SPZ "
             f"bar of {bars[2]['segments']} (expected the whole file)")
    points = [s for s in by_plot["size_quality"][0]["series"] if s["kind"] == "candidate"]
    if [s["label"] for s in points] != [c["label"] for c in cands] or any(len(s["points"]) != 1 for s in points):
        fail(f"{where}: size/quality points {[(s['label'], len(s['points'])) for s in points]}, expected one per "
             "candidate")
    return {f["plot"]: len(f["series"]) or len(f["bars"]) for f in figures}


# Of the first candidate's heatmaps as the page decoded them: pixels that differ at all (brighter than the colour
# map's black) and bright ones (a channel above 0.35).
HEAT_PIXELS = """
(() => {
  let differ = 0, bright = 0;
  Array.from(document.querySelectorAll('img.heatmap')).slice(0, 3).forEach(img => {
    const c = document.createElement('canvas');
    c.width = img.naturalWidth; c.height = img.naturalHeight;
    const g = c.getContext('2d');
    g.drawImage(img, 0, 0);
    const d = g.getImageData(0, 0, c.width, c.height).data;
    for (let i = 0; i < d.length; i += 4) {
      const top = Math.max(d[i], d[i + 1], d[i + 2]) / 255;
      if (top > 0.03) differ++;
      if (top > 0.35) bright++;
    }
  });
  return [differ, bright];
})()
"""

# Colours and share of dark pixels of a screenshot, decoded by the page.
SHOT_STATS = """
new Promise(resolve => {
  const img = new Image();
  img.onload = () => {
    const c = document.createElement('canvas');
    c.width = img.naturalWidth; c.height = img.naturalHeight;
    const g = c.getContext('2d');
    g.drawImage(img, 0, 0);
    const d = g.getImageData(0, 0, c.width, c.height).data;
    const colours = new Set();
    let dark = 0;
    for (let i = 0; i < d.length; i += 4) {
      colours.add((d[i] << 16) | (d[i + 1] << 8) | d[i + 2]);
      if (d[i] + d[i + 1] + d[i + 2] < 0.2 * 3 * 255) dark++;
    }
    resolve([colours.size, dark / (d.length / 4)]);
  };
  img.src = %s;
})
"""

# Drives the first slider and its flip button as a reader would; returns what the page did.
SLIDER_TEST = """
(() => {
  const box = document.querySelector('.compare');
  const slider = box.querySelector('input.slider'), over = box.querySelector('img.over');
  const out = [];
  slider.value = 25;
  slider.dispatchEvent(new Event('input', {bubbles: true}));
  out.push(box.getAttribute('data-split') + ':' + over.style.clipPath);
  box.querySelector('button.flip').click();
  out.push(box.getAttribute('data-split') + ':' + over.style.clipPath);
  box.querySelector('button.flip').click();
  out.push(box.getAttribute('data-split') + ':' + slider.value);
  return out.join('|');
})()
"""

# Keeps the "Differences" heading and note and the first candidate's section without its tables.
HEATMAPS_ONLY = """
(() => {
  const keep = [];
  document.querySelectorAll('h2').forEach(h => {
    if (h.textContent === 'Differences') keep.push(h, h.nextElementSibling);
  });
  const cand = document.querySelector('section.cand');
  keep.push(cand);
  Array.from(document.body.children).forEach(e => { if (keep.indexOf(e) < 0 && e.tagName !== 'SCRIPT') e.remove(); });
  cand.querySelectorAll('.cols, section.cand > p').forEach(e => e.remove());
  document.body.style.margin = '8px auto';
})()
"""


def check_report(browser, report, doc, dom, parsed, work):
    """Colour bars and heatmaps, the slider, the render check, the screenshots of the first report."""
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
    # On the SPZ's largest |d|, ten times the .rgs's, the .rgs heatmaps would have no bright pixel.
    differ, bright = browser.evaluate(HEAT_PIXELS)
    lit = bright / max(differ, 1)
    if differ == 0 or lit < 0.01:
        fail(f".rgs heatmaps: {bright} bright pixels of {differ} that differ ({lit:.2%}): they look black")

    m = re.search(r'data-render-check="images (\d+)/(\d+) plots (\d+)/(\d+)"', dom)
    if not m:
        fail("the page's render check did not run (no data-render-check in the DOM)")
    ok_img, n_img, ok_plot, n_plot = map(int, m.groups())
    # 2 candidates x 3 worst views x (source, candidate, difference); plots: size/quality, per view, sizes.
    if n_img != 18 or ok_img != n_img:
        fail(f"images rendered {ok_img}/{n_img}, expected 18/18")
    if n_plot != 3 or ok_plot != n_plot:
        fail(f"plots rendered {ok_plot}/{n_plot}, expected 3/3")

    slider = browser.evaluate(SLIDER_TEST)
    steps = slider.split("|")
    if len(steps) != 3 or not steps[0].startswith("25:inset(") or "25%" not in steps[0] or \
            not steps[1].startswith("0:") or steps[2] != "100:100":
        fail(f"slider and flip: {slider!r}, expected split 25 (clip at 25%), then 0, then 100")

    browser.open(report)  # afresh, the slider back in the middle
    shot = os.path.join(work, "report.png")
    colours, dark = browser.evaluate(SHOT_STATS % json.dumps(browser.screenshot(shot)))
    if colours < 500 or dark < 0.02:  # the renders have black backgrounds
        fail(f"the screenshot looks blank ({colours} colours, {dark:.1%} dark pixels)")
    for k, name in enumerate(("size_quality", "views", "sizes")):
        box = browser.evaluate(f"(() => {{ const r = document.querySelectorAll('.plot svg')[{k}]"
                               ".getBoundingClientRect(); return {x: r.x + scrollX, y: r.y + scrollY, "
                               "width: r.width, height: r.height}; })()")
        browser.screenshot(os.path.join(work, f"figure_{name}.png"), box)
    browser.open(report, height=820)
    browser.evaluate(HEATMAPS_ONLY)
    browser.screenshot(os.path.join(work, "heatmaps.png"), {"x": 0, "y": 0, "width": 1400, "height": 820})
    return shot, colours, dark, lit, slider


def main():
    rgs_audit, rgs_convert, guitar, work = sys.argv[1:5]
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if not chromium:
        skip("chromium not installed (Debian package chromium)")
    try:
        import websocket  # noqa: F401
    except ImportError:
        skip(f"python3-websocket not importable by {sys.executable}")
    os.makedirs(work, exist_ok=True)
    rgs = os.path.join(work, "guitar.rgs")
    spz = os.path.join(work, "guitar.spz")
    subprocess.run([rgs_convert, "-q", guitar, rgs], check=True)
    subprocess.run([rgs_convert, "-q", "--to", "spz", guitar, spz], check=True)
    # No program to start: an empty PATH and no Python named.
    env = {k: v for k, v in os.environ.items() if k not in ("RGS_PYTHON", "RGS_AUDIT_REPORT_SCRIPT")}
    env["PATH"] = ""

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

    profile = tempfile.mkdtemp(prefix="chromium-", dir=work)
    browser = Browser(chromium, profile)
    try:
        dom, parsed = load(browser, report, "threshold 30 dB")
        if not check_verdict(parsed, doc, 30.0, "threshold 30 dB"):
            fail("threshold 30 dB: guitar's conversions are above 60 dB, the verdict must pass")
        figures = check_figures(browser, doc, "threshold 30 dB")

        # A threshold between the two candidates' foreground means: the better one passes, the report fails;
        # --json is a symbolic link to the report's JSON.
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
        _, parsed2 = load(browser, report2, f"threshold {mid} dB")
        if check_verdict(parsed2, doc2, mid, f"threshold {mid} dB"):
            fail(f"threshold {mid} dB between the candidates' means {means}: the verdict must fail")
        if [c["verdict"]["passed"] for c in doc2["candidates"]] != [m >= mid for m in means]:
            fail(f"threshold {mid} dB: JSON verdicts {[c['verdict'] for c in doc2['candidates']]}, means {means}")

        # A threshold between the SPZ's foreground and whole-frame means: the verdict fails (the whole frame would
        # pass it), and a --min-psnr between its foreground and whole-frame minimum exits 3 (the whole frame
        # passes).
        spz_doc = doc["candidates"][1]
        between = round((fg_mean(spz_doc) + spz_doc["psnr_db"]["mean"]) / 2, 2)
        fg_min = min(v["foreground_psnr_db"] for v in spz_doc["views"])
        gate = round((fg_min + spz_doc["psnr_db"]["min"]) / 2, 2)
        if not (fg_mean(spz_doc) < between < spz_doc["psnr_db"]["mean"] and fg_min < gate < spz_doc["psnr_db"]["min"]):
            fail(f"SPZ: foreground {fg_mean(spz_doc)} / min {fg_min}, whole frame {spz_doc['psnr_db']}: "
                 "no room between")
        report3 = os.path.join(work, "report3.html")
        doc3 = audit(report3, os.path.join(work, "report3.json"), between, min_psnr=gate, exit_code=3)
        _, parsed3 = load(browser, report3, f"threshold {between} dB")
        if (check_verdict(parsed3, doc3, between, f"threshold {between} dB")
                or doc3["candidates"][1]["verdict"]["passed"]):
            fail(f"threshold {between} dB between the SPZ's foreground and whole-frame means: the verdict must fail")
        if doc3["gate"]["passed"] or doc3["gate"].get("metric") != "foreground":
            fail(f"--min-psnr {gate} dB between the SPZ's foreground and whole-frame minimum: gate {doc3['gate']}")
        check_figures(browser, doc3, f"threshold {between} dB")

        dom, parsed = load(browser, report, "threshold 30 dB")
        shot, colours, dark, lit, slider = check_report(browser, report, doc, dom, parsed, work)
    finally:
        browser.close()
        shutil.rmtree(profile, ignore_errors=True)
    print(f"report rendered without console errors: figures {figures}; verdicts at 30 and {mid} dB and {between} dB "
          f"as expected, gate {gate} dB exits 3; .rgs heatmap lit {lit:.1%}; slider {slider}; screenshot {shot}: "
          f"{colours} colours, {dark:.1%} dark; figures and heatmaps.png in {work}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
