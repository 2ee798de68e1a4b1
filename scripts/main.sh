#!/usr/bin/env bash
# The main job: install what is missing, build, profile the built-in MIMONet on this
# machine, and run the paper's minibenchmark on real LibTorch inference, comparing edf,
# red-fg, red-ida, red and red-robust (beside the fifo and mono baselines) on the identical
# workload.
# Prints the table (and the calibrated simulator's prediction beside it) and writes the report to
# out/minibench-tight/ (summary.json, jobs.csv, units.csv, trace.json, plots, index.html).
# Without LibTorch it falls back to the simulator.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/deps.sh
# Only what the main job runs: the red program with its backends (red-full with LibTorch and
# DDS), not the test suites and benchmarks.
RED_TARGETS=red scripts/build.sh
RED=build/tools/red/red
OUT=${RED_OUT:-out/minibench-tight}
mkdir -p out
# The profile is calibrated on the scenario (docs/FIDELITY.md): in-run unit costs, so the
# deadlines (critical_path_x), the scheduler's estimates and the simulator's prediction
# printed beside the real table rest on what units cost inside a real run here.
if "$RED" profile --quiet --out out/profile.json; then
  PROFILE=out/profile.json
  if "$RED" profile --quiet --from out/profile.json --calibrate scenarios/minibench-tight.yaml \
    --out out/profile-calibrated.json; then
    PROFILE=out/profile-calibrated.json
  else
    echo "main: calibration failed; the isolated profile is used" >&2
  fi
  "$RED" compare scenarios/minibench-tight.yaml --backend torch --profile "$PROFILE" --out "$OUT"
else
  echo "main: no LibTorch backend in this build; running the simulator instead" >&2
  "$RED" compare scenarios/minibench-tight.yaml --backend sim --out "$OUT"
fi
echo "report: $OUT/index.html (open it in a browser), $OUT/summary.json, $OUT/trace.json"
