#!/usr/bin/env bash
# ctest driver of tests/mavlink/e2e.cjs (MODE: udp, udpin or signed), autopilots.cjs (MODE:
# contract, the frames as a video), live.cjs (MODE: live, the frames as a live UDP stream),
# tlog.cjs (MODE: tlog, a recorded .tlog read by aerovo and node-mavlink), dji_srt.cjs (MODE:
# dji_srt, real DJI SRT files read by aerovo and dji_srt_parser),
# gps_input.cjs (MODE: gps_input, the simulated flight with its telemetry, so that the track is
# geo-referenced) and map_gps_input.cjs (MODE: map_gps_input, the same with GPS denied and the
# fixes of a map of it fused): installs node-mavlink from the
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
if [ "$MODE" = dji_srt ]; then
  # The real SRT files of several DJI aircraft that dji_srt_parser ships, read by aerovo and by
  # dji_srt_parser (dji_srt.cjs).
  cd "$NODE_DIR" && NODE_PATH="$NODE_DIR/node_modules" exec node "$SRC/dji_srt.cjs" "$AEROVO" \
    "$NODE_DIR/node_modules/dji_srt_parser/samples"
fi
if [ "$MODE" = tlog ]; then
  # A telemetry log a ground station recorded: the package's own examples/vtol.tlog, read by
  # aerovo and by node-mavlink (tlog.cjs).
  cd "$NODE_DIR" && NODE_PATH="$NODE_DIR/node_modules" exec node "$SRC/tlog.cjs" "$AEROVO" \
    "$NODE_DIR/node_modules/node-mavlink/examples/vtol.tlog"
fi
if [ "$MODE" = gps_input ]; then
  # The flight with its telemetry (GPS without noise; the camera's yaw added as a DJI gimbal's,
  # the line's constant heading from ground_truth.csv): geo-referenced from the first frame.
  # Frame 8 blackened: bridged, then re-acquired.
  SIM="$WORK/sim-$MODE"
  rm -rf "$SIM" "$WORK/run-$MODE"
  "$AEROVO" simulate --pattern line --length-m 50 --height-m 60 --width 640 --height 360 --fps 4 \
    --gps-noise-m 0 --frames-only --image-format png --quiet --out "$SIM" || exit 1
  FOCAL=$(node -e 'console.log(require(process.argv[1]).camera.focal_px)' "$SIM/sim.json") || exit 1
  YAW=$(awk -F, 'NR == 2 { print $9 }' "$SIM/ground_truth.csv")
  sed "s/\[ct: /[gb_yaw: $YAW gb_pitch: -90.0 gb_roll: 0.0] [ct: /" "$SIM/telemetry.srt" > "$SIM/telemetry-yaw.srt"
  grep -q "gb_yaw: $YAW" "$SIM/telemetry-yaw.srt" || { echo "FAIL: no yaw written into the SRT"; exit 1; }
  BLACK=$(ls "$SIM/frames" | sort | sed -n 8p)
  ffmpeg -loglevel error -y -f lavfi -i color=c=black:s=640x360 -frames:v 1 "$SIM/frames/$BLACK" || exit 1
  # As a video (lossless, 4 fps): frames with presentation times, the SRT's times.
  VIDEO="$WORK/flight-$MODE.mkv"
  ffmpeg -loglevel error -y -framerate 4 -pattern_type glob -i "$SIM/frames/*.png" -c:v ffv1 "$VIDEO" || exit 1
  # horiz_accuracy grows with the distance flown (1 % of it) and by the bridged step's length
  # (2.5 m): a 0.3 m limit gives 3D fixes before the black frame and "no fix" after it.
  cd "$NODE_DIR" && NODE_PATH="$NODE_DIR/node_modules" exec node "$SRC/gps_input.cjs" "$AEROVO" \
    "$VIDEO" "$SIM/telemetry-yaw.srt" "$FOCAL" "$SIM/ground_truth.csv" 0.3 "$WORK/run-$MODE"
fi
if [ "$MODE" = map_gps_input ]; then
  # A flight with its telemetry (as gps_input, without the black frame), a map of it built from
  # the true telemetry (`aerovo map build`), then the run with GPS denied after 1 s, the map's
  # fixes fused, over telemetry moved 5 m north, and the run with GPS denied from the start over
  # the true telemetry, the map seeding the geo-reference (map_gps_input.cjs).
  SIM="$WORK/sim-$MODE"
  rm -rf "$SIM" "$WORK/run-$MODE" "$WORK/run-$MODE-seeded" "$WORK/map-$MODE"
  "$AEROVO" simulate --pattern line --length-m 60 --height-m 60 --width 480 --height 270 --fps 4 \
    --gps-noise-m 0 --frames-only --image-format png --quiet --out "$SIM" || exit 1
  FOCAL=$(node -e 'console.log(require(process.argv[1]).camera.focal_px)' "$SIM/sim.json") || exit 1
  YAW=$(awk -F, 'NR == 2 { print $9 }' "$SIM/ground_truth.csv")
  sed "s/\[ct: /[gb_yaw: $YAW gb_pitch: -90.0 gb_roll: 0.0] [ct: /" "$SIM/telemetry.srt" > "$SIM/telemetry-yaw.srt"
  # Every latitude 5 m north (metres to degrees by the meridian's 111.2 km per degree: 0.5 %).
  node -e 'const fs = require("fs"); const t = fs.readFileSync(process.argv[1], "utf8");
    fs.writeFileSync(process.argv[2], t.replace(/\[latitude: ([-0-9.]+)\]/g, (m, v) => `[latitude: ${(Number(v) + 5 / 111200).toFixed(6)}]`));' \
    "$SIM/telemetry-yaw.srt" "$SIM/telemetry-north5.srt" || exit 1
  cmp -s "$SIM/telemetry-yaw.srt" "$SIM/telemetry-north5.srt" && { echo "FAIL: the SRT was not shifted"; exit 1; }
  VIDEO="$WORK/flight-$MODE.mkv"
  ffmpeg -loglevel error -y -framerate 4 -pattern_type glob -i "$SIM/frames/*.png" -c:v ffv1 "$VIDEO" || exit 1
  "$AEROVO" map build "$VIDEO" --telemetry "$SIM/telemetry-yaw.srt" --focal-px "$FOCAL" -q \
    --run-dir "$WORK/map-$MODE/run" -o "$WORK/map-$MODE/map.tif" || exit 1
  cd "$NODE_DIR" && NODE_PATH="$NODE_DIR/node_modules" exec node "$SRC/map_gps_input.cjs" "$AEROVO" \
    "$VIDEO" "$SIM/telemetry-north5.srt" "$FOCAL" "$WORK/map-$MODE/map.tif" "$SIM/ground_truth.csv" 1.5 5 "$WORK/run-$MODE" \
    "$SIM/telemetry-yaw.srt"
fi
if [ "$MODE" = live ]; then
  # The flight of MODE contract (a black frame mid-flight: bridged, then re-acquired), 25
  # frames at 4 fps, as an MPEG-TS stream (H.264, a key frame every 4 frames, no B frames) that
  # live.cjs has ffmpeg play at real-time pace over UDP into `aerovo run udp://...`.
  SIM="$WORK/sim-$MODE"
  rm -rf "$SIM" "$WORK/run-$MODE"
  "$AEROVO" simulate --pattern line --length-m 60 --height-m 60 --width 640 --height 360 --fps 4 \
    --gps-noise-m 0 --frames-only --image-format png --quiet --out "$SIM" || exit 1
  FOCAL=$(node -e 'console.log(require(process.argv[1]).camera.focal_px)' "$SIM/sim.json") || exit 1
  SPEED=$(node -e 'console.log(require(process.argv[1]).flight.speed_mps)' "$SIM/sim.json") || exit 1
  BLACK=$(ls "$SIM/frames" | sort | sed -n 10p)
  ffmpeg -loglevel error -y -f lavfi -i color=c=black:s=640x360 -frames:v 1 "$SIM/frames/$BLACK" || exit 1
  STREAM="$WORK/flight-$MODE.ts"
  ffmpeg -loglevel error -y -framerate 4 -pattern_type glob -i "$SIM/frames/*.png" -c:v libx264 \
    -crf 16 -g 4 -bf 0 -pix_fmt yuv420p "$STREAM" || exit 1
  cd "$NODE_DIR" && NODE_PATH="$NODE_DIR/node_modules" exec node "$SRC/live.cjs" "$AEROVO" \
    "$STREAM" "$FOCAL" 60 "$SPEED" "$WORK/run-$MODE"
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
