#!/usr/bin/env bash
# Bad input to the CLI: one line on stderr naming the file and the key or cause, a non-zero exit,
# and nothing written.
set -u
ambler=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0
expect_error() {  # name, pattern, args...
  local name=$1 pattern=$2; shift 2
  "$ambler" "$@" >"$tmp/out" 2>"$tmp/err"
  local rc=$?
  local lines
  lines=$(wc -l <"$tmp/err")
  if [[ $rc -eq 0 ]]; then echo "FAIL $name: exit 0"; fail=1; return; fi
  if [[ $lines -ne 1 ]]; then echo "FAIL $name: $lines lines on stderr:"; cat "$tmp/err"; fail=1; return; fi
  if ! grep -qE -- "$pattern" "$tmp/err"; then echo "FAIL $name: '$(cat "$tmp/err")' does not match '$pattern'"; fail=1; return; fi
  echo "ok   $name: $(cat "$tmp/err")"
}
expect_error missing_file 'nope\.yaml: .*(cannot open|not found|does not exist)' run "$tmp/nope.yaml" --out "$tmp/run1"
printf 'name: x\nterrain: {kind: plane, relif_m: 1}\nviews: [{xyz_m: [0,0,1]}]\n' >"$tmp/unknown.yaml"
expect_error unknown_key 'unknown\.yaml: terrain\.relif_m' run "$tmp/unknown.yaml" --out "$tmp/run2"
printf 'name: x\nterrain: {kind: plane}\nsensor: {rows: many}\nviews: [{xyz_m: [0,0,1]}]\n' >"$tmp/type.yaml"
expect_error wrong_type 'type\.yaml: sensor\.rows' run "$tmp/type.yaml" --out "$tmp/run3"
printf 'name: x\nterrain: {kind: plane}\nsensor: {noise_k: -1}\nviews: [{xyz_m: [0,0,1]}]\n' >"$tmp/range.yaml"
expect_error out_of_range 'range\.yaml: sensor\.noise_k' run "$tmp/range.yaml" --out "$tmp/run4"
printf 'name: x\nterrain: {kind: plane}\nviews: [{xyz_m: [0,0,.nan]}]\n' >"$tmp/nan.yaml"
expect_error nan_value 'nan\.yaml: views\[0\]\.xyz_m' run "$tmp/nan.yaml" --out "$tmp/run5"
printf 'name: x\nterrain: {kind: plane}\nviews: [{xyz_m: [0,0,1]}, {xyz_m: [0.5,0,1]}]\nmap: {}\n' >"$tmp/nomatch.yaml"
expect_error basin_without_matching 'nomatch\.yaml: matching' basin "$tmp/nomatch.yaml" --out "$tmp/run6"
expect_error basin_negative_axis '--translation-m: -1 is negative' basin "$tmp/nomatch.yaml" --out "$tmp/run7" --translation-m 0,-1
expect_error basin_empty_axis '--rotation-deg: expected comma-separated numbers' basin "$tmp/nomatch.yaml" --out "$tmp/run8" --rotation-deg ''
printf 'name: x\nterrain: {kind: plane}\nviews: [{xyz_m: [0,0,1]}]\nmap: {}\nleg: {soil: sand}\n' >"$tmp/leg.yaml"
expect_error leg_without_footfall 'leg\.yaml: leg: needs a footfall section' run "$tmp/leg.yaml" --out "$tmp/run9"
printf 'name: x\nterrain: {kind: plane}\nviews: [{xyz_m: [0,0,1]}]\nmap: {}\nfootfall: {region: {x_m: [8, 9], y_m: [0, 1]}}\n' >"$tmp/ff.yaml"
expect_error footfall_region_off_map 'ff\.yaml: footfall\.region: .*is not inside' run "$tmp/ff.yaml" --out "$tmp/run10"
for k in 1 2 3 4 5 6 7 8 9 10; do
  if [[ -e $tmp/run$k ]]; then echo "FAIL: $tmp/run$k was created for a bad scenario"; fail=1; fi
done
if ((fail)); then echo "1 failed"; exit 1; fi
echo "cli errors: all passed"
