#!/usr/bin/env bash
# cli_smoke.sh: the `stepchoir` command against the real firmware on the virtual board:
# hello prints the board's capabilities, tone plays the asked frequency, status and panic answer.
# Usage: cli_smoke.sh BIN_DIR SCRATCH_DIR
set -euo pipefail
bin=$1
dir=$2
mkdir -p "$dir"
link="$dir/board.pty"
trace="$dir/cli.csv"
rm -f "$link" "$trace"

"$bin/stepchoir-vboard" --board uno --link "$link" --trace "$trace" --quiet > "$dir/vboard.out" &
vboard=$!
trap 'kill $vboard 2>/dev/null || true' EXIT
for _ in $(seq 100); do [ -e "$link" ] && break; sleep 0.05; done

out=$("$bin/stepchoir" hello --port "$link")
echo "$out"
grep -q "^board: uno_cnc_shield_v3$" <<<"$out"
grep -q "^motors: 4$" <<<"$out"
grep -q "^motor 3 endstops: none" <<<"$out"

"$bin/stepchoir" tone --port "$link" --motor 2 --hz 440 --seconds 0.5
status=$("$bin/stepchoir" status --port "$link")
grep -q "^frames_bad: 0$" <<<"$status"
"$bin/stepchoir" tone --port "$link" --motor 1 --hz 300 --seconds 5 & tone=$!
sleep 2.5  # its open reset the board (DTR): the bootloader holds it 1.4 s, then the tone plays
"$bin/stepchoir" panic --port "$link" | grep -q "every motor silent, drivers off"
kill $tone 2>/dev/null || true
wait $tone 2>/dev/null || true
if "$bin/stepchoir" tone --port "$link" --motor 9 --hz 440 --seconds 0.1 2>"$dir/err.txt"; then
  echo "tone on motor 9 should fail"; exit 1
fi
grep -q "motors 0-3" "$dir/err.txt"

kill -TERM $vboard
wait $vboard
trap - EXIT
# motor 2 played 440 Hz for about half a second: check count and mean interval from the trace
python3 - "$trace" <<'PY'
import sys
rows = [l.split(',') for l in open(sys.argv[1]) if l.startswith('step,2,')]
cycles = [int(r[2]) for r in rows]
assert 180 <= len(cycles) <= 260, f"{len(cycles)} steps for 0.5 s at 440 Hz"
mean = (cycles[-1] - cycles[0]) / (len(cycles) - 1)
hz = 16e6 / mean
assert abs(hz - 440) < 0.01, f"measured {hz} Hz"
others = [l for l in open(sys.argv[1]) if l.startswith(('step,0,', 'step,3,'))]
assert not others, "a motor nobody asked for stepped"
m1 = [l for l in open(sys.argv[1]) if l.startswith('step,1,')]
assert 100 < len(m1) < 300 * 2.5, f"motor 1 made {len(m1)} steps: panic did not stop its 5 s tone"
print(f"cli: {len(cycles)} steps at {hz:.4f} Hz")
PY
echo "cli smoke: passed"
