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
  # Every test passes first time, except those labelled `pacing`: they judge timing in real
  # time, so a machine that stalls the virtual board fails them (the board says so on stderr:
  # "the machine stalled the simulation"), and they get one rerun. Flake rates:
  # bench/results/flakes.md.
  ctest --output-on-failure -j"$(nproc)" -LE e2e "$@"
  ctest --output-on-failure -j"$(nproc)" -L e2e -LE pacing "$@"
  ctest --output-on-failure -L pacing --repeat until-pass:2 "$@"
)
[ "${STEPCHOIR_QUICK:-0}" = 1 ] && exit 0

# Sanitizers: every native unit and tool test again, built with -fsanitize=address,undefined.
# Each unit test program runs once, all its cases (STEPCHOIR_TESTS_PER_PROGRAM).
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=Debug -DSTEPCHOIR_FIRMWARE=OFF -DSTEPCHOIR_SANITIZE=address,undefined \
  -DSTEPCHOIR_TESTS_PER_PROGRAM=ON
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

# Fuzzing, bounded: each target 10 s; any crash, leak, hang or sanitizer report fails.
tools/fuzz.sh 10
