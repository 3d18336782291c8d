# Helpers of the cluster tests (slurm.sh, parallel.sh); sourced.

# check_doc_shows DOC FILE: DOC shows FILE verbatim as one of its fenced code blocks, so the file
# the test runs is the one the reader sees.
check_doc_shows() {
  local doc=$1 file=$2 blocks
  blocks=$(mktemp -d)
  awk -v dir="$blocks" '
    /^```/ { if (inside) { inside = 0; close(out) } else { inside = 1; n++; out = dir "/" n; printf "" > out } next }
    inside { print > out }
  ' "$doc"
  local b found=0
  for b in "$blocks"/*; do
    [[ -f $b ]] && cmp -s "$b" "$file" && found=1
  done
  rm -rf "$blocks"
  if ((found)); then
    echo "ok   ${doc##*/} shows ${file##*/} verbatim"
  else
    echo "FAIL ${doc##*/} has no code block equal to $file"
    return 1
  fi
}

# same_bytes NAME EXPECTED ACTUAL: the files are byte-identical (and not empty).
same_bytes() {
  local name=$1 expected=$2 actual=$3
  if [[ ! -s $expected || ! -s $actual ]]; then
    echo "FAIL $name: $expected or $actual missing or empty"
    return 1
  fi
  if cmp "$expected" "$actual"; then
    echo "ok   $name: merged shards == one process ($(($(wc -l <"$actual") - 1)) rows, $(wc -c <"$actual") bytes)"
  else
    diff "$expected" "$actual" | head -n 10
    echo "FAIL $name: the merged shards differ from one process"
    return 1
  fi
}

# elapsed: seconds since $t0, for the progress lines.
elapsed() { awk -v a="$t0" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f s", b - a }'; }
