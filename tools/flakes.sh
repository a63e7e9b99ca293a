#!/usr/bin/env bash
# flakes.sh [RUNS] [OUT]: runs every end-to-end test (ctest label e2e) RUNS times (default 20)
# on the build in build/, one whole pass of the suite at a time, and writes the failures per
# test to OUT (default bench/results/flakes.md), with the `pacing` label of each and how often
# the virtual board said the machine stalled it in a failed run. Nothing else should run on
# the machine meanwhile: the `pacing` tests judge timing in real time. About 3.5 minutes a run
# on a 2-core machine.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-20}
out=${2:-bench/results/flakes.md}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
start=$(date -u '+%Y-%m-%d %H:%M UTC')
(cd build && ctest -N -L pacing | sed -n 's/^ *Test *#[0-9]*: //p') > "$tmp/pacing.txt"
(cd build && ctest -N -L e2e | sed -n 's/^ *Test *#[0-9]*: //p') > "$tmp/all.txt"
for i in $(seq 1 "$runs"); do
  (cd build && ctest -L e2e --output-on-failure > "$tmp/run-$i.log" 2>&1) || true
  # "N/M Test #K: NAME .....   Passed    1.23 sec" or "***Failed"
  sed -n 's/^ *[0-9]*\/[0-9]* Test *#[0-9]*: \(.*[^ .]\) *\.\.*[ *]*\(Passed\|Failed\|Timeout\|Exception\).*/\2 \1/p' \
    "$tmp/run-$i.log" >> "$tmp/results.txt"
  grep -c "the machine stalled the simulation" "$tmp/run-$i.log" >> "$tmp/stalls.txt" || true
  echo "flakes: run $i of $runs: $(grep -cv '^Passed' "$tmp/results.txt" || true) failures so far"
done
python3 - "$tmp" "$runs" "$out" "$start" <<'PY'
import collections, sys, pathlib
tmp, runs, out, start = pathlib.Path(sys.argv[1]), int(sys.argv[2]), sys.argv[3], sys.argv[4]
pacing = set(pathlib.Path(tmp, "pacing.txt").read_text().split("\n")) - {""}
names = [n for n in pathlib.Path(tmp, "all.txt").read_text().split("\n") if n]
seen, failed = collections.Counter(), collections.Counter()
for line in pathlib.Path(tmp, "results.txt").read_text().split("\n"):
    if not line:
        continue
    verdict, name = line.split(" ", 1)
    seen[name] += 1
    if verdict != "Passed":
        failed[name] += 1
stalls = sum(int(x) for x in pathlib.Path(tmp, "stalls.txt").read_text().split() if x.strip())
bad_plain = [n for n in names if n not in pacing and failed[n] > 0]
bad_pacing = [n for n in names if n in pacing and failed[n] > 1]
with open(out, "w") as f:
    f.write("# End-to-end tests: failures in repeated runs\n\n")
    f.write(f"Command: `tools/flakes.sh {runs}` (each run: `ctest -L e2e` in build/, the machine otherwise idle).\n\n")
    f.write(f"Started {start}; {len(names)} tests, {runs} runs each.\n\n")
    f.write("Target: 0 failures for a test without the `pacing` label, at most 1 for a test with it. ")
    f.write(f"Tests over it: {len(bad_plain) + len(bad_pacing)}. ")
    f.write(f"Runs in which the virtual board said the machine stalled it: {stalls} (counted in failed tests' output only).\n\n")
    f.write("| test | pacing | runs | failed |\n|---|---|---|---|\n")
    for n in sorted(names, key=lambda n: (-failed[n], n)):
        f.write(f"| {n} | {'yes' if n in pacing else ''} | {seen[n]} | {failed[n]} |\n")
print(f"flakes: wrote {out}: {len(bad_plain) + len(bad_pacing)} tests over target")
PY
