#!/usr/bin/env python3
"""scripts/check-stdlib.py --except: a source the other build compiled with the same macro
names is left out, one compiled with other macros (red-full's RED_HAVE_TORCH) is compiled
here, and a build configured without RED_STDLIB_FIRST is refused (exit 2, named).

Usage: check_stdlib_test.py SOURCE_DIR
"""

import json
import os
import subprocess
import sys
import tempfile


def write_build(d, entries, stdlib_first):
    os.makedirs(d)
    with open(os.path.join(d, "compile_commands.json"), "w", encoding="utf-8") as f:
        json.dump(entries, f)
    with open(os.path.join(d, "CMakeCache.txt"), "w", encoding="utf-8") as f:
        f.write(f"RED_STDLIB_FIRST:BOOL={'ON' if stdlib_first else 'OFF'}\n")


def entry(d, src, defines):
    flags = " ".join(f"-D{x}" for x in defines)
    return {"directory": d, "file": src,
            "command": f"g++ -std=c++20 {flags} -o x.o -c {src}"}


def main():
    script = os.path.join(sys.argv[1], "scripts", "check-stdlib.py")
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        shared = os.path.join(tmp, "shared.cpp")
        own = os.path.join(tmp, "own.cpp")
        for f in (shared, own):
            with open(f, "w", encoding="utf-8") as out:
                out.write("int f() { return 0; }\n")
        build, asan, plain = (os.path.join(tmp, n) for n in ("build", "asan", "plain"))
        write_build(build, [entry(build, shared, ["NDEBUG", "A=\"/x\""]),
                            entry(build, own, ["A=\"/x\"", "RED_HAVE_TORCH=1"])], False)
        write_build(asan, [entry(asan, shared, ["A=\"/y\"", "RED_SANITIZED=1"]),
                           entry(asan, own, ["A=\"/y\""])], True)
        write_build(plain, [], False)

        r = subprocess.run([sys.executable, script, build, "--except", asan],
                           capture_output=True, text=True)
        if r.returncode != 0 or "1 C++ sources" not in r.stdout or "1 more compiled so" not in r.stdout:
            failures.append(f"--except: exit {r.returncode}, {r.stdout!r} {r.stderr!r}")

        r = subprocess.run([sys.executable, script, build, "--except", plain],
                           capture_output=True, text=True)
        if r.returncode != 2 or "RED_STDLIB_FIRST" not in r.stderr or plain not in r.stderr:
            failures.append(f"--except without RED_STDLIB_FIRST: exit {r.returncode}, {r.stderr!r}")
    for f in failures:
        print("check_stdlib_test: " + f, file=sys.stderr)
    print(f"check_stdlib_test: {2 - len(failures)} of 2 checks pass")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
