#!/usr/bin/env bash
# Installs every build and run dependency of ambler from Debian 12's archive.
# Idempotent: does nothing (and needs no network) when everything is already there.
set -euo pipefail
packages=(
  build-essential cmake ninja-build pkg-config
  libmujoco-dev libqhull-dev        # MuJoCo 2.2.2; its CMake config names libqhull_r
  libccd-dev                        # libccd, whose MPR MuJoCo runs: the leg's own heightfield collision calls it
  libgl-dev libglx-dev libopengl-dev  # MuJoCo's CMake config calls find_dependency(OpenGL)
  libembree-dev libtbb-dev          # ray casting, parallel loops
  libeigen3-dev libopencv-dev       # maths, images
  libyaml-cpp-dev libcli11-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev
  libopen3d-dev                     # the registration peers (eval/peers/ only)
  git jq                            # scripts/same-outputs.sh: revisions to compare, metrics.json
  clang libclang-rt-dev             # scripts/fuzz.sh: clang++ 14 and its libFuzzer/ASan/UBSan runtimes
  slurmctld slurmd slurm-client munge  # tests/cluster/slurm.sh: a one-node Slurm cluster (no daemon is started)
  parallel                          # tests/cluster/parallel.sh: GNU parallel
  libgdal-dev gdal-bin              # terrain.kind: dem (GeoTIFF in), GeoTIFF map rasters out, gdalinfo in tests
  gnuplot-nox fonts-dejavu-core     # the charts of figures and reports (eval/plot.cpp runs gnuplot)
  chromium                          # tests/eval/report_chromium.sh: the report as a browser renders it
  python3-dev pybind11-dev          # the Python module (python/, docs/python.md); optional to the build
  python3-numpy python3-pytest      # its arrays and its tests
  python3-open3d                    # examples/python/basin_open3d.py: Open3D-Python as a user's own method
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  sudo_cmd=""
  [[ $(id -u) -ne 0 ]] && sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  echo "setup: all dependencies present"
fi
