#!/usr/bin/env bash
# run-bench.sh: builds stepchoir-bench-pitch (firmware and virtual board too) and runs the pitch benchmark on uno and mega.
# Usage: tools/bench/run-bench.sh [--out DIR] [--round-seconds S] [--notes LIST]  (options go to stepchoir-bench-pitch)
set -euo pipefail
cd "$(dirname "$0")/../.."

out_dir=bench/results
args=("$@")
for ((i = 0; i < ${#args[@]}; ++i)); do
  if [[ ${args[i]} == --out ]]; then out_dir=${args[i + 1]:-}; fi
done
has_out=0
for a in "$@"; do [[ $a == --out ]] && has_out=1; done
((has_out)) || args+=(--out "$out_dir")

cmake -S . -B build -DSTEPCHOIR_FIRMWARE=ON >/dev/null
cmake --build build -j"$(nproc)" --target stepchoir-bench-pitch

failed=()
written=()
for board in uno mega; do
  echo "== $board"
  if build/bin/stepchoir-bench-pitch --board "$board" "${args[@]}"; then
    written+=("$out_dir/pitch-$board.md")
  else
    failed+=("$board")
  fi
done

echo
for path in "${written[@]}"; do echo "results: $path"; done
echo "traces: build/bench/pitch-<board>-<light|flood>.csv"
if ((${#failed[@]})); then
  echo "run-bench.sh: failed on: ${failed[*]}" >&2
  exit 1
fi
