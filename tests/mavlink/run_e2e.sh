#!/usr/bin/env bash
# ctest driver of tests/mavlink/e2e.cjs (MODE: udp, udpin or signed) and autopilots.cjs (MODE:
# contract, the frames as a video): installs node-mavlink from the
# npm registry (the version pinned in package.json / package-lock.json) into WORK, simulates a
# short flight (one black frame mid-flight: bridged, then re-acquired), runs the check.
# Skips (exit 77) only when node or npm is missing or `npm ci` fails, saying why.
set -u
MODE=$1 AEROVO=$2 SRC=$3 WORK=$4
command -v node >/dev/null || { echo "SKIP: node is not installed (scripts/install-deps.sh installs nodejs)"; exit 77; }
command -v npm >/dev/null || { echo "SKIP: npm is not installed (scripts/install-deps.sh installs npm)"; exit 77; }
command -v ffmpeg >/dev/null || { echo "FAIL: ffmpeg is needed to write the black frame"; exit 1; }
mkdir -p "$WORK"
NODE_DIR="$WORK/node"
# Installed once per build folder (.installed: written after a complete `npm ci` of this lock).
if [ ! -f "$NODE_DIR/.installed" ] || ! cmp -s "$SRC/package-lock.json" "$NODE_DIR/package-lock.json"; then
  mkdir -p "$NODE_DIR"
  rm -f "$NODE_DIR/.installed"
  cp "$SRC/package.json" "$SRC/package-lock.json" "$NODE_DIR/"
  if ! out=$(cd "$NODE_DIR" && npm ci --no-audit --no-fund 2>&1); then
    echo "SKIP: npm ci of node-mavlink failed (registry unreachable?):"
    echo "$out" | tail -20
    exit 77
  fi
  touch "$NODE_DIR/.installed"
fi
# A simulated flight (no sim.json beside the frames: no telemetry, positions in the local frame).
SIM="$WORK/sim-$MODE"
rm -rf "$SIM" "$WORK/frames-$MODE" "$WORK/run-$MODE"
"$AEROVO" simulate --pattern line --length-m 50 --height-m 60 --width 640 --height 360 --fps 4 \
  --gps-noise-m 0 --frames-only --image-format png --quiet --out "$SIM" || exit 1
FOCAL=$(node -e 'console.log(require(process.argv[1]).camera.focal_px)' "$SIM/sim.json") || exit 1
mv "$SIM/frames" "$WORK/frames-$MODE"
FRAMES="$WORK/frames-$MODE"
N=$(ls "$FRAMES" | wc -l)
[ "$N" -ge 12 ] || { echo "FAIL: only $N simulated frames"; exit 1; }
BLACK=$(ls "$FRAMES" | sort | sed -n 8p)
ffmpeg -loglevel error -y -f lavfi -i color=c=black:s=640x360 -frames:v 1 "$FRAMES/$BLACK" || exit 1
if [ "$MODE" = contract ]; then
  # The same frames as a video (lossless, 4 fps): a file whose frames carry presentation times,
  # put through ArduPilot's and PX4's arithmetic (autopilots.cjs).
  SPEED=$(node -e 'console.log(require(process.argv[1]).flight.speed_mps)' "$SIM/sim.json") || exit 1
  VIDEO="$WORK/flight-$MODE.mkv"
  ffmpeg -loglevel error -y -framerate 4 -pattern_type glob -i "$FRAMES/*.png" -c:v ffv1 "$VIDEO" || exit 1
  cd "$NODE_DIR" && NODE_PATH="$NODE_DIR/node_modules" exec node "$SRC/autopilots.cjs" "$AEROVO" "$VIDEO" "$FOCAL" 60 "$SPEED" "$WORK/run-$MODE"
fi
cd "$NODE_DIR" && NODE_PATH="$NODE_DIR/node_modules" node "$SRC/e2e.cjs" "$MODE" "$AEROVO" "$FRAMES" "$FOCAL" 60 "$WORK/run-$MODE"
