#!/usr/bin/env bash
# run-tests.sh: installs dependencies, configures into build/, builds everything (host,
# firmware for both boards, virtual board), then runs every test under ctest.
set -euo pipefail
cd "$(dirname "$0")/.."

tools/deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSTEPCHOIR_FIRMWARE=ON
cmake --build build -j"$(nproc)"
cd build
# A test that fails is run once more before the run fails: the full-line-speed e2e pitch tests
# show a rare late step (about 1 run in 6, docs/ARCHITECTURE.md) that is still being chased.
ctest --output-on-failure -j"$(nproc)" --repeat until-pass:2 "$@"
