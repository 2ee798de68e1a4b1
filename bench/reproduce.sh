#!/usr/bin/env bash
# The reproduction page in one go (docs/REPRODUCTION.md, issue 11): every claim of the
# paper's evaluation, the paper's figure beside ours, computed from runs. Writes
# OUT/reproduction.md, OUT/reproduction.json and OUT/plots/*.svg (bench/reproduce.py).
#
# Usage: bench/reproduce.sh [--quick] [--out DIR] [--runs N] [--reuse DIR ...] [--profile F.json]
#
#   (default)   real LibTorch runs: bench/fidelity.sh --runs N over every bundled scenario
#               (calibrate, N real `red compare --backend torch`, leave-one-out predictions),
#               then Table 4 for real (`--set deadline_scale=V`, six settings, N runs each),
#               then the simulator's sweeps and ablation for breadth. About 2 h on 2 cores
#               with N=3; keep the machine otherwise quiet.
#   --reuse DIR build the page from existing bench/fidelity.sh output directories (repeatable;
#               for a scenario found in several, the last one given wins; DIR/table4 is used
#               when there). Runs nothing real; the simulator parts still run. DIR is only read.
#   --quick     a smoke run for CI (≤ 3 minutes on 2 cores): the simulator stands in for real
#               inference (seeds play the runs), every section is still generated, with a
#               banner; then `reproduce.py check`.
#   --profile   the `red profile` output (isolated units) for Table 1 (default: DIR/profile.json
#               of a reused directory, or the one this script measures).
# Defaults: out/reproduction, 3 runs (2 seeds with --quick). RED=path overrides the binary.
set -euo pipefail
cd "$(dirname "$0")/.."
RED=${RED:-build/tools/red/red}
PY=/usr/bin/python3
quick=0
out=out/reproduction
runs=""
profile=""
reuse=()
command="bench/reproduce.sh $*"
while [[ $# -gt 0 ]]; do
  case "$1" in
    --quick) quick=1; shift ;;
    --out) out=${2:?--out needs a directory}; shift 2 ;;
    --runs) runs=${2:?--runs needs a number}; shift 2 ;;
    --reuse) reuse+=("${2:?--reuse needs a directory}"); shift 2 ;;
    --profile) profile=${2:?--profile needs a file}; shift 2 ;;
    -h|--help) sed -n '2,22p' "$0"; exit 0 ;;
    *) echo "reproduce.sh: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done
if [[ -n $runs && ! $runs =~ ^[1-9][0-9]*$ ]]; then
  echo "reproduce.sh: --runs $runs: must be a positive integer" >&2; exit 2
fi
if [[ $quick == 1 && ${#reuse[@]} -gt 0 ]]; then
  echo "reproduce.sh: --quick and --reuse exclude each other" >&2; exit 2
fi
for d in "${reuse[@]}"; do
  [[ -d $d ]] || { echo "reproduce.sh: --reuse $d: no such directory" >&2; exit 2; }
done
if [[ -n $profile && ! -f $profile ]]; then
  echo "reproduce.sh: --profile $profile: no such file" >&2; exit 2
fi
[[ -x $RED ]] || { echo "reproduce.sh: $RED not built (scripts/build.sh, or RED=path)" >&2; exit 2; }
[[ -n $runs ]] || { [[ $quick == 1 ]] && runs=2 || runs=3; }

scales=(0.75 0.9 1.05 1.2 1.35 1.5)   # the paper's six deadline settings (reproduce.py)
lambdas=0.001,0.01,0.1,1,10
paper=edf,red-fg,red-ida,red
mkdir -p "$out"
rm -rf "$out/runs" "$out/table4" "$out/sim" "$out/plots" "$out/profile.json" "$out/grid.txt"
mkdir -p "$out/runs" "$out/sim"
say() { echo "reproduce: $*" >&2; }
sources=()

if [[ $quick == 1 ]]; then
  mode=quick
  # Seeds play the runs and, for the fidelity section, other seeds play the predictions.
  for s in scenarios/*.yaml; do
    name=$(basename "$s" .yaml)
    say "$name: $runs simulated runs"
    mkdir -p "$out/runs/$name"
    for ((k = 1; k <= runs; k++)); do
      "$RED" compare "$s" --backend sim --seed "$k" --trace-events 0 --out "$out/runs/$name/run$k" \
        >"$out/runs/$name/run$k.txt"
      "$RED" compare "$s" --backend sim --seed $((100 + k)) --trace-events 0 \
        --out "$out/runs/$name/loo$k-seed1" >/dev/null
    done
  done
  for v in "${scales[@]}"; do
    "$RED" compare scenarios/minibench-tight.yaml --backend sim --policies "$paper" \
      --set deadline_scale="$v" --seed 1 --trace-events 0 --out "$out/table4/deadline_scale-$v/run1" \
      >/dev/null
  done
  # Table 1 from a short real profile when this binary has LibTorch; else the page says so.
  if [[ -n $profile ]]; then
    ln -s "$(realpath "$profile")" "$out/profile.json"
  elif "$RED" profile --runs 3 --warmup 1 --max-batch 1 --quiet --out "$out/profile.json" \
    >"$out/profile.txt" 2>&1; then
    say "profile: short real profile (--runs 3)"
  else
    say "profile: not available in this build ($(head -c 200 "$out/profile.txt"))"
    rm -f "$out/profile.json"
  fi
elif [[ ${#reuse[@]} -gt 0 ]]; then
  mode=reuse
  for d in "${reuse[@]}"; do
    abs=$(realpath "$d")
    sources+=("$abs")
    for s in scenarios/*.yaml; do
      name=$(basename "$s" .yaml)
      if compgen -G "$abs/$name/run*/summary.json" >/dev/null; then
        rm -f "$out/runs/$name"
        ln -s "$abs/$name" "$out/runs/$name"
      fi
    done
    if [[ -d $abs/table4 ]]; then rm -f "$out/table4"; ln -s "$abs/table4" "$out/table4"; fi
    if [[ -z $profile && -f $abs/profile.json ]]; then profile=$abs/profile.json; fi
  done
  [[ -n $profile ]] && ln -s "$(realpath "$profile")" "$out/profile.json"
else
  mode=real
  mkdir -p "$out/table4"
  base=()
  [[ -n $profile ]] && base=(--base "$profile")
  RED=$RED bench/fidelity.sh --runs "$runs" --out "$out/runs" "${base[@]}" scenarios/*.yaml
  ln -s "$(realpath "${profile:-$out/runs/profile.json}")" "$out/profile.json"
  for v in "${scales[@]}"; do
    for ((k = 1; k <= runs; k++)); do
      say "table 4: deadline_scale=$v, real run $k of $runs ($(cut -d' ' -f1-3 /proc/loadavg) load)"
      "$RED" compare scenarios/minibench-tight.yaml --backend torch \
        --profile "$out/runs/minibench-tight/profile.json" --policies "$paper" \
        --set deadline_scale="$v" --trace-events 0 --out "$out/table4/deadline_scale-$v/run$k" \
        >"$out/table4/deadline_scale-$v.run$k.txt"
    done
  done
fi

# The simulator, for breadth: Table 4 and 5 sweeps and the no-merge ablation, planned with
# the calibrated profile of the tight runs when there is one.
prof=()
[[ $mode != quick && -f $out/runs/minibench-tight/profile.json ]] &&
  prof=(--profile "$out/runs/minibench-tight/profile.json")
say "simulator sweeps (${prof[*]:-built-in default profile})"
"$RED" sweep scenarios/minibench-tight.yaml --set deadline_scale="$(IFS=,; echo "${scales[*]}")" \
  --policies "$paper" "${prof[@]}" --out "$out/sim/table4" >"$out/sim/table4.txt"
"$RED" sweep scenarios/minibench-tight.yaml --set qoe_lambda="$lambdas" --policies "$paper" \
  "${prof[@]}" --out "$out/sim/table5" >"$out/sim/table5.txt"
for name in minibench-tight minibench-loose; do
  p=()
  [[ $mode != quick && -f $out/runs/$name/profile.json ]] && p=(--profile "$out/runs/$name/profile.json")
  "$RED" compare "scenarios/$name.yaml" --backend sim --policies red-fg --with merge=no "${p[@]}" \
    --trace-events 0 --out "$out/sim/ablation-nomerge/$name" >/dev/null
done
# Case study 2 with the deadline doubled: on this CPU no policy meets 30 ms, so the
# dependency's effect shows only with room to spare (simulator, labelled as such).
for name in case-async case-async-dep; do
  p=()
  [[ $mode != quick && -f $out/runs/$name/profile.json ]] && p=(--profile "$out/runs/$name/profile.json")
  "$RED" compare "scenarios/$name.yaml" --backend sim --policies edf,red,mono --set deadline_scale=2 \
    "${p[@]}" --trace-events 0 --out "$out/sim/case2-x2/$name" >/dev/null
done
grid=$(dirname "$RED")/../../bench/red_load_grid
if [[ $mode != quick && -x $grid ]]; then
  say "red_load_grid --seeds 1 --duration 2"
  "$grid" --seeds 1 --duration 2 >"$out/grid.txt"
fi

src=()
for s in "${sources[@]}"; do src+=(--source "$s"); done
"$PY" bench/reproduce.py page "$out" --mode "$mode" --command "$command" "${src[@]}"
if [[ $mode == quick ]]; then
  # Table 1 needs `red profile` (LibTorch); a core-only build leaves it unmeasured.
  allow=()
  [[ -e $out/profile.json ]] || allow=(--allow-unmeasured table1_overheads)
  "$PY" bench/reproduce.py check "$out" "${allow[@]}"
fi
