#!/usr/bin/env bash
# Installs what is missing, builds, and runs every test: the full suite (core, CLI and
# the LibTorch backend), then the core and runtime suites again under
# AddressSanitizer + UndefinedBehaviorSanitizer, the runtime under ThreadSanitizer, and a
# short run of every libFuzzer target (scripts/fuzz.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/deps.sh
scripts/npm-oracle.sh
JOBS=$(nproc)

echo "== formatting (.clang-format)"
git ls-files '*.cpp' '*.hpp' | xargs clang-format --dry-run -Werror

echo "== build and test (Release, all targets)"
scripts/build.sh -DRED_WERROR=ON
ctest --test-dir build --output-on-failure -j"$JOBS"

echo "== every C++ source again with the whole standard library included first (newer toolchains)"
/usr/bin/python3 scripts/check-stdlib.py build

echo "== build and test under address,undefined sanitizers (core, no LibTorch)"
cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=Debug -DRED_TORCH=OFF -DRED_BUILD_BENCH=OFF \
  -DRED_SANITIZE=address,undefined -DRED_DDS=OFF -DRED_WERROR=ON >/dev/null
cmake --build build-asan -j"$JOBS"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-asan --output-on-failure -j"$JOBS"

echo "== build and test the real-time runtime under the thread sanitizer"
cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=Debug -DRED_TORCH=OFF -DRED_BUILD_BENCH=OFF \
  -DRED_SANITIZE=thread -DRED_DDS=OFF -DRED_WERROR=ON >/dev/null
cmake --build build-tsan -j"$JOBS" --target red_tests
TSAN_OPTIONS=halt_on_error=1 build-tsan/tests/red_tests --gtest_filter='*Runtime*:*AsyncLanes*:RowQueue*'

echo "== install: staging install, examples built against it, pkg-config, .deb"
scripts/check-install.sh

echo "== fuzz each libFuzzer target for 15 s (clang; address, undefined, leaks)"
scripts/fuzz.sh 15

echo "== reproduction page, smoke run (bench/reproduce.sh --quick: every section, numbers parse)"
RED=build/tools/red/red bench/reproduce.sh --quick --out build/reproduce-quick
