#!/usr/bin/env python3
"""scripts/quality_cards.py and the report's curves on a real audit: the bundled guitar converted to SPZ and to
two archives labelled as points of one curve (archive@fine, archive@coarse), audited on the CPU backend in two
runs over the same views. Checks: every card row and curve row against the JSONs (bytes per Gaussian, PSNR,
the ratio to SPZ's bytes); two runs merged into one scene; runs over other views refused; --doc replacing only
what lies between the markers and refusing a file without them (unchanged); the HTML report drawing the
SERIES@POINT candidates as one curve (two points) with its legend.

    test_quality_cards.py RGS_AUDIT RGS_CONVERT GUITAR_PLY WORK_DIR

Exit status: 0 passed, 1 failed.
"""
import json
import os
import shutil
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CARDS = os.path.join(ROOT, "scripts", "quality_cards.py")


def fail(why):
    print(f"FAILED: {why}")
    sys.exit(1)


def run(*args, ok=True):
    r = subprocess.run([*args], capture_output=True, text=True)
    if ok and r.returncode != 0:
        fail(f"{' '.join(args)} exited {r.returncode}: {r.stderr[-2000:]}")
    return r


def main(argv):
    audit, convert, guitar, work = argv[1:5]
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    files = {
        "spz": (os.path.join(work, "g.spz"), ["--to", "spz"]),
        "archive@fine": (os.path.join(work, "fine.rgs"), ["--profile", "archive"]),
        "archive@coarse": (os.path.join(work, "coarse.rgs"), ["--profile", "archive", "--position-error", "0.002"]),
    }
    for path, options in files.values():
        run(convert, "-q", guitar, path, *options)
    views = ["--orbit", "2", "--width", "96", "--height", "54", "--backend", "cpu"]
    first = os.path.join(work, "first.json")
    second = os.path.join(work, "second.json")
    other = os.path.join(work, "other.json")
    run(audit, "-q", guitar, files["spz"][0], files["archive@fine"][0], "--label", "spz", "--label", "archive@fine",
        *views, "--no-report", "--json", first)
    run(audit, "-q", guitar, files["archive@coarse"][0], "--label", "archive@coarse", *views, "--no-report", "--json",
        second)
    run(audit, "-q", guitar, files["spz"][0], "--label", "spz", "--orbit", "2", "--width", "64", "--height", "36",
        "--backend", "cpu", "--no-report", "--json", other)
    docs = [json.load(open(p, encoding="utf-8")) for p in (first, second)]
    cands = {c["label"]: c for d in docs for c in d["candidates"]}

    out = run(sys.executable, CARDS, f"guitar={first},{second}").stdout
    spz = cands["spz"]
    card = next((l for l in out.splitlines() if l.startswith("| SPZ v4")), None)
    if card is None or f"| {spz['bytes_per_gaussian']:.1f} |" not in card:
        fail(f"SPZ card row missing or wrong: {card!r}")
    if f"{spz['psnr_db']['mean']:.2f} / {spz['psnr_db']['min']:.2f}" not in card:
        fail(f"SPZ card row without its PSNR: {card!r}")
    for label in ("archive@fine", "archive@coarse"):
        c = cands[label]
        row = next((l for l in out.splitlines() if l.startswith(f"| guitar | {label} |")), None)
        if row is None:
            fail(f"no curve row for {label} (the second run not merged?):\n{out}")
        want = (f"{c['bytes']:,} | {c['bytes_per_gaussian']:.2f} | {c['psnr_db']['mean']:.2f} / "
                f"{c['psnr_db']['min']:.2f} | {c['bytes'] / spz['bytes']:.2f}x |")
        if want not in row:
            fail(f"curve row {row!r} does not hold {want!r}")
    if cands["archive@coarse"]["bytes"] >= cands["archive@fine"]["bytes"]:
        fail("the coarser archive is not smaller: the fixture does not make a curve")

    r = run(sys.executable, CARDS, f"guitar={first},{other}", ok=False)
    if r.returncode != 1 or "other views" not in r.stderr:
        fail(f"runs over other views were merged (exit {r.returncode}): {r.stderr}")

    doc = os.path.join(work, "doc.md")
    with open(doc, "w", encoding="utf-8") as f:
        f.write("before\n<!-- quality-cards:begin -->\nstale\n<!-- quality-cards:end -->\nafter\n")
    run(sys.executable, CARDS, "--doc", doc, f"guitar={first},{second}")
    text = open(doc, encoding="utf-8").read()
    if not text.startswith("before\n<!-- quality-cards:begin -->\n| format |") or not text.endswith(
            "<!-- quality-cards:end -->\nafter\n") or "stale" in text:
        fail(f"--doc did not replace exactly the marked part:\n{text}")
    plain = os.path.join(work, "plain.md")
    with open(plain, "w", encoding="utf-8") as f:
        f.write("no markers\n")
    r = run(sys.executable, CARDS, "--doc", plain, f"guitar={first}", ok=False)
    if r.returncode != 1 or "markers" not in r.stderr or open(plain, encoding="utf-8").read() != "no markers\n":
        fail(f"a doc without markers was not refused untouched (exit {r.returncode}): {r.stderr}")

    # The report: the two archives as one curve with its legend, the SPZ as a point.
    report = os.path.join(work, "curve.html")
    run(audit, "-q", guitar, files["spz"][0], files["archive@fine"][0], files["archive@coarse"][0], "--label",
        "spz", "--label", "archive@fine", "--label", "archive@coarse", *views, "--report", report)
    page = open(report, encoding="utf-8").read()
    for text in ("archive: mean", "archive: worst view", "rate-distortion curves",
                 "<g class='series' data-kind='curve_mean' data-label='archive: mean' data-points='2'>",
                 "<g class='series' data-kind='candidate' data-label='spz' data-points='1'>"):
        if text not in page:
            fail(f"the report's size-quality plot lacks {text!r}")
    print("quality cards: passed")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
