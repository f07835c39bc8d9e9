#!/usr/bin/env bash
# Installs the dependencies, builds aerovo, and runs `aerovo demo`: a flight simulated over the
# built-in terrain, the visual odometry, the paper's experiments and the HTML reports (~2 min).
# AEROVO_CONFIGURE_ONLY=1: only configure BUILD_DIR (tests/readme_order_test.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build}
# Tests off (the demo needs only the program); ./scripts/test.sh turns them on again.
configure() { cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release -DAEROVO_BUILD_TESTS=OFF; }
if [ "${AEROVO_CONFIGURE_ONLY:-0}" = 1 ]; then
  configure
  exit
fi
./scripts/install-deps.sh
configure
cmake --build "$BUILD_DIR" --parallel "$(nproc)" --target aerovo_cli
"$BUILD_DIR/src/aerovo/cli/aerovo" demo "$@"
