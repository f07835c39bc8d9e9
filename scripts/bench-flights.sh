#!/usr/bin/env bash
# The real-flight benchmark: `aerovo run` on every flight folder under SHARED/data/flights with
# the flags that flight needs (FLIGHT_FLAGS below; a folder not in it runs with the defaults),
# for one or more builds and RANSAC seeds, and ONE Markdown table of what the runs' summary.json
# say (their `evaluation` against the photos' GPS, frame counts, fps, CPU per frame).
#
#   scripts/bench-flights.sh [--seeds N] [--flight NAME]... [--shared DIR] [--write FILE]
#                            [--keep DIR] [BUILD...]
#
# BUILD: a build folder (default: build), whose src/aerovo/cli/aerovo runs; a BUILD may carry
# extra `aerovo run` flags in the same argument ("build --no-surf-adaptive"), to compare a
# default against its alternative. Two or more BUILDs: one table, each flight's rows side by side.
# --seeds N: each flight with --seed 1..N; a cell is then the mean with the range over the
# seeds in brackets (min-max), and the seed-1 run is the one the tests compare with.
# --write FILE: also the first BUILD's figures as a tab-separated table (bench/real_flights.tsv:
# read by tests/e2e/run_flight_test.cc and quoted by README.md and BENCHMARKS.md).
# --flight NAME: only this flight folder (repeatable; default: every folder).
# --keep DIR: keep the run folders in DIR (default: a temporary folder, removed at the end).
#
#   scripts/bench-flights.sh --quote bench/real_flights.tsv
#
# runs nothing: prints README.md's real-flight rows (Results) from a stored table.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)

# README.md's rows from a stored table (tests/e2e/run_flight_test.cc RealFlights.* checks them).
quote() {
  python3 - "$1" <<'PY'
import sys
from collections import OrderedDict
t = OrderedDict()  # flight -> (flags, {figure: {seed1, mean, min, max}})
with open(sys.argv[1]) as fh:
    lines = [l.rstrip("\n") for l in fh if not l.startswith("#")]
for line in lines[1:]:
    f, flags, fig, seed1, mean, lo, hi = line.split("\t")
    t.setdefault(f, (flags, {}))[1][fig] = dict(seed1=float(seed1), mean=float(mean),
                                                min=float(lo), max=float(hi))
print("| flight | frames | distance (GPS) | ATE RMSE SE(2) | ATE RMSE Sim(2) | end-point error "
      "| end error, no alignment | Sim(2) ATE, all seeds |")
print("|---|---|---|---|---|---|---|---|")
for f, (flags, g) in t.items():
    v = lambda k: g[k]["seed1"]
    name = f + (f" (`{flags}`)" if flags else "")
    print(f"| {name} | {v('frames'):.0f} | {v('distance_m'):.0f} m "
          f"| {v('se2_ate_m'):.2f} m ({v('se2_ate_percent'):.2f} %) "
          f"| **{v('sim2_ate_m'):.2f} m ({v('sim2_ate_percent'):.3f} %)** "
          f"| {v('se2_end_m'):.2f} m ({v('se2_end_percent'):.2f} %) "
          f"| {v('end_unaligned_m'):.2f} m ({v('end_unaligned_percent'):.2f} %) "
          f"| {g['sim2_ate_m']['min']:.2f}-{g['sim2_ate_m']['max']:.2f} m |")
PY
}
if [ "${1:-}" = --quote ]; then
  [ -f "${2:-}" ] || { echo "bench-flights.sh: --quote needs a stored table (bench/real_flights.tsv)" >&2; exit 2; }
  quote "$2"
  exit 0
fi

# Flags a flight needs beyond the defaults (what README.md and tests/e2e/run_flight_test.cc use):
# tampa's EXIF altitude is invalid (flown at about 55-60 m, judged from a tennis court); turin
# and brighton carry XMP RelativeAltitude.
declare -A FLIGHT_FLAGS=(
  [tampa-phantom3]="--altitude 57"
)

seeds=1
shared=${AEROVO_SHARED:-$root/../shared}
write=""
keep=""
only=()
builds=()
while [ $# -gt 0 ]; do
  case $1 in
    --seeds) seeds=$2; shift 2 ;;
    --flight) only+=("$2"); shift 2 ;;
    --shared) shared=$2; shift 2 ;;
    --write) write=$2; shift 2 ;;
    --keep) keep=$2; shift 2 ;;
    -h|--help) sed -n '2,22p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "bench-flights.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
    *) builds+=("$1"); shift ;;
  esac
done
[ ${#builds[@]} -gt 0 ] || builds=(build)
if ! [[ $seeds =~ ^[1-9][0-9]*$ ]]; then
  echo "bench-flights.sh: --seeds takes a positive integer, not '$seeds'" >&2; exit 2
fi
flights_dir=$shared/data/flights
if [ ! -d "$flights_dir" ]; then
  echo "bench-flights.sh: no flights folder $flights_dir (give --shared DIR or AEROVO_SHARED)" >&2
  exit 1
fi
for b in "${builds[@]}"; do
  read -r dir _ <<<"$b"
  if [ ! -x "$dir/src/aerovo/cli/aerovo" ]; then
    echo "bench-flights.sh: no $dir/src/aerovo/cli/aerovo (build it: cmake --build $dir --target aerovo)" >&2
    exit 1
  fi
done

if [ -n "$keep" ]; then
  runs=$keep; mkdir -p "$runs"
else
  runs=$(mktemp -d); trap 'rm -rf "$runs"' EXIT
fi

# Every folder of photos under data/flights, in name order.
flights=()
for d in "$flights_dir"/*/; do
  d=${d%/}
  compgen -G "$d/*.[jJ][pP][gG]" >/dev/null && flights+=("$(basename "$d")")
done
if [ ${#only[@]} -gt 0 ]; then
  for f in "${only[@]}"; do
    [ -d "$flights_dir/$f" ] || { echo "bench-flights.sh: no flight folder $flights_dir/$f" >&2; exit 1; }
  done
  flights=("${only[@]}")
fi
[ ${#flights[@]} -gt 0 ] || { echo "bench-flights.sh: no flight folder in $flights_dir" >&2; exit 1; }

# The runs, one at a time (fps and CPU per frame are those of a lone run); list.tsv names each
# run's summary.json: flight, build index, build label, flags, seed, path.
: >"$runs/list.tsv"
for f in "${flights[@]}"; do
  flags=${FLIGHT_FLAGS[$f]:-}
  for i in "${!builds[@]}"; do
    read -r dir extra <<<"${builds[$i]}"
    for ((s = 1; s <= seeds; s++)); do
      out=$runs/$f-b$i-s$s
      rm -rf "$out"
      echo "bench-flights.sh: $f, ${builds[$i]}, seed $s" >&2
      # shellcheck disable=SC2086  # flags are words
      if ! "$dir/src/aerovo/cli/aerovo" run "$flights_dir/$f" $flags $extra --seed "$s" \
          -o "$out" --quiet --no-report >"$out.log" 2>&1; then
        echo "bench-flights.sh: the run failed ($out.log):" >&2; tail -5 "$out.log" >&2; exit 1
      fi
      printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$f" "$i" "${builds[$i]}" "$flags" "$s" "$out/summary.json" \
        >>"$runs/list.tsv"
    done
  done
done

python3 - "$runs/list.tsv" "$seeds" "$write" <<'PY'
import json, sys
from collections import OrderedDict

list_tsv, seeds, write = sys.argv[1], int(sys.argv[2]), sys.argv[3]
# (key in the stored table, how to read it from summary.json)
FIGURES = [
    ("frames", lambda s: s["frames_processed"]),
    ("distance_m", lambda s: s["evaluation"]["se2"]["distance_flown_m"]),
    ("sim2_ate_m", lambda s: s["evaluation"]["sim2"]["ate_m"]["rmse"]),
    ("sim2_ate_percent", lambda s: s["evaluation"]["sim2"]["ate_rmse_percent"]),
    ("se2_ate_m", lambda s: s["evaluation"]["se2"]["ate_m"]["rmse"]),
    ("se2_ate_percent", lambda s: s["evaluation"]["se2"]["ate_rmse_percent"]),
    ("se2_end_m", lambda s: s["evaluation"]["se2"]["end_point_error_m"]),
    ("se2_end_percent", lambda s: s["evaluation"]["se2"]["end_point_error_percent"]),
    ("end_unaligned_m", lambda s: s["evaluation"]["se2"]["end_point_error_unaligned_m"]),
    ("end_unaligned_percent", lambda s: s["evaluation"]["se2"]["end_point_error_unaligned_percent"]),
    ("bridged", lambda s: s["frames_bridged"]),
    ("reacquired", lambda s: s["frames_reacquired"]),
    ("fps", lambda s: s["fps"]),
    ("cpu_ms_per_frame", lambda s: s.get("cpu_ms_per_frame")),
]
# The offline whole-flight optimisation's track (summary.json "optimized"; backend.enable): the
# same accuracy figures beside the causal ones, and its CPU time. Not written to --write's table
# (the stored table is the causal track's).
OPTIMIZED = [
    ("opt_sim2_ate_m", lambda s: s["optimized"]["evaluation"]["sim2"]["ate_m"]["rmse"]),
    ("opt_se2_ate_m", lambda s: s["optimized"]["evaluation"]["se2"]["ate_m"]["rmse"]),
    ("opt_end_unaligned_m", lambda s: s["optimized"]["evaluation"]["se2"]["end_point_error_unaligned_m"]),
    ("opt_end_unaligned_percent", lambda s: s["optimized"]["evaluation"]["se2"]["end_point_error_unaligned_percent"]),
    ("opt_pairs", lambda s: s["optimized"]["pairs_verified"]),
    ("opt_cpu_s", lambda s: s["optimized"]["cpu_s"]),
]
runs = OrderedDict()  # (flight, build index) -> {"label", "flags", "seeds": {seed: summary}}
for line in open(list_tsv):
    f, i, label, flags, seed, path = line.rstrip("\n").split("\t")
    with open(path) as fh:
        s = json.load(fh)
    if s.get("evaluation") is None:  # a flight without GPS: its accuracy cells are "-"
        print(f"bench-flights.sh: {path} has no evaluation against GPS", file=sys.stderr)
    r = runs.setdefault((f, int(i)), {"label": label, "flags": flags, "seeds": {}})
    r["seeds"][int(seed)] = s

def read(get, s):
    try:
        return get(s)
    except (KeyError, TypeError):  # not in this summary.json (no GPS, an older build)
        return None

def stats(r, key, get):
    vals = [read(get, s) for _, s in sorted(r["seeds"].items())]
    if any(v is None for v in vals):
        return None  # a build whose summary.json does not have it
    return {"seed1": vals[0], "mean": sum(vals) / len(vals), "min": min(vals), "max": max(vals)}

def cell(st, fmt, pct=None):
    if st is None:
        return "-"
    text = fmt.format(st["mean"])
    if seeds > 1:
        text += " [" + fmt.format(st["min"]) + "-" + fmt.format(st["max"]) + "]"
    if pct is not None:
        text += " (" + "{:.2f} %".format(pct["mean"]) + ")"
    return text

many = len({i for _, i in runs}) > 1
print("| flight | " + ("build | " if many else "") + "frames | Sim(2) ATE (m) | SE(2) ATE (m) "
      "| end error, no alignment (m) | bridged / re-acquired | fps | CPU ms/frame |")
print("|---|" + ("---|" if many else "") + "---|---|---|---|---|---|---|")
for (f, i), r in runs.items():
    st = {k: stats(r, k, g) for k, g in FIGURES}
    name = f + (f" (`{r['flags']}`)" if r["flags"] else "")
    row = [name] + ([f"`{r['label']}`"] if many else []) + [
        "{:.0f}".format(st["frames"]["mean"]),
        cell(st["sim2_ate_m"], "{:.2f}"), cell(st["se2_ate_m"], "{:.2f}"),
        cell(st["end_unaligned_m"], "{:.2f}", st["end_unaligned_percent"]),
        cell(st["bridged"], "{:g}") + " / " +
        cell(st["reacquired"], "{:g}"),
        cell(st["fps"], "{:.1f}"), cell(st["cpu_ms_per_frame"], "{:.1f}")]
    print("| " + " | ".join(row) + " |")
opt_rows = []
for (f, i), r in runs.items():
    st = {k: stats(r, k, g) for k, g in OPTIMIZED}
    if st["opt_sim2_ate_m"] is None:
        continue
    name = f + (f" (`{r['flags']}`)" if r["flags"] else "")
    opt_rows.append([name] + ([f"`{r['label']}`"] if many else []) + [
        cell(st["opt_sim2_ate_m"], "{:.2f}"), cell(st["opt_se2_ate_m"], "{:.2f}"),
        cell(st["opt_end_unaligned_m"], "{:.2f}", st["opt_end_unaligned_percent"]),
        cell(st["opt_pairs"], "{:g}"), cell(st["opt_cpu_s"], "{:.2f}")])
if opt_rows:
    print("\nThe offline optimisation's track (vo_optimized.*), same flights and runs:\n")
    print("| flight | " + ("build | " if many else "") + "Sim(2) ATE (m) | SE(2) ATE (m) "
          "| end error, no alignment (m) | pairs verified | offline CPU (s) |")
    print("|---|" + ("---|" if many else "") + "---|---|---|---|---|")
    for row in opt_rows:
        print("| " + " | ".join(row) + " |")
if seeds > 1:
    print(f"\nMean over seeds 1-{seeds} [min-max]; the end error's % is of the distance flown.")

if write:
    with open(write, "w") as out:
        out.write("# Real flights: `aerovo run` on each flight of ../shared/data/flights, written by\n"
                  "# scripts/bench-flights.sh --write (BENCHMARKS.md, \"Real flights\": the build,\n"
                  "# machine and command). seed1 is the default run (--seed 1); mean, min and max\n"
                  f"# are over seeds 1-{seeds}. Units: m, % of the distance flown, frames, fps, ms.\n")
        out.write("flight\tflags\tfigure\tseed1\tmean\tmin\tmax\n")
        for (f, i), r in runs.items():
            if i != 0:
                continue
            for k, g in FIGURES:
                st = stats(r, k, g)
                if st is None:
                    continue
                out.write("\t".join([f, r["flags"], k] +
                          ["{:.6g}".format(st[c]) for c in ("seed1", "mean", "min", "max")]) + "\n")
PY
