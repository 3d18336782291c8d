#!/usr/bin/env bash
# Do the outputs change? Builds revision REV (default HEAD) in a temporary worktree, runs every
# scenario of scenarios/ that is one run, one sweep (scenarios/sweeps/noise_check.yaml) and one
# basin (basin_rocks on a 2 × 2 grid), and the reports of the sweep and the basin (a run's report shows its timings), with it and with this tree's build/ambler, and compares every
# file byte for byte: metrics.json without its
# timing_s block (and each registration's time_s), rasters, pictures, scans, results.csv. Prints each file that differs (and, for
# metrics.json, the differing values) and exits 1 if any does.
#   bash scripts/same-outputs.sh [REV]        # this tree must be built (scripts/build.sh)
# Needs git and jq (scripts/setup.sh installs both). The other revision's build is kept in
# ${AMBLER_SAME_OUTPUTS_CACHE:-/tmp/ambler-same-outputs}/<commit> for the next comparison. With
# AMBLER_SAME_OUTPUTS_KEEP=DIR both output trees are left in DIR/before and DIR/after.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
rev=$(git rev-parse "${1:-HEAD}")
cache=${AMBLER_SAME_OUTPUTS_CACHE:-/tmp/ambler-same-outputs}/$rev
[ -x build/ambler ] || { echo "same-outputs: build/ambler missing: run scripts/build.sh first" >&2; exit 2; }
command -v jq >/dev/null || { echo "same-outputs: jq missing: run scripts/setup.sh" >&2; exit 2; }

if [ ! -x "$cache/build/ambler" ]; then
  echo "same-outputs: building $rev in $cache/src" >&2
  rm -rf "$cache"; mkdir -p "$cache"
  git worktree add --detach -f "$cache/src" "$rev" >/dev/null
  cmake -S "$cache/src" -B "$cache/build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$cache/build" --target ambler --parallel "$(nproc)" >/dev/null
  git worktree remove --force "$cache/src"
fi

# The same inputs for both: this tree's scenario files.
# Every single-run scenario in scenarios/ (a file with views: or traverse:, not a sweep's base/axes), one sweep
# with every run directory kept, and a basin on a small grid.
run_all() {  # $1 = ambler binary, $2 = output directory
  rm -rf "$2"; mkdir -p "$2"
  local f name
  while IFS= read -r f; do
    name=${f#scenarios/}; name=${name%.yaml}; name=${name//\//_}
    "$1" run "$f" --out "$2/$name" --quiet
  done < <(grep -lE '^(views|traverse):' $(find scenarios -name '*.yaml' | sort))
  "$1" sweep scenarios/sweeps/noise_check.yaml --out "$2/sweep" --keep all --quiet
  "$1" basin scenarios/experiments/basin_rocks.yaml --out "$2/basin" --quiet \
    --translation-m 0,0.5 --rotation-deg 0,5 --trials 2
  for name in sweep basin; do "$1" report "$2/$name" >/dev/null 2>&1; done
}
if [ -n "${AMBLER_SAME_OUTPUTS_KEEP:-}" ]; then
  out=$AMBLER_SAME_OUTPUTS_KEEP; mkdir -p "$out"
else
  out=$(mktemp -d)
  trap 'rm -rf "$out"' EXIT
fi
echo "same-outputs: running $rev" >&2
run_all "$cache/build/ambler" "$out/before"
echo "same-outputs: running this tree" >&2
run_all "$root/build/ambler" "$out/after"

# The measured times: timing_s, a registration's time_s (in metrics.json and matching/*.json), a
# traverse's seconds_per_stop.
untimed='del(.timing_s) | del(.time_s) | del(.traverse.seconds_per_stop) | if .registration then .registration |= map(del(.time_s)) else . end'
status=0
while IFS= read -r f; do
  a=$out/before/$f b=$out/after/$f
  if [ ! -e "$b" ]; then echo "only before: $f"; status=1; continue; fi
  case "$f" in
    */metrics.json|*/matching/*.json)
      if ! cmp -s <(jq -S "$untimed" "$a") <(jq -S "$untimed" "$b"); then
        echo "differs: $f"; status=1
        diff <(jq -S "$untimed" "$a" | jq -c 'paths(scalars) as $p | [($p|map(tostring)|join(".")), getpath($p)]') \
             <(jq -S "$untimed" "$b" | jq -c 'paths(scalars) as $p | [($p|map(tostring)|join(".")), getpath($p)]') |
          head -40 || true
      fi ;;
    *) cmp -s "$a" "$b" || { echo "differs: $f"; status=1; } ;;
  esac
done < <(cd "$out/before" && find . -type f | sed 's|^\./||' | sort)
while IFS= read -r f; do
  [ -e "$out/before/$f" ] || { echo "only after: $f"; status=1; }
done < <(cd "$out/after" && find . -type f | sed 's|^\./||' | sort)
n=$(cd "$out/before" && find . -type f | wc -l)
[ $status = 0 ] && echo "same-outputs: all $n files identical to $rev (metrics.json: timing_s aside)"
exit $status
