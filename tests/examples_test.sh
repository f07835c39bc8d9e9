#!/usr/bin/env bash
# The README's C++ examples (examples/) on a simulated nadir flight over the built-in terrain:
# a straight line at 100 m with a 1000 px focal length, 5 m per frame (50 px of image motion).
# surf_pair must find that shift between frames 1 and 2; odometry_frames must track the 6
# frames to 25 m along the line within 2 %. Needs no ../shared.
# Usage: examples_test.sh AEROVO SURF_PAIR ODOMETRY_FRAMES
set -euo pipefail
aerovo=$1 surf_pair=$2 odometry=$3
fail() { echo "FAIL: $*"; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

"$aerovo" simulate --pattern line --length-m 25 --speed-mps 10 --fps 2 --height-m 100 \
  --focal-px 1000 --frames-only --image-format png -o "$work/sim" -q >/dev/null
frames=("$work"/sim/frames/frame_*.png)
(( ${#frames[@]} >= 6 )) || fail "aerovo simulate wrote ${#frames[@]} frames"

out=$("$surf_pair" "${frames[0]}" "${frames[1]}")
echo "$out"
shift_px=$(sed -n 's/^curr_from_prev: \[[^ ]* [^ ]* \([^;]*\); [^ ]* [^ ]* \(.*\)\]$/\1 \2/p' <<<"$out")
[[ -n $shift_px ]] || fail "surf_pair printed no transform"
awk -v s="$shift_px" 'BEGIN { split(s, t, " "); d = sqrt(t[1]^2 + t[2]^2);
  exit !(d > 49 && d < 51) }' || fail "surf_pair: shift ($shift_px) px, expected 50 px"

out=$("$odometry" 1000 100 2 "${frames[@]:0:6}")
echo "$out"
last=$(tail -n 1 <<<"$out")
[[ $last == "frame 5 "* ]] || fail "odometry_frames did not process 6 frames"
dist=$(sed -n 's/.*: x \([-0-9.]*\) m, y \([-0-9.]*\) m,.*/\1 \2/p' <<<"$last")
awk -v p="$dist" 'BEGIN { split(p, t, " "); d = sqrt(t[1]^2 + t[2]^2);
  exit !(d > 24.5 && d < 25.5) }' || fail "odometry_frames ended at ($dist) m, expected 25 m away"
echo "PASS: surf_pair shift ($shift_px) px, odometry_frames end ($dist) m"
