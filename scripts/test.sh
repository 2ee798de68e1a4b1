#!/usr/bin/env bash
# Installs what is missing, builds, and runs every test: the full suite (core, CLI and
# the LibTorch backend), then the core and runtime suites again under
# AddressSanitizer + UndefinedBehaviorSanitizer, the runtime under ThreadSanitizer, and a
# short run of every libFuzzer target (scripts/fuzz.sh).
#
# Each phase's wall time is printed at the end and written to build/test-times.tsv (phase,
# seconds), also when a phase fails. Builds go through ccache when it is installed
# (scripts/ccache-env.sh), so a second run rebuilds only what changed. The quick tier for
# daily work is scripts/test-quick.sh (docs/TESTING.md).
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/ccache-env.sh
JOBS=$(nproc)

# Phase timing: `phase NAME` ends the phase before it and starts NAME. Microseconds from
# bash's EPOCHREALTIME.
now_us() { echo "${EPOCHREALTIME/./}"; }
PHASE_NAMES=()
PHASE_US=()
PHASE_NAME=""
PHASE_START=0
TEST_START=$(now_us)
end_phase() {
  if [ -n "$PHASE_NAME" ]; then
    PHASE_NAMES+=("$PHASE_NAME")
    PHASE_US+=($(($(now_us) - PHASE_START)))
    PHASE_NAME=""
  fi
}
phase() {
  end_phase
  PHASE_NAME=$1
  PHASE_START=$(now_us)
  echo "== $1"
}
seconds() { printf '%d.%d' $(($1 / 1000000)) $(($1 % 1000000 / 100000)); }
report_times() {
  local rc=$? i total
  if [ -n "$PHASE_NAME" ] && [ $rc -ne 0 ]; then PHASE_NAME="$PHASE_NAME (failed)"; fi
  end_phase
  total=$(($(now_us) - TEST_START))
  mkdir -p build
  {
    printf 'phase\tseconds\n'
    for i in "${!PHASE_NAMES[@]}"; do printf '%s\t%s\n' "${PHASE_NAMES[$i]}" "$(seconds "${PHASE_US[$i]}")"; done
    printf 'total\t%s\n' "$(seconds $total)"
  } >build/test-times.tsv
  echo "== wall time per phase (build/test-times.tsv)"
  for i in "${!PHASE_NAMES[@]}"; do
    printf '%8s s  %s\n' "$(seconds "${PHASE_US[$i]}")" "${PHASE_NAMES[$i]}"
  done
  printf '%8s s  total (%d min), exit %d\n' "$(seconds $total)" $((total / 60000000)) $rc
  exit $rc
}
trap report_times EXIT

phase "packages (scripts/deps.sh), ROS 2 byte oracle (npm)"
scripts/deps.sh
scripts/npm-oracle.sh
. scripts/ccache-env.sh  # ccache may have come with the packages just now

phase "formatting (.clang-format)"
git ls-files '*.cpp' '*.hpp' | xargs clang-format --dry-run -Werror

phase "build (Release, every target)"
scripts/build.sh -DRED_WERROR=ON

# Newer LibTorch: every source that includes it, syntax only, against the headers of other
# LibTorch versions given in RED_TORCH_HEADERS (docs/GPU.md, "Versions tried"); skipped,
# saying so, where none are given. Nothing is downloaded.
phase "newer LibTorch headers (scripts/check-torch-headers.py, RED_TORCH_HEADERS)"
/usr/bin/python3 scripts/check-torch-headers.py build

phase "test (Release, ctest)"
ctest --test-dir build --output-on-failure -j"$JOBS"

# The sanitizer builds compile every source of theirs with the whole standard library
# included first (RED_STDLIB_FIRST, cmake/Precompile.cmake): what newer libstdc++ headers
# pull in (a file-local name clashing with a std:: one) fails there as on g++ 13+.
phase "build under address,undefined sanitizers (core, no LibTorch; whole standard library first)"
cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=Debug -DRED_TORCH=OFF -DRED_BUILD_BENCH=OFF \
  -DRED_SANITIZE=address,undefined -DRED_DDS=OFF -DRED_WERROR=ON -DRED_STDLIB_FIRST=ON >/dev/null
cmake --build build-asan -j"$JOBS"

phase "newer toolchains: the sources the sanitizer build leaves out, with the whole standard library"
/usr/bin/python3 scripts/check-stdlib.py build --except build-asan

phase "test under address,undefined sanitizers (ctest)"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-asan --output-on-failure -j"$JOBS"

# The runtime's tests are in red_tests (the Release and ASan runs) and, for the thread
# sanitizer, in red_runtime_tests alone: it must hold every test of red_tests that the filter
# matches, so that a new runtime test in another file is not left out here.
phase "build and test the real-time runtime under the thread sanitizer"
TSAN_FILTER='*Runtime*:*AsyncLanes*:RowQueue*'
cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=Debug -DRED_TORCH=OFF -DRED_BUILD_BENCH=OFF \
  -DRED_SANITIZE=thread -DRED_DDS=OFF -DRED_WERROR=ON -DRED_STDLIB_FIRST=ON >/dev/null
cmake --build build-tsan -j"$JOBS" --target red_runtime_tests
list_tests() { # Suite.Test, sorted
  "$1" --gtest_list_tests --gtest_filter="$TSAN_FILTER" |
    awk '/^Running main/ {next} /^[^ ]/ {suite = $1; next} {print suite $1}' | sort
}
release_list=$(list_tests build/tests/red_tests)
missing=$(comm -23 <(echo "$release_list") <(list_tests build-tsan/tests/red_runtime_tests))
if [ -z "$release_list" ] || [ -n "$missing" ]; then
  echo "test.sh: red_runtime_tests lacks these runtime tests of red_tests: add their source to" \
    "RED_RUNTIME_TEST_SOURCES in tests/CMakeLists.txt" >&2
  echo "$missing" >&2
  exit 1
fi
TSAN_OPTIONS=halt_on_error=1 build-tsan/tests/red_runtime_tests --gtest_filter="$TSAN_FILTER"

phase "install: staging install, examples, pkg-config, .deb, API docs"
scripts/check-install.sh

phase "fuzz each libFuzzer target for 15 s (clang; address, undefined, leaks)"
scripts/fuzz.sh 15

phase "reproduction page, smoke run (bench/reproduce.sh --quick)"
RED=build/tools/red/red bench/reproduce.sh --quick --out build/reproduce-quick
end_phase
