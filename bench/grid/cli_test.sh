#!/usr/bin/env bash
# red_load_grid's arguments (ctest red_load_grid_cli): a bad value exits 2 naming the option,
# an unwritable --points file exits 1 naming the path, and a small sweep runs.
# Usage: cli_test.sh PATH/TO/red_load_grid
set -u
PROGRAM=$1
# shellcheck source=bench/expect.sh
source "$(dirname "$0")/../expect.sh"
expect 2 "--robots: 'x' is not a number" --robots x
expect 2 "--robots must be >= 1" --robots 0
expect 2 "--frames must be >= 1" --robots 1 --frames 0
expect 2 "--frames: '2x' is not a number" --robots 1 --frames 2x
expect 2 "--frames: 'inf' is not a number" --robots 1 --frames inf
expect 2 "--robot needs a SEED >= 1" --robot -1 --yaml
expect 2 "--seeds: '1.5' is not a number" --seeds 1.5
expect 2 "--point: 'x' is not a number" --point plain chain 1 x 1.0
expect 2 "--frames needs a value" --robots 1 --frames
expect 2 "usage: red_load_grid" --no-such-option
# Under a plain file nothing can be created, even by root.
blocker=$(mktemp)
trap 'rm -f "$blocker"' EXIT
expect 1 "cannot write $blocker/points.tsv" --robots 1 --frames 3 --points "$blocker/points.tsv"
expect 0 "5 points (1 robot workloads x 5 loads)" --robots 1 --frames 3
expect 0 "5 points (1 robot workloads x 5 loads)" --robots 1 --frames 3 --shared
expect 0 "remove_operation: {operation: critical}" --robot 1 --shared --yaml
exit $((fails > 0))
