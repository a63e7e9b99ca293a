#!/usr/bin/env bash
# deps.sh: installs the Debian 12 packages stepchoir needs to build, test and run the demo.
# Idempotent: installs only what is missing. Needs root (or sudo) when something is missing.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config python3
  gcc-avr avr-libc binutils-avr arduino-core-avr  # firmware: avr-gcc 5.4 + Arduino core
  libsimavr-dev libelf-dev                        # virtual board
  catch2                                          # tests (Catch2 v2)
  libcli11-dev libspdlog-dev libserialport-dev    # host
  libpng-dev                                      # piano-roll pictures
  midicsv abcmidi                                 # song tests: MIDI files to check the reader against
  libpugixml-dev libzip-dev                       # MusicXML scores (.musicxml, .mxl)
  librtmidi-dev libreaderwriterqueue-dev          # live: MIDI in, lock-free queues
  libtomlplusplus-dev                             # live: configuration file
  jackd2 libjack-jackd2-dev                       # live: JACK (jackd2, not jack1: librtmidi-dev takes either)
  libncurses-dev tmux                             # live: the console (curses), its test (tmux)
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "deps.sh: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
