#!/usr/bin/env bash
# Kill and resume (docs/sweeps.md, "Resuming"): a sweep, one shard of a sharded sweep, and a basin
# are each killed with SIGKILL at 20 or more seeded random moments and resumed with --resume each
# time; the final results.csv / basin.csv must be byte-identical to an uninterrupted run (no row
# lost, none duplicated, no partial run counted). Then a file-size limit (a full disk as the
# program sees it: write() fails with EFBIG) must end a resumed sweep with one line naming the
# file and the cause, and leave the runs recorded before it intact for the next --resume.
#   kill_resume.sh AMBLER [SEED]
set -u
ambler=$1
RANDOM=${2:-20261126}  # the kill moments are seeded
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0
min_kills=24  # kill moments drawn; at least 20 must land on a live process

cat >"$tmp/base.yaml" <<'EOF'
name: tiny
terrain:
  kind: plane
  size_m: [6, 6]
  cell_m: 0.1
sensor: {rows: 16, cols: 64}
views:
  - {xyz_m: [0, -2.5, 1.5], rpy_deg: [0, -30, 0]}
map:
  cell_m: 0.1
  region: {x_m: [-1, 1], y_m: [-1, 1]}
EOF
cat >"$tmp/sweep.yaml" <<'EOF'
name: kill_resume
base: base.yaml
axes:
  terrain.slope_deg: [[0, 0], [10, 0], [20, 0]]
  sensor.noise_k: [0.0003, 0.001]
  seed: [1, 2, 3, 4, 5]
EOF
cat >"$tmp/basin.yaml" <<'EOF'
name: basin_kill
seed: 5
terrain:
  kind: mars
  size_m: [12, 12]
  cell_m: 0.05
  rocks: {abundance_k: 0.08, min_diameter_m: 0.1, max_diameter_m: 1.0}
  craters: {count: 3, min_diameter_m: 1.0, max_diameter_m: 4.0}
sensor: {noise_k: 0, quantization_m: 0, mixed_pixels: false}
views:
  - {xyz_m: [0, -6, 3.0], rpy_deg: [0, -30, 0]}
  - {xyz_m: [0.3, -5.2, 3.0], rpy_deg: [0, -30, 5]}
map:
  cell_m: 0.10
  region: {x_m: [-2, 2], y_m: [-2, 2]}
  baseline: none
matching:
  methods: [iconic_lm, iconic_weighted]
EOF
basin_grid=(--translation-m 0,0.5,1 --rotation-deg 0,5 --trials 4)

now_ms() { date +%s%3N; }

# kill_until_done NAME CSV ITEMS START_MS ITEM_MS CMD...: runs CMD --resume and kills it with
# SIGKILL min_kills times, then lets it finish. The kill moments are seeded and spread over the
# whole job: kill i waits until the journal holds a random number of items (sorted, 0..ITEMS-1), then
# a random further delay of up to START_MS (a kill during start-up: reading the sweep, building a
# basin's pair) when that many were already recorded, or of up to ITEM_MS (a kill inside a run,
# or while a row or the CSV is written) otherwise.
journal_items() { local n; n=$( (cat "$1" 2>/dev/null || true) | wc -l); echo $((n > 0 ? n - 1 : 0)); }
kill_until_done() {
  local name=$1 csv=$2 items=$3 start_ms=$4 item_ms=$5; shift 5
  local journal="${csv%.csv}.journal" kills=0 rc delay_ms at="" targets pid target tries
  targets=$(for ((i = 0; i < min_kills; i++)); do echo $((RANDOM % items)); done | sort -n)
  for target in $targets done; do
    # A kill that comes too late (the resume finished first, as on a loaded machine whose timings
    # differ from the ones measured above) is drawn again at half the delay, so every kill moment
    # lands on a live process however fast or slow the machine is.
    for ((tries = 0; tries < 8; tries++)); do
      "$@" --resume -q 2>>"$tmp/$name.err" &
      pid=$!
      if [[ $target == done ]]; then
        wait "$pid"
        rc=$?
        if ((rc != 0)); then echo "FAIL $name: the last resume exited with $rc:"; tail -3 "$tmp/$name.err"; fail=1; return; fi
        break
      fi
      if (($(journal_items "$journal") >= target)); then
        delay_ms=$((RANDOM % (start_ms + 1) >> tries))
      else
        while kill -0 "$pid" 2>/dev/null && (($(journal_items "$journal") < target)); do sleep 0.005; done
        delay_ms=$((RANDOM % (item_ms + 1) >> tries))
      fi
      sleep "$(printf '%d.%03d' $((delay_ms / 1000)) $((delay_ms % 1000)))"
      if kill -9 "$pid" 2>/dev/null; then
        wait "$pid" 2>/dev/null
        kills=$((kills + 1))
        at+=" $(journal_items "$journal")"
        break
      fi
      wait "$pid"
      rc=$?
      if ((rc != 0)); then echo "FAIL $name: a resume exited with $rc:"; tail -3 "$tmp/$name.err"; fail=1; return; fi
      at+=" (finished)"
    done
  done
  if ((kills < 20)); then echo "FAIL $name: only $kills kills landed on a live process"; fail=1; return; fi
  if [[ ! -f $csv ]]; then echo "FAIL $name: no $csv"; fail=1; return; fi
  echo "ok   $name: killed $kills times, then finished; items recorded after each kill:$at"
}

same() {  # name, expected, actual
  if cmp -s "$2" "$3"; then
    echo "ok   $1: $(basename "$3") byte-identical to the uninterrupted run ($(($(wc -l <"$3") - 1)) rows)"
  else
    echo "FAIL $1: $3 differs from $2"; diff "$2" "$3" | head -5; fail=1
  fi
}

# elapsed_ms CMD...: the wall time of CMD in milliseconds (it must succeed).
elapsed_ms() {
  local t0
  t0=$(now_ms)
  "$@" -q || { echo "FAIL: $*" >&2; exit 1; }
  echo $(($(now_ms) - t0))
}

# 1. A whole sweep. START_MS is a resume with nothing left to run (reading and checking the sweep,
# writing results.csv), ITEM_MS one run's share of the rest.
sweep_ms=$(elapsed_ms "$ambler" sweep "$tmp/sweep.yaml" --out "$tmp/ref")
start_ms=$(elapsed_ms "$ambler" sweep "$tmp/sweep.yaml" --out "$tmp/ref" --resume)
work_ms=$((sweep_ms > start_ms ? sweep_ms - start_ms : 1))
kill_until_done sweep "$tmp/killed/results.csv" 30 "$start_ms" $((work_ms / 30)) \
  "$ambler" sweep "$tmp/sweep.yaml" --out "$tmp/killed"
same sweep "$tmp/ref/results.csv" "$tmp/killed/results.csv"

# 2. A sharded sweep, shard 2 of 3 killed and resumed, then merged.
"$ambler" sweep "$tmp/sweep.yaml" --out "$tmp/sharded" --shard 1/3 -q &&
  "$ambler" sweep "$tmp/sweep.yaml" --out "$tmp/sharded" --shard 3/3 -q || { echo "FAIL: shards 1, 3"; exit 1; }
kill_until_done shard "$tmp/sharded/results.shard-2-of-3.csv" 10 "$start_ms" $((work_ms / 30)) \
  "$ambler" sweep "$tmp/sweep.yaml" --out "$tmp/sharded" --shard 2/3
"$ambler" sweep "$tmp/sweep.yaml" --out "$tmp/sharded" --merge -q || { echo "FAIL: merge"; fail=1; }
same shard "$tmp/ref/results.csv" "$tmp/sharded/results.csv"

# 3. A basin.
basin_ms=$(elapsed_ms "$ambler" basin "$tmp/basin.yaml" --out "$tmp/bref" "${basin_grid[@]}")
bstart_ms=$(elapsed_ms "$ambler" basin "$tmp/basin.yaml" --out "$tmp/bref" "${basin_grid[@]}" --resume)
bwork_ms=$((basin_ms > bstart_ms ? basin_ms - bstart_ms : 1))
kill_until_done basin "$tmp/bkilled/basin.csv" 24 "$bstart_ms" $((bwork_ms / 24)) \
  "$ambler" basin "$tmp/basin.yaml" --out "$tmp/bkilled" "${basin_grid[@]}"
same basin "$tmp/bref/basin.csv" "$tmp/bkilled/basin.csv"

# 4. A full disk: a file-size limit (SIGXFSZ ignored, so write() fails with EFBIG) that the run
# directories outgrow after a few runs. The sweep must stop with one line naming a file and the
# cause, keep the runs it recorded, and a resume without the limit must finish the same CSV.
"$ambler" sweep "$tmp/sweep.yaml" --out "$tmp/full" -q --keep all 2>/dev/null &
pid=$!
# Kill it once a third of the runs' time has passed and the journal holds a record (on a loaded
# machine the start alone can outlast a third of the quiet sweep).
sleep "$(printf '%d.%03d' $((sweep_ms / 3000)) $((sweep_ms / 3 % 1000)))"
for _ in $(seq 600); do
  [[ -s "$tmp/full/results.journal" ]] || ! kill -0 $pid 2>/dev/null && break
  sleep 0.05
done
kill -9 $pid 2>/dev/null; wait $pid 2>/dev/null
[[ -s "$tmp/full/results.journal" ]] || { echo "FAIL full_disk: no journal after 30 s"; exit 1; }
journal_before=$(wc -c <"$tmp/full/results.journal")
cp "$tmp/full/results.journal" "$tmp/journal.before"
(
  trap '' XFSZ
  ulimit -f 64  # bash counts 1024-byte blocks: 64 KiB, which a map's PNG outgrows
  exec "$ambler" sweep "$tmp/sweep.yaml" --out "$tmp/full" --resume -q --keep all
) 2>"$tmp/full.err"
rc=$?
lines=$(wc -l <"$tmp/full.err")
if ((rc == 0)); then
  echo "FAIL full_disk: exit 0 under a 64 KiB file-size limit"; fail=1
elif ((lines != 1)) || ! grep -qE '(File too large|No space left)' "$tmp/full.err"; then
  echo "FAIL full_disk: expected one line naming the cause, got $lines:"; cat "$tmp/full.err"; fail=1
elif ! cmp -s "$tmp/journal.before" <(head -c "$journal_before" "$tmp/full/results.journal"); then
  echo "FAIL full_disk: the runs recorded before the failure were changed"; fail=1
else
  echo "ok   full_disk: $(cat "$tmp/full.err")"
fi
"$ambler" sweep "$tmp/sweep.yaml" --out "$tmp/full" --resume -q || { echo "FAIL full_disk: resume"; fail=1; }
same full_disk "$tmp/ref/results.csv" "$tmp/full/results.csv"

if ((fail)); then echo "kill and resume: FAILED"; exit 1; fi
echo "kill and resume: all passed"
