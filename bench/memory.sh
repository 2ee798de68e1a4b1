#!/usr/bin/env bash
# Memory of a real run (docs/BENCHMARKS.md, "Memory of a real run"; issue 10 item 4).
# Runs bench/memory.yaml (the minibenchmark's model, 10 s) REPEAT times each way and prints
# the resident set that `red` reports on stderr ("RSS MB: before, after warm-up, peak,
# end, after release", one line per policy run):
#   1. red run --backend torch, with the real-time settings and with --no-realtime;
#   2. red compare --backend torch over six policies: RSS after each policy;
#   3. RED's own memory beside LibTorch: peak minus after warm-up on LibTorch (the model
#      loaded and warmed, idle), and the same on the synthetic backend (no model at all).
# Usage: bench/memory.sh [REPEAT] [OUT_DIR]; RED=path/to/red (default build/tools/red/red,
# built with LibTorch: scripts/build.sh). Not part of CI: about 3 minutes per repeat, CPU
# heavy; the real-time runs use SCHED_FIFO when permitted.
set -euo pipefail
cd "$(dirname "$0")/.."
REPEAT=${1:-3}
OUT=${2:-out/memory}
RED=${RED:-build/tools/red/red}
S=bench/memory.yaml
POLICIES=fifo,mono,edf,red-fg,red,red-robust
mkdir -p "$OUT"
echo "memory: $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg), $(uname -r), $REPEAT repeat(s)"
for i in $(seq 1 "$REPEAT"); do
  "$RED" run "$S" --backend torch --policy red --watchdog-x 0 --trace-events 0 \
    >/dev/null 2>"$OUT/rt-$i.err"
  "$RED" run "$S" --backend torch --policy red --watchdog-x 0 --trace-events 0 --no-realtime \
    >/dev/null 2>"$OUT/nort-$i.err"
  "$RED" compare "$S" --backend torch --policies "$POLICIES" --watchdog-x 0 --trace-events 0 \
    --out "$OUT/compare-$i" >/dev/null 2>"$OUT/compare-$i.err"
  "$RED" run "$S" --backend synthetic --policy red --trace-events 0 --no-realtime \
    --out "$OUT/synthetic-$i" >/dev/null 2>"$OUT/synthetic-$i.err"
done
python3 - "$OUT" "$REPEAT" <<'PY'
import re, sys
out, n = sys.argv[1], int(sys.argv[2])
pat = re.compile(r"RSS MB: before ([\d.]+), after warm-up ([\d.]+), peak ([\d.]+), end ([\d.]+), after release ([\d.]+)")
def runs(name):
    return [tuple(map(float, m.groups())) for m in pat.finditer(open(f"{out}/{name}.err").read())]
def mlock(name):
    m = re.search(r"mlockall: (.*)", open(f"{out}/{name}.err").read())
    return m.group(1) if m else "?"
def spread(xs, digits=1):
    f = f"{{:.{digits}f}}"
    return f"{f.format(min(xs))}..{f.format(max(xs))}" if len(xs) > 1 else f.format(xs[0])
rt = [runs(f"rt-{i}")[0] for i in range(1, n + 1)]
nort = [runs(f"nort-{i}")[0] for i in range(1, n + 1)]
print(f"mlockall: {mlock('rt-1')}")
print("red run, LibTorch: peak RSS MB")
for i in range(n):
    print(f"  repeat {i + 1}: real-time {rt[i][2]:.1f}, --no-realtime {nort[i][2]:.1f} -> {rt[i][2] / nort[i][2]:.3f}")
print(f"  real-time / no-realtime peak: {spread([r[2] / q[2] for r, q in zip(rt, nort)], 3)} (target <= 1.1)")
print("red compare, LibTorch, six policies: RSS after each policy (after release) and peak, MB")
ratios = []
for i in range(1, n + 1):
    c = runs(f"compare-{i}")
    after = [x[4] for x in c]
    peaks = [x[2] for x in c]
    ratios.append(after[-1] / after[0])
    print(f"  repeat {i}: after " + " ".join(f"{x:.1f}" for x in after) + "; peak " + " ".join(f"{x:.1f}" for x in peaks))
print(f"  after the sixth / after the first: " + " ".join(f"{r:.3f}" for r in ratios) + " (target <= 1.1)")
own_t = [r[2] - r[1] for r in nort]
own_s = [x[2] - x[1] for i in range(1, n + 1) for x in runs(f"synthetic-{i}")]
print(f"RED's own memory, peak - after warm-up: LibTorch run (no real-time) {spread(own_t)} MB; "
      f"synthetic backend {spread(own_s)} MB (target <= 5)")
PY
