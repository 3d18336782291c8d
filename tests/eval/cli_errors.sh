#!/usr/bin/env bash
# Bad input to the CLI: one line on stderr naming the file and the key or cause, a non-zero exit,
# and nothing written (no file or directory appears or changes in the scratch directory). Each
# case is one class of docs/errors.md; tests/eval/errors_catalogue.sh checks that the catalogue's
# example messages are exactly the "ok" lines printed here. The cases run in a scratch directory
# with relative paths; an absolute path in a message shows the scratch directory as /tmp/t.
set -u
ambler=$(realpath "$1")
tmp=$(mktemp -d)
logs=$(mktemp -d)
trap 'chmod -R u+w "$tmp" 2>/dev/null; rm -rf "$tmp" "$logs"' EXIT
cd "$tmp" || exit 1
fail=0
wrap=()  # a command that runs ambler (below: in a mount namespace with a read-only directory)

# The scratch directory's files and their contents, to see that a refused command wrote nothing.
snapshot() { find . -printf '%p %y %s %T@\n' | sort; }

# name, pattern, args...: one line on stderr matching pattern, a non-zero exit, nothing written.
expect_error() {
  local name=$1 pattern=$2; shift 2
  local before
  before=$(snapshot)
  "${wrap[@]}" "$ambler" "$@" >"$logs/out" 2>"$logs/err"
  local rc=$?
  check "$name" "$pattern" "$rc" || return
  if [[ $(snapshot) != "$before" ]]; then
    echo "FAIL $name: wrote:"; diff <(echo "$before") <(snapshot); fail=1; return
  fi
  echo "ok   $name: $(shown)"
}

# The same for a command that fails after it has started (a sweep's run): it may leave the runs it
# made, but no results file.
expect_error_after_start() {  # name, pattern, results file, args...
  local name=$1 pattern=$2 results=$3; shift 3
  "$ambler" "$@" >"$logs/out" 2>"$logs/err"
  local rc=$?
  check "$name" "$pattern" "$rc" || return
  if [[ -e $results ]]; then echo "FAIL $name: $results was written"; fail=1; return; fi
  echo "ok   $name: $(shown)"
}

# The message as the catalogue shows it: the scratch directory written /tmp/t.
shown() { local m; m=$(cat "$logs/err"); m=${m//$tmp//tmp/t}; echo "$m"; }

check() {  # name, pattern, rc
  local name=$1 pattern=$2 rc=$3 lines
  lines=$(wc -l <"$logs/err")
  if [[ $rc -eq 0 ]]; then echo "FAIL $name: exit 0"; fail=1; return 1; fi
  if [[ $lines -ne 1 ]]; then echo "FAIL $name: $lines lines on stderr:"; cat "$logs/err"; fail=1; return 1; fi
  if ! grep -qE -- "$pattern" "$logs/err"; then
    echo "FAIL $name: '$(cat "$logs/err")' does not match '$pattern'"; fail=1; return 1
  fi
  if ! grep -q '^ambler: error: ' "$logs/err"; then
    echo "FAIL $name: '$(cat "$logs/err")' does not start with 'ambler: error: '"; fail=1; return 1
  fi
}

scenario() {  # file, extra lines: a valid minimal scenario (20 x 20 m plane, one view) plus extras
  printf 'name: x\nterrain: {kind: plane}\nviews: [{xyz_m: [0, 0, 1]}]\n%b' "${2-}" >"$1"
}
two_views='name: x\nterrain: {kind: plane}\nviews: [{xyz_m: [0, 0, 1]}, {xyz_m: [0.5, 0, 1]}]\nmap: {}\n'

# ---- Scenario files
expect_error missing_file 'nope\.yaml: cannot open file' run nope.yaml --out out
mkdir adir
expect_error scenario_is_directory 'adir: cannot open file' run adir --out out
printf 'name: x\nterrain: {kind: plane\nviews: []\n' >syntax.yaml
expect_error not_yaml 'syntax\.yaml: line 3, column 6: YAML syntax error' run syntax.yaml --out out
: >empty.yaml
expect_error empty_file 'empty\.yaml: expected a mapping of scenario keys, got nothing' run empty.yaml --out out
scenario two_docs.yaml '---\nname: y\n'
expect_error several_documents 'two_docs\.yaml: expected one YAML document, got 2' run two_docs.yaml --out out
printf -- '- a\n- b\n' >list.yaml
expect_error not_a_mapping 'list\.yaml: expected a mapping of scenario keys, got a list of 2' run list.yaml --out out
printf 'name: x\nterrain: {kind: plane, relif_m: 1}\nviews: [{xyz_m: [0,0,1]}]\n' >unknown.yaml
expect_error unknown_key 'unknown\.yaml: terrain\.relif_m: unknown key \(did you mean relief_m\?\)' run unknown.yaml --out out
scenario colour.yaml 'colour: red\n'
expect_error unknown_key_no_suggestion 'colour\.yaml: colour: unknown key \(allowed: ' run colour.yaml --out out
scenario dup.yaml 'seed: 1\nseed: 2\n'
expect_error duplicate_key 'dup\.yaml: seed: duplicate key' run dup.yaml --out out
printf 'name: x\nterrain: {size_m: [10, 10]}\nviews: [{xyz_m: [0, 0, 1]}]\n' >nokind.yaml
expect_error missing_required_key 'nokind\.yaml: terrain\.kind: missing required key' run nokind.yaml --out out
printf 'name: x\nterrain: {kind: plane}\nsensor: {rows: many}\nviews: [{xyz_m: [0,0,1]}]\n' >type.yaml
expect_error wrong_type 'type\.yaml: sensor\.rows' run type.yaml --out out
scenario quoted.yaml 'sensor: {max_range_m: "40"}\n'
expect_error quoted_number "quoted\.yaml: sensor\.max_range_m: expected a number > 0, got the string '40'" run quoted.yaml --out out
scenario yes.yaml 'sensor: {mixed_pixels: yes}\n'
expect_error not_a_boolean "yes\.yaml: sensor\.mixed_pixels: expected true or false, got 'yes'" run yes.yaml --out out
scenario seclist.yaml 'sensor: [64, 256]\n'
expect_error section_not_a_mapping 'seclist\.yaml: sensor: expected a mapping, got a list of 2' run seclist.yaml --out out
scenario secnone.yaml 'sensor:\n'
expect_error empty_section 'secnone\.yaml: sensor: expected a mapping, got nothing' run secnone.yaml --out out
printf 'name: x\nterrain: {kind: fractl}\nviews: [{xyz_m: [0, 0, 1]}]\n' >kind.yaml
expect_error not_one_of 'kind\.yaml: terrain\.kind: expected one of .*\(did you mean fractal\?\)' run kind.yaml --out out
scenario int.yaml 'sensor: {rows: 2.5}\n'
expect_error not_an_integer 'int\.yaml: sensor\.rows: expected an integer in \[1, 4096\], got 2\.5' run int.yaml --out out
printf 'name: x\nterrain: {kind: plane}\nsensor: {noise_k: -1}\nviews: [{xyz_m: [0,0,1]}]\n' >range.yaml
expect_error out_of_range 'range\.yaml: sensor\.noise_k' run range.yaml --out out
printf 'name: x\nterrain: {kind: plane}\nviews: [{xyz_m: [0,0,.nan]}]\n' >nan.yaml
expect_error nan_value 'nan\.yaml: views\[0\]\.xyz_m' run nan.yaml --out out
scenario huge.yaml 'sensor: {max_range_m: 1e999}\n'
expect_error beyond_a_double 'huge\.yaml: sensor\.max_range_m: .*beyond the range of a double' run huge.yaml --out out
printf 'name: x\nterrain: {kind: plane}\nviews: [{xyz_m: [0, 1]}]\n' >short.yaml
expect_error list_length 'short\.yaml: views\[0\]\.xyz_m: expected a list of 3 numbers, got a list of 2' run short.yaml --out out
printf 'name: x\nterrain: {kind: plane}\nviews: []\n' >noviews.yaml
expect_error empty_list 'noviews\.yaml: views: expected a non-empty list of views, got a list of 0' run noviews.yaml --out out
printf 'name: Demo 1\nterrain: {kind: plane}\nviews: [{xyz_m: [0, 0, 1]}]\n' >name.yaml
expect_error bad_name "name\.yaml: name: expected lowercase letters, digits, '_' and '-' only" run name.yaml --out out
printf 'name: x\nterrain: {kind: mars, rocks: {min_diameter_m: 0.5, max_diameter_m: 0.5}}\nviews: [{xyz_m: [0, 0, 1]}]\n' >rocks.yaml
expect_error max_not_above_min 'rocks\.yaml: terrain\.rocks\.max_diameter_m: expected a number > min_diameter_m' run rocks.yaml --out out
scenario region.yaml 'map: {region: {x_m: [5, -5]}}\n'
expect_error region_reversed 'region\.yaml: map\.region\.x_m: expected \[lo, hi\] with lo < hi' run region.yaml --out out
printf 'name: x\nterrain: {kind: plane, size_m: [500, 500], cell_m: 0.05}\nviews: [{xyz_m: [0, 0, 1]}]\n' >grid.yaml
expect_error grid_too_large 'grid\.yaml: terrain\.cell_m: expected at most 25000000 grid points' run grid.yaml --out out
printf 'name: x\nterrain: {kind: plane, size_m: [0.4, 20], cell_m: 1}\nviews: [{xyz_m: [0, 0, 1]}]\n' >coarse.yaml
expect_error cell_too_coarse 'coarse\.yaml: terrain\.cell_m: expected at most twice the smaller side' run coarse.yaml --out out
printf 'name: x\nterrain: {kind: mars, size_m: [1.5, 20]}\nviews: [{xyz_m: [0, 0, 1]}]\n' >bigrock.yaml
expect_error rock_too_large 'bigrock\.yaml: terrain\.rocks\.max_diameter_m: expected at most half' run bigrock.yaml --out out
printf 'name: x\nterrain: {kind: plane, mjcf: w.xml}\nviews: [{xyz_m: [0, 0, 1]}]\n' >conflict.yaml
expect_error conflicting_keys 'conflict\.yaml: terrain\.mjcf: only allowed with kind: mjcf' run conflict.yaml --out out
printf 'name: x\nterrain: {kind: mjcf, mjcf: worlds/none.xml}\nviews: [{xyz_m: [0, 0, 1]}]\n' >nomjcf.yaml
expect_error mjcf_missing "nomjcf\.yaml: terrain\.mjcf: cannot find the MJCF file 'worlds/none\.xml'" run nomjcf.yaml --out out
printf 'name: x\nterrain: {kind: plane}\nviews: [{xyz_m: [0, 0, 1]}, {xyz_m: [1, 0, 1]}]\nmatching: {}\n' >nomap.yaml
expect_error section_needs_map 'nomap\.yaml: matching: needs a map section' run nomap.yaml --out out
printf 'name: x\nterrain: {kind: plane}\nviews: [{xyz_m: [0,0,1]}]\nmap: {}\nleg: {soil: sand}\n' >leg.yaml
expect_error leg_without_footfall 'leg\.yaml: leg: needs a footfall section' run leg.yaml --out out
scenario oneview.yaml 'map: {}\nmatching: {}\n'
expect_error matching_one_view 'oneview\.yaml: matching: needs at least two views' run oneview.yaml --out out
printf "$two_views"'matching: {pairs: [[0, 2]]}\n' >pair.yaml
expect_error matching_pair_out_of_range 'pair\.yaml: matching\.pairs\[0\]: expected two view indices in \[0, 1\]' run pair.yaml --out out
printf "$two_views"'matching: {pairs: [[1, 1]]}\n' >self.yaml
expect_error matching_self_pair 'self\.yaml: matching\.pairs\[0\]: a view cannot be registered against itself' run self.yaml --out out
printf "$two_views"'matching: {draw_initial_error: true, initial_error: {xyz_m: [0.1, 0, 0]}}\n' >drawn.yaml
expect_error matching_drawn_and_given_error 'drawn\.yaml: matching\.draw_initial_error: true draws the initial error from the odometry model; remove initial_error' run drawn.yaml --out out
printf 'name: x\nterrain: {kind: plane}\nviews: [{xyz_m: [0, 0, 1]}, {xyz_m: [1, 0, 1]}, {xyz_m: [2, 0, 1]}]\nmap: {}\nmatching: {pairs: [[0, 1]]}\nmerge: {}\n' >link.yaml
expect_error merge_not_linked 'link\.yaml: merge\.poses: matched, but view 2 is not linked to view 0' run link.yaml --out out
printf 'name: x\nterrain: {kind: plane}\nviews: [{xyz_m: [0,0,1]}]\nmap: {}\nfootfall: {region: {x_m: [8, 9], y_m: [0, 1]}}\n' >ff.yaml
expect_error footfall_region_off_map 'ff\.yaml: footfall\.region: .*is not inside' run ff.yaml --out out
scenario foot.yaml 'map: {}\nfootfall: {region: {x_m: [0, 0.2], y_m: [0, 1]}}\n'
expect_error foot_larger_than_region 'foot\.yaml: footfall\.foot_diameter_m: 0\.3 m is larger than the region' run foot.yaml --out out
scenario ffmap.yaml 'map: {}\nfootfall: {map: view_3}\n'
expect_error footfall_map_unknown "ffmap\.yaml: footfall\.map: expected composite or view_K with K in \[0, 0\], got 'view_3'" run ffmap.yaml --out out

# ---- Traverses (a 30 x 10 m plane; the path 20 m along x)
traverse='name: x\nterrain: {kind: plane, size_m: [30, 10]}\nmap: {}\n'
line='{start_xy_m: [-10, 0], heading_deg: 0, length_m: 20}'
printf "$traverse"'traverse: {path: %s}\nviews: [{xyz_m: [0, 0, 1]}]\n' "$line" >tviews.yaml
expect_error traverse_with_views 'tviews\.yaml: views: a traverse generates its views, one per stop; remove views' run tviews.yaml --out out
printf "$traverse"'traverse: {path: %s}\nfootfall: {}\n' "$line" >tfoot.yaml
expect_error traverse_with_footfall 'tfoot\.yaml: footfall: not yet supported in a traverse' run tfoot.yaml --out out
printf "$traverse"'traverse: {path: %s}\nmatching: {pairs: [[0, 1]]}\n' "$line" >tpairs.yaml
expect_error traverse_matching_pairs 'tpairs\.yaml: matching\.pairs: a traverse registers each stop as traverse\.register says; remove pairs' run tpairs.yaml --out out
printf "$traverse"'traverse: {path: {start_xy_m: [-10, 0], heading_deg: 0, length_m: 20, waypoints_xy_m: [[0, 0], [1, 0]]}}\n' >tforms.yaml
expect_error traverse_path_both_forms 'tforms\.yaml: traverse\.path: expected start_xy_m, heading_deg and length_m, or waypoints_xy_m, got both forms' run tforms.yaml --out out
printf "$traverse"'traverse: {path: {waypoints_xy_m: [[0, 0], [1, 0], [1, 0]]}}\n' >trepeat.yaml
expect_error traverse_waypoint_repeated 'trepeat\.yaml: traverse\.path\.waypoints_xy_m\[2\]: expected a point other than the one before' run trepeat.yaml --out out
printf "$traverse"'traverse: {path: {start_xy_m: [-10, 0], heading_deg: 0, length_m: 30}}\n' >toff.yaml
expect_error traverse_path_off_terrain "toff\.yaml: traverse\.path\.length_m: expected the path's end within the terrain less the footprint radius 1" run toff.yaml --out out
printf "$traverse"'traverse: {path: %s, stop_spacing_m: 25}\n' "$line" >tspacing.yaml
expect_error traverse_spacing_beyond_path "tspacing\.yaml: traverse\.stop_spacing_m: expected at most the path's length \(20\), got 25" run tspacing.yaml --out out
printf 'name: x\nterrain: {kind: plane, size_m: [30, 10]}\ntraverse: {path: %s}\n' "$line" >tnomap.yaml
expect_error traverse_without_map 'tnomap\.yaml: traverse\.register: composite needs a map section' run tnomap.yaml --out out
printf "$traverse"'traverse: {path: %s}\n' "$line" >traverse.yaml
expect_error traverse_not_basin 'traverse\.yaml: traverse: not yet supported by ambler basin' basin traverse.yaml --out out

# ---- Views: over the terrain and above it
printf 'name: x\nterrain: {kind: plane, size_m: [20, 20]}\nviews: [{xyz_m: [0, -6, 3]}, {xyz_m: [12, 0, 3]}]\n' >outside.yaml
expect_error view_outside_terrain 'outside\.yaml: views\[1\]\.xyz_m: expected x in \[-10, 10\] and y in \[-10, 10\] \(over the terrain\), got \[12, 0, 3\]' run outside.yaml --out out
printf 'name: x\nterrain: {kind: steps, size_m: [10, 10], cell_m: 0.1, steps: [{x_m: 0, height_m: 0.4}]}\nviews: [{xyz_m: [-3, 0, 1]}, {xyz_m: [3, 0, 0.3]}]\n' >below.yaml
expect_error view_below_terrain 'below\.yaml: views\[1\]\.xyz_m: expected the sensor above the terrain, whose surface is at z = 0\.400 there, got z = 0\.3' run below.yaml --out out
printf '<mujoco>\n  <worldbody>\n    <geom type="box" size="3 3 0.5" pos="0 0 -0.5"/>\n  </worldbody>\n</mujoco>\n' >box.xml
printf 'name: x\nterrain: {kind: mjcf, mjcf: box.xml}\nmap: {}\ntraverse: {path: %s}\n' "$line" >tmjcf.yaml
expect_error traverse_on_mjcf 'tmjcf\.yaml: terrain\.kind: a traverse stands its body on a generated terrain or a DEM, not on an MJCF world' run tmjcf.yaml --out out
printf 'name: x\nterrain: {kind: mjcf, mjcf: box.xml}\nviews: [{xyz_m: [5, 0, 2]}]\n' >mjcf_outside.yaml
expect_error mjcf_view_outside_world 'mjcf_outside\.yaml: views\[0\]\.xyz_m: expected a sensor over the terrain, got \[5, 0, 2\], where there is no ground' run mjcf_outside.yaml --out out
printf 'name: x\nterrain: {kind: mjcf, mjcf: box.xml}\nviews: [{xyz_m: [0, 0, -2]}]\n' >mjcf_below.yaml
expect_error mjcf_view_below_ground 'mjcf_below\.yaml: views\[0\]\.xyz_m: expected the sensor above the terrain, whose surface is at z = 0\.000 there, got z = -2' run mjcf_below.yaml --out out
# ---- DEM terrains (terrain.kind: dem): small GeoTIFFs made with gdal_translate from an ASCII grid
{ printf 'ncols 41\nnrows 41\nxllcorner 500000\nyllcorner 4100000\ncellsize 1\nNODATA_value -9999\n'
  for r in $(seq 41); do for c in $(seq 41); do if ((r == 21 && c == 22)); then printf -- '-9999 '; else printf '1 '; fi; done; echo; done
} >grid.asc
gdal_translate -q -a_srs EPSG:4326 grid.asc geo.tif
gdal_translate -q grid.asc nocrs.tif
gdal_translate -q -a_srs EPSG:2227 grid.asc feet.tif
gdal_translate -q -a_srs EPSG:32633 grid.asc hole.tif
echo 'not a tiff' >text.tif
rm -f ./*.aux.xml
dem() { printf 'name: x\nterrain: {kind: dem, dem: %s, size_m: [10, 10], cell_m: 0.5%s}\nviews: [{xyz_m: [0, 0, 3]}]\n' "$2" "${3-}" >"$1"; }
dem nodem.yaml none.tif
expect_error dem_missing "nodem\.yaml: terrain\.dem: cannot find the DEM file 'none\.tif' \(looked for /" run nodem.yaml --out out
dem notdem.yaml text.tif
expect_error dem_not_a_geotiff 'notdem\.yaml: terrain\.dem: /.*/text\.tif: not a GeoTIFF GDAL can read' run notdem.yaml --out out
dem geo.yaml geo.tif
expect_error dem_geographic "geo\.yaml: terrain\.dem: /.*/geo\.tif: geographic CRS 'WGS 84' \(degrees\); expected a projected CRS in metres" run geo.yaml --out out
dem nocrs.yaml nocrs.tif
expect_error dem_no_crs 'nocrs\.yaml: terrain\.dem: /.*/nocrs\.tif: no coordinate reference system; expected a projected CRS in metres' run nocrs.yaml --out out
dem feet.yaml feet.tif
expect_error dem_feet "feet\.yaml: terrain\.dem: /.*/feet\.tif: linear unit 'US survey foot' \(0\.30480060960121924 m\); expected a projected CRS in metres" run feet.yaml --out out
dem hole.yaml hole.tif
expect_error dem_nodata 'hole\.yaml: terrain\.dem: /.*/hole\.tif: 1 nodata pixel under the window \(the first at column 21, row 20\); expected none: move or shrink the window' run hole.yaml --out out
dem big.yaml hole.tif ', centre_m: [500038, 4100020]'
expect_error dem_window_beyond 'big\.yaml: terrain\.window_m: /.*/hole\.tif: the window of 10 x 10 m centred at \(500038, 4100020\) reaches beyond the DEM.s outermost pixel centres \(E 500000\.5 to 500040\.5, N 4100000\.5 to 4100040\.5\)' run big.yaml --out out
dem twins.yaml hole.tif ', window_m: [12, 10]'
expect_error dem_window_not_size 'twins\.yaml: terrain\.window_m: expected size_m \(\[10, 10\]\) or nothing: the DEM window is the terrain.s extent, got \[12, 10\]' run twins.yaml --out out
printf 'name: x\nterrain: {kind: plane, dem: hole.tif}\nviews: [{xyz_m: [0, 0, 1]}]\n' >demplane.yaml
expect_error dem_key_other_kind 'demplane\.yaml: terrain\.dem: only allowed with kind: dem \(kind is plane\)' run demplane.yaml --out out

# ---- Sweep files (base.yaml: a valid scenario beside them)
scenario base.yaml 'map: {}\n'
sweep() {  # file, axes and other lines
  printf 'name: s\nbase: base.yaml\n%b' "$2" >"$1"
}
expect_error sweep_missing_file 'nosweep\.yaml: cannot open file' sweep nosweep.yaml --out out
sweep slope.yaml 'axes:\n  terrain.slope_deg: [[0, 0], [75, 0]]\n'
expect_error sweep_bad_value 'slope\.yaml: axes\.terrain\.slope_deg = \[75, 0\]: base\.yaml: terrain\.slope_deg\[0\]: expected a number in \(-60, 60\), got 75' sweep slope.yaml --out out
sweep axiskey.yaml 'axes:\n  sensor.noise: [0.001]\n'
expect_error sweep_unknown_axis_key 'axiskey\.yaml: axes\.sensor\.noise = 0\.001: base\.yaml: sensor\.noise: unknown key \(did you mean noise_k\?\)' sweep axiskey.yaml --out out
sweep index.yaml 'axes:\n  views.1.xyz_m: [[0, 0, 2]]\n'
expect_error sweep_no_such_index 'index\.yaml: axes\.views\.1\.xyz_m: views has 1 entry: no index 1' sweep index.yaml --out out
sweep value.yaml 'axes:\n  terrain.kind.x: [1]\n'
expect_error sweep_value_not_a_section 'value\.yaml: axes\.terrain\.kind\.x: terrain\.kind is a value \(plane\), not a section' sweep value.yaml --out out
sweep overlap.yaml 'axes:\n  views.0: [{xyz_m: [0, 0, 1]}]\n  views.0.xyz_m: [[0, 0, 2]]\n'
expect_error sweep_overlapping_axes 'overlap\.yaml: axes\.views\.0\.xyz_m: overlaps axis views\.0; give each key once' sweep overlap.yaml --out out
sweep emptyaxis.yaml 'axes:\n  sensor.rows: []\n'
expect_error sweep_empty_axis 'emptyaxis\.yaml: axes\.sensor\.rows: expected a non-empty list of values, got \[\]' sweep emptyaxis.yaml --out out
sweep nameaxis.yaml 'axes:\n  name: [a, b]\n'
expect_error sweep_name_axis 'nameaxis\.yaml: axes\.name: the sweep names each run' sweep nameaxis.yaml --out out
printf 'name: s\nbase: nope.yaml\naxes: {seed: [1]}\n' >nobase.yaml
expect_error sweep_base_missing 'nobase\.yaml: base: cannot find the scenario file "nope\.yaml"' sweep nobase.yaml --out out
printf 'name: s\nbase: unknown.yaml\naxes: {seed: [1]}\n' >badbase.yaml
expect_error sweep_base_invalid 'badbase\.yaml: base: unknown\.yaml: terrain\.relif_m: unknown key' sweep badbase.yaml --out out
sweep sweepkey.yaml 'axis: {seed: [1]}\n'
expect_error sweep_unknown_key 'sweepkey\.yaml: axis: unknown key \(allowed: name, description, base, axes, metrics\)' sweep sweepkey.yaml --out out
sweep metric.yaml 'axes: {seed: [1]}\nmetrics: [seed]\n'
expect_error sweep_metric_is_an_axis 'metric\.yaml: metrics\[0\]: seed is already a column: it is an axis' sweep metric.yaml --out out
values=$(seq -s, 1 47)
sweep many.yaml "axes:\n  seed: [$values]\n  sensor.rows: [$values]\n  sensor.cols: [$values]\n"
expect_error sweep_too_many_runs 'many\.yaml: axes: expected at most 100000 runs' sweep many.yaml --out out
sweep runfail.yaml 'axes:\n  views.0.xyz_m: [[0, 0, 1], [0, 0, -1]]\n'
expect_error_after_start sweep_run_refused 'runfail\.yaml: run 1 \(views\.0\.xyz_m = \[0, 0, -1\]\): base\.yaml: views\[0\]\.xyz_m: expected the sensor above the terrain' out_runfail/results.csv sweep runfail.yaml --out out_runfail --quiet

# ---- Command-line options
sweep ok.yaml 'axes: {seed: [1, 2]}\n'
expect_error unknown_option 'The following argument was not expected: --colour' run base.yaml --out out --colour
expect_error missing_required_option '--out is required' run base.yaml
expect_error unknown_command 'walk: unknown command \(expected one of run, sweep, basin, make-dem, report, bench, experiment; see --help\)' walk base.yaml
expect_error shard_malformed '--shard: expected K/N with 1 <= K <= N \(shard K of N, 1-based\), got "3/2"' sweep ok.yaml --out out --shard 3/2
expect_error shard_too_many '--shard: 3/3: the sweep has 2 runs, so at most 2 shards' sweep ok.yaml --out out --shard 3/3
expect_error keep_unknown '--keep: expected one of none, metrics, all, got "some"' sweep ok.yaml --out out --keep some
expect_error jobs_below_one '--jobs: expected an integer >= 1, got 0' sweep ok.yaml --out out --jobs 0
expect_error merge_with_shard '--merge: merges the shards. files; --shard does not apply' sweep ok.yaml --out out --merge --shard 1/2
expect_error not_a_number 'Value x not in range|could not be converted|--jobs' sweep ok.yaml --out out --jobs x

# ---- Basin grids
printf "$two_views" >nomatch.yaml
printf "$two_views"'matching: {}\n' >basin.yaml
expect_error basin_without_matching 'nomatch\.yaml: matching' basin nomatch.yaml --out out
expect_error basin_negative_axis '--translation-m: -1 is negative' basin basin.yaml --out out --translation-m 0,-1
expect_error basin_empty_axis '--rotation-deg: expected comma-separated numbers' basin basin.yaml --out out --rotation-deg ''
expect_error basin_axis_not_increasing '--rotation-deg: values must increase, got 5 after 10' basin basin.yaml --out out --rotation-deg 0,10,5
expect_error basin_axis_too_large '--rotation-deg: 200 is beyond 180' basin basin.yaml --out out --rotation-deg 0,200
expect_error basin_trials_below_one '--trials: expected an integer >= 1, got 0' basin basin.yaml --out out --trials 0
expect_error basin_rotation_axis_unknown '--rotation-axis: expected random or vertical, got "up"' basin basin.yaml --out out --rotation-axis up
expect_error basin_too_many_shards '--shard: 9/9: ' basin basin.yaml --out out --translation-m 0 --rotation-deg 0,5 --trials 2 --shard 9/9
expect_error basin_merge_with_timing '--merge: merges the shards. files; --timing does not apply' basin basin.yaml --out out --merge --timing

# ---- Experiments
expect_error experiment_sweeps_missing 'nosweeps/tilt_noise\.yaml: cannot open file' experiment locus-vs-cartesian --out out --sweeps nosweeps --quiet
expect_error descent_seeds_below_one '--seeds: expected an integer >= 1, got 0' experiment descent --out out --seeds 0 --quiet
expect_error descent_quick_with_seeds '--quick excludes --seeds \(see --help\)' experiment descent --out out --quick --seeds 3
expect_error descent_report_without_results 'adir/results\.csv: cannot open file' experiment descent --out adir --report --quiet

# ---- Reports (adir: an empty directory, made above)
expect_error report_not_a_run_directory 'adir: not a run, sweep or basin directory \(no metrics\.json, results\.csv or basin\.csv\)' report adir
mkdir -p badsweep && printf 'run,seed\n0\n' >badsweep/results.csv
expect_error report_results_csv_ragged 'badsweep/results\.csv: row 1 has 1 cells, the header 2' report badsweep
mkdir -p badbasin && printf 'method,t\n' >badbasin/basin.csv
expect_error report_basin_csv_header 'badbasin/basin\.csv: not a basin table \(expected a CSV header starting with method,translation_m,rotation_deg,trial,translation_error_m,rotation_error_deg,success\)' report badbasin

# ---- Output directories (--out): in the program's words, before any work
printf 'a file\n' >afile
expect_error out_under_a_file_run '--out afile/run: cannot create the directory: afile is a file' run base.yaml --out afile/run
expect_error out_under_a_file_sweep '--out afile/sweep: cannot create the directory: afile is a file' sweep ok.yaml --out afile/sweep
expect_error out_under_a_file_basin '--out afile/basin: cannot create the directory: afile is a file' basin basin.yaml --out afile/basin
expect_error out_is_a_file '--out afile: expected a directory, got a file' run base.yaml --out afile
expect_error out_empty '--out: expected a directory, got ""' run base.yaml --out ''
expect_error out_cannot_be_created '/proc/ambler_out: cannot create the directory \(No such file or directory\)' run base.yaml --out /proc/ambler_out --quiet

# A read-only file system (a tmpfs mounted read-only on ro/ in a private mount namespace; root's
# permission bits stop nothing, a read-only mount stops root too).
mkdir ro
if unshare -m sh -c 'mount -t tmpfs -o ro tmpfs ro' 2>/dev/null; then
  wrap=(unshare -m sh -c 'mount -t tmpfs -o ro tmpfs ro && exec "$@"' sh)
  expect_error out_read_only_parent '--out ro/run: cannot create the directory in ro \(Read-only file system\)' run base.yaml --out ro/run
  expect_error out_read_only_directory '--out ro: cannot write in the directory \(Read-only file system\)' sweep ok.yaml --out ro --merge
  wrap=()
else
  echo "skip out_read_only_parent, out_read_only_directory: cannot mount a read-only tmpfs here (not root?)"
fi

# ---- Merging shards (hand-made shard files: the merge reads them, runs nothing)
mkdir noshards split missing
expect_error merge_no_such_directory 'nodir: no such directory' sweep ok.yaml --out nodir --merge
expect_error merge_no_shards 'noshards: no results\.shard-K-of-N\.csv files to merge' sweep ok.yaml --out noshards --merge
printf 'run,seed\n0,1\n' >missing/results.shard-1-of-2.csv
expect_error merge_missing_shard 'missing/results\.shard-2-of-2\.csv: missing \(shard 2 of 2\)' sweep ok.yaml --out missing --merge
printf 'run,seed\n0,1\n' >split/results.shard-1-of-2.csv
printf 'run,seed\n1,2\n' >split/results.shard-2-of-2.csv
printf 'run,seed\n0,1\n' >split/results.shard-1-of-3.csv
expect_error merge_shard_of_another_split 'split: shards of different splits \(results\.shard-1-of-2\.csv, results\.shard-1-of-3\.csv\): remove the stale ones' sweep ok.yaml --out split --merge
mkdir wrong && printf 'run,seed\n1,2\n' >wrong/results.shard-1-of-2.csv && printf 'run,seed\n1,2\n' >wrong/results.shard-2-of-2.csv
expect_error merge_run_in_wrong_shard 'wrong/results\.shard-1-of-2\.csv: row 2: run 1 belongs to shard 2 of 2' sweep ok.yaml --out wrong --merge
mkdir header && printf 'run,seed\n0,1\n' >header/results.shard-1-of-2.csv && printf 'run,seed,x\n1,2,3\n' >header/results.shard-2-of-2.csv
expect_error merge_header_differs 'header/results\.shard-2-of-2\.csv: header differs from header/results\.shard-1-of-2\.csv.s' sweep ok.yaml --out header --merge
mkdir quote && printf 'run,seed\n0,"1\n' >quote/results.shard-1-of-1.csv
expect_error merge_not_a_csv 'quote/results\.shard-1-of-1\.csv: not a CSV file \(an open or stray quote\)' sweep ok.yaml --out quote --merge
# ---- Resume journal (--resume)
mkdir -p jnot/runs && printf 'run,seed\n0,1\n' >jnot/results.journal
expect_error journal_not_a_journal 'jnot/results\.journal: not an ambler journal \(its first line is not "ambler-journal 1 <identity>"\); remove it or run without --resume' sweep ok.yaml --out jnot --resume
mkdir -p jother/runs && printf 'ambler-journal 1 0000000000000000\n' >jother/results.journal
expect_error journal_of_another_sweep 'jother/results\.journal: recorded for another sweep or basin, or with other options \(its identity differs\); run without --resume to start over, or give this one its own --out' sweep ok.yaml --out jother --resume
"$ambler" sweep ok.yaml --out jref --quiet  # a real journal, for its header
mkdir -p jbad/runs && { head -1 jref/results.journal; printf '0 00000000 []\n1 00000000 []\n'; } >jbad/results.journal
expect_error journal_corrupt 'jbad/results\.journal: line 2: damaged record \(checksum mismatch\) followed by others; the journal is corrupt: run without --resume to start over' sweep ok.yaml --out jbad --resume
expect_error merge_with_resume '--merge: merges the shards. files; --resume does not apply' sweep ok.yaml --out out --merge --resume
mkdir short && printf 'run,seed\n0,1\n' >short/results.shard-1-of-1.csv
expect_error merge_run_missing 'short: run 1 is missing' sweep ok.yaml --out short --merge
mkdir twice && printf 'run,seed\n0,1\n1,2\n0,1\n' >twice/results.shard-1-of-1.csv
expect_error merge_run_duplicated 'twice/results\.shard-1-of-1\.csv: row 4: run 0 is duplicated' sweep ok.yaml --out twice --merge
mkdir axes && printf 'run,noise\n0,1\n1,2\n' >axes/results.shard-1-of-1.csv
expect_error merge_header_not_the_sweeps 'axes/results\.shard-1-of-1\.csv: header does not start with run and the sweep.s axes' sweep ok.yaml --out axes --merge
mkdir notbasin && printf 'run,seed\n0,1\n' >notbasin/basin.shard-1-of-1.csv
expect_error basin_merge_not_a_basin_csv 'notbasin/basin\.shard-1-of-1\.csv: not a basin CSV' basin basin.yaml --out notbasin --merge --translation-m 0 --rotation-deg 0 --trials 1
basin_header='method,translation_m,rotation_deg,trial,translation_error_m,rotation_error_deg,success,iterations,time_s,accepted,false_accept'
mkdir basintwice && printf '%s\niconic_lm,0,0,0,0,0,true,1,,true,false\niconic_lm,0,0,0,0,0,true,1,,true,false\n' "$basin_header" >basintwice/basin.shard-1-of-1.csv
expect_error basin_merge_row_twice 'basintwice/basin\.shard-1-of-1\.csv: row 3: a second row of iconic_lm' basin basin.yaml --out basintwice --merge --translation-m 0 --rotation-deg 0 --trials 1
mkdir basinmethod && printf '%s\ngicp,0,0,0,0,0,true,1,,true,false\n' "$basin_header" >basinmethod/basin.shard-1-of-1.csv
expect_error basin_merge_unknown_method 'basinmethod/basin\.shard-1-of-1\.csv: row 2: method gicp is not one of the scenario.s' basin basin.yaml --out basinmethod --merge --translation-m 0 --rotation-deg 0 --trials 1
mkdir offgrid && printf '%s\niconic_lm,0.7,0,0,0,0,true,1,,true,false\n' "$basin_header" >offgrid/basin.shard-1-of-1.csv
expect_error basin_merge_row_off_the_grid 'offgrid/basin\.shard-1-of-1\.csv: row 2: translation 0\.7 m is not on --translation-m' basin basin.yaml --out offgrid --merge --translation-m 0,0.5 --rotation-deg 0 --trials 1

if ((fail)); then echo "some cases failed"; exit 1; fi
echo "cli errors: all passed"
