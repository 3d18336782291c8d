#!/usr/bin/env bash
# Runs the README's two quick-start commands in a brand-new Debian 12 root (debootstrap
# minbase: nothing installed), as a newcomer's machine would be, and prints how long each took.
# Run it before any change to scripts/setup.sh, CMakeLists.txt's find_package calls or the
# README's commands: the development machines carry packages a newcomer's lacks, so a green
# build here proves nothing about theirs. Needs root, debootstrap and ../shared/tools.
# On success it writes the dependencies' digest (scripts/deps-digest.sh) to .ci/fresh-checked:
# commit it, and CI skips this check until the dependencies change again.
#   usage (from anywhere in the repository): bash scripts/fresh-check.sh
set -euo pipefail
cd "$(dirname "$0")/.."
fresh=../shared/tools/fresh-debian.sh
[[ -x $fresh || -f $fresh ]] || { echo "fresh-check: $fresh not found (needs ../shared beside the repository)"; exit 2; }
command -v debootstrap >/dev/null || { echo "fresh-check: needs debootstrap (apt-get install debootstrap)"; exit 2; }
# Both commands in one root, in the README's order: the second one's setup finds everything
# installed and its build is incremental, as it would be for a newcomer typing both.
demo='bash scripts/setup.sh && bash scripts/build.sh && build/ambler run scenarios/demo.yaml --out runs/demo'
tests='bash scripts/setup.sh && bash scripts/build.sh && ctest --test-dir build --output-on-failure -j2'
bash "$fresh" "
  set -e
  t0=\$(date +%s)
  ( $demo )
  test -s runs/demo/metrics.json
  t1=\$(date +%s)
  ( $tests ) > /tmp/ctest.log 2>&1 || { tail -n 60 /tmp/ctest.log; exit 1; }
  grep -E 'tests passed|tests failed' /tmp/ctest.log
  t2=\$(date +%s)
  echo \"fresh-check: demo command \$((t1 - t0)) s, test command \$((t2 - t1)) s (fresh Debian 12 minbase)\"
"
bash scripts/deps-digest.sh >.ci/fresh-checked
echo "fresh-check: passed; .ci/fresh-checked updated (commit it)"
