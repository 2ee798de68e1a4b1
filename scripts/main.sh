#!/usr/bin/env bash
# The main job: install what is missing, build, profile the built-in MIMONet on this
# machine, and run the paper's minibenchmark on real LibTorch inference, comparing edf,
# red-fg, red-ida, red and red-robust (beside the fifo and mono baselines) on the identical
# workload.
# Prints the table (and the simulator's prediction beside it) and writes the report to
# out/minibench-tight/ (summary.json, jobs.csv, units.csv, trace.json, plots, index.html).
# Without LibTorch it falls back to the simulator.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/deps.sh
scripts/build.sh
RED=build/tools/red/red
OUT=${RED_OUT:-out/minibench-tight}
mkdir -p out
if "$RED" profile --quiet --out out/profile.json; then
  "$RED" compare scenarios/minibench-tight.yaml --backend torch --profile out/profile.json --out "$OUT"
else
  echo "main: no LibTorch backend in this build; running the simulator instead" >&2
  "$RED" compare scenarios/minibench-tight.yaml --backend sim --out "$OUT"
fi
echo "report: $OUT/index.html (open it in a browser), $OUT/summary.json, $OUT/trace.json"
