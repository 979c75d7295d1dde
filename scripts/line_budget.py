#!/usr/bin/env python3
"""Prints the product's size against its line budgets (CONTRIBUTING.md#line-budgets).

The product is the C++/CUDA sources of the libraries and tools (format/ converter/ kernels/ runtime/ api/ audit/
view/ parallel/ tools/), as tracked by git; lab/, tests/, python/ and samples/ are apart. Two figures: every line
(`wc -l`) and code lines (cloc: neither blank nor comment, so that comments and docs are never what is cut).
Each layer's lines follow, largest first.

Usage: scripts/line_budget.py [--check]   (--check: exit 1 when a budget is exceeded)
Needs git and cloc (apt-get install cloc).
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


def row(name, value, budget):
    state = "within" if value <= budget else "over by %d" % (value - budget)
    return "%-28s %7d   budget %7d   %s" % (name, value, budget, state)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--check", action="store_true", help="exit 1 when a budget is exceeded")
    args = parser.parse_args()
    if shutil.which("cloc") is None:
        print("line_budget: cloc not found (apt-get install cloc)", file=sys.stderr)
        return 2
    paths = product_sources()
    lines, code = count_lines(paths), cloc_code_lines(paths)
    print("product sources: %d files" % len(paths))
    print(row("lines (wc -l)", lines, BUDGET_LINES))
    print(row("code lines (cloc)", code, BUDGET_CODE_LINES))
    by_dir = {d: count_lines([p for p in paths if p.startswith(d + "/")]) for d in PRODUCT_DIRS}
    for d, n in sorted(by_dir.items(), key=lambda item: -item[1]):
        print("  %-10s %7d lines" % (d + "/", n))
    return 1 if args.check and (lines > BUDGET_LINES or code > BUDGET_CODE_LINES) else 0


if __name__ == "__main__":
    sys.exit(main())
