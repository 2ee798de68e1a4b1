#!/usr/bin/env bash
# What carrying one camera frame through Cyclone DDS on loopback costs, alone (issue 8's
# second target; docs/BENCHMARKS.md, "The node's targets"): `red camera` publishes frames,
# `red_ros2_listener` subscribes to them (best effort, as `red node` does) and measures
# header stamp (the camera's wall clock before dds_write) -> the sample taken from its reader.
# No node, no runtime: serialization, the UDP datagrams through the kernel, reassembly,
# delivery and deserialization. Each Cyclone configuration runs ROUNDS times, interleaved
# (default, A, B, default, A, B, ...), so that a change of the machine's load hits all alike.
# Usage: bench/ros2_transport.sh [OUT_DIR]
#   CONFIGS="builtin bench/ros2/cyclone-14k.xml" (builtin: the node's default configuration;
#   otherwise Cyclone DDS XML files given to both sides) ROUNDS=3 SECS=10 RATE=30 SIZE=640x480
#   DOMAIN=60 RED=... LISTENER=...
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/ros2-transport}
BUILD=build
[ -x build/tools/red/red ] || [ ! -x build-core/tools/red/red ] || BUILD=build-core
RED=${RED:-$BUILD/tools/red/red}
LISTENER=${LISTENER:-$BUILD/bench/red_ros2_listener}
CONFIGS=${CONFIGS:-builtin bench/ros2/cyclone-14k.xml}
ROUNDS=${ROUNDS:-3}
SECS=${SECS:-10}
RATE=${RATE:-30}
SIZE=${SIZE:-640x480}
DOMAIN=${DOMAIN:-60}
for exe in "$RED" "$LISTENER"; do
  [ -x "$exe" ] || { echo "ros2 transport: $exe not found (build with scripts/build.sh)" >&2; exit 2; }
done
mkdir -p "$OUT"
echo "ros2 transport: ${SIZE} rgb8 frames at ${RATE} Hz for ${SECS}s, camera -> listener on loopback," \
  "${ROUNDS} rounds; $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg) at $(date -u +%H:%M) UTC"
printf '%-36s %5s %7s %8s %8s %8s %8s\n' configuration round frames "p50 ms" "p90 ms" "p99 ms" "load"
for round in $(seq "$ROUNDS"); do
  for config in $CONFIGS; do
    args=()
    [ "$config" != builtin ] && args=(--config "$config")
    tag="$(basename "$config" .xml)-$round"
    d=$DOMAIN
    DOMAIN=$((DOMAIN + 1))
    "$LISTENER" --domain "$d" --deadline-ms 1000 --warmup 1 --idle 1 --timeout $((SECS + 30)) \
      --camera-stamps /camera/stamps --topic frames:/camera/image_raw "${args[@]}" \
      >"$OUT/$tag.json" 2>"$OUT/$tag.log" &
    listener=$!
    sleep 0.5
    "$RED" camera --rate "$RATE" --duration "$SECS" --size "$SIZE" --domain "$d" \
      --stamps-topic /camera/stamps "${args[@]}" 2>>"$OUT/$tag.log"
    wait $listener
    python3 - "$OUT/$tag.json" "$config" "$round" "$(cut -d' ' -f1 /proc/loadavg)" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
r = d["response_ms"]
print(f"{sys.argv[2][-36:]:<36} {sys.argv[3]:>5} {d['complete']:>4}/{d['frames']:<3} "
      f"{r['p50']:8.3f} {r['p90']:8.3f} {r['p99']:8.3f} {sys.argv[4]:>8}")
PY
  done
done
