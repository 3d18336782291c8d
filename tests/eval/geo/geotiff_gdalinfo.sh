#!/usr/bin/env bash
# gdalinfo, what a GIS user runs first, on the map rasters of a run (docs/conventions.md, "GeoTIFF"):
# every .tiff under maps/, footfall/ and leg/ must be a GeoTIFF whose origin and pixel size, as
# gdalinfo prints them, are the map's meta.json corner (x_min_m, y_max_m) and cell (cell_m, −cell_m),
# whose size is its cols × rows, with NaN as nodata, the local metre frame as its CRS, and nothing on
# gdalinfo's stderr.
#   geotiff_gdalinfo.sh AMBLER SOURCE_DIR
set -u
ambler=$1
src=$2
command -v gdalinfo >/dev/null || { echo "gdalinfo not installed (gdal-bin, scripts/setup.sh)"; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0
# The sandbox footfall experiment, made small: one view, a map, footfall scores and the leg's tilt.
sed -e 's/cell_m: 0.02/cell_m: 0.04/' -e 's/^sensor: {}/sensor: {rows: 32, cols: 128}/' \
  "$src/scenarios/experiments/sandbox.yaml" >"$tmp/s.yaml"
"$ambler" run "$tmp/s.yaml" --out "$tmp/run" --quiet >"$tmp/run.log" 2>&1 || { cat "$tmp/run.log"; exit 1; }
n=0
for tif in "$tmp"/run/maps/*.tiff "$tmp"/run/footfall/*.tiff "$tmp"/run/leg/*.tiff; do
  [[ -e $tif ]] || continue
  n=$((n + 1))
  name=${tif#"$tmp/run/"}
  meta=$tmp/run/maps/view_0_meta.json  # footfall and leg rasters are on the footfall map's grid (view_0)
  [[ $tif == */maps/* ]] && meta=${tif%_*.tiff}_meta.json && meta=${meta/_cartesian_meta/_meta} &&
    meta=${meta/_shadow_meta/_meta}
  [[ -e $meta ]] || { echo "FAIL $name: no meta file $meta"; fail=1; continue; }
  info=$(gdalinfo "$tif" 2>"$tmp/err") || { echo "FAIL $name: gdalinfo failed: $(head -1 "$tmp/err")"; fail=1; continue; }
  [[ -s $tmp/err ]] && { echo "FAIL $name: gdalinfo wrote to stderr: $(head -1 "$tmp/err")"; fail=1; }
  got_origin=$(sed -n 's/^Origin = (\(.*\),\(.*\))$/\1 \2/p' <<<"$info")
  got_pixel=$(sed -n 's/^Pixel Size = (\(.*\),\(.*\))$/\1 \2/p' <<<"$info")
  read -r x0 y1 cell rows cols < <(jq -r '"\(.x_min_m) \(.y_max_m) \(.cell_m) \(.rows) \(.cols)"' "$meta")
  # gdalinfo prints 15 decimals: compare as numbers.
  awk -v g="$got_origin" -v p="$got_pixel" -v x0="$x0" -v y1="$y1" -v c="$cell" 'BEGIN {
      split(g, o, " "); split(p, s, " ");
      e = 1e-12; d = 0;
      d += (o[1] - x0)^2 > e^2; d += (o[2] - y1)^2 > e^2; d += (s[1] - c)^2 > e^2; d += (s[2] + c)^2 > e^2;
      exit d > 0 }' || { echo "FAIL $name: gdalinfo origin ($got_origin) pixel ($got_pixel), meta says ($x0 $y1) cell $cell"; fail=1; }
  grep -qx "Size is $cols, $rows" <<<"$info" || { echo "FAIL $name: $(grep '^Size' <<<"$info"), meta $cols x $rows"; fail=1; }
  grep -qx "  NoData Value=nan" <<<"$info" || { echo "FAIL $name: nodata is not NaN"; fail=1; }
  grep -q 'ENGCRS\["ambler world frame' <<<"$info" || { echo "FAIL $name: not in the local ambler frame"; fail=1; }
  grep -q "Type=Float32" <<<"$info" || { echo "FAIL $name: not Float32"; fail=1; }
done
for must in maps/view_0_elevation.tiff maps/view_0_sigma.tiff footfall/max_min_score.tiff leg/predicted_tilt.tiff; do
  [[ -e $tmp/run/$must ]] || { echo "FAIL: the run wrote no $must"; fail=1; }
done
((n >= 4)) || { echo "FAIL: only $n GeoTIFFs checked"; fail=1; }
((fail)) || echo "ok: $n GeoTIFFs, gdalinfo shows each one's geotransform as its meta.json"
exit $fail
