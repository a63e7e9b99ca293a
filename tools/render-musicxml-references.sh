#!/usr/bin/env bash
# render-musicxml-references.sh: renders every MusicXML score in tests/data/songs with MuseScore 3
# (Debian musescore3), an independent reader, into tests/data/songs/reference/NAME.mid. The
# MusicXML reader's test compares its notes with these files (tests/host/test_musicxml.cpp).
# Run it after changing a score; commit the .mid files it writes. Installs musescore3 if missing
# (about 50 packages, which is why the tests use the committed files instead of running it).
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v mscore3 >/dev/null; then
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq musescore3
fi

out=tests/data/songs/reference
mkdir -p "$out"
export QT_QPA_PLATFORM=offscreen XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
for score in tests/data/songs/*.musicxml tests/data/songs/*.mxl; do
  name=$(basename "$score")
  log=$(mscore3 -o "$out/$name.mid" "$score" 2>&1) || { echo "$log" >&2; exit 1; }
  # MuseScore imports a score that breaks the MusicXML schema and says so; a reference must
  # come from a valid score.
  if grep -q "not a valid MusicXML file" <<<"$log"; then
    echo "$score: MuseScore 3 says it is not valid MusicXML:" >&2
    echo "$log" >&2
    exit 1
  fi
  echo "$out/$name.mid"
done
echo "mscore3 $(dpkg-query -W -f='${Version}' musescore3)"
