#!/usr/bin/env bash
# run-song-bench.sh: builds stepchoir-bench-song and writes bench/results/song-parse.md (time and
# peak memory to read a 1 MB MIDI file; time to make the sample songs' G-code).
set -euo pipefail
cd "$(dirname "$0")/../.."
cmake -S . -B build >/dev/null
nice cmake --build build -j2 --target stepchoir-bench-song >/dev/null
build/bin/stepchoir-bench-song bench/results tests/data/songs
