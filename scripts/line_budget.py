#!/usr/bin/env python3
"""Prints the product's size against its line budgets (CONTRIBUTING.md#line-budgets).

The product is the C++/CUDA sources of the libraries and tools (format/ converter/ kernels/ runtime/ api/ audit/
view/ parallel/ tools/), as tracked by git; lab/, tests/, python/ and samples/ are apart. Its size is counted in
code lines (cloc: neither blank nor comment, so that comments and docs are never what is cut); every line
(`wc -l`) and each layer's lines are printed too, and limit nothing.

One limit on the code lines (CONTRIBUTING.md#line-budgets), the ceiling, which the product may not pass: its
size after the last cut. A cut lowers it, and only a commit that adds a feature raises it, by the line budget
that commit states.

Usage: scripts/line_budget.py [--check]   (--check: exit 1 above the ceiling; the test suite runs it)
Needs git and cloc (apt-get install cloc). Outside a git checkout there is nothing to count: --check says so and
exits 0.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PRODUCT_DIRS = ["format", "converter", "kernels", "runtime", "api", "audit", "view", "parallel", "tools"]
SOURCE_SUFFIXES = (".h", ".hpp", ".cpp", ".cc", ".cu", ".cuh")
CEILING_CODE_LINES = 35_545


def product_sources():
    out = subprocess.run(["git", "ls-files", "--", *PRODUCT_DIRS], cwd=ROOT, check=True, capture_output=True,
                         text=True).stdout
    return [p for p in out.splitlines() if p.endswith(SOURCE_SUFFIXES)]


def count_lines(paths):
    total = 0
    for p in paths:
        with open(os.path.join(ROOT, p), "rb") as f:
            total += f.read().count(b"\n")
    return total


def cloc_code_lines(paths):
    with tempfile.NamedTemporaryFile("w", suffix=".txt") as list_file:
        list_file.write("\n".join(paths) + "\n")
        list_file.flush()
        out = subprocess.run(["cloc", "--json", "--quiet", "--list-file=" + list_file.name], cwd=ROOT, check=True,
                             capture_output=True, text=True).stdout
    return json.loads(out)["SUM"]["code"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--check", action="store_true", help="exit 1 above the ceiling")
    args = parser.parse_args()
    if not os.path.isdir(os.path.join(ROOT, ".git")) and not os.path.isfile(os.path.join(ROOT, ".git")):
        print("line_budget: skipped: %s is not a git checkout" % ROOT)
        return 0
    if shutil.which("cloc") is None:
        print("line_budget: cloc not found (apt-get install cloc)", file=sys.stderr)
        return 2
    paths = product_sources()
    lines, code = count_lines(paths), cloc_code_lines(paths)
    above = code > CEILING_CODE_LINES
    verdict = ("ABOVE THE CEILING by %d" % (code - CEILING_CODE_LINES) if above
               else "within the ceiling of %d" % CEILING_CODE_LINES)
    print("line_budget: %d code lines in %d product files, %s; %d lines by wc -l" % (code, len(paths), verdict, lines))
    by_dir = {d: count_lines([p for p in paths if p.startswith(d + "/")]) for d in PRODUCT_DIRS}
    print("  lines by layer: " + ", ".join("%s %d" % (d, n) for d, n in sorted(by_dir.items(), key=lambda i: -i[1])))
    if above:
        print("line_budget: the product grew past its ceiling: cut as much elsewhere, or, for a new feature, raise "
              "CEILING_CODE_LINES in scripts/line_budget.py by the line budget its commit states", file=sys.stderr)
    return 1 if args.check and above else 0

if __name__ == "__main__":
    sys.exit(main())
