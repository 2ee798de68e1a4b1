#!/usr/bin/env bash
# The GPU checks of docs/GPU.md in one script, for a CUDA machine with RED built against a
# CUDA LibTorch (docs/GPU.md): two profiles (is batch 1 warm, within 10 % of the second
# profile's?), a calibration on the GPU (in-run / isolated ratios of a GPU, not 23x), and
# the frames offered and released at 20, 200 and 800 frames/s (bench/releases.yaml), and
# asynchronous lanes side by side with synchronous ones (bench/async_lanes.sh).
# Usage: bench/gpu.sh RED_BINARY [OUT_DIR] [DEVICE]     (default out/gpu-check, cuda)
# Prints the figures; everything it ran is kept in OUT_DIR.
set -euo pipefail
RED=${1:?usage: bench/gpu.sh RED_BINARY [OUT_DIR] [DEVICE]}
OUT=${2:-out/gpu-check}
DEVICE=${3:-cuda}
cd "$(dirname "$0")/.."
mkdir -p "$OUT"

echo "== two profiles on $DEVICE"
for i in 1 2; do
  "$RED" profile --device "$DEVICE" --quiet --out "$OUT/profile-$i.json" >"$OUT/profile-$i.txt"
  tail -2 "$OUT/profile-$i.txt"
done
/usr/bin/env python3 - "$OUT" <<'EOF'
import json, sys
out = sys.argv[1]
a, b = (json.load(open(f"{out}/profile-{i}.json")) for i in (1, 2))
print(f"timing: {a.get('measurement', {}).get('timing')}")
print(f"{'unit':<16} {'batch':>5} {'mean ms 1':>10} {'mean ms 2':>10} {'1/2':>6} {'warm-up':>8}")
for unit, entries in a["units"].items():
    for e in entries:
        f = next(x for x in b["units"][unit] if x["batch"] == e["batch"])
        print(f"{unit:<16} {e['batch']:>5} {e['mean_us']/1000:>10.3f} {f['mean_us']/1000:>10.3f} "
              f"{e['mean_us']/max(f['mean_us'], 1e-9):>6.2f} {e.get('warmup_runs', 0):>8}")
EOF

echo "== calibration on $DEVICE (the profile's device)"
"$RED" profile --from "$OUT/profile-2.json" --calibrate scenarios/minibench-tight.yaml \
  --calibrate-s 6 --out "$OUT/calibrated.json" | tee "$OUT/calibration.txt" | head -40

echo "== frames offered and released at 20, 200 and 800 frames/s"
for r in 1 10 40; do
  echo "-- rate_scale $r ($((20 * r)) frames/s)"
  "$RED" compare bench/releases.yaml --backend torch --device "$DEVICE" \
    --profile "$OUT/calibrated.json" --set rate_scale=$r --policies edf,mono,red,red-robust \
    --out "$OUT/releases-$r" 2>"$OUT/releases-$r.err" | sed -n '/^frames/,$p'
  grep "warning" "$OUT/releases-$r.err" || true
done

echo "== asynchronous lanes against one unit per lane: 200, 800 and 3200 frames/s on 1 and 2 lanes"
OUT="$OUT/async-lanes" bench/async_lanes.sh "$RED" "$OUT/calibrated.json" torch "$DEVICE" 1 \
  "10 40 160" "1 2"
