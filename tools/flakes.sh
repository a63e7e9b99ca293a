#!/usr/bin/env bash
# flakes.sh [RUNS] [OUT]: runs every end-to-end test (ctest label e2e) RUNS times (default 20)
# on the build in build/ (or $STEPCHOIR_BUILD), one whole pass of the suite at a time, and writes the failures per
# test to OUT (default bench/results/flakes.md) after every pass (tools/flakes_report.py), with
# the `pacing` label of each and how often the virtual board said the machine stalled it in a
# failed run. The whole log of a pass with a failure is kept as BUILD/flake-logs/pass-N.log
# (ctest --output-on-failure: the failed test's output and the virtual board's stderr). Nothing
# else should run on the machine meanwhile: the `pacing` tests judge timing in real time. About
# 12 minutes a pass on a 2-core machine.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-20}
out=${2:-bench/results/flakes.md}
build=${STEPCHOIR_BUILD:-build}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
start=$(date -u '+%Y-%m-%d %H:%M UTC')
(cd "$build" && ctest -N -L pacing | sed -n 's/^ *Test *#[0-9]*: //p') > "$tmp/pacing.txt"
(cd "$build" && ctest -N -L e2e | sed -n 's/^ *Test *#[0-9]*: //p') > "$tmp/all.txt"
rm -rf "$build/flake-logs"  # a log left by an earlier invocation would be taken for this one's
: > "$tmp/results.txt"
: > "$tmp/stalls.txt"
for i in $(seq 1 "$runs"); do
  (cd "$build" && ctest -L e2e --output-on-failure > "$tmp/run-$i.log" 2>&1) || true
  # "N/M Test #K: NAME .....   Passed    1.23 sec" or "***Failed"
  sed -n 's/^ *[0-9]*\/[0-9]* Test *#[0-9]*: \(.*[^ .]\) *\.\.*[ *]*\(Passed\|Failed\|Timeout\|Exception\).*/\2 \1/p' \
    "$tmp/run-$i.log" >> "$tmp/results.txt"
  grep -c "the machine stalled the simulation" "$tmp/run-$i.log" >> "$tmp/stalls.txt" || true
  if grep -q "tests failed out of" "$tmp/run-$i.log" && ! grep -q " 0 tests failed out of" "$tmp/run-$i.log"; then
    mkdir -p "$build/flake-logs"
    cp "$tmp/run-$i.log" "$build/flake-logs/pass-$i.log"
  fi
  python3 tools/flakes_report.py "$tmp" "$i" "$runs" "$out" "$start"
done
