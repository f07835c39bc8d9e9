#!/usr/bin/env bash
# Installs the dependencies, builds aerovo, and runs `aerovo demo`: a flight simulated over the
# built-in terrain, the visual odometry, the paper's experiments and the HTML reports (~2 min).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
BUILD_DIR=${BUILD_DIR:-build}
cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release -DAEROVO_BUILD_TESTS=OFF
cmake --build "$BUILD_DIR" --parallel "$(nproc)" --target aerovo_cli
"$BUILD_DIR/src/aerovo/cli/aerovo" demo "$@"
