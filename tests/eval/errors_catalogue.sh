#!/usr/bin/env bash
# docs/errors.md cannot drift from the program: every row of the catalogue cites a test that
# exists, every example message cited from cli_errors.sh is exactly what the program prints in that
# case, every case of cli_errors.sh is in the catalogue, and there are at least 30 classes.
#
# Row format: | N | class | `message, after "ambler: error: "` | tests |, where tests cites
# cli_errors.sh:CASE and/or test_FILE.cpp:Suite.Name (a TEST in tests/). A row without a test must
# say "placeholder" (classes another change fills in).
set -u
ambler=$1
root=$2
doc=$root/docs/errors.md
log=$(mktemp)
trap 'rm -f "$log"' EXIT
fail=0

if ! bash "$root/tests/eval/cli_errors.sh" "$ambler" >"$log" 2>&1; then
  echo "FAIL: cli_errors.sh fails:"; grep -v '^ok ' "$log"; exit 1
fi
declare -A printed skipped
while IFS= read -r line; do
  if [[ $line =~ ^skip\ ([a-z0-9_, ]+): ]]; then  # a case this machine cannot run (a mount, as root)
    for name in ${BASH_REMATCH[1]//,/ }; do skipped[$name]=1; done
  fi
  [[ $line =~ ^ok\ +([a-z0-9_]+):\ ambler:\ error:\ (.*)$ ]] || continue
  printed[${BASH_REMATCH[1]}]=${BASH_REMATCH[2]}
done <"$log"

declare -A cited
rows=0
while IFS= read -r line; do
  [[ $line =~ ^\|\ *[0-9]+\ *\| ]] || continue
  rows=$((rows + 1))
  # Cells: | N | class | `message` | tests |
  IFS='|' read -r _ number class message tests _ <<<"$line"
  number=${number// /}
  message=$(sed -E 's/^ *`(.*)` *$/\1/' <<<"$message")
  found=0
  for ref in $(grep -oE '[A-Za-z0-9_]+\.(sh|cpp):[A-Za-z0-9_.]+' <<<"$tests"); do
    found=1
    file=${ref%%:*} name=${ref#*:}
    if [[ $file == cli_errors.sh ]]; then
      cited[$name]=1
      if [[ -n ${skipped[$name]+x} ]]; then
        echo "warning row $number: cli_errors.sh skipped $name here; its message is not checked"
      elif [[ -z ${printed[$name]+x} ]]; then
        echo "FAIL row $number: cli_errors.sh has no passing case $name"; fail=1
      elif [[ ${printed[$name]} != "$message" ]]; then
        echo "FAIL row $number ($name): the catalogue says"
        echo "       $message"
        echo "     the program prints"
        echo "       ${printed[$name]}"
        fail=1
      fi
    else
      path=$(find "$root/tests" -name "$file" | head -1)
      suite=${name%%.*} test=${name#*.}
      if [[ -z $path ]]; then
        echo "FAIL row $number: no test file $file"; fail=1
      elif ! grep -qE "TEST(_F)?\($suite, *$test\)" "$path"; then
        echo "FAIL row $number: $file has no TEST($suite, $test)"; fail=1
      fi
    fi
  done
  if ((!found)) && [[ $tests != *placeholder* ]]; then
    echo "FAIL row $number ($class): cites no test"; fail=1
  fi
done <"$doc"

for name in "${!printed[@]}"; do
  [[ -n ${cited[$name]+x} ]] || { echo "FAIL: cli_errors.sh case $name is not in docs/errors.md"; fail=1; }
done
if ((rows < 30)); then echo "FAIL: $rows classes in docs/errors.md, expected at least 30"; fail=1; fi
if ((fail)); then exit 1; fi
echo "errors catalogue: $rows classes, ${#printed[@]} messages checked against the program"
