#!/usr/bin/env bash
# red_host_probe (ctest red_host_probe_cli): a bad value exits 2 naming the option, an
# unwritable --csv exits 1 naming the path, and a short probe prints both loops' blocks and
# writes every chunk. Not a timing test: no figure is compared with anything.
# Usage: cli_test.sh PATH/TO/red_host_probe
set -u
PROGRAM=$1
EXPECT_GREP=-E
# shellcheck source=bench/expect.sh
source "$(dirname "$0")/../expect.sh"
expect 2 "--seconds: 'x' is not a number" --seconds x
expect 2 "--seconds: 'nan' is not a number" --seconds nan
expect 2 "--seconds: '0' is not between 0.1 and 86400" --seconds 0
expect 2 "--block-s: '0' is not between 0.01 and 3600" --block-s 0
expect 2 "--stream-mb: '2.5' is not a whole number" --stream-mb 2.5
expect 2 "--stream-mb: '0' is not between 1 and 65536" --stream-mb 0
expect 2 "The following argument was not expected: --no-such-option" --no-such-option
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
: >"$tmp/blocker"
expect 1 "cannot write $tmp/blocker/c.csv" --seconds 0.2 --stream-mb 1 --csv "$tmp/blocker/c.csv"
expect 0 "^core-bound +[0-9]+ chunks, median [0-9.]+ ms; blocks [0-9.]+-[0-9.]+ of it:( [0-9.]+){2,}$" \
  --seconds 1 --block-s 0.1 --stream-mb 4 --csv "$tmp/c.csv"
expect 0 "^memory-bound +[0-9]+ chunks, median [0-9.]+ ms; blocks" --seconds 0.3 --stream-mb 4
# Every chunk written: the header, then rows of both probes with their times.
if [[ "$(head -1 "$tmp/c.csv")" != "probe,at_s,ms" ]] || ! grep -q '^core,' "$tmp/c.csv" ||
  ! grep -q '^memory,' "$tmp/c.csv"; then
  echo "FAIL: --csv wrote:"
  head -3 "$tmp/c.csv"
  fails=$((fails + 1))
else
  echo "ok: --csv holds both probes' chunks ($(($(wc -l <"$tmp/c.csv") - 1)) rows)"
fi
exit $((fails > 0))
