#!/usr/bin/env bash
# compare_lead.sh VBOARD WORK_DIR: builds compare_lead.c, runs it on the virtual board and checks
# its trace (how far ahead a Timer1 compare must be armed to fire, and that it fires on its tick).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$2"
avr-gcc -mmcu=atmega328p -DF_CPU=16000000UL -Os -Wall -Wextra -o "$2/compare-lead.elf" "$here/compare_lead.c"
"$1" --board uno --elf "$2/compare-lead.elf" --no-pacing --seconds 0.4 --trace "$2/compare-lead.csv" --quiet
python3 "$here/check_compare_lead.py" "$2/compare-lead.csv"
