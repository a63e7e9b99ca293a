#!/usr/bin/env bash
# dry_run.sh: `stepchoir play --dry-run` on a General MIDI band arrangement: the plan's lines keep
# their format, the drums are not sung (and play as bursts with --drums), the summary per track
# and channel says what was kept and dropped and why, and bad options get a clear error.
# Usage: dry_run.sh STEPCHOIR SONGS_DIR
set -euo pipefail
bin=$1
song=$2/band-blues.mid
err=$(mktemp)
trap 'rm -f "$err"' EXIT

out=$("$bin" play "$song" --dry-run 4)
# Every plan line: "T s  motor M  note P (F Hz)" or "T s  motor M  silent".
plan=$(grep -E '^ +[0-9]+\.[0-9]{4} s  motor [0-9]+  ' <<<"$out")
[ "$(wc -l <<<"$plan")" -gt 200 ] || { echo "too few plan lines"; exit 1; }
if grep -vE '  (note [0-9]+\.[0-9]{2} \([0-9]+\.[0-9]{3} Hz\)|silent)$' <<<"$plan"; then
  echo "a plan line out of format"; exit 1
fi
# No motor beyond 3.
if grep -qE 'motor [4-9]' <<<"$plan"; then echo "a fifth motor"; exit 1; fi
# The summary: channel 10 left out as percussion; the melody (channel 1) kept.
grep -qE '^  track 3 channel 10: [0-9]+ notes, kept 0, dropped [0-9]+: [0-9]+ percussion' <<<"$out"
grep -qE '^  track 1 "Band Blues" channel 1: [0-9]+ notes, kept [0-9]+ \([0-9]+ melody' <<<"$out"

# --drums 3: the hits as bursts on motor 3, the pitched notes on motors 0-2.
drums=$("$bin" play "$song" --dry-run 4 --drums 3)
grep -qE '^  track 3 channel 10: [0-9]+ notes, kept [1-9][0-9]* \([0-9]+ drums\)' <<<"$drums"
[ "$(grep -cE 'motor 3  note' <<<"$drums")" -gt 100 ] || { echo "too few drum bursts"; exit 1; }

# --keep melody: only the melody plays.
keep=$("$bin" play "$song" --dry-run 4 --keep melody)
if grep -E '^  track.*(bass|inner)' <<<"$keep"; then echo "--keep melody kept another role"; exit 1; fi

# Bad options: what and why, exit code 1.
for bad in "--voices x2:--voices: 'x2': expected tN" "--keep tune:--keep: 'tune': expected melody, bass or inner" \
           "--drums 7:--drums 7: not one of the song's motors"; do
  opt=${bad%%:*}
  want=${bad#*:}
  if "$bin" play "$song" --dry-run 4 $opt 2>"$err" >/dev/null; then echo "$opt should fail"; exit 1; fi
  grep -qF -- "$want" "$err" || { echo "$opt: got $(cat "$err")"; exit 1; }
done
echo "dry run: passed"
