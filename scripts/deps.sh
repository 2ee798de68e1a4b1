#!/usr/bin/env bash
# Installs the Debian 12 packages RED needs, skipping those already installed.
# Debian packages only; nothing is downloaded from anywhere else.
set -euo pipefail

PACKAGES=(
  build-essential g++ cmake ninja-build pkg-config clang-format ccache
  libyaml-cpp-dev libyaml-dev nlohmann-json3-dev libcli11-dev libspdlog-dev libfmt-dev
  libgtest-dev libgmock-dev googletest libbenchmark-dev
  gnuplot-nox doxygen
  chromium
  clang libclang-rt-14-dev
  libtorch-dev python3-torch
  cyclonedds-dev cyclonedds-tools
  iceoryx
  libfastrtps-dev fastddsgen
  libpng-dev libjpeg-dev
  openssl nftables tcpdump
)
# ccache: a second build of the same sources (the test command run again, another clone
# of the same commit) compiles only what changed (scripts/ccache-env.sh).
# iceoryx: RouDi (iox-roudi), the daemon of the shared memory that Debian's Cyclone DDS is
# built with (libddsc0debian depends on libiceoryx-binding-c2), for `red node --shm` and its
# test (docs/ROS2.md, "Shared memory (iceoryx)").
# openssl: `red security` makes SROS2 keystores with the openssl program, as SROS2 does.
# nftables, tcpdump: the DDS node's tests on a bad link (packet loss and an outage made with
# nftables in a network namespace of the test's own) and of its encrypted traffic (a tcpdump
# capture of that namespace's loopback); root only, skipped with a reason elsewhere
# (docs/ROS2.md, "Tests").
# node and npm run the independent ROS 2 serializer of the DDS wire test (docs/ROS2.md,
# scripts/npm-oracle.sh); a node installed another way (NodeSource bundles npm) is kept.
command -v npm >/dev/null || PACKAGES+=(nodejs npm)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "deps: need root (or sudo) to install: ${missing[*]}" >&2; exit 1; }
  SUDO="sudo"
fi
echo "deps: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
