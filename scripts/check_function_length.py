#!/usr/bin/env python3
"""Reports every C++/CUDA function whose body is longer than a limit, and exits 1 if there is one.

Scans the product's sources (format/ converter/ kernels/ runtime/ api/ audit/ view/ parallel/ tools/), the lab
(lab/) and the Python module (python/), but no tests/ or samples/ folder (lab/tests/ neither), with a
brace-matching pass over the text after comments, string and character literals and preprocessor lines are
blanked out. A function's length is counted from the line of its opening brace to the line of its closing brace,
both included. Functions defined inside classes and namespaces count; lambdas and blocks inside a function count
towards that function.

Usage: scripts/check_function_length.py [--max-lines N] [PATH ...]   (default 150 lines, the folders above)
Exit status: 0 when no function is longer than N lines, 1 when one is, 2 on a usage error.
"""
import argparse
import os
import re
import sys

PRODUCT_DIRS = ["format", "converter", "kernels", "runtime", "api", "audit", "view", "parallel", "tools"]
CHECKED_DIRS = PRODUCT_DIRS + ["lab", "python"]
SKIPPED_DIRS = {"tests", "samples", "build"}
SOURCE_SUFFIXES = (".h", ".hpp", ".cpp", ".cc", ".cu", ".cuh")

_CONTAINER_HEADER = re.compile(r"^\s*(?:template\s*<.*>\s*)?(?:class|struct|union|namespace|extern)\b", re.S)
_ENUM_HEADER = re.compile(r"^\s*enum\b")
_CONTROL_HEADER = re.compile(r"^\s*(?:if|for|while|switch|catch|do|else|try)\b")
_INIT_LIST = re.compile(r"\)\s*(?:noexcept\s*)?:(?!:)")
_MACRO_NAME = re.compile(r"^(?:__\w+__|[A-Z][A-Z0-9_]*)$")
_NAME_BEFORE_PAREN = re.compile(r"((?:~?[A-Za-z_]\w*(?:\s*<[^()]*>)?\s*::\s*)*(?:operator\s*\S+?|~?[A-Za-z_]\w*))\s*$")


def blank_non_code(text):
    """Returns `text` with comments, literals and preprocessor lines replaced by spaces (newlines kept)."""
    out = list(text)
    i, n = 0, len(text)
    at_line_start = True
    while i < n:
        c = text[i]
        if at_line_start and c == "#":
            j = i
            while j < n and text[j] != "\n":
                if text[j] == "\\" and j + 1 < n and text[j + 1] == "\n":
                    j += 2
                    continue
                j += 1
            for k in range(i, j):
                if out[k] != "\n":
                    out[k] = " "
            i = j
            continue
        if c == "\n":
            at_line_start = True
            i += 1
            continue
        if c not in " \t":
            at_line_start = False
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
        elif c == "R" and text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            m = re.match(r'R"([^(\s]*)\(', text[i:])
            if not m:
                i += 1
                continue
            end = text.find(")" + m.group(1) + '"', i)
            j = n if end < 0 else end + len(m.group(1)) + 2
        elif c in "\"'":
            if c == "'" and i > 0 and text[i - 1].isalnum():  # digit separator 1'000
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
        else:
            i += 1
            continue
        for k in range(i, j):
            if out[k] != "\n":
                out[k] = " "
        i = j
    return "".join(out)


def matching_brace(code, open_index):
    """Index of the `}` closing the `{` at `open_index` (len(code) if unbalanced)."""
    depth = 0
    for k in range(open_index, len(code)):
        if code[k] == "{":
            depth += 1
        elif code[k] == "}":
            depth -= 1
            if depth == 0:
                return k
    return len(code)


def function_name(header):
    """The (qualified) name before the parameter list of a function header."""
    angle = paren = 0
    names = []
    for k, ch in enumerate(header):
        if ch == "<" and paren == 0:
            angle += 1
        elif ch == ">" and angle > 0 and paren == 0:
            angle -= 1
        elif ch == "(":
            if angle == 0 and paren == 0:
                m = _NAME_BEFORE_PAREN.search(header[:k])
                names.append(re.sub(r"\s+", "", m.group(1)) if m else "(lambda)" if "]" in header[:k] else "(unnamed)")
            paren += 1
        elif ch == ")" and paren > 0:
            paren -= 1
    # Attribute macros such as __launch_bounds__(256) or RGS_ALIGN(16) come before the function's own name.
    for name in names:
        if not _MACRO_NAME.match(name):
            return name
    return names[0] if names else "(unnamed)"


def long_functions(code, max_lines):
    """Yields (line, length, name) for each function body in `code` longer than `max_lines` lines."""
    line_of = [0] * (len(code) + 1)
    line = 1
    for k, ch in enumerate(code):
        line_of[k] = line
        if ch == "\n":
            line += 1
    line_of[len(code)] = line

    def scan(begin, end):
        header_start = begin
        k = begin
        while k < end:
            ch = code[k]
            if ch in ";}":
                header_start = k + 1
            elif ch == "{":
                header = code[header_start:k]
                before = header.rstrip()
                if _INIT_LIST.search(header) and before and (before[-1].isalnum() or before[-1] in "_>"):
                    k = matching_brace(code, k) + 1  # a member initialiser `x_{...}`
                    continue
                close = matching_brace(code, k)
                if _CONTAINER_HEADER.match(header) and "(" not in header.split("{")[0]:
                    yield from scan(k + 1, close)
                elif ("(" in header and not before.endswith("=") and not _ENUM_HEADER.match(header)
                      and not _CONTROL_HEADER.match(header)):
                    length = line_of[close] - line_of[k] + 1
                    if length > max_lines:
                        yield line_of[k], length, function_name(header)
                k = close + 1
                header_start = k
                continue
            k += 1

    yield from scan(0, len(code))


def source_files(paths):
    for path in paths:
        if os.path.isfile(path):
            yield path
            continue
        for directory, subdirs, files in os.walk(path):
            subdirs[:] = sorted(d for d in subdirs if d not in SKIPPED_DIRS and not d.startswith("build"))
            for name in sorted(files):
                if name.endswith(SOURCE_SUFFIXES):
                    yield os.path.join(directory, name)


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--max-lines", type=int, default=150, help="longest allowed function body (default 150)")
    parser.add_argument("paths", nargs="*", help="files or folders (default: the product's, lab and python)")
    args = parser.parse_args(argv)
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    paths = args.paths or [os.path.join(root, d) for d in CHECKED_DIRS if os.path.isdir(os.path.join(root, d))]
    found = 0
    for path in source_files(paths):
        with open(path, encoding="utf-8", errors="replace") as f:
            code = blank_non_code(f.read())
        for line, length, name in long_functions(code, args.max_lines):
            found += 1
            print(f"{os.path.relpath(path, root)}:{line}: {name} is {length} lines (limit {args.max_lines})")
    if found:
        print(f"check_function_length: {found} function(s) over {args.max_lines} lines", file=sys.stderr)
        return 1
    print(f"check_function_length: no function over {args.max_lines} lines")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
