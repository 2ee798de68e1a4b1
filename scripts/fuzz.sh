#!/usr/bin/env bash
# Runs every libFuzzer target for SECONDS each (default 15) from its seed corpus, with
# AddressSanitizer, UndefinedBehaviorSanitizer and leak detection; fails on any finding.
# Usage: scripts/fuzz.sh [SECONDS] [BUILD_DIR]   (docs/TESTING.md)
# New corpus entries and crash artifacts go to a scratch directory (printed), never into
# tests/fuzz/corpus: add an input there by hand when it is worth keeping.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/ccache-env.sh
SECONDS_EACH=${1:-15}
BUILD=${2:-build-fuzz}
# RED_STDLIB_FIRST: the standard library precompiled (11 % less build time here), and the
# newer-toolchain check of cmake/Precompile.cmake with clang as well.
if [ ! -x "$BUILD/tests/fuzz/fuzz_scenario" ]; then
  CC=clang CXX=clang++ cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DRED_TORCH=OFF -DRED_BUILD_BENCH=OFF -DRED_BUILD_TESTS=OFF -DRED_FUZZ=ON -DRED_WERROR=ON \
    -DRED_STDLIB_FIRST=ON >/dev/null
fi
cmake --build "$BUILD" -j"$(nproc)" --target fuzz
WORK=$(mktemp -d /tmp/red-fuzz.XXXXXX)
echo "fuzz: ${SECONDS_EACH}s per target, scratch corpus and artifacts in $WORK"
status=0
TARGETS="fuzz_scenario fuzz_override fuzz_profile fuzz_manifest"
# The DDS message decoder is there when the fuzz build has the DDS bridge (Cyclone DDS).
[ -x "$BUILD/tests/fuzz/fuzz_dds" ] && TARGETS="$TARGETS fuzz_dds"
for target in $TARGETS; do
  mkdir -p "$WORK/$target"
  if ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    "$BUILD/tests/fuzz/$target" -max_total_time="$SECONDS_EACH" -rss_limit_mb=2048 -timeout=10 \
      -detect_leaks=1 -print_final_stats=1 -artifact_prefix="$WORK/$target-" \
      "$WORK/$target" "tests/fuzz/corpus/$target" >"$WORK/$target.log" 2>&1; then
    echo "fuzz: $target ok: $(grep -E '^stat::number_of_executed_units' "$WORK/$target.log" |
      awk '{print $2}') runs, coverage $(grep -oE 'cov: [0-9]+' "$WORK/$target.log" | tail -1)"
  else
    status=1
    echo "fuzz: $target FAILED; log $WORK/$target.log, artifacts $WORK/$target-*" >&2
    tail -40 "$WORK/$target.log" >&2
  fi
done
exit $status
