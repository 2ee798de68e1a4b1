#!/usr/bin/env bash
# The paper's ROS 2 case study on loopback DDS (docs/BENCHMARKS.md, "The ROS 2 case
# study"): `red camera` publishes frames; the perception work of scenarios/interference-*.yaml
# (lane, segmentation, detection and cruise control on one camera) runs
#   red, red-robust, edf  one `red node` serving the four heads under that policy, or
#   separate              four single-task `red node`s, one per head, each its own full
#                         network (encoder + one head; policy fifo, as ROS 2's executor:
#                         release order, nothing dropped)
# under each interference-* background load (the load runs once per configuration, in
# the first node's process); `red_ros2_listener` measures every frame end to end: header
# stamp -> the last of its four outputs received (/red/perceive/{L,S,O,C/stamped}). A frame
# misses when an output is missing or later than the deadline. Prints one table.
#
# Usage: bench/ros2.sh [OUT_DIR]
#   LOADS=none,high (default; any of none,low,medium,high)  CONFIGS=red,red-robust,edf,separate
#   SECS=10 (camera seconds per configuration)  BACKEND=torch|synthetic (default torch)
#   RATE=HZ (the camera's rate; default the scenario's rate_hz; the deadline stays)
#   PROFILE=F.json, or builtin for the built-in default profile (default: `red profile` once
#   into OUT_DIR, torch only; on a loaded machine that profile is far off)  THREADS=N (LibTorch
#   intra-op threads per node; default LibTorch's)  RED=build/tools/red/red
#   LISTENER=build/bench/red_ros2_listener  DOMAIN=40 (first DDS domain; one per configuration)
#   WATCHDOG_X=0 (the runtime's watchdog, off by default)
# Not part of CI: about 20 s of wall time per configuration (8 by default).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/ros2-bench}
RED=${RED:-build/tools/red/red}
LISTENER=${LISTENER:-build/bench/red_ros2_listener}
LOADS=${LOADS:-none,high}
CONFIGS=${CONFIGS:-red,red-robust,edf,separate}
SECS=${SECS:-10}
BACKEND=${BACKEND:-torch}
DOMAIN=${DOMAIN:-40}
for exe in "$RED" "$LISTENER"; do
  [ -x "$exe" ] || { echo "ros2 bench: $exe not found (build with scripts/build.sh)" >&2; exit 2; }
done
mkdir -p "$OUT"
echo "ros2 bench: backend $BACKEND, loads $LOADS, configurations $CONFIGS, ${SECS}s each," \
  "camera rate ${RATE:-as in the scenario} (Hz);" \
  "$(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg) at $(date -u +%H:%M) UTC"

PROFILE_ARGS=()
if [ "${PROFILE:-}" = builtin ]; then
  : # the scenario's own (the built-in default profile)
elif [ -n "${PROFILE:-}" ]; then
  PROFILE_ARGS=(--profile "$PROFILE")
elif [ "$BACKEND" = torch ]; then
  "$RED" profile --quiet --out "$OUT/profile.json" >/dev/null
  PROFILE_ARGS=(--profile "$OUT/profile.json")
fi
# The watchdog is off by default: its limits come from the profile (10 x p99), and a profile
# from a quiet machine fails every unit of a loaded one as a "timeout".
NODE_ARGS=(--backend "$BACKEND" --watchdog-x "${WATCHDOG_X:-0}" "${PROFILE_ARGS[@]}")
[ -n "${THREADS:-}" ] && NODE_ARGS+=(--threads "$THREADS")

# The four single-task scenarios of a load: the same camera, deadline and topics, a network
# of one head each; only the first keeps the background load.
write_separate() { # LOAD
  python3 - "scenarios/interference-$1.yaml" "$OUT/separate-$1" <<'PY'
import re, sys
src, prefix = sys.argv[1], sys.argv[2]
text = open(src).read()
get = lambda pat: re.search(pat, text).group(1)
intensity, deadline, rate = get(r"intensity:\s*([0-9.]+)"), get(r"deadline_ms:\s*([0-9.]+)"), get(r"rate_hz:\s*([0-9.]+)")
heads = {"L": "lane", "S": "seg", "O": "det", "C": "steer"}
for i, (node, head) in enumerate(heads.items()):
    load = f"interference: {{kind: cpu, intensity: {intensity}}}\n" if i == 0 else ""
    open(f"{prefix}-{node}.yaml", "w").write(
        f"name: separate-{node}\nduration_s: 10\nwarmup_s: 1\nseed: 5\ndevice: {{lanes: 1}}\n"
        f"model: {{builtin: mimonet, heads: [{head}], input: [3, 192, 384]}}\n{load}"
        f"sensors:\n  camera: {{rate_hz: {rate}}}\noperations:\n  - name: perceive\n"
        f"    trigger: camera\n    deadline_ms: {deadline}\n    nodes:\n"
        f"      {node}: {{head: {head}, sensor: camera}}\n")
PY
}

# Waits until every node log shows its topics (the model is loaded), at most 120 s.
wait_ready() { # LOG...
  for _ in $(seq 1200); do
    local all=1
    for log in "$@"; do grep -q "out /diagnostics" "$log" 2>/dev/null || all=0; done
    [ $all = 1 ] && return 0
    sleep 0.1
  done
  echo "ros2 bench: a node did not start; see $*" >&2
  return 1
}

RESULTS="$OUT/results.jsonl"
: >"$RESULTS"
IFS=, read -ra load_list <<<"$LOADS"
IFS=, read -ra config_list <<<"$CONFIGS"
for load in "${load_list[@]}"; do
  scenario=scenarios/interference-$load.yaml
  [ -f "$scenario" ] || { echo "ros2 bench: no $scenario" >&2; exit 2; }
  deadline=$(grep -oE 'deadline_ms: *[0-9.]+' "$scenario" | grep -oE '[0-9.]+$')
  rate=${RATE:-$(grep -oE 'rate_hz: *[0-9.]+' "$scenario" | head -1 | grep -oE '[0-9.]+$')}
  for config in "${config_list[@]}"; do
    d=$DOMAIN
    DOMAIN=$((DOMAIN + 1))
    tag=$load-$config
    pids=()
    logs=()
    if [ "$config" = separate ]; then
      write_separate "$load"
      for node in L S O C; do
        logs+=("$OUT/$tag-$node.log")
        "$RED" node "$OUT/separate-$load-$node.yaml" --policy fifo --domain "$d" "${NODE_ARGS[@]}" \
          2>"$OUT/$tag-$node.log" &
        pids+=($!)
      done
    else
      logs+=("$OUT/$tag.log")
      "$RED" node "$scenario" --policy "$config" --domain "$d" "${NODE_ARGS[@]}" 2>"$OUT/$tag.log" &
      pids+=($!)
    fi
    wait_ready "${logs[@]}"
    "$LISTENER" --domain "$d" --deadline-ms "$deadline" --warmup 1 --idle 2 --timeout $((SECS + 60)) \
      --topic image:/red/perceive/L --topic image:/red/perceive/S \
      --topic detections:/red/perceive/O --topic twist_stamped:/red/perceive/C/stamped \
      >"$OUT/$tag.json" &
    listener=$!
    sleep 0.5
    "$RED" camera --rate "$rate" --duration "$SECS" --size 640x480 --domain "$d" 2>"$OUT/$tag-camera.log"
    wait $listener
    rss=0
    for p in "${pids[@]}"; do
      kb=$(awk '/^VmRSS/ {print $2}' "/proc/$p/status" 2>/dev/null || echo 0)
      rss=$((rss + ${kb:-0}))
    done
    kill -INT "${pids[@]}" 2>/dev/null || true
    for p in "${pids[@]}"; do wait "$p" || true; done
    python3 - "$OUT/$tag.json" "$load" "$config" "$rss" "${logs[@]}" >>"$RESULTS" <<'PY'
import json, re, sys
r = json.load(open(sys.argv[1]))
r.update(load=sys.argv[2], config=sys.argv[3], rss_mb=int(sys.argv[4]) / 1024)
rel = []
for log in sys.argv[5:]:
    m = re.search(r"frame received -> released p50 ([0-9.]+) us, p99 ([0-9.]+) us", open(log).read())
    if m: rel.append(float(m.group(2)))
r["release_p99_us"] = max(rel) if rel else None
print(json.dumps(r))
PY
    echo "ros2 bench: $tag done ($(tail -1 "$RESULTS" | cut -c1-100)...)" >&2
  done
done

python3 - "$RESULTS" <<'PY'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
print(f"{'load':8} {'configuration':14} {'frames':>6} {'complete':>8} {'miss %':>7} {'mean ms':>8} "
      f"{'p50 ms':>8} {'p99 ms':>8} {'node RSS MB':>11}")
for r in rows:
    t = r["response_ms"]
    print(f"{r['load']:8} {r['config']:14} {r['frames']:6d} {r['complete']:8d} {100 * r['miss_rate']:7.2f} "
          f"{t['mean']:8.2f} {t['p50']:8.2f} {t['p99']:8.2f} {r['rss_mb']:11.1f}")
by = {(r["load"], r["config"]): r for r in rows}
for load in dict.fromkeys(r["load"] for r in rows):
    edf = by.get((load, "edf"))
    if not edf:
        continue
    for c in ("red", "red-robust", "separate"):
        r = by.get((load, c))
        if not r:
            continue
        fewer = (f"{(1 - r['miss_rate'] / edf['miss_rate']) * 100:.1f} % fewer misses"
                 if edf["miss_rate"] > 0 else "edf missed nothing")
        lower = (f"{(1 - r['response_ms']['mean'] / edf['response_ms']['mean']) * 100:.1f} % lower mean response time"
                 if edf["complete"] > 0 and r["complete"] > 0 else "no mean response time to compare (a side completed no frame)")
        print(f"{load}: {c} vs edf: {fewer}, {lower} (paper, red vs edf: 67.3 %, 32.7 %)")
PY
