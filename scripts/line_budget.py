#!/usr/bin/env python3
"""Prints the product's size against its line budgets (CONTRIBUTING.md#line-budgets).

The product is the C++/CUDA sources of the libraries and tools (format/ converter/ kernels/ runtime/ api/ audit/
view/ parallel/ tools/), as tracked by git; lab/, tests/, python/ and samples/ are apart. Two figures: every line
(`wc -l`) and code lines (cloc: neither blank nor comment, so that comments and docs are never what is cut).
Each layer's lines follow, largest first.

Two limits (CONTRIBUTING.md#line-budgets): the budgets, where the product is to be, and the ceiling, which it may
not pass. The ceiling is the product's size after the last cut; a cut lowers it, and only a commit that adds a
feature raises it, by the line budget that commit states.

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
BUDGET_LINES = 38_500
BUDGET_CODE_LINES = 29_500
CEILING_LINES = 46_102
CEILING_CODE_LINES = 34_917


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


def row(name, value, budget, ceiling):
    state = "within" if value <= budget else "over by %d" % (value - budget)
    above = "" if value <= ceiling else "   ABOVE THE CEILING %d by %d" % (ceiling, value - ceiling)
    return "%-20s %7d   budget %7d   %-14s ceiling %7d%s" % (name, value, budget, state, ceiling, above)


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
    print("product sources: %d files" % len(paths))
    print(row("lines (wc -l)", lines, BUDGET_LINES, CEILING_LINES))
    print(row("code lines (cloc)", code, BUDGET_CODE_LINES, CEILING_CODE_LINES))
    by_dir = {d: count_lines([p for p in paths if p.startswith(d + "/")]) for d in PRODUCT_DIRS}
    for d, n in sorted(by_dir.items(), key=lambda item: -item[1]):
        print("  %-10s %7d lines" % (d + "/", n))
    above = lines > CEILING_LINES or code > CEILING_CODE_LINES
    if above:
        print("line_budget: the product grew past its ceiling: cut as much elsewhere, or, for a new feature, raise "
              "CEILING_LINES and CEILING_CODE_LINES in scripts/line_budget.py by the line budget its commit states",
              file=sys.stderr)
    return 1 if args.check and above else 0


if __name__ == "__main__":
    sys.exit(main())
