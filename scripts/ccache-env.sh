# Sourced by scripts/build.sh, test.sh, check-install.sh and fuzz.sh: compile through
# Debian's ccache when it is installed, so that a second run rebuilds only what changed
# (docs/TESTING.md, "How long the test command takes"). The cache is ccache's own
# (~/.cache/ccache, or $CCACHE_DIR); paths under the checkout are hashed relative to it
# (base_dir), so another clone of the same commit hits too. RED_CCACHE=0 turns it off.
# Takes effect when a build directory is configured for the first time (CMake reads
# CMAKE_<LANG>_COMPILER_LAUNCHER from the environment then).
# A ccache that cannot open its cache (no HOME, a read-only directory) is not used.
if [ "${RED_CCACHE:-1}" != 0 ] && command -v ccache >/dev/null && ccache --show-stats >/dev/null 2>&1; then
  export CMAKE_CXX_COMPILER_LAUNCHER=ccache CMAKE_C_COMPILER_LAUNCHER=ccache
  export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$PWD}
  # The build directory's path is not hashed (it only changes the debug info's working
  # directory); precompiled headers (cmake/Precompile.cmake) need the two pch/time sloppinesses.
  export CCACHE_NOHASHDIR=${CCACHE_NOHASHDIR:-1}
  export CCACHE_SLOPPINESS=${CCACHE_SLOPPINESS:-pch_defines,time_macros,include_file_mtime,include_file_ctime}
  # Every configuration of the test command (Release with LibTorch, the sanitizers, the
  # staging install, the fuzzers) fits, compressed.
  export CCACHE_MAXSIZE=${CCACHE_MAXSIZE:-12G}
fi
