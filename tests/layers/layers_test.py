#!/usr/bin/env python3
"""No include runs up a layer (issue 54, item 2).

The modules of RED are layered: a file of one module includes headers of its own module and
of the modules below it, never of one above. The order is the numbered list under "Layers" in
docs/ARCHITECTURE.md, bottom first; modules named on the same line are one layer and do not
include each other. This test reads that list and every `#include "red/..."` (or <red/...>)
of include/red, src, backends/*/ and bridges/*/ and tools/, and names each include that goes
up: a new one fails CI, and the list and the code cannot drift apart.

    layers_test.py SOURCE_DIR           exit 0 when no include goes up, 1 with one line each
    layers_test.py SOURCE_DIR --list    also print each file's module and what it includes
"""
import os
import re
import sys

DOC = "docs/ARCHITECTURE.md"
INCLUDE = re.compile(r'^\s*#\s*include\s*[<"]red/([^">]+)[">]', re.M)
ITEM = re.compile(r"^\d+\.\s+(.*)$")
NAME = re.compile(r"`([^`]+)`")
ROOTS = ["include/red", "src", "backends", "bridges", "tools"]
SUFFIXES = (".hpp", ".cpp", ".h", ".hpp.in")


def layers(root):
    """{module: layer number} from the numbered list of the doc's "## Layers" section."""
    with open(os.path.join(root, DOC), encoding="utf-8") as f:
        text = f.read()
    m = re.search(r"^## Layers\n(.*?)(?=^## |\Z)", text, re.M | re.S)
    if not m:
        sys.exit(f"{DOC}: no '## Layers' section")
    order = {}
    for line in m.group(1).splitlines():
        item = ITEM.match(line.strip())
        if not item:
            continue
        level = len(set(order.values()))
        for name in NAME.findall(item.group(1).split(":")[0]):
            order[name.strip("/")] = level
    if not order:
        sys.exit(f"{DOC}: the '## Layers' section has no numbered list")
    return order


def module_of_file(path):
    """The module a file of the checkout belongs to: include/red/<m>/, src/<m>/,
    backends/<m>/ or bridges/<m>/ (as backends/torch), tools/<m>/ (as tools)."""
    parts = path.split("/")
    if parts[0] == "include":
        return "core" if len(parts) == 3 else parts[2]  # red/version.hpp: a core header
    if parts[0] == "src":
        return parts[1]
    if parts[0] in ("backends", "bridges"):
        return parts[0] + "/" + parts[1]
    return "tools"


def module_of_header(header, order):
    """The module of an included "red/<m>/x.hpp": its directory, or the backend or bridge
    whose include/red/<m>/ holds it (red/torch/ -> backends/torch)."""
    if "/" not in header:
        return "core"
    first = header.split("/")[0]
    if first in order:
        return first
    for group in ("backends", "bridges"):
        if f"{group}/{first}" in order:
            return f"{group}/{first}"
    return first


def main(argv):
    root = argv[1] if len(argv) > 1 else "."
    listing = "--list" in argv
    order = layers(root)
    problems, unknown, seen = [], set(), 0
    for top in ROOTS:
        for d, dirs, names in os.walk(os.path.join(root, top)):
            dirs[:] = sorted(x for x in dirs if not x.startswith(("build", ".")))
            for n in sorted(names):
                if not n.endswith(SUFFIXES):
                    continue
                path = os.path.relpath(os.path.join(d, n), root)
                mine = module_of_file(path)
                with open(os.path.join(root, path), encoding="utf-8") as f:
                    text = f.read()
                for header in INCLUDE.findall(text):
                    seen += 1
                    theirs = module_of_header(header, order)
                    for m in (mine, theirs):
                        if m not in order:
                            unknown.add(m)
                    if mine not in order or theirs not in order:
                        continue
                    if listing:
                        print(f"{path} ({mine}) -> red/{header} ({theirs})")
                    if theirs != mine and order[theirs] >= order[mine]:
                        problems.append(
                            f"{path}: module {mine} includes red/{header} of {theirs}, "
                            f"which is {'above' if order[theirs] > order[mine] else 'beside'} "
                            f"it ({DOC}, \"Layers\")")
    if seen == 0:
        problems.append(f"no #include \"red/...\" found under {', '.join(ROOTS)}")
    for m in sorted(unknown):
        problems.append(f"module {m} is not in the list of {DOC}, \"Layers\"")
    for p in problems:
        print(p)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
