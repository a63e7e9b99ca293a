#!/usr/bin/env bash
# fuzz.sh: builds the libFuzzer targets with clang (AddressSanitizer and
# UndefinedBehaviorSanitizer) in build-fuzz/ and runs each for SECONDS (default 30), as many at
# once as the machine has cores.
# Usage: tools/fuzz.sh [SECONDS] [TARGET...]
#   targets: fuzz_sng fuzz_midi fuzz_tab fuzz_musicxml (song readers), fuzz_firmware (the firmware's frame decoder and
#   command handlers, host build), fuzz_replies (the host's reply parsers), fuzz_config (the live
#   configuration loader); default all seven.
# Seeds come from tests/fuzz/corpus/<kind>/ and the sample songs (read only); new inputs collect in
# build-fuzz/corpus/<target>/, crashes in build-fuzz/artifacts/. Exits non-zero on a crash.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-30}
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(fuzz_sng fuzz_midi fuzz_tab fuzz_musicxml fuzz_firmware fuzz_replies fuzz_config)

tools/deps.sh
CC=clang CXX=clang++ cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSTEPCHOIR_FIRMWARE=OFF \
  -DSTEPCHOIR_FUZZ=ON > build-fuzz.log
nice cmake --build build-fuzz -j2 --target "${targets[@]}" >> build-fuzz.log
rm -f build-fuzz.log
mkdir -p build-fuzz/artifacts
declare -A extra_seeds=([sng]=tests/data/songs)  # the sample songs seed the .sng target too
# One target: its run's exit status goes to build-fuzz/<target>.rc.
run_target() {
  local t=$1 kind=${1#fuzz_} rc=0
  local dict=()
  [ -f "tests/fuzz/$kind.dict" ] && dict=(-dict="tests/fuzz/$kind.dict")
  "build-fuzz/bin/$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=512 -print_final_stats=1 \
    "${dict[@]}" -artifact_prefix="build-fuzz/artifacts/$t-" \
    "build-fuzz/corpus/$t" "tests/fuzz/corpus/$kind" ${extra_seeds[$kind]:-} > "build-fuzz/$t.log" 2>&1 || rc=$?
  echo "$rc" > "build-fuzz/$t.rc"
}
# As many targets at once as the machine has cores (each fuzzer runs on one).
for t in "${targets[@]}"; do
  mkdir -p "build-fuzz/corpus/$t"
  while [ "$(jobs -rp | wc -l)" -ge "$(nproc)" ]; do wait -n || true; done
  echo "fuzz.sh: $t for ${seconds} s"
  run_target "$t" &
done
wait
for t in "${targets[@]}"; do
  echo "fuzz.sh: $t:"
  grep -E "^(stat::(number_of_executed_units|new_units_added|peak_rss_mb)|==[0-9]+==|SUMMARY)" "build-fuzz/$t.log" || true
  rc=$(cat "build-fuzz/$t.rc")
  [ "$rc" -eq 0 ] || { echo "fuzz.sh: $t failed (exit $rc): see build-fuzz/$t.log and build-fuzz/artifacts/"; exit 1; }
done
echo "fuzz.sh: no crash"
