#!/usr/bin/env bash
# GNU parallel on this machine: runs docs/examples/shards-parallel.sh, the script docs/sweeps.md
# shows, with two shards at a time (PARALLEL=-j2), on a 3-shard sweep and a 3-shard basin, and
# checks that the merged results.csv and basin.csv are byte-identical to the same sweep and basin
# run in one process. Exit 77 (ctest: skipped) when GNU parallel is not installed.
#   usage: parallel.sh AMBLER SOURCE_DIR
set -uo pipefail
ambler=$(realpath "$1")
src=$(realpath "$2")
here=$src/tests/cluster
source "$here/lib.sh"
t0=$(date +%s.%N)

command -v parallel >/dev/null || { echo "SKIPPED: parallel: GNU parallel not found (bash scripts/setup.sh installs it)"; exit 77; }
parallel --version 2>/dev/null | grep -q 'GNU parallel' \
  || { echo "SKIPPED: parallel: $(command -v parallel) is not GNU parallel"; exit 77; }

tmp=$(mktemp -d /tmp/ambler-parallel.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
export AMBLER=$ambler PARALLEL=-j2
script=$src/docs/examples/shards-parallel.sh
fail=0
check_doc_shows "$src/docs/sweeps.md" "$script" || fail=1

sweep=$here/sweep.yaml
if bash "$script" 3 sweep "$sweep" --out "$tmp/sweep" >"$tmp/sweep.log" 2>&1; then
  echo "parallel: sweep shards merged after $(elapsed)"
  "$ambler" sweep "$sweep" --out "$tmp/sweep-whole" --quiet || fail=1
  same_bytes sweep "$tmp/sweep-whole/results.csv" "$tmp/sweep/results.csv" || fail=1
else
  cat "$tmp/sweep.log"; echo "FAIL sweep: $script failed"; fail=1
fi

scenario=$here/basin.yaml
grid=(--translation-m 0,0.5 --rotation-deg 0,5 --trials 2)
if bash "$script" 3 basin "$scenario" --out "$tmp/basin" "${grid[@]}" >"$tmp/basin.log" 2>&1; then
  echo "parallel: basin shards merged after $(elapsed)"
  "$ambler" basin "$scenario" --out "$tmp/basin-whole" --quiet "${grid[@]}" || fail=1
  same_bytes basin "$tmp/basin-whole/basin.csv" "$tmp/basin/basin.csv" || fail=1
else
  cat "$tmp/basin.log"; echo "FAIL basin: $script failed"; fail=1
fi

if ((fail)); then echo "parallel: FAILED"; exit 1; fi
echo "parallel: all passed in $(elapsed)"
