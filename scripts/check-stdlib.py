#!/usr/bin/env python3
"""Compiles every C++ source of a build once more with the whole standard library included
first (`-include bits/stdc++.h -fsyntax-only`).

Newer standard libraries reach more of themselves through each header (libstdc++ 13 pulls
<iomanip> in where 12 did not), so a file-local name that argument-dependent lookup can
confuse with a std:: one (a `quoted(std::string_view)` against `std::quoted`) compiles
with g++ 12 and fails with g++ 13. Including everything first makes such ambiguities fail
here, on Debian 12, as they would on a newer toolchain.

Usage: scripts/check-stdlib.py [BUILD_DIR]   (default: build; reads its compile_commands.json)
"""

import json
import os
import shlex
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor


def syntax_only(entry):
    args = entry.get("arguments") or shlex.split(entry["command"])
    out = []
    skip = False
    for a in args:
        if skip:
            skip = False
            continue
        if a == "-o":
            skip = True
            continue
        if a.startswith("-o") and len(a) > 2:
            continue
        out.append(a)
    # Precompiled headers and dependency files of the real build stay untouched.
    out = [a for a in out if a not in ("-MD", "-MMD")]
    cleaned = []
    skip = False
    for a in out:
        if skip:
            skip = False
            continue
        if a in ("-MF", "-MT", "-MQ"):
            skip = True
            continue
        cleaned.append(a)
    return [cleaned[0], "-include", "bits/stdc++.h", "-fsyntax-only"] + cleaned[1:]


def main():
    build = sys.argv[1] if len(sys.argv) > 1 else "build"
    path = os.path.join(build, "compile_commands.json")
    try:
        with open(path, encoding="utf-8") as f:
            entries = json.load(f)
    except OSError as e:
        print(f"check-stdlib: {path}: {e.strerror} (build first: scripts/build.sh)", file=sys.stderr)
        return 2
    cpp = [e for e in entries if e["file"].endswith((".cpp", ".cc", ".cxx"))]
    if not cpp:
        print(f"check-stdlib: {path}: no C++ sources", file=sys.stderr)
        return 2

    def run(e):
        r = subprocess.run(syntax_only(e), cwd=e["directory"], capture_output=True, text=True)
        return e["file"], r.returncode, r.stderr

    failed = 0
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        for file, rc, err in pool.map(run, cpp):
            if rc != 0:
                failed += 1
                print(f"check-stdlib: {file}: fails with the whole standard library included\n{err}",
                      file=sys.stderr)
    print(f"check-stdlib: {len(cpp)} C++ sources of {build} with -include bits/stdc++.h: "
          f"{failed or 'none'} failing")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
