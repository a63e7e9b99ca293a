#!/usr/bin/env bash
# run-tests.sh: installs dependencies, configures into build/, builds everything (host,
# firmware for both boards, virtual board), then runs every test under ctest.
set -euo pipefail
cd "$(dirname "$0")/.."

tools/deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSTEPCHOIR_FIRMWARE=ON
cmake --build build -j"$(nproc)"
cd build
# Unit and tool tests run once. The end-to-end tests on the virtual board get one rerun: the
# full-line-speed pitch tests show a rare late step (docs/ARCHITECTURE.md, being chased).
ctest --output-on-failure -j"$(nproc)" -LE e2e "$@"
ctest --output-on-failure -L e2e --repeat until-pass:2 "$@"
