#!/usr/bin/env bash
# Installs the independent ROS 2 serializer the DDS wire test compares against (docs/ROS2.md):
# pinned npm packages into build-npm/ (ignored by git). Needs node and npm; without node the
# wire test skips itself and says so.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v npm >/dev/null || { echo "npm-oracle: npm not found; the DDS wire test will skip" >&2; exit 0; }
PKGS=(@foxglove/rosmsg2-serialization@3.1.0 @foxglove/rosmsg@5.0.5 @foxglove/rosmsg-msgs-common@3.2.3)
if [ -f build-npm/.installed ] && [ "$(cat build-npm/.installed)" = "${PKGS[*]}" ]; then exit 0; fi
mkdir -p build-npm
npm install --prefix build-npm --no-audit --no-fund --no-save "${PKGS[@]}" >/dev/null
echo "${PKGS[*]}" > build-npm/.installed
echo "npm-oracle: installed ${PKGS[*]} into build-npm/"
