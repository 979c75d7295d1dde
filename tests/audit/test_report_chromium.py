#!/usr/bin/env python3
"""The HTML report in a real browser: runs rgs-audit (CPU backend) on the bundled guitar against a conversion
of it, opens the report in headless Chromium, reads the page's render check (every <img> decoded, every plot
laid out) from the DOM after load, and screenshots it, checking that the screenshot is not blank.

    test_report_chromium.py RGS_AUDIT RGS_CONVERT GUITAR_PLY WORK_DIR

Exit status: 0 passed, 1 failed, 77 skipped (no chromium, or no python3-matplotlib for the report script),
with a "skipped: ..." line.
"""
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
    subprocess.run([rgs_convert, "-q", guitar, rgs], check=True)
    report = os.path.join(work, "report.html")
    env = dict(os.environ, RGS_PYTHON=sys.executable)
    run = subprocess.run([rgs_audit, guitar, rgs, rgs, "--label", "a", "--label", "b", "--orbit", "3", "--width",
                          "240", "--height", "135", "--backend", "cpu", "--report", report, "--min-psnr", "30", "-q"],
                         env=env, capture_output=True, text=True)
    if run.returncode != 0 or not os.path.exists(report):
        fail(f"rgs-audit exit {run.returncode}: {run.stderr}")
    if not os.path.exists(os.path.join(work, "report.json")):
        fail("no report.json next to report.html")
    with open(report, encoding="utf-8") as f:
        text = f.read()
    if re.search(r"(src|href)=['\"]https?:", text):
        fail("the report refers to the network")
    common = [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars"]
    url = "file://" + os.path.abspath(report)
    dom = subprocess.run(common + ["--virtual-time-budget=10000", "--dump-dom", url], capture_output=True, text=True,
                         timeout=120).stdout
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
    subprocess.run(common + ["--window-size=1400,2600", f"--screenshot={shot}", url], capture_output=True,
                   timeout=120)
    if not os.path.exists(shot):
        fail("chromium wrote no screenshot")
    img = mpimg.imread(shot)[:, :, :3]
    colours = len(np.unique((img * 255).astype(np.uint8).reshape(-1, 3), axis=0))
    dark = float((img.mean(axis=2) < 0.2).mean())  # the renders have black backgrounds
    if colours < 500 or dark < 0.02:
        fail(f"the screenshot looks blank ({colours} colours, {dark:.1%} dark pixels)")
    print(f"report rendered: images {ok_img}/{n_img}, plots {ok_plot}/{n_plot}; screenshot {shot}: "
          f"{colours} colours, {dark:.1%} dark")
    return 0


if __name__ == "__main__":
    sys.exit(main())
