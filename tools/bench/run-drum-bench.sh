#!/usr/bin/env bash
# run-drum-bench.sh: renders tests/data/songs/drum-kit.mid with --drums 0 through the real
# firmware on the virtual board and writes bench/results/drums.md: each General MIDI kind's burst
# as planned and as heard in the WAV.
set -euo pipefail
cd "$(dirname "$0")/../.."
tools/deps.sh
cmake -S . -B build >/dev/null
nice cmake --build build -j2 --target stepchoir stepchoir-vboard firmware_avr stepchoir-bench-drums >/dev/null
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
song=tests/data/songs/drum-kit.mid
XDG_CONFIG_HOME="$work" build/bin/stepchoir render "$song" --drums 0 -o "$work/kit.wav" --trace "$work/kit.csv" >/dev/null
build/bin/stepchoir-bench-drums bench/results/drums.md "tools/bench/run-drum-bench.sh" "$song" "$work/kit.csv" "$work/kit.wav"
