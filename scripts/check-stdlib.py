#!/usr/bin/env python3
"""Compiles every C++ source of a build once more with the whole standard library included
first (`-include bits/stdc++.h -fsyntax-only`).

Newer standard libraries reach more of themselves through each header (libstdc++ 13 pulls
<iomanip> in where 12 did not), so a file-local name that argument-dependent lookup can
confuse with a std:: one (a `quoted(std::string_view)` against `std::quoted`) compiles
with g++ 12 and fails with g++ 13. Including everything first makes such ambiguities fail
here, on Debian 12, as they would on a newer toolchain.

Usage: scripts/check-stdlib.py [BUILD_DIR] [--except OTHER_BUILD_DIR]
(default: build; reads its compile_commands.json). With --except, the sources that OTHER_BUILD_DIR
compiles are left out: that build must have been configured with -DRED_STDLIB_FIRST=ON, which
compiles each of them with the whole standard library included first already (scripts/test.sh
does this for the sanitizer build, so that only what it leaves out, LibTorch, DDS and the
benchmarks, is compiled here once more).
"""

import argparse
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
    # Precompiled headers and dependency files of the real build stay untouched. A target's
    # precompiled header (-include .../cmake_pch.hxx) cannot be used after bits/stdc++.h, so
    # GCC reads the header itself: without -Winvalid-pch, which would say so as an error.
    out = [a for a in out if a not in ("-MD", "-MMD", "-Winvalid-pch")]
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


def load_entries(build):
    path = os.path.join(build, "compile_commands.json")
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except OSError as e:
        print(f"check-stdlib: {path}: {e.strerror} (build first: scripts/build.sh)", file=sys.stderr)
        return None


def stdlib_first(build):
    path = os.path.join(build, "CMakeCache.txt")
    try:
        with open(path, encoding="utf-8") as f:
            return any(line.strip() == "RED_STDLIB_FIRST:BOOL=ON" for line in f)
    except OSError:
        return False


def key(entry):
    args = entry.get("arguments") or shlex.split(entry["command"])
    names = set()
    for i, a in enumerate(args):
        d = a[2:] if a.startswith("-D") and len(a) > 2 else (
            args[i + 1] if a == "-D" and i + 1 < len(args) else None)
        if d is not None:
            names.add(d.split("=", 1)[0])
    names -= {"NDEBUG", "RED_SANITIZED"}
    return os.path.realpath(os.path.join(entry["directory"], entry["file"])), frozenset(names)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("build", nargs="?", default="build")
    parser.add_argument("--except", dest="covered", metavar="OTHER_BUILD_DIR",
                        help="leave out the sources this build (RED_STDLIB_FIRST=ON) compiles")
    args = parser.parse_args()
    build = args.build
    entries = load_entries(build)
    if entries is None:
        return 2
    cpp = [e for e in entries if e["file"].endswith((".cpp", ".cc", ".cxx"))
           and not os.path.basename(e["file"]).startswith("cmake_pch")]
    if not cpp:
        print(f"check-stdlib: {build}/compile_commands.json: no C++ sources", file=sys.stderr)
        return 2
    left_out = 0
    if args.covered:
        if not stdlib_first(args.covered):
            print(f"check-stdlib: {args.covered} is not configured with -DRED_STDLIB_FIRST=ON, so "
                  "its sources were not compiled with the whole standard library first",
                  file=sys.stderr)
            return 2
        other = load_entries(args.covered)
        if other is None:
            return 2
        # A source counts as compiled there when it was compiled with the same macros defined
        # (tools/red/main.cpp is another program with RED_HAVE_TORCH); their values (paths
        # into each build directory) and the build type's NDEBUG may differ.
        covered = {key(e) for e in other}
        kept = [e for e in cpp if key(e) not in covered]
        left_out = len(cpp) - len(kept)
        cpp = kept

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
    also = (f" ({left_out} more compiled so in {args.covered})" if args.covered else "")
    print(f"check-stdlib: {len(cpp)} C++ sources of {build} with -include bits/stdc++.h{also}: "
          f"{failed or 'none'} failing")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
