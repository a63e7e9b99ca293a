#!/usr/bin/env bash
# probe.sh NAME SECONDS VBOARD WORK_DIR: builds the tiny AVR program NAME.c, runs it on the virtual
# board (uno, no pacing) for SECONDS of board time and checks its trace with check_NAME.py.
# NAME: compare_lead (how far ahead a Timer1 compare must be armed to fire, and that it fires on
# its tick) or timer_quirks (a TIFR write clears every set flag of the timer; a waiting interrupt
# is taken only two instructions after sei; a Timer1 compare at OCR1A 0 is lost in some wraps)
# or uart_rxcie (a receive interrupt turned on while a byte waits is taken at once, as on the
# chip: the virtual board's fix of simavr 1.6). A probe with NAME_client.py runs paced, with that
# client writing to the board's pty.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
out=$4/${1//_/-}
mkdir -p "$4"
avr-gcc -mmcu=atmega328p -DF_CPU=16000000UL -Os -Wall -Wextra -o "$out.elf" "$here/$1.c"
if [[ -f $here/${1}_client.py ]]; then
  # A probe with a client (NAME_client.py PTY) runs paced, the client writing to its pty.
  source "$here/board.sh"
  start_board "$out.stdout" /dev/stderr "$3" --board uno --elf "$out.elf" --seconds "$2" --trace "$out.csv" --quiet
  python3 "$here/${1}_client.py" "$board_pty"
  wait "$board_pid"
  trap - EXIT
else
  "$3" --board uno --elf "$out.elf" --no-pacing --seconds "$2" --trace "$out.csv" --quiet
fi
python3 "$here/check_$1.py" "$out.csv"
