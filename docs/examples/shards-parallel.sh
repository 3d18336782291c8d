#!/bin/bash
# Runs a sweep or a basin as N shards with GNU parallel, then merges them; docs/sweeps.md.
#   shards-parallel.sh N sweep SWEEP.yaml --out DIR
#   shards-parallel.sh N basin SCENARIO.yaml --out DIR [grid options: --translation-m ... --trials ...]
# parallel's own options come from $PARALLEL: PARALLEL=-j2 runs two shards at a time here;
# PARALLEL='-S host1,host2 --workdir .' runs them over ssh (the same paths on every host, DIR on
# a shared file system). Uses $AMBLER if set, else ambler on PATH.
set -euo pipefail
n=$1
shift
parallel --will-cite --halt now,fail=1 -q "${AMBLER:-ambler}" "$@" --quiet --shard {}/"$n" ::: $(seq "$n")
"${AMBLER:-ambler}" "$@" --merge
