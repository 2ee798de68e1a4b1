#!/usr/bin/env bash
# Configures and builds RED into build/ (or $RED_BUILD_DIR): core, CLI, LibTorch backend
# (when libtorch-dev is installed), tests and benchmarks.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${RED_BUILD_DIR:-build}
cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release -DRED_TORCH=AUTO "$@" >/dev/null
cmake --build "$BUILD_DIR" -j"$(nproc)"
