#!/usr/bin/env python3
"""Checks that every link to a Markdown file of the repository resolves: the file exists and, where the link names
a section (a `.md` name, then `#` and an anchor; or `#` and an anchor alone), that file has a heading with that
anchor (python3 standard library only).

    scripts/check_doc_links.py [ROOT]        # ROOT: the repository (default: this script's parent folder)

What is checked, in the files of ROOT that git tracks or would track (not ignored; every file outside build*/ and
hidden folders when ROOT is not a git checkout):
  - in Markdown files, every link and image `[text](target)` whose target is relative (no scheme, not absolute):
    the target exists, relative to the linking file, and a `.md` target's anchor (or a bare `#anchor`: the file
    itself) names one of its headings. Links in fenced code blocks and code spans are not links and are skipped.
  - in every text file (source comments, scripts, CMake; Markdown outside its links), each mention of a `.md` path,
    with or without `#` and an anchor: a mention with an anchor, or whose first path component is a top-level
    entry of the repository (`docs/LOD.md`), must resolve, relative to the mentioning file or to ROOT; a bare name
    (`SPEC.md`) is looked up beside the mentioning file, then at ROOT, then as the one tracked file of that name
    (file names are unique in the repository). A mention preceded by `$` or `}` (a variable's folder), one under a
    folder the repository does not have, and a bare name without an anchor that no tracked file has (an output
    file a script writes) are not links and are skipped.
Anchors follow GitHub's rules: the heading's text with inline markup removed (code spans keep their text, links
their label), lower-cased, every character that is not a letter, digit, underscore, space or hyphen dropped, each
space turned into a hyphen; a repeated anchor gets -1, -2, ... in order. `<a name="x">` and `<a id="x">` count too.

Prints each broken link as `FILE:LINE: TARGET: why` and exits 1 if there is any, else 0 (2: usage).
"""
import os
import re
import subprocess
import sys

MD_LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\[\]]*\])*\]\(\s*<?([^()\s>]+(?:\([^()\s]*\))?)>?(?:\s+\"[^\"]*\")?\s*\)")
MENTION = re.compile(r"(?<![A-Za-z0-9_.$}/-])((?:\.{0,2}/)?[A-Za-z0-9_][A-Za-z0-9_./-]*\.md)(#[A-Za-z0-9_-]+)?")
FENCE = re.compile(r"^\s{0,3}(```|~~~)")
HEADING = re.compile(r"^\s{0,3}(#{1,6})\s+(.*?)\s*#*\s*$")
HTML_ANCHOR = re.compile(r"<a\s+(?:name|id)=\"([^\"]+)\"")
TEXT_SUFFIXES = (".cpp", ".h", ".cu", ".cuh", ".c", ".py", ".pyi", ".sh", ".cmake", ".txt", ".toml", ".js", ".html",
                 ".css", ".in", ".json", ".yml", ".yaml", ".cfg", ".ini")


def slug(text):
    """GitHub's anchor of a heading's Markdown text."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", text)  # links and images: their label
    text = re.sub(r"<[^>]+>", "", text)  # HTML tags
    text = text.replace("`", "").replace("*", "")
    text = re.sub(r"(?<![A-Za-z0-9])_+|_+(?![A-Za-z0-9])", "", text)  # _emphasis_ markers, not snake_case
    text = text.strip().lower()
    text = "".join(c for c in text if c.isalnum() or c in "_- ")
    return text.replace(" ", "-")


def strip_fenced(lines):
    """The lines with fenced code blocks blanked (line numbers kept)."""
    out, fence = [], None
    for line in lines:
        m = FENCE.match(line)
        if fence is None and m:
            fence = m.group(1)
            out.append("")
        elif fence is not None:
            if line.strip().startswith(fence):
                fence = None
            out.append("")
        else:
            out.append(line)
    return out


_anchor_cache = {}


def anchors(path):
    if path not in _anchor_cache:
        found, seen = set(), {}
        with open(path, encoding="utf-8") as f:
            lines = strip_fenced(f.read().split("\n"))
        for line in lines:
            for name in HTML_ANCHOR.findall(line):
                found.add(name)
            m = HEADING.match(line)
            if not m:
                continue
            base = slug(m.group(2))
            n = seen.get(base, 0)
            seen[base] = n + 1
            found.add(base if n == 0 else f"{base}-{n}")
        _anchor_cache[path] = found
    return _anchor_cache[path]


def tracked_files(root):
    try:
        out = subprocess.run(["git", "-C", root, "ls-files", "-z", "--cached", "--others", "--exclude-standard"], check=True, capture_output=True).stdout
        return [p for p in out.decode("utf-8").split("\0") if p and os.path.isfile(os.path.join(root, p))]
    except (OSError, subprocess.CalledProcessError):
        files = []
        for d, dirs, names in os.walk(root):
            dirs[:] = [x for x in dirs if not x.startswith(".") and not x.startswith("build")]
            files += [os.path.relpath(os.path.join(d, n), root) for n in names]
        return files


def check_anchor(target_path, anchor, shown):
    """None if TARGET_PATH (a file) has ANCHOR (without '#'; None: no anchor), else why not."""
    if anchor is None or not target_path.endswith(".md"):
        return None
    if anchor not in anchors(target_path):
        return f"no heading with the anchor #{anchor} in {shown}"
    return None


def check_markdown(root, rel, top_level, by_name, problems):
    path = os.path.join(root, rel)
    with open(path, encoding="utf-8") as f:
        lines = strip_fenced(f.read().split("\n"))
    text = "\n".join(lines)
    # Inline code spans (within a paragraph) become blanks of the same length, so offsets keep their line.
    text = re.sub(r"(`+)(?:(?!\1|\n[ \t]*\n)[\s\S])+?\1", lambda m: re.sub(r"[^\n]", " ", m.group(0)), text)
    for m in MD_LINK.finditer(text):
        target = m.group(1)
        number = text.count("\n", 0, m.start(1)) + 1
        if re.match(r"^[A-Za-z][A-Za-z0-9+.-]*:", target) or target.startswith("/"):
            continue  # a URL (http:, mailto:) or an absolute path: not the repository's
        file_part, _, anchor = target.partition("#")
        if file_part:
            resolved = os.path.normpath(os.path.join(os.path.dirname(path), file_part))
            if not os.path.exists(resolved):
                problems.append(f"{rel}:{number}: {target}: no file {os.path.relpath(resolved, root)}")
                continue
        else:
            resolved = path
        if os.path.isfile(resolved):
            why = check_anchor(resolved, anchor or None, os.path.relpath(resolved, root))
            if why:
                problems.append(f"{rel}:{number}: {target}: {why}")
    # Mentions outside links (`docs/AUDITS.md#default-views` in prose or code spans), as in source files.
    unlinked = MD_LINK.sub(lambda m: re.sub(r"[^\n]", " ", m.group(0)), "\n".join(lines))
    check_mentions(root, rel, top_level, by_name, problems, unlinked)


def check_mentions(root, rel, top_level, by_name, problems, text=None):
    path = os.path.join(root, rel)
    if text is None:
        try:
            with open(path, encoding="utf-8") as f:
                text = f.read()
        except UnicodeDecodeError:
            return
    for number, line in enumerate(text.split("\n"), 1):
        for m in MENTION.finditer(line):
            name, anchor = m.group(1), m.group(2)
            anchor = anchor[1:] if anchor else None
            bare = name.lstrip("./")
            candidates = [os.path.normpath(os.path.join(os.path.dirname(path), name))]
            if "/" in bare:
                if bare.split("/", 1)[0] not in top_level and anchor is None:
                    continue  # a folder of the machine running the code, not of the repository
                candidates.append(os.path.normpath(os.path.join(root, bare)))
            else:
                candidates.append(os.path.join(root, bare))
                if len(by_name.get(bare, [])) == 1:
                    candidates.append(os.path.join(root, by_name[bare][0]))
            resolved = next((c for c in candidates if os.path.isfile(c)), None)
            shown = name + (f"#{anchor}" if anchor else "")
            if resolved is None:
                if "/" not in bare and anchor is None and bare not in by_name:
                    continue  # an output file's name, not a link
                problems.append(f"{rel}:{number}: {shown}: no such file in the repository")
                continue
            why = check_anchor(resolved, anchor, os.path.relpath(resolved, root))
            if why:
                problems.append(f"{rel}:{number}: {shown}: {why}")


def main(argv):
    if len(argv) > 1 or (argv and argv[0].startswith("-")):
        sys.stderr.write(__doc__.split("\n\n")[1] + "\n")
        return 2
    root = os.path.abspath(argv[0] if argv else os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    files = tracked_files(root)
    top_level = {f.split("/", 1)[0] for f in files}
    by_name = {}
    for f in files:
        by_name.setdefault(os.path.basename(f), []).append(f)
    problems = []
    for rel in sorted(files):
        if rel.endswith(".md"):
            check_markdown(root, rel, top_level, by_name, problems)
        elif rel.endswith(TEXT_SUFFIXES) or os.path.basename(rel) == "CMakeLists.txt":
            check_mentions(root, rel, top_level, by_name, problems)
    for p in problems:
        print(p)
    if problems:
        print(f"check_doc_links: {len(problems)} broken link(s)", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
