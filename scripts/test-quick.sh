#!/usr/bin/env bash
# The quick tier for daily work (docs/TESTING.md, "The quick tier"): builds Release into build/
# (the test suite and the red program it runs; ccache when installed) and runs the unit and
# CLI suites (CTest label `unit`: red_tests, the docs check, reproduce.py's computations).
# A few minutes after a first build. It leaves out the wall-clock integration tests, LibTorch,
# DDS, the sanitizers, the fuzzers and the install checks: scripts/test.sh runs everything.
# Arguments go to ctest (for example -R Overload).
set -euo pipefail
cd "$(dirname "$0")/.."
RED_TARGETS=red_tests scripts/build.sh -DRED_WERROR=ON
ctest --test-dir build -L unit -j"$(nproc)" --output-on-failure "$@"
