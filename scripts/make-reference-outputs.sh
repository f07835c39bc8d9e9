#!/usr/bin/env bash
# Writes the reference outputs that tests/e2e/reference_outputs_test.cc compares every build
# with: `aerovo run` on tampa-phantom3 (--altitude 57), turin-p4m and a simulated flight over
# the built-in terrain, each in the default mode and in the paper's mode (--paper).
# Per case, tests/reference/CASE.csv holds each frame's position (vo.tum, metres, 6 decimals),
# status, matches, inliers and cell; CASE.summary.json the summary's frame counts and
# comparisons (with GPS, with the truth). Run it with a build whose behaviour is the reference,
# only when a change of behaviour is intended, and say so in the commit. Which build wrote which:
# - *-paper.*: the build before the pipeline refactor (then with --guided 0 --refine 0; --paper
#   reproduces them exactly, which the test proves);
# - *-default.*: the build of branch feat (adaptive interest points, the new default),
#   regenerated with MODES=default so that the paper ones stay those of the pre-refactor build;
#   tampa-default.* again by the build that estimates the camera's tilt from the flight
#   (attitude_estimation auto: tampa's 15 deg; turin and sim unchanged, their telemetry gives
#   the attitude or the estimate is not significant);
# - sim-*.summary.json's truth_evaluation again (NAMES=sim) by the build whose CSV reader takes
#   units from column names: the simulator's ground_truth.csv `alt_m` is read since, and the
#   truth's conversion into the run's ENU frame uses it (distance flown +0.018 m of 302 m, the
#   ATE within 1.2 mm); every position, status and count unchanged.
#   scripts/make-reference-outputs.sh path/to/aerovo [shared-dir]
#   (MODES="default paper", NAMES="tampa turin sim")
set -euo pipefail
cli=$(realpath "$1")
shared=$(realpath "${2:-$(dirname "$0")/../../shared}")
ref=$(realpath "$(dirname "$0")/../tests/reference")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# Keep in step with kSimulateArgs in tests/e2e/reference_outputs_test.cc.
"$cli" simulate --pattern lawnmower --length-m 120 --legs 2 --spacing-m 40 --height-m 80 \
  --width 640 --height 360 --fps 4 --gps-noise-m 1.5 --frames-only --image-format png --quiet \
  --out "$work/sim" > /dev/null
declare -A input=([tampa]="$shared/data/flights/tampa-phantom3 --altitude 57"
  [turin]="$shared/data/flights/turin-p4m" [sim]="$work/sim/frames")
for name in ${NAMES:-tampa turin sim}; do
  for mode in ${MODES:-default paper}; do
    extra=""
    [ "$mode" = paper ] && extra="--paper"
    out="$work/$name-$mode"
    # shellcheck disable=SC2086
    "$cli" run ${input[$name]} $extra --quiet --no-report -o "$out" > /dev/null
    {
      echo "frame,x_m,y_m,status,n_matched,n_inliers,cluster"
      paste -d' ' <(tail -n +2 "$out/frames.csv" | cut -d, -f1,9,10,11,17) "$out/vo.tum" |
        awk '{ split($1, f, ","); printf "%s,%s,%s,%s,%s,%s,%s\n", f[1], $3, $4, f[5], f[2], f[3], f[4] }'
    } > "$ref/$name-$mode.csv"
    python3 - "$out/summary.json" "$ref/$name-$mode.summary.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
keep = ["frames_processed", "frames_ok", "frames_reacquired", "frames_bridged", "frames_with_gps",
        "frames_with_truth", "focal_px", "focal_source", "height_source", "heading_source",
        "vo_path_length_m", "evaluation", "truth_evaluation"]
json.dump({k: s[k] for k in keep}, open(sys.argv[2], "w"), indent=1, sort_keys=True)
PY
    echo "$name-$mode: $(($(wc -l < "$ref/$name-$mode.csv") - 1)) frames"
  done
done
