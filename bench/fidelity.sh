#!/usr/bin/env bash
# Simulator fidelity (docs/FIDELITY.md, docs/REPRODUCTION.md): does the simulator, fed a
# calibrated profile, predict the real run? For each scenario: calibrate the profile on it
# (`red profile --from BASE --calibrate S`), play every policy for real RUNS times
# (`red compare --backend torch`), and compare the median real run with the simulator's
# prediction (median over seeds). Writes DIR/fidelity.md (and .json) and prints the table.
#
# Then, leave one out: for each real run k, a calibration fitted from the OTHER runs' units
# (`red profile --calibrate-from`) predicts run k in the simulator (`--costs`, 5 seeds; the
# scheduler plans with the same profile as the real run did).
#
# Usage: bench/fidelity.sh [--runs N] [--out DIR] [--base PROFILE.json] [--calibrate-s S]
#                          [--calibrate-rounds R] [--policies LIST] [--set key=value]
#                          [scenario.yaml ...]
# Defaults: 3 runs, out/fidelity, a fresh `red profile`, 8 s per calibration policy in
# `red profile`'s turns (3 of 2.7 s), every bundled scenario. Real-time: keep the machine
# otherwise quiet and say what else ran.
set -euo pipefail
cd "$(dirname "$0")/.."
RED=${RED:-build/tools/red/red}
PY=/usr/bin/python3
runs=3
out=out/fidelity
base=""
calib_s=8
rounds=()
policies=""
sets=()
scenarios=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --runs) runs=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --base) base=$2; shift 2 ;;
    --calibrate-s) calib_s=$2; shift 2 ;;
    --calibrate-rounds) rounds=(--calibrate-rounds "$2"); shift 2 ;;
    --policies) policies=$2; shift 2 ;;
    --set) sets+=(--set "$2"); shift 2 ;;
    -h|--help) sed -n '2,16p' "$0"; exit 0 ;;
    -*) echo "fidelity.sh: unknown option $1" >&2; exit 2 ;;
    *) scenarios+=("$1"); shift ;;
  esac
done
[[ ${#scenarios[@]} -gt 0 ]] || scenarios=(scenarios/*.yaml)
[[ -x $RED ]] || { echo "fidelity.sh: $RED not built (scripts/build.sh)" >&2; exit 2; }
mkdir -p "$out"
if [[ -z $base ]]; then
  base=$out/profile.json
  "$RED" profile --quiet --out "$base" >"$out/profile.txt"
fi
pol=()
[[ -n $policies ]] && pol=(--policies "$policies")
for s in "${scenarios[@]}"; do
  name=$(basename "$s" .yaml)
  dir=$out/$name
  mkdir -p "$dir"
  echo "fidelity: $name: calibrating ($(cut -d' ' -f1-3 /proc/loadavg) load)" >&2
  calib=()
  [[ ${#sets[@]} -gt 0 ]] && for ((i = 1; i < ${#sets[@]}; i += 2)); do calib+=(--calibrate-set "${sets[i]}"); done
  "$RED" profile --quiet --from "$base" --calibrate "$s" --calibrate-s "$calib_s" "${rounds[@]}" "${calib[@]}" \
    --out "$dir/profile.json" >"$dir/calibration.txt"
  for ((k = 1; k <= runs; k++)); do
    echo "fidelity: $name: real run $k of $runs ($(cut -d' ' -f1-3 /proc/loadavg) load)" >&2
    "$RED" compare "$s" --backend torch --profile "$dir/profile.json" "${pol[@]}" "${sets[@]}" \
      --trace-events 0 --out "$dir/run$k" >"$dir/run$k.txt"
    cut -d' ' -f1-3 /proc/loadavg >"$dir/run$k.load"
  done
  if [[ $runs -ge 2 ]]; then
    for ((k = 1; k <= runs; k++)); do
      from=()
      for ((j = 1; j <= runs; j++)); do [[ $j != "$k" ]] && from+=(--calibrate-from "$dir/run$j"); done
      "$RED" profile --from "$base" --calibrate "$s" "${calib[@]}" "${from[@]}" \
        --out "$dir/loo$k.json" >"$dir/loo$k.txt"
      for seed in 1 2 3 4 5; do
        "$RED" compare "$s" --backend sim --profile "$dir/profile.json" --costs "$dir/loo$k.json" \
          "${pol[@]}" "${sets[@]}" --seed "$seed" --trace-events 0 --out "$dir/loo$k-seed$seed" \
          >/dev/null
      done
    done
  fi
done
"$PY" bench/fidelity_table.py "$out" "${scenarios[@]}"
