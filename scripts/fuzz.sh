#!/usr/bin/env bash
# Runs the libFuzzer targets (tests/fuzz/, docs/fuzzing.md) one after the other.
#   bash scripts/fuzz.sh                      # every target, 60 s each
#   FUZZ_SECONDS=20 bash scripts/fuzz.sh      # CI: a short run of each
#   FUZZ_SECONDS=600 bash scripts/fuzz.sh scenario sweep   # some targets, 10 minutes each
# Configures ./build-fuzz with clang++ (-DAMBLER_FUZZ=ON: ASan + UBSan + libFuzzer) and builds only
# the fuzz targets. Each target runs on a copy of its seed corpus tests/fuzz/corpus/<target>/ in a
# temporary directory (the repository is never written), with -timeout=10 -rss_limit_mb=4096
# -detect_leaks=1. Inputs that fail are saved as build-fuzz/findings/<target>/{crash,leak,timeout,
# oom}-<sha1>; each target's log is build-fuzz/findings/<target>.log. Prints per target the
# executions per second, executions, corpus size and findings, and exits non-zero on any finding.
set -euo pipefail
cd "$(dirname "$0")/.."

seconds=${FUZZ_SECONDS:-60}
all=(scenario sweep results_csv scan_meta range_tiff journal)
targets=("$@")
((${#targets[@]})) || targets=("${all[@]}")

command -v clang++ >/dev/null || { echo "fuzz: clang++ not found (bash scripts/setup.sh installs clang)" >&2; exit 2; }
cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g" \
  -DCMAKE_CXX_COMPILER=clang++ -DAMBLER_FUZZ=ON >/dev/null
cmake --build build-fuzz --parallel 2 --target "${targets[@]/#/fuzz_}"

findings_dir=$PWD/build-fuzz/findings
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
status=0
summary=()
for t in "${targets[@]}"; do
  work=$(mktemp -d "${TMPDIR:-/tmp}/ambler-fuzz-$t.XXXXXX")
  cp -r "tests/fuzz/corpus/$t" "$work/corpus"
  mkdir -p "$findings_dir/$t"
  log=$findings_dir/$t.log
  dict=()
  [[ -f tests/fuzz/$t.dict ]] && dict=(-dict="tests/fuzz/$t.dict")
  echo "fuzz: $t for $seconds s (log $log)"
  rc=0
  (cd "$work" && "$OLDPWD/build-fuzz/tests/fuzz/fuzz_$t" "${dict[@]}" -max_total_time="$seconds" -timeout=10 \
     -rss_limit_mb=4096 -detect_leaks=1 -print_final_stats=1 -artifact_prefix="$findings_dir/$t/" corpus) \
    >"$log" 2>&1 || rc=$?
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  files=$(find "$work/corpus" -type f | wc -l)
  bytes=$(du -sb "$work/corpus" | cut -f1)
  found=$(find "$findings_dir/$t" -type f -newer "$work/corpus" | wc -l)
  if ((rc != 0)); then
    status=1
    echo "fuzz: $t FAILED (exit $rc); the input is in $findings_dir/$t/, the report in $log:" >&2
    grep -E "ERROR|FINDING|SUMMARY|Test unit written" "$log" | head -5 >&2 || true
  fi
  summary+=("$(printf '%-12s %6s s %10s exec/s %12s execs %5s files %9s B  %s' "$t" "$seconds" "${rate:-?}" \
    "${execs:-?}" "$files" "$bytes" "$( ((rc == 0)) && echo "no findings" || echo "FINDING ($found saved, exit $rc)")")")
  rm -rf "$work"
done
printf '%s\n' "fuzz: summary" "${summary[@]}"
exit $status
