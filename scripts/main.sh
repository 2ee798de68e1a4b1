#!/usr/bin/env bash
# The main job: install what is missing, build, and run the paper's minibenchmark,
# comparing edf, red-fg, red-ida and red (and the fifo and mono baselines) side by side.
# Prints the table and writes the report to out/minibench-tight/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/deps.sh
scripts/build.sh
OUT=${RED_OUT:-out/minibench-tight}
build/tools/red/red compare scenarios/minibench-tight.yaml --backend sim --out "$OUT"
echo "report: $OUT/summary.json, $OUT/jobs.csv, $OUT/units.csv"
