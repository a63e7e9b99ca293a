#!/usr/bin/env bash
# run-tests.sh: installs dependencies, configures into build/, builds everything (host,
# firmware for both boards, virtual board), then runs every test under ctest; then the host
# and unit tests again under AddressSanitizer + UndefinedBehaviorSanitizer (build-asan/), the
# live path's threaded tests under ThreadSanitizer (build-tsan/), and each libFuzzer target
# for a bounded time (tools/fuzz.sh; longer runs: tools/fuzz.sh 600).
# Options are passed to the first ctest runs (e.g. -R pattern). STEPCHOIR_QUICK=1 skips the
# sanitizer and fuzzing stages.
set -euo pipefail
cd "$(dirname "$0")/.."

tools/deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSTEPCHOIR_FIRMWARE=ON
cmake --build build -j"$(nproc)"
(
  cd build
  # Unit and tool tests run once. The end-to-end tests on the virtual board get four reruns: the
  # full-line-speed pitch tests' p99 bound sits near the top of their spread (docs/ARCHITECTURE.md;
  # their late steps are gone since 2026-12-02, 0 in 50 runs), and
  # the tests that judge real time fail, saying so, when the machine stalls the virtual board
  # (seen here: 2-11 ms behind real time in two runs in a row, with any firmware; 2-35 ms in
  # three in a row, twice in one day, once with the machine otherwise idle). A failure that is
  # the firmware's fails all five.
  ctest --output-on-failure -j"$(nproc)" -LE e2e "$@"
  ctest --output-on-failure -L e2e --repeat until-pass:5 "$@"
)
[ "${STEPCHOIR_QUICK:-0}" = 1 ] && exit 0

# Sanitizers: every native unit and tool test again, built with -fsanitize=address,undefined.
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=Debug -DSTEPCHOIR_FIRMWARE=OFF -DSTEPCHOIR_SANITIZE=address,undefined
cmake --build build-asan -j"$(nproc)"
(
  cd build-asan
  export LSAN_OPTIONS="suppressions=$PWD/../tests/sanitizers/lsan.supp"
  export UBSAN_OPTIONS="print_stacktrace=1"
  ctest --output-on-failure -j"$(nproc)" -LE e2e
)

# ThreadSanitizer over the threaded live path (MIDI callback queue, engine, writer, reader,
# session): its test program, built with -fsanitize=thread.
cmake -S . -B build-tsan -DCMAKE_BUILD_TYPE=Debug -DSTEPCHOIR_FIRMWARE=OFF -DSTEPCHOIR_SANITIZE=thread
cmake --build build-tsan -j"$(nproc)" --target test_live
TSAN_OPTIONS="halt_on_error=1 suppressions=$PWD/tests/sanitizers/tsan.supp" build-tsan/bin/test_live

# Fuzzing, bounded: each target 30 s; any crash, leak, hang or sanitizer report fails.
tools/fuzz.sh 30
