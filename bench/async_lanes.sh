#!/usr/bin/env bash
# Asynchronous lanes side by side with synchronous ones (issue 36, docs/journal/runtime.md,
# "Issue 36: asynchronous lanes"): bench/releases.yaml at several camera rates, each policy in each
# MODE: `sync` (the lane's handler runs the unit, then decides the next; on a GPU the
# torch backend is always asynchronous, so this is d2 there), `d1` (--async, one unit per
# lane: enqueued, then waited for) and `d2` (--async, queue_depth 2: an on-demand handler
# queues the next unit shortly before the running one ends). Backend `synthetic` (the CPU
# stand-in: each lane a worker thread spending the profile's times) or `torch` (with
# DEVICE cuda: a GPU). MODES defaults to "sync d1 d2" (synthetic) or "d1 d2" (torch).
# Usage: bench/async_lanes.sh RED PROFILE.json [BACKEND] [DEVICE] [SCALE] [RATES] [LANES]
#   SCALE divides every unit time of PROFILE (e.g. 60 turns a CPU profile into GPU-sized
#   units for the synthetic backend; 1 for a real GPU profile); RATES are rate_scale values
#   (20 frames/s each), LANES lane counts.
set -euo pipefail
RED=${1:?usage: bench/async_lanes.sh RED PROFILE.json [BACKEND] [DEVICE] [SCALE] [RATES] [LANES]}
PROFILE=${2:?profile}
BACKEND=${3:-synthetic}
DEVICE=${4:-cpu}
SCALE=${5:-1}
RATES=${6:-"10 40 80"}
LANES=${7:-1}
POLICIES=${POLICIES:-edf,mono,red,red-robust}
if [ "$BACKEND" = torch ]; then MODES=${MODES:-"d1 d2"}; else MODES=${MODES:-"sync d1 d2"}; fi
OUT=${OUT:-out/async-lanes}
cd "$(dirname "$0")/.."
mkdir -p "$OUT"
/usr/bin/env python3 - "$PROFILE" "$SCALE" "$OUT/profile.json" <<'PY'
import json, sys
p = json.load(open(sys.argv[1]))
k = float(sys.argv[2])
for entries in p["units"].values():
    for e in entries:
        for key in list(e):
            if key.endswith("_us"):
                e[key] /= k
p.pop("calibration", None)
json.dump(p, open(sys.argv[3], "w"), indent=1)
PY
dev=()
[ "$BACKEND" = torch ] && dev=(--device "$DEVICE")
printf '%-6s %-5s %-6s %-11s %7s %8s %8s %9s %9s\n' lanes fps mode policy miss% mean_ms ahead gap_p50us hand_p50us
for lanes in $LANES; do
  for r in $RATES; do
    for mode in $MODES; do
      flag=()
      [ "$mode" = d1 ] && flag=(--async --set queue_depth=1)
      [ "$mode" = d2 ] && flag=(--async --set queue_depth=2)
      tag="l$lanes-r$r-$mode"
      "$RED" compare bench/releases.yaml --backend "$BACKEND" "${dev[@]}" "${flag[@]}" \
        --profile "$OUT/profile.json" --set rate_scale="$r" --set lanes="$lanes" \
        --watchdog-x 0 --policies "$POLICIES" >"$OUT/$tag.txt" 2>"$OUT/$tag.err"
      /usr/bin/env python3 - "$OUT/$tag.txt" "$OUT/$tag.err" "$lanes" "$((20 * r))" "$mode" <<'PY'
import re, sys
table, err, lanes, fps, mode = sys.argv[1:]
stats = {}
policy = None
for line in open(err):
    m = re.match(r"red: policy (\S+): decisions .*completion->next start p50 ([\d.]+) us", line)
    if m:
        policy = m.group(1)
        stats[policy] = {"hand": float(m.group(2)), "ahead": 0, "gap": float("nan")}
    m = re.match(r"red:   asynchronous lanes: (\d+) unit.*p50 ([\d.]+) us", line)
    if m and policy:
        stats[policy]["ahead"] = int(m.group(1))
        stats[policy]["gap"] = float(m.group(2))
rows = False
for line in open(table):
    if line.startswith("policy"):
        rows = not rows and "jobs" in line
        continue
    f = line.split()
    if rows and len(f) > 5 and f[0] in stats:
        s = stats[f[0]]
        print(f"{lanes:<6} {fps:<5} {mode:<6} {f[0]:<11} {float(f[2]):7.2f} {float(f[4]):8.2f} "
              f"{s['ahead']:8d} {s['gap']:9.1f} {s['hand']:9.1f}")
    elif rows and not line.strip():
        rows = False
PY
    done
  done
done
