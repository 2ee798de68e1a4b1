#!/usr/bin/env bash
# Overload soak in real time (docs/BENCHMARKS.md, "Overload soak"): the minibenchmark
# (scenarios/minibench-tight.yaml) at 10 x its frame rate, policy red, for SECONDS, then
# the resident-set curve (rss.csv: one sample a second), the ready-queue and in-flight
# samples and the job accounting from summary.json and jobs.csv.
#
# Usage: bench/soak.sh [synthetic|torch] [SECONDS] [OUT_DIR] [red run options...]
#        bench/soak.sh runtime [SECONDS]   the runtime alone, without red's per-job records:
#                                          tests/soak (red_soak_tests) for SECONDS
#   RED=path/to/red (default build/tools/red/red), REALTIME=1 to try the real-time knobs
#   (default --no-realtime; mlockall now locks only touched pages, bench/memory.sh).
# Not part of CI: it takes SECONDS of wall time (60 s, and 600 s for the long soak).
set -euo pipefail
cd "$(dirname "$0")/.."
BACKEND=${1:-synthetic}
SECS=${2:-60}
OUT=${3:-out/soak-$BACKEND-$SECS}
RED=${RED:-build/tools/red/red}
if [ "$BACKEND" = runtime ]; then
  TESTS=${SOAK_TESTS:-build/tests/red_soak_tests}
  echo "soak: runtime only, ${SECS}s, $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"
  RED_SOAK_SECONDS="$SECS" exec "$TESTS"
fi
RT_FLAG=--no-realtime
[ "${REALTIME:-0}" = 1 ] && RT_FLAG=
echo "soak: $BACKEND, ${SECS}s, minibench-tight x10 frame rate, $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"
"$RED" run scenarios/minibench-tight.yaml --backend "$BACKEND" --policy red $RT_FLAG \
  --set rate_scale=10 --set duration_s="$SECS" --trace-events 0 --out "$OUT" "${@:4}"
python3 - "$OUT" <<'PY'
import csv, json, sys
out = sys.argv[1]
rows = list(csv.DictReader(open(f"{out}/rss.csv")))
t = [float(r["t_s"]) for r in rows]
rss = [float(r["rss_mb"]) for r in rows]
ready = [int(r["ready"]) for r in rows]
infl = [int(r["in_flight"]) for r in rows]
warm = next((i for i, x in enumerate(t) if x >= 5.0), 0)
tw, rw = t[warm:], rss[warm:]
n = len(tw)
mt, mr = sum(tw) / n, sum(rw) / n
var = sum((x - mt) ** 2 for x in tw)
slope = sum((x - mt) * (y - mr) for x, y in zip(tw, rw)) / var if var > 0 else 0.0
p = json.load(open(f"{out}/summary.json"))["policies"][0]
jobs_rows = sum(1 for _ in open(f"{out}/jobs.csv")) - 1
print(f"rss MB: first {rss[0]:.1f}, at {tw[0]:.0f} s {rw[0]:.1f}, min {min(rw):.1f}, max {max(rss):.1f}, "
      f"last {rss[-1]:.1f}; slope after warm-up {slope * 60:.3f} MB/min ({slope * 1024:.1f} KB/s)")
print("rss MB every 10 s: " + " ".join(f"{rss[i]:.1f}" for i in range(0, len(rss), 10)))
print(f"ready units: max {max(ready)}, mean {sum(ready) / len(ready):.2f}; jobs in flight: max {max(infl)}")
released = p["jobs"]
acct = p["completed"] + (p["dropped"] - p["skipped"]) + p["skipped"] + p["unfinished"]
print(f"jobs (after warm-up) {released} = completed {p['completed']} + dropped {p['dropped'] - p['skipped']} "
      f"(failed {p['failed']}) + skipped {p['skipped']} + unfinished {p['unfinished']} -> "
      f"{'exact' if acct == released else 'MISMATCH'}; jobs.csv rows {jobs_rows}; peak_rss_mb {p.get('peak_rss_mb')}")
sys.exit(0 if acct == released else 1)
PY
