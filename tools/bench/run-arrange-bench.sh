#!/usr/bin/env bash
# run-arrange-bench.sh: builds stepchoir-bench-arrange and writes bench/results/arrangement.md:
# melody and bass coverage, drum hits sung and notes dropped, with 4 and 5 motors, for the
# arranger and the planner it replaced, on General MIDI band arrangements: the two checked-in
# test songs (tests/data/songs, made with abc2midi) and every example of Debian's mma that has a
# melody track (named Solo, Aria, Melody or Vocal) and drums.
set -euo pipefail
cd "$(dirname "$0")/../.."
if ! dpkg -s mma >/dev/null 2>&1; then
  sudo=""; [ "$(id -u)" -eq 0 ] || sudo=sudo
  $sudo apt-get install -y -q --no-install-recommends mma >/dev/null
fi
cmake -S . -B build >/dev/null
nice cmake --build build -j2 --target stepchoir-bench-arrange >/dev/null
files=(tests/data/songs/band-blues.mid tests/data/songs/band-waltz.mid)
while IFS= read -r f; do
  names=$(midicsv "$f" 2>/dev/null | awk -F', ' '$3 == "Title_t" && $1 > 1 {print $4}')
  drums=$(midicsv "$f" 2>/dev/null | awk -F', ' '$3 == "Note_on_c" && $4 == 9' | wc -l)
  if grep -qiE 'solo|aria|melody|vocal' <<<"$names" && [ "$drums" -gt 0 ]; then files+=("$f"); fi
done < <(find /usr/share/doc/mma/examples -name '*.mid' | sort)
build/bin/stepchoir-bench-arrange bench/results/arrangement.md "tools/bench/run-arrange-bench.sh" "${files[@]}"
