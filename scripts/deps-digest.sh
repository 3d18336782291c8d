#!/usr/bin/env bash
# Prints a digest of everything a fresh machine's build depends on: scripts/setup.sh,
# scripts/build.sh, every CMakeLists.txt and the README (its quick-start commands). When it equals
# the one in .ci/fresh-checked, scripts/fresh-check.sh has passed on these files.
set -euo pipefail
cd "$(dirname "$0")/.."
{ echo scripts/setup.sh; echo scripts/build.sh; echo README.md; git ls-files '*CMakeLists.txt'; } | sort -u |
  while read -r f; do printf '%s ' "$f"; sha256sum <"$f"; done | sha256sum | cut -d' ' -f1
