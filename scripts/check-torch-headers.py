#!/usr/bin/env python3
"""Compiles every source that includes LibTorch again, syntax only, against other LibTorch
versions' headers: the torch backend, the CLI files and the torch tests, as the build compiles
them (compile_commands.json) but with another LibTorch's include directories first
(`-fsyntax-only`, warnings still errors for RED's own code). Where CUDA's headers are found too
(CUDA_INCLUDE, else /usr/local/cuda*/include or /usr/include with cuda_runtime_api.h), the
sources with a CUDA branch (RED_TORCH_CUDA) are compiled again with it on, against the
c10/cuda and ATen/cuda headers of each LibTorch and of the build's own.

Nothing is downloaded. The header sets are prefixes holding include/torch/csrc/api/include,
given as arguments or in RED_TORCH_HEADERS (colon-separated); Debian's libtorch-dev packages
unpacked give them (docs/GPU.md, "Versions tried"):

    apt-get download libtorch-dev=2.6.0+dfsg-7   # from a trixie source list
    dpkg-deb -x libtorch-dev_2.6.0+dfsg-7_amd64.deb /opt/libtorch-2.6   # prefix /opt/libtorch-2.6/usr

Without any header set it says so and exits 0 (a machine without them skips the check).

Usage: scripts/check-torch-headers.py BUILD_DIR [PREFIX ...] [--jobs N]
"""

import concurrent.futures
import glob
import json
import os
import re
import shlex
import subprocess
import sys
import tempfile

TORCH_API = "torch/csrc/api/include"


def version_of(prefix):
    """MAJOR.MINOR.PATCH of the LibTorch whose headers are under `prefix`, or None."""
    text = ""
    # From 2.10 or so torch/version.h includes torch/headeronly/version.h.
    for rel in (os.path.join(TORCH_API, "torch", "version.h"), "torch/headeronly/version.h"):
        try:
            text += open(os.path.join(prefix, "include", rel), encoding="utf-8").read()
        except OSError:
            pass
    if not text:
        return None
    parts = [re.search(r"#define TORCH_VERSION_%s (\d+)" % k, text) for k in ("MAJOR", "MINOR", "PATCH")]
    return ".".join(p.group(1) for p in parts) if all(parts) else "?"


def cuda_include():
    given = os.environ.get("CUDA_INCLUDE")
    candidates = [given] if given else sorted(glob.glob("/usr/local/cuda*/include")) + ["/usr/include"]
    for c in candidates:
        if c and os.path.exists(os.path.join(c, "cuda_runtime_api.h")):
            return c
    return None


def torch_entries(build):
    with open(os.path.join(build, "compile_commands.json"), encoding="utf-8") as f:
        entries = json.load(f)
    return [e for e in entries if TORCH_API in e.get("command", "")]


# A CUDA build of LibTorch generates c10/cuda/impl/cuda_cmake_macros.h from
# c10/cuda/impl/cuda_cmake_macros.h.in (one #cmakedefine C10_CUDA_BUILD_SHARED_LIBS); Debian's
# CPU packages ship c10/cuda's other headers without it. For the CUDA branch the check supplies
# what a shared-library CUDA build generates.
CUDA_CMAKE_MACROS = """#pragma once
// Supplied by scripts/check-torch-headers.py: what a CUDA build of LibTorch generates.
#define C10_CUDA_BUILD_SHARED_LIBS
"""


def cuda_macros_dir(tmp):
    d = os.path.join(tmp, "c10", "cuda", "impl")
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, "cuda_cmake_macros.h"), "w", encoding="utf-8") as f:
        f.write(CUDA_CMAKE_MACROS)
    return tmp


def rewrite(entry, prefix, cuda, extra):
    """The entry's command, syntax only, against `prefix` (None: the build's own LibTorch)."""
    args = shlex.split(entry["command"])
    out = []
    skip = False
    for i, a in enumerate(args):
        if skip:
            skip = False
            continue
        if a in ("-o", "-MT", "-MF"):
            skip = True
            continue
        if a in ("-MD", "-MMD"):
            continue
        if prefix and a == "-isystem" and i + 1 < len(args) and args[i + 1].endswith(TORCH_API):
            out += ["-isystem", os.path.join(prefix, "include", TORCH_API), "-isystem",
                    os.path.join(prefix, "include")]
            skip = True
            continue
        if cuda and a.startswith("-DRED_TORCH_CUDA="):
            a = "-DRED_TORCH_CUDA=1"
        out.append(a)
    out.insert(1, "-fsyntax-only")
    out.insert(1, "-H")  # the headers read, to check none came from another LibTorch
    if cuda:
        out[1:1] = ["-isystem", cuda, "-idirafter", extra]
    return out


def run(job):
    """Compiles one; fails also when a LibTorch header came from outside `prefix`."""
    label, entry, cmd, prefix = job
    r = subprocess.run(cmd, cwd=entry["directory"], capture_output=True, text=True)
    headers = [l.lstrip(". ") for l in r.stderr.splitlines() if re.match(r"^\.+ /", l)]
    errors = "\n".join(l for l in r.stderr.splitlines() if not re.match(r"^\.+ /", l)
                       and not l.startswith("Multiple include guards")
                       and not l.startswith("/"))  # -H's summary of guard candidates
    rc = r.returncode
    if prefix:
        root = os.path.realpath(prefix)
        stray = [h for h in headers if re.search(r"/include/(ATen|c10|torch|caffe2)/", h)
                 and not os.path.realpath(h).startswith(root)]
        if stray:
            rc = rc or 1
            errors += "\nLibTorch headers from outside %s:\n  %s" % (prefix, "\n  ".join(stray[:5]))
    return label, entry["file"], rc, errors


def main(argv):
    jobs_n = 2
    if "--jobs" in argv:
        i = argv.index("--jobs")
        jobs_n = int(argv[i + 1])
        del argv[i:i + 2]
    if len(argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    build = argv[1]
    prefixes = argv[2:] or [p for p in os.environ.get("RED_TORCH_HEADERS", "").split(":") if p]
    prefixes = [p for p in prefixes if version_of(p)]
    if not prefixes:
        print("check-torch-headers: skipped: no LibTorch header set given (arguments or "
              "RED_TORCH_HEADERS: prefixes holding include/%s)" % TORCH_API)
        return 0
    if not os.path.exists(os.path.join(build, "compile_commands.json")):
        print("check-torch-headers: %s/compile_commands.json missing (configure with LibTorch)"
              % build, file=sys.stderr)
        return 2
    entries = torch_entries(build)
    if not entries:
        print("check-torch-headers: skipped: %s compiles nothing against LibTorch" % build)
        return 0
    cuda = cuda_include()
    extra = cuda_macros_dir(tempfile.mkdtemp(prefix="red-torch-headers-")) if cuda else None
    with_cuda = [e for e in entries if "RED_TORCH_CUDA" in open(e["file"], encoding="utf-8").read()]
    todo = []
    for p in prefixes:
        label = "LibTorch %s (%s)" % (version_of(p), p)
        todo += [(label, e, rewrite(e, p, None, None), p) for e in entries]
        if cuda:
            todo += [(label + " with CUDA", e, rewrite(e, p, cuda, extra), p) for e in with_cuda]
    if cuda:
        todo += [("the build's LibTorch with CUDA", e, rewrite(e, None, cuda, extra), None)
                 for e in with_cuda]
    failed = 0
    with concurrent.futures.ThreadPoolExecutor(max_workers=jobs_n) as pool:
        for label, path, rc, err in pool.map(run, todo):
            if rc != 0:
                failed += 1
                print("FAILED %s: %s\n%s" % (label, os.path.relpath(path), err))
    sets = ", ".join("LibTorch %s" % version_of(p) for p in prefixes)
    print("check-torch-headers: %d compilation(s) of %d source(s) against %s; CUDA branch (%d "
          "source(s)) %s: %d failed" % (len(todo), len(entries), sets, len(with_cuda),
                                        "with " + cuda + " and a supplied cuda_cmake_macros.h"
                                        if cuda else "skipped (no cuda_runtime_api.h found)",
                                        failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
