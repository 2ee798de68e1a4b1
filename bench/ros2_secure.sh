#!/usr/bin/env bash
# The secure node against the open node (issue 55's target: throughput and per-frame intake
# cost within 1.3x; docs/BENCHMARKS.md, "The node on a shared network"): `red camera` ->
# `red node` (synthetic backend, tests/dds/data/node.yaml) on loopback, once open and once with
# DDS Security (an SROS2 keystore made here by `red security`: authentication, access control,
# discovery, metadata and data encrypted), side by side, ROUNDS rounds per frame size.
# Per run: frames published and released, released per second, and the node's own figures:
# transport (stamp -> taken) and intake (taken -> pushed) p50/p99.
# Usage: bench/ros2_secure.sh [OUT_DIR]   SIZES="640x480 1280x720" RATE=20 SECS=8 ROUNDS=3
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/ros2-secure}
RED=${RED:-build/tools/red/red}
SIZES=${SIZES:-640x480 1280x720}
RATE=${RATE:-20}
SECS=${SECS:-8}
ROUNDS=${ROUNDS:-3}
DOMAIN=${DOMAIN:-70}
SCENARIO=tests/dds/data/node.yaml
[ -x "$RED" ] || { echo "ros2 secure: $RED not found (build with scripts/build.sh)" >&2; exit 2; }
mkdir -p "$OUT"
KS="$OUT/keystore"
rm -rf "$KS"
"$RED" security create-keystore "$KS" 2>/dev/null
"$RED" security create-enclave "$KS" /red/node --scenario "$SCENARIO" 2>/dev/null
"$RED" security create-enclave "$KS" /camera 2>/dev/null
echo "ros2 secure: rgb8 frames at ${RATE} Hz for ${SECS}s, camera -> node (synthetic) on loopback," \
  "${ROUNDS} rounds; $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg) at $(date -u +%H:%M) UTC"
printf '%-9s %-6s %5s %6s %8s %7s %12s %12s %12s %12s\n' size mode round sent released "rel/s" \
  "transp p50" "transp p99" "intake p50" "intake p99"
field() { sed -n "s/.*$1 p50 \([0-9.]*\) us, p99 \([0-9.]*\) us.*/\1 \2/p" "$2" | head -1; }
for size in $SIZES; do
  for round in $(seq "$ROUNDS"); do
    for mode in open secure; do
      d=$DOMAIN
      DOMAIN=$((DOMAIN + 1))
      env=()
      sec=()
      if [ "$mode" = secure ]; then
        env=(ROS_SECURITY_KEYSTORE="$KS" ROS_SECURITY_ENABLE=true ROS_SECURITY_STRATEGY=Enforce)
      fi
      tag="$size-$mode-$round"
      [ "$mode" = secure ] && sec=(--security-enclave /red/node)
      env "${env[@]}" "$RED" node "$SCENARIO" --backend synthetic --domain "$d" \
        --duration $((SECS + 4)) "${sec[@]}" 2>"$OUT/node-$tag.err" &
      node=$!
      [ "$mode" = secure ] && sec=(--security-enclave /camera)
      env "${env[@]}" "$RED" camera --size "$size" --rate "$RATE" --duration "$SECS" --domain "$d" \
        "${sec[@]}" 2>"$OUT/camera-$tag.err"
      wait "$node"
      sent=$(sed -n 's/.*published \([0-9]*\) frames.*/\1/p' "$OUT/camera-$tag.err")
      released=$(sed -n 's/.*frames (\([0-9]*\) released).*/\1/p' "$OUT/node-$tag.err")
      read -r tp50 tp99 <<<"$(field 'frame stamp -> taken (camera to node over DDS)' "$OUT/node-$tag.err")"
      read -r ip50 ip99 <<<"$(field 'frame taken -> pushed (check, move, keep; converted after the release)' "$OUT/node-$tag.err")"
      printf '%-9s %-6s %5s %6s %8s %7.1f %12s %12s %12s %12s\n' "$size" "$mode" "$round" "$sent" \
        "$released" "$(echo "$released / $SECS" | bc -l)" "$tp50" "$tp99" "$ip50" "$ip99"
    done
  done
done
