#!/usr/bin/env bash
# run.sh: builds the selftest AVR program, runs it on stepchoir-vboard and checks echo and trace.
# usage: run.sh PATH/TO/stepchoir-vboard WORK_DIR
set -euo pipefail

vboard=$1
work=$2
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$work"
elf=$work/vboard-selftest.elf
trace=$work/selftest-trace.csv
out=$work/vboard.stdout
err=$work/vboard.stderr
travel=3200
start=1600

avr-gcc -mmcu=atmega328p -DF_CPU=16000000UL -Os -Wall -Wextra -o "$elf" "$here/selftest.c"

# 3 s of board time: with 1 s, a fresh-clone CI run's sanitizer pass (2 cores, tests in
# parallel) started the echo client after the board had finished and its pty was gone.
source "$here/board.sh"
start_board "$out" "$err" "$vboard" --board uno --elf "$elf" --seconds 3 --trace "$trace" \
  --travel-steps $travel --start-position $start --chatter-us 300 --link "$work/tty"
[ "$(readlink "$work/tty")" = "$board_pty" ] || { echo "--link not made"; exit 1; }

python3 "$here/echo_client.py" "$board_pty"

rc=0
wait "$board_pid" || rc=$?
trap - EXIT
[ $rc -eq 0 ] || { echo "vboard exited with $rc"; cat "$err"; exit 1; }
[ "$(wc -l <"$out")" -eq 1 ] || { echo "stdout has more than the pty line"; cat "$out"; exit 1; }
[ ! -e "$work/tty" ] || { echo "--link not removed"; exit 1; }
python3 "$here/check_trace.py" "$trace" $travel $start
grep -E 'irq_off|isr=|uart|end=' "$err" | sed 's/^stepchoir-vboard: /  /'
echo "vboard selftest passed"
