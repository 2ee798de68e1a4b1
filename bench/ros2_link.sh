#!/usr/bin/env bash
# `red node` over a bad link (issue 55; docs/BENCHMARKS.md, "The node on a shared network"):
# `red camera` -> `red node` (synthetic backend, tests/dds/data/node.yaml) on the loopback of a
# network namespace of this script's own, where nftables drops a share of the domain's UDP
# packets (LOSSES, in %) or all of them for 2 s (an outage), from 2 s to 4 s after the camera
# starts, with best-effort and reliable input QoS. Per case: frames the camera sent, taken
# by the node, counted lost, released, the drive operation's miss rate and latency p99 over
# the run, and its largest gap between releases (an outage's 2 s plus the time results took
# to resume). Needs root, unshare and nft (Debian nftables).
# Usage: sudo bench/ros2_link.sh [OUT_DIR]   LOSSES="1 5 20" SIZE=64x48 RATE=20 SECS=6
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=$(realpath -m "${1:-out/ros2-link}")
RED=$(realpath "${RED:-build/tools/red/red}")
LOSSES=${LOSSES:-1 5 20}
SIZE=${SIZE:-64x48}
RATE=${RATE:-20}
SECS=${SECS:-6}
DOMAIN=${DOMAIN:-80}
SCENARIO=$(realpath tests/dds/data/node.yaml)
[ "$(id -u)" -eq 0 ] || { echo "ros2 link: needs root (a network namespace)" >&2; exit 2; }
command -v nft >/dev/null || { echo "ros2 link: nft not found (apt-get install nftables)" >&2; exit 2; }
mkdir -p "$OUT"
echo "ros2 link: ${SIZE} rgb8 at ${RATE} Hz for ${SECS}s, camera -> node in a netns, link fault" \
  "from 2 s to 4 s; $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg) at $(date -u +%H:%M) UTC"
printf '%-8s %-11s %5s %6s %5s %8s %6s %8s %10s\n' fault input sent taken lost released miss \
  "p99 ms" "max gap ms"
for fault in $LOSSES ${OUTAGE-outage}; do
  for qos in best_effort reliable; do
    d=$DOMAIN
    DOMAIN=$((DOMAIN + 1))
    tag="$fault-$qos"
    dir="$OUT/$tag"
    rm -rf "$dir"
    mkdir -p "$dir"
    echo "input: {reliability: $qos, depth: 10}" >"$dir/qos.yaml"
    ports="$((7400 + 250 * d))-$((7400 + 250 * d + 249))"
    if [ "$fault" = outage ]; then rule="udp dport $ports drop"
    else rule="udp dport $ports numgen random mod 100 < $fault drop"; fi
    unshare --net bash -c "
      ip link set lo up
      nft add table inet red && nft add chain inet red c '{ type filter hook input priority 0; }'
      '$RED' node '$SCENARIO' --backend synthetic --duration $((SECS + 3)) --domain $d \
        --qos-file '$dir/qos.yaml' --out '$dir/run' 2>'$dir/node.err' &
      sleep 1
      '$RED' camera --size $SIZE --rate $RATE --duration $SECS --domain $d \
        --qos-file '$dir/qos.yaml' 2>'$dir/camera.err' & cp=\$!
      sleep 2; nft add rule inet red c '$rule' || exit 3; sleep 2; nft flush chain inet red c
      wait \$cp; wait"
    python3 - "$dir" "$fault" "$qos" <<'PY'
import csv, json, re, sys
d, fault, qos = sys.argv[1:]
sent = int(re.search(r"published (\d+) frames", open(f"{d}/camera.err").read()).group(1))
n = json.load(open(f"{d}/run/node.json"))
lost = n["not_taken_by_reason"]["lost_in_transport"]
rel = sorted(float(r["release_ms"]) for r in csv.DictReader(open(f"{d}/run/jobs.csv"))
             if r["operation"] == "drive")
gap = max((b - a for a, b in zip(rel, rel[1:])), default=0)
s = json.load(open(f"{d}/run/summary.json"))
op = s["policies"][0]["phases"][0]["operations"]["drive"]
print(f"{fault:<8} {qos:<11} {sent:5d} {n['frames']:6d} {lost:5d} {n['released']:8d} "
      f"{op['miss_rate']:6.3f} {op['latency_ms']['p99']:8.1f} {gap:10.0f}")
PY
  done
done
