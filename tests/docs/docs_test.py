#!/usr/bin/env python3
"""The documentation stands alone (issue 40, item 4).

1. No file of the project cites a design specification by section number ("DESIGN §3",
   a bare "§15") or points into a directory outside the repository (the paper's source
   under ../shared): a user cannot follow either. A rule is cited by a link to the project
   doc that explains it (docs/DESIGN.md#overload) or, in code, by the doc and the section
   title. Sections of the RED paper ("paper §3.4") and of other cited papers by name stay
   allowed: the paper is cited by title and arXiv number in docs/DESIGN.md, "Paper".
2. Every relative link in README.md and docs/**/*.md leads to a file that exists and, when
   it names an anchor in a Markdown file, to a heading or an explicit <a id> there.

    docs_test.py SOURCE_DIR      exit 0 when both hold, 1 with one line per problem
"""
import os
import re
import subprocess
import sys

SELF = "tests/docs/docs_test.py"
# Built from pieces so that this file does not match itself.
SECTION = "\u00a7"
FORBIDDEN = [
    (re.compile(r"DESIGN(\.md)?,?\s?" + SECTION), "a section number of a design spec"),
    (re.compile(r"(?<!paper )(?<!paper's )(?<!Paper )" + SECTION + r"\s?\d"),
     "a bare section number (which document?)"),
    (re.compile(r"\.\./" + "shared"), "a path outside the repository"),
    (re.compile("shared/" + "paper|red-" + "paper\\.tex"), "a path to the paper's source"),
]
LINK = re.compile(r"(?<!!)\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
IMAGE = re.compile(r"!\[[^\]]*\]\(\s*([^)\s]+)")
ANCHOR_ID = re.compile(r"<a\s+(?:id|name)=\"([^\"]+)\"")


def tracked_files(root):
    try:
        out = subprocess.run(["git", "-C", root, "ls-files", "-z"], capture_output=True,
                             check=True).stdout.decode()
        files = [f for f in out.split("\0") if f]
        if files:
            return files
    except (OSError, subprocess.CalledProcessError):
        pass
    files = []  # not a git checkout (a source archive): every file but build trees
    for d, dirs, names in os.walk(root):
        dirs[:] = [x for x in dirs if not x.startswith(("build", ".git"))]
        files += [os.path.relpath(os.path.join(d, n), root) for n in names]
    return files


def read_text(path):
    try:
        with open(path, encoding="utf-8") as f:
            return f.read()
    except (UnicodeDecodeError, OSError):
        return None  # binary, or a link to nowhere


def strip_code(text, spans=True):
    """Markdown lines without fenced blocks and (with spans) inline code spans: links
    there are examples."""
    out, fenced = [], False
    for line in text.split("\n"):
        if line.lstrip().startswith(("```", "~~~")):
            fenced = not fenced
            out.append("")
            continue
        out.append("" if fenced else re.sub(r"`[^`]*`", "", line) if spans else line)
    return out


def slug(heading):
    """GitHub's anchor of a heading: rendered text, lower case, punctuation dropped."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link: its text
    text = re.sub(r"<[^>]+>", "", text).strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


_anchors = {}


def anchors(path):
    if path not in _anchors:
        found, seen = set(), {}
        text = read_text(path) or ""
        for line in strip_code(text, spans=False):
            m = re.match(r"#{1,6}\s+(.*?)\s*#*\s*$", line)
            if m:
                s = slug(m.group(1))
                n = seen.get(s, 0)
                seen[s] = n + 1
                found.add(s if n == 0 else f"{s}-{n}")
        # explicit anchors, also inside lines the code stripping blanked
        found.update(ANCHOR_ID.findall(text))
        _anchors[path] = found
    return _anchors[path]


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else ".")
    problems = []
    files = tracked_files(root)
    for rel in files:
        if rel == SELF:
            continue
        text = read_text(os.path.join(root, rel))
        if text is None:
            continue
        for no, line in enumerate(text.split("\n"), 1):
            for pattern, what in FORBIDDEN:
                if pattern.search(line):
                    problems.append(f"{rel}:{no}: {what}: {line.strip()[:100]}")
    docs = [f for f in files if f == "README.md" or (f.startswith("docs/") and f.endswith(".md"))]
    for rel in docs:
        path = os.path.join(root, rel)
        text = read_text(path)
        if text is None:
            continue
        for no, line in enumerate(strip_code(text), 1):
            for target in LINK.findall(line) + IMAGE.findall(line):
                if re.match(r"[a-z][a-z0-9+.-]*:", target):  # https:, mailto:
                    continue
                file_part, _, anchor = target.partition("#")
                dest = os.path.normpath(os.path.join(os.path.dirname(path), file_part)) \
                    if file_part else path
                if not os.path.exists(dest):
                    problems.append(f"{rel}:{no}: link to a missing file: {target}")
                elif anchor and dest.endswith(".md") and anchor not in anchors(dest):
                    problems.append(f"{rel}:{no}: link to a missing anchor: {target}")
    for p in problems:
        print(p)
    print(f"docs_test: {len(files)} files, {len(docs)} Markdown pages, "
          f"{len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
