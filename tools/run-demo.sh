#!/usr/bin/env bash
# run-demo.sh: installs, builds, then plays a song (Für Elise, or STEPCHOIR_DEMO_SONG) through
# the host's player and the real firmware on the virtual board (an emulated Arduino Uno + CNC
# Shield, or STEPCHOIR_DEMO_BOARD=mega), and leaves what the motors played as
# build/demo/demo.wav (listen) and build/demo/demo.png (a piano roll).
set -euo pipefail
cd "$(dirname "$0")/.."

tools/deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSTEPCHOIR_FIRMWARE=ON >/dev/null
cmake --build build -j"$(nproc)"

out=build/demo
mkdir -p "$out"
board=${STEPCHOIR_DEMO_BOARD:-uno}
song=${STEPCHOIR_DEMO_SONG:-tests/data/songs/furelise.sng}

# The song goes through the host's player (clock sync, timestamped frames into the board's
# queue) to the real firmware ELF on the virtual board, simulated as fast as it runs; the
# virtual board records every step, and the steps become the WAV and the picture.
echo "demo: playing $song on the virtual board ($board, build/firmware/stepchoir-$board.elf)"
build/bin/stepchoir render "$song" --vboard "$board" -o "$out/demo.wav" --png "$out/demo.png" --trace "$out/demo.csv"
echo "demo: wrote $out/demo.wav and $out/demo.png (trace: $out/demo.csv)"
