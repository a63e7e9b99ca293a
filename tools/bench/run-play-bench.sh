#!/usr/bin/env bash
# run-play-bench.sh: builds the player's benchmark and writes bench/results/play-onsets.md (each
# note of the sample songs against the file: onset, pitch in real time with the crystal off by
# +/-0.5 %, ends; and with the host stalled). About a minute and a half.
set -euo pipefail
cd "$(dirname "$0")/../.."
cmake -S . -B build >/dev/null
nice cmake --build build -j2 --target stepchoir-bench-play >/dev/null
build/bin/stepchoir-bench-play bench/results tests/data/songs
