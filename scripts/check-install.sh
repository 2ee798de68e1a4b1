#!/usr/bin/env bash
# Checks RED as an installed library (docs/EMBEDDING.md): builds the core configuration
# (no LibTorch, no tests, no benchmarks) in build-install/ ($RED_STAGE/build when RED_STAGE is
# set), installs it into the staging prefix build-stage/prefix, checks the installed files,
# builds both examples/ against the INSTALLED package (find_package(red) via
# CMAKE_PREFIX_PATH) and runs them, compiles a program with `pkg-config --cflags --libs red`,
# and builds the .deb and inspects it. A missing install rule fails here. Called by
# scripts/test.sh; takes about a minute.
#
#     scripts/check-install.sh                     # as in CI (static red_core)
#     RED_STAGE=/tmp/stage scripts/check-install.sh   # elsewhere
#     RED_SHARED=ON scripts/check-install.sh          # with BUILD_SHARED_LIBS=ON
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/ccache-env.sh
ROOT=$PWD
STAGE=${RED_STAGE:-$ROOT/build-stage}
PREFIX=$STAGE/prefix
# The core's build directory sits beside build/ by default, at the same depth, so that
# ccache (scripts/ccache-env.sh) finds the objects scripts/build.sh compiled with the same
# flags: the core and most of the CLI are not compiled again.
BUILD=${RED_STAGE:+$STAGE/build}
BUILD=${BUILD:-$ROOT/build-install}
SHARED=${RED_SHARED:-OFF}
[[ $SHARED =~ ^(ON|OFF)$ ]] || { echo "check-install: RED_SHARED must be ON or OFF" >&2; exit 2; }
JOBS=$(nproc)
fail() { echo "check-install: $*" >&2; exit 1; }

echo "== install: configure and build the core into $PREFIX"
rm -rf "$PREFIX" "$STAGE/examples" "$STAGE/pc"
cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release -DRED_TORCH=OFF \
  -DRED_BUILD_TESTS=OFF -DRED_BUILD_BENCH=OFF -DBUILD_SHARED_LIBS="$SHARED" \
  -DCMAKE_INSTALL_PREFIX="$PREFIX" -DRED_WERROR=ON >/dev/null
cmake --build "$BUILD" -j"$JOBS"
cmake --install "$BUILD" >/dev/null

echo "== install: installed files"
VERSION=$(sed -n 's/^project(red VERSION \([0-9.]*\).*/\1/p' CMakeLists.txt)
[ -n "$VERSION" ] || fail "cannot read the version from CMakeLists.txt"
LIBDIR=$(cmake -L -N "$BUILD" 2>/dev/null | sed -n 's/^CMAKE_INSTALL_LIBDIR:PATH=//p')
LIBDIR=${LIBDIR:-lib}
if [ "$SHARED" = ON ]; then
  CORE_LIB=$LIBDIR/libred_core.so.$VERSION
  SONAME=$(objdump -p "$PREFIX/$CORE_LIB" | awk '$1 == "SONAME" {print $2}')
  [ "$SONAME" = "libred_core.so.${VERSION%.*}" ] || fail "SONAME is '$SONAME', not libred_core.so.${VERSION%.*}"
else
  CORE_LIB=$LIBDIR/libred_core.a
fi
for f in bin/red \
         include/red/version.hpp include/red/runtime/backend.hpp include/red/sched/policy.hpp \
         include/red/scenario/builder.hpp \
         "$CORE_LIB" \
         "$LIBDIR/cmake/red/redConfig.cmake" "$LIBDIR/cmake/red/redConfigVersion.cmake" \
         "$LIBDIR/cmake/red/red-core-targets.cmake" "$LIBDIR/pkgconfig/red.pc" \
         share/red/scenarios/minibench-tight.yaml share/doc/red/README.md \
         share/doc/red/EMBEDDING.md share/doc/red/examples/custom_backend/CMakeLists.txt; do
  [ -e "$PREFIX/$f" ] || fail "not installed: $f"
done
# Every public header is installed, and nothing of the source tree leaks into the package.
for h in $(cd include && find red -name '*.hpp'); do
  [ -e "$PREFIX/include/$h" ] || fail "header not installed: include/$h"
done
if grep -rq "$ROOT/include\|$ROOT/src" "$PREFIX/$LIBDIR/cmake/red"; then
  fail "the exported CMake package refers to the source tree"
fi
got=$("$PREFIX/bin/red" --version)
[ "$got" = "red $VERSION" ] || fail "red --version printed '$got', expected 'red $VERSION'"
"$PREFIX/bin/red" validate "$PREFIX/share/red/scenarios/minibench-tight.yaml" >/dev/null
# With DDS (or LibTorch), red links neither and runs libexec/red/red-full for the commands
# that need them (tools/red/full.hpp).
LIBEXECDIR=$(cmake -L -N "$BUILD" 2>/dev/null | sed -n 's/^CMAKE_INSTALL_LIBEXECDIR:PATH=//p')
LIBEXECDIR=${LIBEXECDIR:-libexec}
FULL=""
if [ -e "$BUILD/tools/red/red-full" ]; then
  FULL=$LIBEXECDIR/red/red-full
  [ -x "$PREFIX/$FULL" ] || fail "not installed: $FULL"
  if ldd "$PREFIX/bin/red" | grep -E 'libddsc|libtorch|libc10'; then
    fail "bin/red links DDS or LibTorch: every command would pay their loading"
  fi
  "$PREFIX/bin/red" camera --help >/dev/null || fail "red camera --help (through $FULL) failed"
fi

echo "== install: examples built against the installed package"
for ex in custom_backend own_loop; do
  cmake -S "examples/$ex" -B "$STAGE/examples/$ex" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_PREFIX_PATH="$PREFIX" -DCMAKE_CXX_FLAGS="-Wall -Wextra -Wpedantic -Wconversion -Wshadow -Werror" \
    >/dev/null
  cmake --build "$STAGE/examples/$ex" -j"$JOBS"
  # The example must have used the installed headers, not the source tree.
  if grep -q "$ROOT/include" "$STAGE/examples/$ex/build.ninja"; then
    fail "example $ex was built against the source tree"
  fi
  echo "-- $ex"
  timeout 60 "$STAGE/examples/$ex/$ex" 0.5
  if [ "$ex" = custom_backend ]; then timeout 60 "$STAGE/examples/$ex/$ex" 0.5 --async; fi
done
# Version and component requests: 99.0 and an unknown component fail, 0.1 succeeds.
mkdir -p "$STAGE/examples/version"
cat >"$STAGE/examples/version/CMakeLists.txt" <<'EOF'
cmake_minimum_required(VERSION 3.25)
project(red_version_check LANGUAGES CXX)
find_package(red 99.0 QUIET)
if(red_FOUND)
  message(FATAL_ERROR "find_package(red 99.0) accepted version ${red_VERSION}")
endif()
find_package(red 0.1 QUIET COMPONENTS no_such_component)
if(red_FOUND)
  message(FATAL_ERROR "find_package(red COMPONENTS no_such_component) succeeded")
endif()
find_package(red 0.1 REQUIRED COMPONENTS core)
if(NOT TARGET red::core OR NOT red_VERSION VERSION_EQUAL "${EXPECTED_VERSION}")
  message(FATAL_ERROR "find_package(red 0.1): no red::core, or version ${red_VERSION}")
endif()
EOF
cmake -S "$STAGE/examples/version" -B "$STAGE/examples/version/build" \
  -DCMAKE_PREFIX_PATH="$PREFIX" -DEXPECTED_VERSION="$VERSION" >/dev/null

echo "== install: pkg-config"
export PKG_CONFIG_PATH="$PREFIX/$LIBDIR/pkgconfig"
[ "$(pkg-config --modversion red)" = "$VERSION" ] || fail "pkg-config --modversion red is not $VERSION"
FLAGS=$(pkg-config --cflags --libs red)
echo "pkg-config --cflags --libs red: $FLAGS"
mkdir -p "$STAGE/pc"
cat >"$STAGE/pc/main.cpp" <<'EOF'
#include <red/profile/profile.hpp>
#include <red/sched/policy.hpp>
#include <red/version.hpp>
#include <iostream>
int main() {
  auto p = red::make_policy("red");
  const red::Profile profile = red::default_profile();
  std::cout << "red " << red::kVersion << " policy " << p->name() << ", "
            << profile.units.size() << " profiled units\n";
  return p && !profile.units.empty() ? 0 : 1;
}
EOF
# shellcheck disable=SC2086  # FLAGS is a list of flags
g++ -std=c++20 -o "$STAGE/pc/pc_check" "$STAGE/pc/main.cpp" $FLAGS
LD_LIBRARY_PATH="$PREFIX/$LIBDIR" "$STAGE/pc/pc_check"  # a shared red_core is not on the loader path

echo "== install: .deb (cpack -G DEB)"
(cd "$BUILD" && cpack -G DEB >/dev/null)
DEB=$(ls "$BUILD"/red_"$VERSION"_*.deb)
INFO=$(dpkg-deb -I "$DEB")
echo "$INFO" | grep -q "^ Package: red$" || fail "$DEB: no Package: red"
echo "$INFO" | grep -q "^ Version: $VERSION$" || fail "$DEB: version is not $VERSION"
echo "$INFO" | grep "^ Depends:" || fail "$DEB: no Depends"
for dep in libfmt-dev libyaml-cpp libyaml-0-2 libstdc++6; do  # -dev and run-time (dpkg-shlibdeps)
  echo "$INFO" | grep "^ Depends:" | grep -q "$dep" || fail "$DEB: Depends lacks $dep"
done
CONTENTS=$(dpkg-deb -c "$DEB")
for f in ./usr/bin/red ./usr/include/red/runtime/backend.hpp ./usr/share/red/scenarios/minibench-tight.yaml \
         /cmake/red/redConfig.cmake /cmake/red/FindLibYAML.cmake /pkgconfig/red.pc "/$(basename "$CORE_LIB")"; do
  echo "$CONTENTS" | grep -q -- "$f" || fail "$DEB: does not contain $f"
done
if [ -n "$FULL" ]; then
  echo "$CONTENTS" | grep -q -- "./usr/$FULL" || fail "$DEB: does not contain ./usr/$FULL"
fi

echo "== install: API documentation (Doxygen, target red_docs)"
cmake --build "$BUILD" --target red_docs
[ -s "$BUILD/docs/api/html/index.html" ] || fail "red_docs wrote no index.html"
[ -e "$BUILD/docs/api/html/examples.html" ] || fail "red_docs did not link the examples"
echo "doxygen warnings (undocumented members): $(wc -l <"$BUILD/docs/doxygen-warnings.log")"
echo "check-install: ok ($DEB)"
