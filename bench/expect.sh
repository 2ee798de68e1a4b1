# shellcheck shell=bash
# expect(), shared by the benchmark programs' argument tests (bench/grid/cli_test.sh,
# bench/host/cli_test.sh). Source it after setting PROGRAM (the binary) and, for extended
# regular expressions instead of fixed strings, EXPECT_GREP=-E; it counts failures in $fails.
fails=0
expect() {  # expect RC PATTERN ARGS...
  local rc=$1 pattern=$2
  shift 2
  local out got name
  name=$(basename "$PROGRAM")
  out=$("$PROGRAM" "$@" 2>&1)
  got=$?
  if [[ $got -ne $rc ]] || ! grep -q "${EXPECT_GREP:--F}" -- "$pattern" <<<"$out"; then
    echo "FAIL: $name $* -> exit $got (want $rc), output:"
    echo "$out" | tail -3
    echo "  (want a line matching: $pattern)"
    fails=$((fails + 1))
  else
    echo "ok: $name $* -> exit $rc, '$pattern'"
  fi
}
