#!/usr/bin/env bash
# run-song-bench.sh: builds stepchoir-bench-song and stepchoir-bench-gcode and writes
# bench/results/song-parse.md (time and peak memory to read a 1 MB MIDI file; time to make the
# sample songs' G-code) and bench/results/gcode.md (note time in tune on the firmware motion model).
set -euo pipefail
cd "$(dirname "$0")/../.."
cmake -S . -B build >/dev/null
nice cmake --build build -j2 --target stepchoir-bench-song stepchoir-bench-gcode >/dev/null
build/bin/stepchoir-bench-song bench/results tests/data/songs
build/bin/stepchoir-bench-gcode bench/results tests/data/songs
