#!/usr/bin/env bash
# cli_smoke.sh: the `stepchoir` command against the real firmware on the virtual board:
# hello prints the board's capabilities, tone plays the asked frequency, status and panic answer,
# driver puts a driver to sleep and resets it through the pins a configuration file names,
# config --check names a bad file's first mistake by line and column (without a file: the one
# commands read).
# Usage: cli_smoke.sh BIN_DIR SCRATCH_DIR
set -euo pipefail
bin=$1
dir=$2
mkdir -p "$dir"
link="$dir/board.pty"
trace="$dir/cli.csv"
rm -f "$link" "$trace"

"$bin/stepchoir-vboard" --board uno --link "$link" --trace "$trace" --quiet --sleep-pin 0=14 --reset-pin 0=15 \
  > "$dir/vboard.out" &
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

if "$bin/stepchoir" driver --port "$link" --motor 0 sleep 2>"$dir/err.txt"; then
  echo "driver sleep without a SLEEP pin should fail"; exit 1
fi
grep -q "refused sleep: config (no SLEEP or RESET pin" "$dir/err.txt"
printf '[[boards]]\nport = "%s"\n[[boards.motors]]\nsleep_pin = 14\nreset_pin = 15\n' "$link" > "$dir/rig.toml"
"$bin/stepchoir" driver --port "$link" --config "$dir/rig.toml" --motor 0 sleep | grep -q "motor 0's driver asleep"
"$bin/stepchoir" driver --port "$link" --config "$dir/rig.toml" --motor 0 reset | grep -q "motor 0's driver reset"

# config --check: the file above is good; a wrong value and a broken string each name their
# line and column.
"$bin/stepchoir" config --check "$dir/rig.toml" | grep -q "rig.toml: ok (1 boards)"
printf '[[boards]]\nport = "x"\n[[boards.motors]]\ndriver = "tb6601"\n' > "$dir/bad.toml"
if "$bin/stepchoir" config --check "$dir/bad.toml" 2>"$dir/err.txt"; then
  echo "config --check of a wrong driver should fail"; exit 1
fi
grep -q "bad.toml:4:10: driver 'tb6601': expected a4988, drv8825 or tb6600" "$dir/err.txt"
printf '[[boards]]\nport = "x\n' > "$dir/bad.toml"
if "$bin/stepchoir" config --check "$dir/bad.toml" 2>"$dir/err.txt"; then
  echo "config --check of a broken string should fail"; exit 1
fi
grep -q "bad.toml:2:10: " "$dir/err.txt"
# A file of virtual boards only: a one-board command says it needs a port.
printf '[[boards]]\nboard = "mega"\n' > "$dir/virtual.toml"
if "$bin/stepchoir" hello --config "$dir/virtual.toml" 2>"$dir/err.txt"; then
  echo "hello with no port anywhere should fail"; exit 1
fi
grep -q "virtual.toml names no board port (its boards are virtual: live, play, jam and render start them" "$dir/err.txt"
# Without a file it checks the one commands read: the default location, or says there is none.
mkdir -p "$dir/xdg/stepchoir"
cp "$dir/rig.toml" "$dir/xdg/stepchoir/stepchoir.toml"
XDG_CONFIG_HOME="$dir/xdg" "$bin/stepchoir" config --check | grep -q "xdg/stepchoir/stepchoir.toml: ok (1 boards)"
if XDG_CONFIG_HOME="$dir/no-xdg" "$bin/stepchoir" config --check 2>"$dir/err.txt"; then
  echo "config --check without a file anywhere should fail"; exit 1
fi
grep -q "no file given, and none at $dir/no-xdg/stepchoir/stepchoir.toml" "$dir/err.txt"

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
levels = lambda kind: [(int(l.split(',')[2]), int(l.split(',')[3])) for l in open(sys.argv[1]) if l.startswith(kind + ',0,')]
sleeps, resets = levels('sleep'), levels('reset')
assert [v for _, v in sleeps] == [0, 1], f"SLEEP of motor 0: {sleeps} (asleep, then awake again when reconfigured)"
assert [v for _, v in resets] == [0, 1] and resets[1][0] - resets[0][0] >= 160, f"RESET of motor 0: {resets}"
print(f"cli: SLEEP low and high again, RESET low for {(resets[1][0] - resets[0][0]) / 16:.1f} us")
PY
echo "cli smoke: passed"
