#!/usr/bin/env bash
# Configures and builds RED into build/ (or $RED_BUILD_DIR): core, CLI, LibTorch backend
# (when libtorch-dev is installed), tests and benchmarks; only the targets in $RED_TARGETS
# (a list) when it is set (scripts/main.sh: RED_TARGETS=red, the program and its backends).
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/ccache-env.sh
BUILD_DIR=${RED_BUILD_DIR:-build}
cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release -DRED_TORCH=AUTO "$@" >/dev/null
# shellcheck disable=SC2086  # RED_TARGETS is a list of targets
cmake --build "$BUILD_DIR" -j"$(nproc)" ${RED_TARGETS:+--target $RED_TARGETS}
