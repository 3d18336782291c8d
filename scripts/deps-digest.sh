#!/usr/bin/env bash
# Prints a digest of what a fresh machine's build depends on: scripts/setup.sh (the packages),
# scripts/build.sh, every find_package / pkg_check_modules / find_library / find_path line of the
# CMake files (which packages the build looks for) and the README's quick-start command lines.
# When it equals .ci/fresh-checked, scripts/fresh-check.sh has passed with these dependencies, and
# CI skips the fresh-root check: a new source file or test changes none of this, a new package does.
set -euo pipefail
cd "$(dirname "$0")/.."
{
  cat scripts/setup.sh scripts/build.sh
  git ls-files '*CMakeLists.txt' '*.cmake' | sort | while read -r f; do
    grep -E '^\s*(find_package|pkg_check_modules|find_library|find_path)\(' "$f" | sed "s|^|$f: |" || true
  done
  grep -E '^    bash ' README.md
} | sha256sum | cut -d' ' -f1
