#!/usr/bin/env bash
# run-demo.sh: installs, builds, then plays a scale through the host and the real firmware on
# the virtual board (an emulated Arduino Uno + CNC Shield), and leaves what the motors played
# as build/demo/demo.wav (listen) and build/demo/demo.png (a piano roll).
set -euo pipefail
cd "$(dirname "$0")/.."

tools/deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSTEPCHOIR_FIRMWARE=ON >/dev/null
cmake --build build -j"$(nproc)"

out=build/demo
mkdir -p "$out"
link="$out/board.pty"
board=${STEPCHOIR_DEMO_BOARD:-uno}

echo "demo: starting the virtual board ($board) with build/firmware/stepchoir-$board.elf"
build/bin/stepchoir-vboard --board "$board" --link "$link" --trace "$out/demo.csv" --quiet > "$out/vboard.out" &
vboard=$!
trap 'kill $vboard 2>/dev/null || true' EXIT
for _ in $(seq 100); do [ -e "$link" ] && break; sleep 0.05; done

build/bin/stepchoir hello --port "$link"

# C major scale up and down, one note per motor in turn (MIDI 60..72, A4 = 440 Hz).
notes=(60 62 64 65 67 69 71 72 71 69 67 65 64 62 60)
motors=$(build/bin/stepchoir hello --port "$link" | awk '/^motors:/ {print $2}')
i=0
for n in "${notes[@]}"; do
  hz=$(python3 -c "print(440 * 2 ** (($n - 69) / 12))")
  printf 'demo: motor %d plays MIDI %d (%.2f Hz)\n' $((i % motors)) "$n" "$hz"
  build/bin/stepchoir tone --port "$link" --motor $((i % motors)) --hz "$hz" --seconds 0.35
  i=$((i + 1))
done
build/bin/stepchoir status --port "$link"

kill -TERM $vboard
wait $vboard || true
trap - EXIT
build/bin/stepchoir-render "$out/demo.csv" -o "$out/demo.wav" --png "$out/demo.png"
echo "demo: wrote $out/demo.wav and $out/demo.png (trace: $out/demo.csv)"
