#!/usr/bin/env bash
# `aerovo correspondence` on a real tampa-phantom3 pair: the default clustered RANSAC (refined,
# with its final pass, which runs because the scene is not flat) and the standard method agree
# within 1 px at the frame corners once both are polished; the final pass can be skipped by
# --final-min-shift; the paper's variant is reported as such; the k-d forest matcher works;
# bad options are clear errors.
# Usage: cli_correspondence_test.sh AEROVO_BINARY SHARED_DIR   (exit 77 = skipped)
set -euo pipefail
aerovo=$1
shared=${AEROVO_SHARED:-$2}
dir=$shared/data/flights/tampa-phantom3
if [[ ! -f $dir/DJI_0060.JPG ]]; then
  echo "SKIPPED: $dir not found (set AEROVO_SHARED to the shared data folder)"
  exit 77
fi
fail() { echo "FAIL: $*"; exit 1; }

out=$("$aerovo" correspondence "$dir/DJI_0060.JPG" "$dir/DJI_0061.JPG" --polish 20)
echo "$out"
grep -q "clustered, refined" <<<"$out" || fail "default clustered result not refined"
# A real photo pair (relief, tilted camera): the cell's fit does not extrapolate, so the final
# pass runs.
grep -q "final pass run" <<<"$out" || fail "the final pass did not run on a tampa pair"
apart=$(sed -n 's/.*transforms \([0-9.]*\) px apart.*/\1/p' <<<"$out")
[[ -n $apart ]] || fail "no corner difference printed"
awk -v d="$apart" 'BEGIN { exit !(d < 1.0) }' || fail "refined vs standard ${apart} px apart (>= 1 px)"
inliers=$(sed -n 's/^clustered: success .*; \([0-9]*\) inliers .*/\1/p' <<<"$out")
[[ -n $inliers && $inliers -ge 100 ]] || fail "refined clustered result has ${inliers:-no} inliers"

out=$("$aerovo" correspondence "$dir/DJI_0060.JPG" "$dir/DJI_0061.JPG" --paper)
grep -q "refined" <<<"$out" && fail "--paper result claims a refinement"
grep -q "^clustered: success" <<<"$out" || fail "--paper failed on a good pair"

# The approximate k-d forest matcher (unguided matching) still gives a good standard fit.
out=$("$aerovo" correspondence "$dir/DJI_0060.JPG" "$dir/DJI_0061.JPG" --matcher kdtree)
grep -q "^standard: success" <<<"$out" || fail "--matcher kdtree: standard failed on a good pair"
grep -q "^clustered: success" <<<"$out" || fail "--matcher kdtree: clustered failed on a good pair"
if err=$("$aerovo" correspondence "$dir/DJI_0060.JPG" "$dir/DJI_0061.JPG" --matcher flann 2>&1); then
  fail "--matcher flann accepted"
fi
grep -q "flann" <<<"$err" || fail "unclear error for --matcher flann: $err"

out=$("$aerovo" correspondence "$dir/DJI_0060.JPG" "$dir/DJI_0061.JPG" --final-min-shift 1000)
grep -q "final pass skipped" <<<"$out" || fail "--final-min-shift 1000 still ran the final pass"

out=$("$aerovo" correspondence "$dir/DJI_0060.JPG" "$dir/DJI_0061.JPG" --final-min-shift 1000 \
  --early-exit false)
grep -q "final pass skipped" <<<"$out" || fail "--early-exit false: final pass not skipped"
if grep -q "early exit" <<<"$out"; then fail "--early-exit false still exited early"; fi
if err=$("$aerovo" correspondence "$dir/DJI_0060.JPG" "$dir/DJI_0061.JPG" --early-exit maybe 2>&1); then
  fail "--early-exit maybe accepted"
fi
grep -q "early-exit" <<<"$err" || fail "unclear error for --early-exit maybe: $err"

if err=$("$aerovo" correspondence "$dir/DJI_0060.JPG" "$dir/DJI_0061.JPG" --final-points -5 2>&1); then
  fail "--final-points -5 accepted"
fi
grep -qF -- "--final-points: clustered.refine_final_max_points must be in [0, 10000000], got -5" <<<"$err" || fail "unclear error: $err"

if err=$("$aerovo" correspondence "$dir/DJI_0060.JPG" "$dir/DJI_0061.JPG" --final-min-shift -1 2>&1); then
  fail "--final-min-shift -1 accepted"
fi
grep -q "refine_final_min_shift_px must be finite and >= 0" <<<"$err" || fail "unclear error: $err"

if err=$("$aerovo" correspondence "$dir/DJI_0060.JPG" "$dir/DJI_0061.JPG" --final-radius -1 2>&1); then
  fail "--final-radius -1 accepted"
fi
grep -q "refine_final_radius_px must be finite and >= 0" <<<"$err" || fail "unclear error: $err"
echo "PASS (corners ${apart} px apart, ${inliers} inliers)"
