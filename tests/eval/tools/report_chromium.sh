#!/usr/bin/env bash
# `ambler report` as a person sees it (docs/report.md, "Tests"): headless Chromium opens the
# reports of the demo run, of a small sweep and of a small basin with every host name mapped to
# nowhere (anything the page fetched would fail) and checks that every image loaded (complete,
# naturalWidth > 0), that the demo's page has one image per PNG of its run directory, that the
# console stayed silent, and that a screenshot renders. A page with a broken image must be seen as
# broken (the check can fail). Exit 77 (ctest: skipped) when chromium is not installed.
#   report_chromium.sh AMBLER SOURCE_DIR
set -u
ambler=$(realpath "$1")
src=$(realpath "$2")
if ! command -v chromium >/dev/null 2>&1; then
  echo "skip: chromium is not installed (scripts/setup.sh installs it)"
  exit 77
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0

browse() {  # output flag, page: chromium headless, offline, its log on $tmp/chromium.err
  timeout 120 chromium --headless --no-sandbox --disable-gpu --enable-logging=stderr --v=0 \
    --user-data-dir="$tmp/profile" --host-resolver-rules="MAP * ~NOTFOUND" --virtual-time-budget=10000 \
    --window-size=1200,2000 --hide-scrollbars "$1" "file://$2" 2>"$tmp/chromium.err"
}

# The report with a checker appended: on load it counts the images that did not decode and writes
# both counts into attributes of <body>, which --dump-dom prints.
checked_copy() {  # report.html, copy.html
  sed 's|</body>|<script>addEventListener("load",function(){var n=0,im=document.images;for(var i=0;i<im.length;i++)if(!(im[i].complete\&\&im[i].naturalWidth>0))n++;document.body.setAttribute("data-images",im.length);document.body.setAttribute("data-broken",n);});</script></body>|' "$1" >"$2"
}

# name, report.html, expected number of images (or "any"): loads, screenshot, console.
check_page() {
  local name=$1 html=$2 want=$3 bad=0
  checked_copy "$html" "$tmp/$name.check.html"
  browse --dump-dom "$tmp/$name.check.html" >"$tmp/$name.dom"
  local images broken
  images=$(grep -o 'data-images="[0-9]*"' "$tmp/$name.dom" | grep -o '[0-9]\+')
  broken=$(grep -o 'data-broken="[0-9]*"' "$tmp/$name.dom" | grep -o '[0-9]\+')
  if [[ -z $images || -z $broken ]]; then
    echo "FAIL $name: the checker did not run (no data-images in the DOM)"; head -5 "$tmp/chromium.err"; fail=1; return
  fi
  if [[ $broken != 0 ]]; then echo "FAIL $name: $broken of $images images did not load"; bad=1; fi
  if [[ $want != any && $images != "$want" ]]; then echo "FAIL $name: $images images, expected $want"; bad=1; fi
  if [[ $images == 0 ]]; then echo "FAIL $name: no images"; bad=1; fi
  if grep -q 'CONSOLE' "$tmp/chromium.err"; then
    echo "FAIL $name: console messages:"; grep 'CONSOLE' "$tmp/chromium.err" | head -5; bad=1
  fi
  browse --screenshot="$tmp/$name.png" "$html" >/dev/null
  local size
  size=$(stat -c %s "$tmp/$name.png" 2>/dev/null || echo 0)
  if [[ $size -lt 20000 || $(head -c 8 "$tmp/$name.png" | od -An -tx1 | tr -d ' ') != 89504e470d0a1a0a ]]; then
    echo "FAIL $name: screenshot missing or near-empty ($size bytes)"; bad=1
  fi
  [[ $bad == 1 ]] && fail=1
  [[ $bad == 0 ]] && echo "ok   $name: $images images loaded, 0 broken, no console message, screenshot $size bytes"
}

# The control: a page with one good and one broken image (bytes that are not a PNG), one from the
# network and a console.error must count two broken and log the message.
good=$(base64 -w0 <"$src/docs/experiments/basin/rocks_boundary.png")
printf '<!DOCTYPE html><html><body><img src="data:image/png;base64,%s"><img src="data:image/png;base64,AAAA"><img src="http://example.com/x.png"><script>console.error("control")</script></body></html>\n' \
  "$good" >"$tmp/control.html"
checked_copy "$tmp/control.html" "$tmp/control.check.html"
browse --dump-dom "$tmp/control.check.html" >"$tmp/control.dom"
if grep -q 'data-broken="2"' "$tmp/control.dom" && grep -q 'data-images="3"' "$tmp/control.dom" &&
  grep -q 'CONSOLE.*control' "$tmp/chromium.err"; then
  echo "ok   control: a broken and an offline image are seen as broken, a console message is seen"
else
  echo "FAIL control: expected 2 broken of 3 images and a console message; got $(grep -o 'data-[a-z]*="[0-9]*"' "$tmp/control.dom" | tr '\n' ' ')$(grep -c CONSOLE "$tmp/chromium.err") console lines"
  fail=1
fi

# The demo run.
if ! "$ambler" run "$src/scenarios/demo.yaml" --out "$tmp/demo" >"$tmp/run.log" 2>&1; then
  echo "FAIL demo: ambler run failed"; tail -3 "$tmp/run.log"; exit 1
fi
"$ambler" report "$tmp/demo" || { echo "FAIL demo: ambler report failed"; exit 1; }
check_page demo "$tmp/demo/report.html" "$(find "$tmp/demo" -name '*.png' | wc -l)"

# A sweep (6 small runs, every run kept) and a basin (2 methods, 2 x 2 cells, 2 trials).
if "$ambler" sweep "$src/tests/cluster/sweep.yaml" --out "$tmp/sweep" --keep all --quiet >"$tmp/sweep.log" 2>&1 &&
  "$ambler" report "$tmp/sweep"; then
  check_page sweep "$tmp/sweep/report.html" any
  if ! grep -q 'href="runs/[0-9]*/"' "$tmp/sweep/report.html"; then echo "FAIL sweep: no link to a run directory"; fail=1; fi
else
  echo "FAIL sweep: ambler sweep or report failed"; tail -3 "$tmp/sweep.log"; fail=1
fi
if "$ambler" basin "$src/tests/cluster/basin.yaml" --out "$tmp/basin" --translation-m 0,0.5 --rotation-deg 0,5 \
  --trials 2 --quiet >"$tmp/basin.log" 2>&1 && "$ambler" report "$tmp/basin"; then
  check_page basin "$tmp/basin/report.html" "$(find "$tmp/basin" -name '*.png' | wc -l)"
else
  echo "FAIL basin: ambler basin or report failed"; tail -3 "$tmp/basin.log"; fail=1
fi
exit $fail
