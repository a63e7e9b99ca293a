#!/usr/bin/env bash
# compare-isr.sh [REV]: builds the firmware of git revision REV (default HEAD) and of the work
# tree, both boards, and prints each step-path function whose code differs
# (isr_fingerprint.py: size, instruction count, code with addresses taken out). A change meant
# to leave the AVR output alone must print "N functions the same" and nothing above it.
set -euo pipefail
cd "$(dirname "$0")/../.."
rev=${1:-HEAD}
tmp=$(mktemp -d)
trap 'git worktree remove --force "$tmp/rev" >/dev/null 2>&1 || true; rm -rf "$tmp"' EXIT
git worktree add --detach "$tmp/rev" "$rev" >/dev/null 2>&1
build() {  # source dir, build dir
  cmake -S "$1/firmware/avr" -B "$2" -DCMAKE_TOOLCHAIN_FILE="$1/firmware/cmake/avr-gcc.cmake" \
        -DCMAKE_BUILD_TYPE=MinSizeRel -DSTEPCHOIR_OUT="$2/out" >/dev/null
  cmake --build "$2" -j"$(nproc)" >/dev/null
}
build "$tmp/rev" "$tmp/a"
build "$PWD" "$tmp/b"
for board in uno mega; do
  echo "== $board: $rev -> work tree"
  python3 tools/firmware/isr_fingerprint.py "$tmp/a/out/stepchoir-$board.elf" > "$tmp/a-$board.txt"
  python3 tools/firmware/isr_fingerprint.py "$tmp/b/out/stepchoir-$board.elf" > "$tmp/b-$board.txt"
  python3 tools/firmware/isr_fingerprint.py --diff "$tmp/a-$board.txt" "$tmp/b-$board.txt"
done
