#!/usr/bin/env bash
# `aerovo correspondence` on two frames of a simulated nadir flight over the built-in terrain
# (`aerovo simulate`: a flat ground seen from straight above, so the frame-to-frame motion is an
# exact map, here a 42.7 px shift per frame): the default clustered RANSAC refines the cell's fit
# on the first half of its spread points, which confirms it (early exit, no final pass), and
# agrees with the standard method within 0.5 px at the frame corners; with --early-exit false it
# matches every spread point and still skips the final pass. Needs no ../shared.
# Usage: cli_correspondence_sim_test.sh AEROVO_BINARY
set -euo pipefail
aerovo=$1
fail() { echo "FAIL: $*"; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

"$aerovo" simulate --pattern line --length-m 40 --speed-mps 10 --fps 2 --frames-only \
  --image-format png --out "$work/sim" -q >/dev/null
a=$work/sim/frames/frame_000001.png
b=$work/sim/frames/frame_000002.png
[[ -f $a && -f $b ]] || fail "aerovo simulate wrote no frames 1 and 2"

# The previous step's motion (the same shift) sets the crop, as in a run.
out=$("$aerovo" correspondence "$a" "$b" --last-shift 0 42.7)
echo "$out"
grep -q "^clustered: success" <<<"$out" || fail "clustered failed on a simulated pair"
grep -q "first half of its points: early exit), final pass skipped" <<<"$out" ||
  fail "no early exit on exact motion"
apart=$(sed -n 's/.*transforms \([0-9.]*\) px apart.*/\1/p' <<<"$out")
[[ -n $apart ]] || fail "no corner difference reported"
awk -v d="$apart" 'BEGIN { exit !(d < 0.5) }' || fail "clustered ${apart} px from standard"

out=$("$aerovo" correspondence "$a" "$b" --last-shift 0 42.7 --early-exit false)
grep -q "final pass skipped" <<<"$out" || fail "--early-exit false: final pass ran on exact motion"
if grep -q "early exit" <<<"$out"; then fail "--early-exit false still exited early"; fi
apart2=$(sed -n 's/.*transforms \([0-9.]*\) px apart.*/\1/p' <<<"$out")
awk -v d="$apart2" 'BEGIN { exit !(d < 0.5) }' || fail "one pass: ${apart2} px from standard"
echo "PASS (early exit ${apart} px, one pass ${apart2} px from standard)"
