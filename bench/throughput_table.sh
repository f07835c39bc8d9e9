#!/usr/bin/env bash
# The throughput table of BENCHMARKS.md ("Throughput: 720p, 1080p, 4K"): CPU time per
# frame, peak memory and processed frames per second of `aerovo run` (default settings, no HTML
# report) on simulated videos at 1280x720, 1920x1080 and 3840x2160, with 1 and 2 threads
# (--threads: SURF and matching; decoding is on its own reader thread either way), on an idle
# machine and with a competing load of two busy-looping processes (python3 -c 'while True:
# pass', one per core of a 2-core machine; LOAD_PROCS changes the count).
#
# Usage: bench/throughput_table.sh [AEROVO_BINARY [BASE_BINARY]]
#   AEROVO_BINARY  default build/src/aerovo/cli/aerovo
#   BASE_BINARY    optional: an older build, run on the same videos right after each row
#                  (side by side, same load), its rows marked "base"
# Env: FRAMES (frames per video, default 120), WORK (scratch folder, default a new mktemp -d,
#      removed at the end unless KEEP=1), RESOLUTIONS (default "1280x720 1920x1080 3840x2160"),
#      THREADS (default "1 2"), LOADS (default "idle busy").
# Prints one markdown table on stdout (progress on stderr). Needs /usr/bin/time (GNU time).
set -euo pipefail

AEROVO=${1:-build/src/aerovo/cli/aerovo}
BASE=${2:-}
FRAMES=${FRAMES:-120}
RESOLUTIONS=${RESOLUTIONS:-"1280x720 1920x1080 3840x2160"}
THREADS=${THREADS:-"1 2"}
LOADS=${LOADS:-"idle busy"}
LOAD_PROCS=${LOAD_PROCS:-2}
[ -x "$AEROVO" ] || { echo "throughput_table: no aerovo binary at '$AEROVO'" >&2; exit 2; }
[ -z "$BASE" ] || [ -x "$BASE" ] || { echo "throughput_table: no base binary '$BASE'" >&2; exit 2; }
[ -x /usr/bin/time ] || { echo "throughput_table: needs GNU time (/usr/bin/time)" >&2; exit 2; }
WORK=${WORK:-$(mktemp -d /tmp/aerovo_throughput.XXXXXX)}
mkdir -p "$WORK"

LOAD_PIDS=()
stop_load() {
  for p in "${LOAD_PIDS[@]}"; do kill "$p" 2>/dev/null || true; done
  for p in "${LOAD_PIDS[@]}"; do wait "$p" 2>/dev/null || true; done
  LOAD_PIDS=()
}
cleanup() {
  stop_load
  [ "${KEEP:-0}" = 1 ] || rm -rf "$WORK"
}
trap cleanup EXIT
start_load() {
  for _ in $(seq "$LOAD_PROCS"); do
    python3 -c 'while True: pass' &
    LOAD_PIDS+=($!)
  done
  sleep 1
}

# One video per resolution: the same straight flight (10 m/s at 80 m, 30 fps), FRAMES frames.
duration=$(python3 -c "print(($FRAMES - 0.5) / 30.0)")
for res in $RESOLUTIONS; do
  w=${res%x*} h=${res#*x}
  if [ ! -f "$WORK/sim_$res/video.mp4" ]; then
    echo "throughput_table: simulating $res ($FRAMES frames)" >&2
    "$AEROVO" simulate --pattern line --length-m 400 --height-m 80 --speed-mps 10 --fps 30 \
      --duration-s "$duration" --width "$w" --height "$h" --noise 1.5 --terrain-seed 3 --seed 1 \
      -q -o "$WORK/sim_$res" >/dev/null
  fi
done

# One row: binary, label, resolution, threads, load.
row() {
  local bin=$1 label=$2 res=$3 threads=$4 load=$5
  local out="$WORK/run_${label}_${res}_${threads}_${load}"
  rm -rf "$out"
  echo "throughput_table: $label $res threads $threads $load" >&2
  /usr/bin/time -f "%e %U %S %M" -o "$out.time" "$bin" run "$WORK/sim_$res/video.mp4" -q \
    --no-report --threads "$threads" -o "$out" >"$out.log" 2>&1 || {
    echo "throughput_table: run failed, see $out.log" >&2
    return 1
  }
  python3 - "$out" "$label" "$res" "$threads" "$load" <<'EOF'
import json, sys
out, label, res, threads, load = sys.argv[1:]
s = json.load(open(out + "/summary.json"))
wall, user, sys_s, rss_kb = open(out + ".time").read().split()[-4:]
n = s["frames_processed"]
cpu_ms = 1e3 * (float(user) + float(sys_s)) / n
ate = s.get("evaluation", {}).get("se2", {}).get("ate_m", {}).get("rmse")
ate_s = f"{100 * ate:.1f}" if ate is not None else "-"
print(f"| {res} | {s['processed_width_px']}x{s['processed_height_px']} | {threads} | {load} | "
      f"{label} | {s['fps']:.1f} | {cpu_ms:.1f} | {int(rss_kb) / 1024:.0f} | {ate_s} |")
EOF
}

echo "| video | detected at | threads | load | build | fps | CPU ms/frame | peak MB | ATE RMSE cm |"
echo "|---|---|---|---|---|---|---|---|---|"
for load in $LOADS; do
  [ "$load" = busy ] && start_load
  for res in $RESOLUTIONS; do
    for t in $THREADS; do
      row "$AEROVO" new "$res" "$t" "$load"
      [ -z "$BASE" ] || row "$BASE" base "$res" "$t" "$load"
    done
  done
  [ "$load" = busy ] && stop_load
done
