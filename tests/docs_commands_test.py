#!/usr/bin/env python3
"""The docs tell the truth: every fenced shell and Python block of README.md and docs/*.md is run
as a new user would run it (in a scratch folder, one per page), and the exit codes, files and
messages the docs state are checked.

Usage: docs_commands_test.py AEROVO_BINARY SOURCE_DIR [SHARED_DIR] [PYTHON_MODULE_DIR]
SHARED_DIR: $AEROVO_SHARED, else the argument, else SOURCE_DIR/../shared. Without it the test
exits 77 (skipped, with a message): half of the docs' commands run on its flights.

How it stays honest:
- Every command of a fenced block must have a row in PLAN below (a command added to the docs
  without one fails the test, and so does a row whose command is no longer in the docs). A row
  runs the command as written, with only the substitutions of PLACEHOLDERS (a file the docs name
  as an example: `flight.mp4`) and the row's own `extra` flags (each explained), or skips it
  with a reason. Skipped: what needs hardware (a camera, a serial autopilot, a stream sender),
  root and the network (the install scripts) or minutes of CPU (the Oxford evaluation).
- CLAIMS checks statements made in the text (exit codes, messages, files), each naming the page.
Cost: 43 s of CPU; 150-180 s wall measured on the shared 2-core VM under a load of ~18
(`/usr/bin/time python3 tests/docs_commands_test.py build/src/aerovo/cli/aerovo . ../shared`).
"""
import json
import os
import re
import shlex
import shutil
import socket
import subprocess
import sys
import tempfile
import time

SKIP = 77


def usage():
    print(__doc__)
    sys.exit(2)


if len(sys.argv) < 3:
    usage()
AEROVO = os.path.abspath(sys.argv[1])
SOURCE = os.path.abspath(sys.argv[2])
SHARED = os.environ.get("AEROVO_SHARED") or (sys.argv[3] if len(sys.argv) > 3 else "") or \
    os.path.join(SOURCE, "..", "shared")
SHARED = os.path.abspath(SHARED)
PYTHON_MODULE = os.path.abspath(sys.argv[4]) if len(sys.argv) > 4 and sys.argv[4] else ""
TAMPA = os.path.join(SHARED, "data", "flights", "tampa-phantom3")
TURIN = os.path.join(SHARED, "data", "flights", "turin-p4m")

if not os.path.isfile(os.path.join(TAMPA, "DJI_0054.JPG")):
    print(f"SKIP: no shared data at {SHARED} (set AEROVO_SHARED): the docs' commands run on its "
          "flights (tampa-phantom3, turin-p4m)")
    sys.exit(SKIP)

results = {"passed": 0, "failed": 0, "skipped": 0}
failures = []


def passed(what):
    results["passed"] += 1
    print(f"PASS: {what}")


def failed(what, detail=""):
    results["failed"] += 1
    failures.append(what)
    print(f"FAIL: {what}" + (f"\n{detail}" if detail else ""))


def skipped(what, why):
    results["skipped"] += 1
    print(f"SKIP: {what}: {why}")


# ------------------------------------------------------------------------- the docs' blocks

def fenced_blocks(path):
    """(language, first line number, text) of every fenced block of a Markdown file."""
    blocks, lang, start, body = [], None, 0, []
    with open(path, encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            m = re.match(r"^```(\S*)\s*$", line)
            if m and lang is None:
                lang, start, body = m.group(1), n + 1, []
            elif m and lang is not None and not m.group(1):
                blocks.append((lang, start, "".join(body)))
                lang = None
            elif lang is not None:
                body.append(line)
    return blocks


def shell_commands(text):
    """The commands of a shell block: continuation lines joined, comments dropped."""
    out = []
    for line in text.replace("\\\n", " ").splitlines():
        cmd = re.sub(r"\s+#.*$", "", line).strip()
        if cmd and not cmd.startswith("#"):
            out.append(re.sub(r"\s+", " ", cmd))
    return out


PAGES = ["README.md"] + sorted(
    os.path.join("docs", p) for p in os.listdir(os.path.join(SOURCE, "docs")) if p.endswith(".md"))
BLOCKS = {page: fenced_blocks(os.path.join(SOURCE, page)) for page in PAGES}


def doc_text(page):
    with open(os.path.join(SOURCE, page), encoding="utf-8") as f:
        return f.read()


# ------------------------------------------------------------------------- running aerovo

WORK = tempfile.mkdtemp(prefix="aerovo_docs_")
INPUTS = os.path.join(WORK, "inputs")
ENV = dict(os.environ)
ENV.pop("AEROVO_SIMD", None)


def run(args, cwd, env=None, timeout=240, stdin=None):
    """Runs a command line (a list; "aerovo" is the binary under test); returns (code, out)
    with stdout and stderr together, as a user sees them."""
    args = [AEROVO if a == "aerovo" else a for a in args]
    p = subprocess.run(args, cwd=cwd, env=env or ENV, stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, timeout=timeout, text=True, stdin=stdin)
    return p.returncode, p.stdout


def aerovo(cmd, cwd, **kw):
    return run(shlex.split(cmd), cwd, **kw)


def free_udp_port():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# The files the docs name as examples, and what stands for them here: a small simulated flight
# (video, its DJI SRT and GPX, copied without sim.json as a camera's files would be: the focal
# length and the height come from the SRT) and tampa's photos.
def make_inputs():
    os.makedirs(INPUTS)
    code, out = aerovo("aerovo simulate --pattern line --length-m 60 --speed-mps 10 --fps 10 "
                       "--width 640 --height 480 --gps-noise-m 0.5 -q -o sim", INPUTS)
    if code != 0:
        raise SystemExit(f"FAIL: cannot simulate the placeholder flight:\n{out}")
    sim = os.path.join(INPUTS, "sim")
    shutil.copy(os.path.join(sim, "video.mp4"), os.path.join(INPUTS, "flight.mp4"))
    shutil.copy(os.path.join(sim, "telemetry.srt"), os.path.join(INPUTS, "flight.SRT"))
    shutil.copy(os.path.join(sim, "track.gpx"), os.path.join(INPUTS, "rtk.gpx"))
    # A DJI video and its SRT side by side, as the aircraft records them.
    os.makedirs(os.path.join(INPUTS, "dji"))
    shutil.copy(os.path.join(sim, "video.mp4"), os.path.join(INPUTS, "dji", "DJI_0042.MP4"))
    shutil.copy(os.path.join(sim, "telemetry.srt"), os.path.join(INPUTS, "dji", "DJI_0042.SRT"))
    with open(os.path.join(INPUTS, "run.yaml"), "w") as f:
        f.write(f"input: {INPUTS}/flight.mp4\ntelemetry: {INPUTS}/flight.SRT\nstep: 2\n"
                "out: run-from-yaml\n")


PLACEHOLDERS = {  # word of the docs -> path here
    "flight.mp4": lambda: os.path.join(INPUTS, "flight.mp4"),
    "flight.SRT": lambda: os.path.join(INPUTS, "flight.SRT"),
    "DJI_0042.MP4": lambda: os.path.join(INPUTS, "dji", "DJI_0042.MP4"),
    "f.SRT": lambda: os.path.join(INPUTS, "flight.SRT"),
    "rtk.gpx": lambda: os.path.join(INPUTS, "rtk.gpx"),
    "run.yaml": lambda: os.path.join(INPUTS, "run.yaml"),
    "image.jpg": lambda: os.path.join(TAMPA, "DJI_0054.JPG"),
    "prev.jpg": lambda: os.path.join(TAMPA, "DJI_0054.JPG"),
    "curr.jpg": lambda: os.path.join(TAMPA, "DJI_0055.JPG"),
    # A ground station's address: the loopback here (never another host).
    "udp:192.168.1.10:14550": lambda: f"udp:127.0.0.1:{free_udp_port()}",
}


def substitute(cmd):
    words = []
    for w in shlex.split(cmd):
        if w in PLACEHOLDERS:
            w = PLACEHOLDERS[w]()
        elif w.startswith("../shared/"):
            w = os.path.join(SHARED, w[len("../shared/"):])
        words.append(w)
    return words


# ------------------------------------------------------------------------- the plan
# One row per command of a fenced block, by its text. `extra`: flags added (each with its why),
# `expect`: exit code, `says`: texts of its output, `files`: files it must leave (relative to
# the page's folder), `check`: a function(cwd, out) returning a problem or "".

class Row:
    def __init__(self, skip="", extra=(), extra_why="", expect=0, says=(), files=(),
                 check=None, timeout=240):
        self.skip, self.extra, self.extra_why = skip, list(extra), extra_why
        self.expect, self.says, self.files, self.check = expect, list(says), list(files), check
        self.timeout = timeout


def readme_output_line():
    """The run's answer as README.md quotes it (its unlabeled block after the tampa command)."""
    for lang, _, text in BLOCKS["README.md"]:
        if not lang and text.startswith("Tracked "):
            return text.strip()
    return "(README.md quotes no run answer)"


def run_folder_files_listed():
    """The files README.md says a run folder holds (its paragraph 'A run folder holds ...')."""
    text = doc_text("README.md")
    m = re.search(r"A run folder holds(.*?)\n\n", text, re.S)
    return set(re.findall(r"`([\w.]+\.(?:csv|tum|geojson|kml|gpx|json))`", m.group(1))) if m else set()


def check_tampa(cwd, out):
    problems = []
    folder = os.path.join(cwd, "tampa")
    written = {f for f in os.listdir(folder) if os.path.isfile(os.path.join(folder, f))}
    listed = run_folder_files_listed()
    # Every file README.md lists is there, and every file there is listed (hidden ones aside).
    for f in sorted(listed - written):
        problems.append(f"README.md lists {f}, the run did not write it")
    for f in sorted(w for w in written - listed if not w.startswith(".")):
        problems.append(f"the run wrote {f}, README.md's list of a run folder does not name it")
    # The lock stays (docs/reliability.md) and is not listed among the outputs.
    if ".aerovo.lock" not in written:
        problems.append("tampa/.aerovo.lock is not left (docs/reliability.md says it stays)")
    listing = out[out.find("Outputs in"):]
    if ".aerovo.lock" in listing:
        problems.append("the run lists .aerovo.lock among its outputs")
    # README.md's Results table: the tampa row is this run's summary.json.
    with open(os.path.join(folder, "summary.json")) as f:
        e = json.load(f)["evaluation"]
    row = re.search(r"^\| tampa-phantom3 \(`--altitude 57`\) \| 172 \| 1558 m \| ([\d.]+) m \(([\d.]+) %\)"
                    r" \| \*\*([\d.]+) m \(([\d.]+) %\)\*\* \| ([\d.]+) m \(([\d.]+) %\) \|",
                    doc_text("README.md"), re.M)
    if not row:
        problems.append("README.md's Results table has no tampa row in the expected form")
    else:
        quoted = [float(v) for v in row.groups()]
        measured = [e["se2"]["ate_m"]["rmse"], e["se2"]["ate_rmse_percent"],
                    e["sim2"]["ate_m"]["rmse"], e["sim2"]["ate_rmse_percent"],
                    e["se2"]["end_point_error_m"], e["se2"]["end_point_error_percent"]]
        for q, m_ in zip(quoted, measured):
            if abs(q - m_) > 0.006 + 0.005 * abs(m_):
                problems.append(f"README.md's tampa row says {q}, the run measured {m_:.3f} "
                                f"(Results table, in order: {quoted})")
    return "; ".join(problems)


def check_tampa_again(cwd, out):
    """`--config tampa/config.json` reproduces the run: the same positions, frame by frame."""
    def positions(folder):
        with open(os.path.join(cwd, folder, "frames.csv")) as f:
            rows = [line.split(",") for line in f.read().splitlines()]
        i, j = rows[0].index("x_m"), rows[0].index("y_m")
        return [(r[i], r[j]) for r in rows[1:]]
    a, b = positions("tampa"), positions("tampa-again")
    return "" if a == b and len(a) == 172 else f"tampa-again differs from tampa ({len(a)} vs {len(b)} rows)"


def check_report(cwd, out):
    figures = os.path.join(cwd, "tampa", "figures")
    names = os.listdir(figures) if os.path.isdir(figures) else []
    problems = []
    if "mosaic.jpg" not in names:
        problems.append("no tampa/figures/mosaic.jpg")
    if os.path.exists(os.path.join(cwd, "tampa", "mosaic.jpg")):
        problems.append("a mosaic.jpg in tampa/ itself, where README.md does not put it")
    if not any(n.endswith(".svg") for n in names) or not any(n.endswith(".png") for n in names):
        problems.append("no SVG or PNG figure in tampa/figures")
    # README.md's geo-referenced mosaic table: its files in the run folder.
    for f in ("mosaic.tif", "mosaic.kmz", "mosaic_geo.png", "mosaic_geo.json", "run.kml"):
        if not os.path.isfile(os.path.join(cwd, "tampa", f)):
            problems.append(f"no tampa/{f} (README.md, Geo-referenced mosaic)")
    return "; ".join(problems)


def check_mavlink(cwd, out):
    with open(os.path.join(cwd, "aerovo-run", "summary.json")) as f:
        m = json.load(f).get("mavlink") or {}
    return "" if m.get("sent", 0) > 0 and m.get("send_failed", 1) == 0 else \
        f"summary.json mavlink says nothing was sent: {m}"


def check_map_cover(cwd, out):
    """docs/map.md: summary.json `map` says the map covers the whole track."""
    with open(os.path.join(cwd, "with-map", "summary.json")) as f:
        m = json.load(f).get("map") or {}
    return "" if m.get("track_points", 0) > 0 and m.get("covered") == m.get("track_points") else \
        f"summary.json map says {m}"


def check_map_seed(cwd, out):
    """docs/map.md: GPS denied from the start, the map seeds the geo-reference."""
    with open(os.path.join(cwd, "no-gps", "summary.json")) as f:
        s = json.load(f)
    g = (s.get("map_fixes") or {}).get("georef") or {}
    return "" if s.get("heading_source") == "map" and g.get("seeded") is True else \
        f"summary.json heading_source {s.get('heading_source')!r}, map_fixes.georef {g}"


def check_map_fixes(cwd, out):
    """docs/map.md: summary.json `map_fixes` counts the attempts, map_fixes.csv has a row each."""
    with open(os.path.join(cwd, "map-fixes", "summary.json")) as f:
        m = json.load(f).get("map_fixes") or {}
    with open(os.path.join(cwd, "map-fixes", "map_fixes.csv")) as f:
        rows = len(f.read().splitlines()) - 1
    return "" if m.get("attempted", 0) > 0 and rows == m.get("attempted") else \
        f"summary.json map_fixes says {m}, map_fixes.csv has {rows} rows"


def check_two_maps(cwd, out):
    """docs/map.md: summary.json `map.paths` lists both maps in the order given, `map_fixes.by_map`
    counts per map and adds up to the fixes, map_fixes.csv has the `map` column."""
    with open(os.path.join(cwd, "two-maps", "summary.json")) as f:
        s = json.load(f)
    paths = (s.get("map") or {}).get("paths") or []
    m = s.get("map_fixes") or {}
    by_map = m.get("by_map") or []
    with open(os.path.join(cwd, "two-maps", "map_fixes.csv")) as f:
        header = f.readline().strip().split(",")
    if len(paths) != 2 or not paths[0].endswith("survey.tif") or not paths[1].endswith("map.tif"):
        return f"summary.json map.paths {paths}"
    if len(by_map) != 2 or sum(b.get("fixes", 0) for b in by_map) != m.get("fixes"):
        return f"summary.json map_fixes.by_map {by_map}, fixes {m.get('fixes')}"
    return "" if "map" in header else f"map_fixes.csv header {header}"


def check_online(cwd, out):
    with open(os.path.join(cwd, "online_run", "summary.json")) as f:
        o = json.load(f).get("online") or {}
    return "" if o.get("pairs_verified", 0) > 0 else \
        f"summary.json online says no pair was verified: {o}"


def check_closures(cwd, out):
    with open(os.path.join(cwd, "closures_run", "summary.json")) as f:
        o = json.load(f).get("optimized") or {}
    keys = ("closures_tried", "closures_verified", "closures_gated")
    if any(k not in o for k in keys):
        return f"summary.json optimized lacks the closure counts: {o.keys()}"
    return "" if o["closures_verified"] + o["closures_gated"] <= o["closures_tried"] else \
        f"summary.json optimized's closure counts do not add up: {[o[k] for k in keys]}"


HARDWARE = "needs hardware this machine does not have"
TAMPA_FIGURE = ("the recipe of docs/map_fixes_tampa.png (20 s of CPU over tampa-phantom3, writes "
                "into docs/); its path is run by tests/e2e/map_several_test.cc on a simulated "
                "flight: fixes from two maps, fused, and the report's markers and figure")
PLAN = {
    # docs/map.md
    "aerovo run flight.mp4 --telemetry flight.SRT --gps-denied-after-s 3 -o denied": Row(
        extra=["--no-report"], extra_why="the page is about summary.json and the summary text",
        says=["GPS denied from frame", "end error per km without GPS"],
        files=["denied/summary.json", "denied/frames.csv"]),
    "aerovo map build flight.mp4 --telemetry flight.SRT -o map.tif": Row(
        says=["running the flight into", "overviews"], files=["map.tif", "map_run/frames.csv"]),
    "aerovo map build map_run -o survey.tif --mosaic-size-px 1000": Row(
        says=["from the run 'map_run'", "512 x 512 px blocks, compression DEFLATE"],
        files=["survey.tif"]),
    "aerovo run flight.mp4 --telemetry flight.SRT --map map.tif --no-report -o with-map": Row(
        files=["with-map/summary.json"], check=check_map_cover),
    "aerovo run flight.mp4 --telemetry flight.SRT --map map.tif --gps-denied-after-s 3 "
    "--map-fix-every-n-frames 5 --no-report -o map-fixes": Row(
        files=["map-fixes/summary.json", "map-fixes/map_fixes.csv"], check=check_map_fixes),
    "aerovo run flight.mp4 --telemetry flight.SRT --map survey.tif --map map.tif "
    "--map-fix-apply --no-report -o two-maps": Row(
        files=["two-maps/summary.json", "two-maps/map_fixes.csv"], check=check_two_maps),
    "aerovo map build ../shared/data/flights/tampa-phantom3 --altitude 57 --end-s 657 -o "
    "tampa_first_half.tif": Row(skip=TAMPA_FIGURE),
    "aerovo run ../shared/data/flights/tampa-phantom3 --altitude 57 --gps-denied-after-s 657 --map "
    "tampa_first_half.tif --map-fix-every-n-frames 1 --map-fix-max-distance-px 4 "
    "--map-fix-frame-points 2000 --map-fix-match-width-px 300 --map-fix-apply --no-report -o "
    "tampa_map": Row(skip=TAMPA_FIGURE),
    "aerovo report tampa_map --no-mosaic": Row(skip=TAMPA_FIGURE),
    "cp tampa_map/figures/map_fixes.png docs/map_fixes_tampa.png": Row(skip=TAMPA_FIGURE),
    "aerovo run flight.mp4 --telemetry flight.SRT --map map.tif --gps-denied-after-s 0 "
    "--map-fix-apply --no-report -o no-gps": Row(
        says=["geo-reference", "from the map: frame"], files=["no-gps/map_fixes.csv"],
        check=check_map_seed),
    "aerovo map info map.tif": Row(says=["(EPSG:326", "m/px", "extent wgs84"]),
    "aerovo map info --json survey.tif": Row(says=['"extent_lonlat"', '"overviews"']),
    # docs/backend.md
    "aerovo simulate --pattern lawnmower --legs 4 --length-m 250 --spacing-m 50 --width 480 "
    "--height 270 --fps 1.5 --quiet -o backend_sim": Row(
        files=["backend_sim/video.mp4", "backend_sim/sim.json"]),
    "aerovo run backend_sim/video.mp4 --backend-enable --quiet --no-report -o "
    "backend_run": Row(
        files=["backend_run/vo_optimized.tum", "backend_run/vo_optimized.gpx",
               "backend_run/transforms_optimized.csv", "backend_run/summary.json"]),
    "aerovo run backend_sim/video.mp4 --backend-online --quiet --no-report -o "
    "online_run": Row(files=["online_run/vo.tum", "online_run/summary.json"],
                      check=check_online),
    "aerovo run backend_sim/video.mp4 --backend-enable --backend-closures --quiet --no-report -o "
    "closures_run": Row(files=["closures_run/vo_optimized.tum"], check=check_closures),
    # README.md
    "./scripts/demo.sh": Row(skip="installs Debian packages (apt-get, as root, over the network) "
                             "and builds; its `aerovo demo` takes minutes (the README says ~2-3 "
                             "min); the test scripts.demo_then_test_registers_every_test runs it "
                             "configure-only"),
    "./scripts/test.sh": Row(skip="is the whole CI (about 30 CPU-minutes), of which this test is "
                             "a part"),
    "aerovo run ../shared/data/flights/tampa-phantom3 --altitude 57 -o tampa": Row(
        extra=["--no-report"], extra_why="`aerovo report tampa` below writes the same report",
        says=[readme_output_line()], check=check_tampa),
    "aerovo run flight.mp4 --telemetry flight.SRT --step 10 -o flight": Row(
        says=["Tracked 7 of 7 frames"], files=["flight/frames.csv", "flight/summary.json"]),
    "aerovo run DJI_0042.MP4 -o dji_flight": Row(
        extra=["--no-report"], extra_why="the command is about where the telemetry comes from",
        says=["DJI_0042.SRT (found beside the video", "Tracked 61 of 61 frames"],
        files=["dji_flight/summary.json"]),
    "aerovo run flight.mp4 --telemetry 00000042.BIN --telemetry-offset-s 312.5 -o flight": Row(
        skip="needs an ArduPilot DataFlash log recorded with the example video; the reader is "
        "tested on logs written byte for byte (DataFlash.* in telemetry/dataflash_reader_test.cc)"),
    "aerovo run photos/ --telemetry 00000042.BIN -o survey": Row(
        skip="needs the photos of a camera an autopilot triggered and its DataFlash log; the "
        "pairing is tested on turin-p4m's photos with a log written from their EXIF "
        "(Runner.PhotosTakeTheCameraTriggersOfAnArduPilotLog in tests/e2e/run_flight_test.cc)"),
    "aerovo run flight.mp4 --telemetry flight.tlog --telemetry-offset-s 312.5 -o flight": Row(
        skip="needs a ground station's MAVLink telemetry log recorded with the example video; the "
        "reader is tested on logs written byte for byte (Tlog.* in telemetry/tlog_reader_test.cc) "
        "and on a ground station's real log (ctest mavlink.node_mavlink_tlog)"),
    "aerovo run flight.mp4 --telemetry log_12_2026-5-3-10-20-00.ulg --telemetry-offset-s 312.5 "
    "-o flight": Row(
        skip="needs a PX4 ULog recorded with the example video; the reader is tested on logs "
        "written byte for byte (ULog.* in telemetry/ulog_reader_test.cc)"),
    "aerovo run 0 --print-poses --altitude 80 --hfov-deg 70": Row(
        skip=f"{HARDWARE}: a camera (index 0)"),
    "aerovo run udp://0.0.0.0:5600 --poses-jsonl - --altitude 80 --hfov-deg 70 | my-consumer": Row(
        skip=f"{HARDWARE}: a video stream sent to port 5600 (and `my-consumer`)"),
    "aerovo run --config run.yaml": Row(files=["run-from-yaml/config.json",
                                               "run-from-yaml/frames.csv"]),
    "aerovo run --config tampa/config.json -o tampa-again": Row(
        extra=["--no-report"], extra_why="the reproduction is checked on frames.csv",
        check=check_tampa_again),
    "aerovo simulate --pattern lawnmower --height-m 100 -o sim": Row(
        extra=["--duration-s", "4", "--fps", "5"],
        extra_why="the whole survey is 3172 frames, minutes of rendering (README.md says so); "
                  "its first 4 s at 5 fps are the same flight",
        files=["sim/video.mp4", "sim/telemetry.srt", "sim/track.gpx", "sim/ground_truth.tum",
               "sim/ground_truth.csv", "sim/sim.json"]),
    "aerovo run sim/video.mp4 -o sim-run": Row(
        says=["Focal length", "(sim.json)", "Comparison with the ground truth"]),
    "aerovo run flight.mp4 --telemetry f.SRT --truth rtk.gpx": Row(
        says=["Comparison with the ground truth"], files=["aerovo-run/summary.json"]),
    "aerovo features detect image.jpg": Row(says=["800x600, 954 keypoints"]),
    "aerovo features eval ../shared/data/oxford --markdown": Row(
        skip="evaluates 40 image pairs with 4 detectors: over 5 minutes on 2 cores "
             "(BENCHMARKS.md has its tables)"),
    "aerovo correspondence prev.jpg curr.jpg": Row(
        says=["DJI_0054.JPG: 800x600, 955 SURF points", "standard: success",
              "clustered: success"]),
    "aerovo telemetry flight.SRT --print": Row(
        says=["records ", "time_s,frame,lat_deg,lon_deg"]),
    "aerovo report tampa": Row(says=["tampa/report.html"], files=["tampa/report.html"],
                               check=check_report),
    "aerovo report exp --no-mosaic": Row(files=["exp/report.html"]),
    # docs/autopilot.md
    "aerovo run /dev/video0 --hfov-deg 70 --mavlink serial:/dev/ttyAMA0:921600": Row(
        skip=f"{HARDWARE}: a camera and a flight controller on a UART "
             "(tests/mavlink runs the serial link's protocol over UDP)"),
    "aerovo run /dev/video0 --hfov-deg 70 --mavlink udpin:0.0.0.0:14540": Row(
        skip=f"{HARDWARE}: a camera (the udpin link is tested by mavlink.node_mavlink_udpin)"),
    "aerovo run flight.mp4 --altitude 80 --hfov-deg 70 --mavlink udp:192.168.1.10:14550": Row(
        extra=["--no-report"], extra_why="the link is what is checked",
        check=check_mavlink),
    # docs/python.md (run twice: --force makes it repeatable; checked below)
    "aerovo simulate --pattern line --length-m 20 --speed-mps 10 --fps 2 --height-m 100 "
    "--focal-px 500 --width 640 --height 480 --frames-only --image-format png -o sim --force": Row(
        files=["sim/frames/frame_000000.png", "sim/sim.json"]),
}

# Before a command: what the docs' text says to do first (an experiment folder for `aerovo
# report exp`: the README's table makes one with `aerovo experiment ransac`; here on the
# placeholder flight, every 5th frame).
BEFORE = {
    "aerovo report exp --no-mosaic":
        "aerovo experiment ransac flight.mp4 --telemetry flight.SRT --step 5 --no-report -o exp",
}

SUBCOMMANDS = {"run", "simulate", "report", "features", "correspondence", "experiment", "demo",
               "telemetry", "help", "completion"}

NOT_RUN_BLOCKS = {  # language -> why its blocks are not run here
    "cmake": "a consumer's CMakeLists.txt: install.find_package_consumer builds one",
    "cpp": "excerpts of examples/*.cc: readme.cpp_excerpts_are_in_examples and "
           "examples.on_a_simulated_flight",
    "mermaid": "a diagram",
}


def page_dir(page):
    """The scratch folder of a page's commands (one per page: README.md and docs/python.md
    both write `sim`)."""
    return os.path.join(WORK, page.replace("/", "_"))


def run_page_commands(page, cwd):
    for lang, line, text in BLOCKS[page]:
        where = f"{page}:{line}"
        if lang in NOT_RUN_BLOCKS:
            skipped(f"{where} ```{lang}", NOT_RUN_BLOCKS[lang])
            continue
        if lang == "python":
            continue  # below, per page
        commands = shell_commands(text)
        if lang == "" and not all(re.match(r"(aerovo [a-z]+ |\./)", c) and
                                  c.split()[1] in SUBCOMMANDS | {"demo.sh", "test.sh"}
                                  or c.startswith("./") for c in commands):
            continue  # output or a diagram, not commands (checked where it is quoted)
        for cmd in commands:
            row = PLAN.get(cmd)
            if row is None:
                failed(f"{where}: `{cmd}` has no row in PLAN (tests/docs_commands_test.py): "
                       "say how to run it or why not")
                continue
            row.used = True
            if row.skip:
                skipped(f"{where}: `{cmd}`", row.skip)
                continue
            if cmd in BEFORE:
                code, out = run(substitute(BEFORE[cmd]), cwd)
                if code != 0:
                    failed(f"{where}: before `{cmd}`: `{BEFORE[cmd]}` exit {code}", out[-3000:])
                    continue
            args = substitute(cmd) + row.extra
            start = time.monotonic()
            if "|" in args:
                failed(f"{where}: `{cmd}`: a pipe in a command that is run")
                continue
            try:
                code, out = run(args, cwd, timeout=row.timeout)
            except subprocess.TimeoutExpired:
                failed(f"{where}: `{cmd}` did not end within {row.timeout} s")
                continue
            took = time.monotonic() - start
            problems = []
            if code != row.expect:
                problems.append(f"exit {code}, expected {row.expect}")
            problems += [f"does not say {s!r}" for s in row.says if s not in out]
            problems += [f"left no {f}" for f in row.files if not os.path.exists(os.path.join(cwd, f))]
            if not problems and row.check:
                p = row.check(cwd, out)
                if p:
                    problems.append(p)
            label = f"{where}: `{cmd}`" + (f" (+ {' '.join(row.extra)}: {row.extra_why})"
                                          if row.extra else "") + f" [{took:.1f} s]"
            if problems:
                failed(label + ": " + "; ".join(problems), out[-3000:])
            else:
                passed(label)


def run_python_pages():
    """docs/python.md's example: its shell block, then its Python blocks in one namespace, the
    second after the `aerovo run` its text names. README.md's Python lines are an excerpt of it
    (python_tests checks that)."""
    for lang, line, _ in BLOCKS["README.md"]:
        if lang == "python":
            skipped(f"README.md:{line} ```python", "an excerpt of docs/python.md's example, which "
                    "runs below (python_tests checks every line is there)")
    page = os.path.join("docs", "python.md")
    cwd = page_dir(page)
    code_blocks = [(ln, t) for lang, ln, t in BLOCKS[page] if lang == "python"]
    # Its shell command again, into the used folder: --force makes it repeatable; without it,
    # the refusal the page describes.
    (cmd,) = [c for lang, _, t in BLOCKS[page] if lang == "sh" for c in shell_commands(t)]
    code, out = run(substitute(cmd), cwd)
    if code != 0:
        failed(f"{page}: `{cmd}` run a second time: exit {code}", out[-2000:])
    else:
        passed(f"{page}: its shell command runs a second time (with --force)")
    no_force = [w for w in substitute(cmd) if w != "--force"]
    code, out = run(no_force, cwd)
    said = "aerovo: error: output folder 'sim' is not empty ("
    if code != 1 or said not in out:
        failed(f"{page}: without --force a second run should stop, exit 1, saying {said!r}: "
               f"exit {code}", out[-2000:])
    else:
        passed(f"{page}: without --force a second run stops: exit 1, {said!r}")
    if not PYTHON_MODULE or not os.path.isdir(PYTHON_MODULE) or not any(
            n.startswith("aerovo.") and n.endswith(".so") for n in os.listdir(PYTHON_MODULE)):
        for ln, _ in code_blocks:
            skipped(f"{page}:{ln} ```python", "the Python module was not built (pybind11-dev, "
                    "python3-dev, python3-numpy missing)")
        return
    try:
        import numpy  # noqa: F401  (the blocks' own import; the module needs it too)
    except ImportError:
        for ln, _ in code_blocks:
            skipped(f"{page}:{ln} ```python", f"{sys.executable} has no numpy: run this test with "
                    "the interpreter the module was built for (ctest does)")
        return
    text = doc_text(page)
    m = re.search(r"`(aerovo run sim/frames -o run --force)`", text)
    if not m:
        failed(f"{page}: names no `aerovo run sim/frames -o run --force` for its run folder")
        return
    namespace = {}
    env_path = list(sys.path)
    sys.path.insert(0, PYTHON_MODULE)
    old = os.getcwd()
    os.chdir(cwd)
    try:
        for i, (ln, block) in enumerate(code_blocks):
            if i == 1:
                code, out = run(substitute(m.group(1)), cwd)
                if code != 0:
                    failed(f"{page}: `{m.group(1)}` exit {code}", out[-2000:])
                    return
            try:
                exec(compile(block, f"{page}:{ln}", "exec"), namespace)
                passed(f"{page}:{ln} ```python runs")
            except Exception as e:  # the block's own assert or an error: the page is wrong
                failed(f"{page}:{ln} ```python: {type(e).__name__}: {e}")
                return
    finally:
        os.chdir(old)
        sys.path[:] = env_path


# ------------------------------------------------------------------------- claims of the text

def claim(page, statement, ok, detail=""):
    (passed if ok else failed)(f"{page}: {statement}", *([detail] if not ok else []))


def check_claims():
    cwd = os.path.join(WORK, "claims")
    os.makedirs(cwd)
    flight = PLACEHOLDERS["flight.mp4"]()

    # docs/reliability.md: `--end-s` before `--start-s` is a usage error before any output.
    code, out = aerovo(f"aerovo run {flight} --start-s 3 --end-s 2 -o w", cwd)
    claim("docs/reliability.md", "`--end-s` before `--start-s`: exit 2, "
          "`end_s must be >= start_s (or < 0)`, no output folder",
          code == 2 and "end_s must be >= start_s (or < 0)" in out
          and not os.path.exists(os.path.join(cwd, "w")), f"exit {code}\n{out}")
    # docs/reliability.md: `--altitude 1e308`, `--focal-px 1e-300`.
    code, out = aerovo(f"aerovo run {flight} --altitude 1e308 -o w", cwd)
    claim("docs/reliability.md", "`--altitude 1e308`: exit 2, "
          "`run configuration: altitude_m must be in [0, 100000], got 1e+308`",
          code == 2 and "run configuration: altitude_m must be in [0, 100000], got 1e+308" in out,
          f"exit {code}\n{out}")
    code, out = aerovo(f"aerovo run {flight} --focal-px 1e-300 -o w", cwd)
    claim("docs/reliability.md", "`--focal-px 1e-300`: exit 2, "
          "`focal_px must be 0 (unknown) or at least 1 px, got 1e-300`",
          code == 2 and "focal_px must be 0 (unknown) or at least 1 px, got 1e-300" in out,
          f"exit {code}\n{out}")
    # docs/options.md is `aerovo run --list-options`, ranges as the messages write them.
    code, out = aerovo("aerovo run --list-options", cwd)
    claim("docs/options.md", "is `aerovo run --list-options` (regenerate it with that command)",
          code == 0 and out == doc_text(os.path.join("docs", "options.md")))

    # README.md: the exit codes table, and every --help ends with the same codes.
    table = re.search(r"\*\*Exit codes\*\*.*?\n\n((?:\s*\|.*\n)+)", doc_text("README.md"), re.S)
    codes = re.findall(r"\b(\d+)\b", " ".join(
        re.match(r"\s*\|\s*([\d, ]+)\s*\|", r).group(1) for r in table.group(1).splitlines()
        if re.match(r"\s*\|\s*[\d, ]+\s*\|", r))) if table else []
    code, help_text = aerovo("aerovo --help", cwd)
    listed = help_text[help_text.find("Exit codes:"):]
    missing = [c for c in codes if not re.search(rf"\b{c}\b", listed)]
    claim("README.md", f"exit codes {', '.join(codes)} are all in `aerovo --help`",
          code == 0 and len(codes) >= 7 and not missing, f"missing {missing}\n{listed}")
    code, out = aerovo("aerovo rnu", cwd)
    claim("README.md", "`aerovo rnu` says `aerovo: unknown command 'rnu'; did you mean 'run'?` "
          "(exit 2)", code == 2 and "aerovo: unknown command 'rnu'; did you mean 'run'?" in out,
          f"exit {code}\n{out}")

    # README.md: `aerovo --version` names the SIMD kernels; AEROVO_SIMD=scalar, highway.
    names = {}
    for mode in ("", "scalar", "highway"):
        env = dict(ENV, AEROVO_SIMD=mode) if mode else ENV
        code, out = run([AEROVO, "--version"], cwd, env=env)
        m = re.search(r"^aerovo [\d.]+ \(SIMD: ([a-z0-9_]+)\)$", out.strip())
        names[mode or "native"] = m.group(1) if m and code == 0 else f"? ({out.strip()})"
    highway_targets = {"avx3", "avx3_dl", "avx3_zen4", "avx3_spr", "avx2", "sse4", "ssse3",
                       "neon", "neon_bf16", "sve", "sve2", "sve_256", "sve2_128", "emu128"}
    claim("README.md", "`aerovo --version` names the kernels: scalar with AEROVO_SIMD=scalar, "
          "a Highway target with AEROVO_SIMD=highway",
          names["scalar"] == "scalar" and names["highway"] in highway_targets
          and names["native"] in {"avx2", "sse4"} | highway_targets, str(names))

    # README.md: a demo into a used aerovo-demo stops at once, naming it.
    demo = os.path.join(cwd, "aerovo-demo")
    os.makedirs(os.path.join(demo, "run"))
    with open(os.path.join(demo, "run", "summary.json"), "w") as f:
        f.write("{}\n")
    start = time.monotonic()
    code, out = aerovo("aerovo demo --quick", cwd, timeout=60)
    claim("README.md", "a second `aerovo demo` into a used aerovo-demo stops at once: exit 1, "
          "`output folder 'aerovo-demo' is not empty (`",
          code == 1 and "output folder 'aerovo-demo' is not empty (" in out and "--force" in out
          and time.monotonic() - start < 10, f"exit {code}\n{out}")

    # docs/inputs.md: `flight.srt:42: latitude 123.4 out of range [-90, 90]`, the line named
    # being the one that holds the value: DJI subtitles of 6 lines, the sixth's latitude on its
    # 5th line (its first line is 36).
    example = "`flight.srt:42: latitude 123.4 out of range [-90, 90]`"
    lines = []
    for k in range(1, 8):
        lat = "123.4" if k == 6 else f"43.{k}"
        lines += [str(k), f"00:00:0{k - 1},000 --> 00:00:0{k},000",
                  f'<font size="28">FrameCnt: {k}, DiffTime: 1000ms',
                  "2023-05-01 12:00:00,000,000", f"[latitude: {lat}] [longitude: 6.{k}]",
                  "[rel_alt: 50.0 abs_alt: 300.0] </font>", ""]
    bad_line = lines.index("[latitude: 123.4] [longitude: 6.6]") + 1
    with open(os.path.join(cwd, "flight.srt"), "w") as f:
        f.write("\n".join(lines))
    code, out = aerovo("aerovo telemetry flight.srt", cwd)
    said = f"flight.srt:{bad_line}: latitude 123.4 out of range [-90, 90]"
    claim("docs/inputs.md", f"an SRT error names the file and the line holding the bad value "
          f"(its example {example}; here `{said}`)",
          example in doc_text(os.path.join("docs", "inputs.md")) and code == 1 and said in out,
          f"exit {code}\n{out}")

    # docs/inputs.md: `aerovo telemetry PHOTO` says where the XMP came from, "unknown" otherwise.
    turin = sorted(p for p in os.listdir(TURIN) if p.upper().endswith(".JPG"))[0]
    code, out = aerovo(f"aerovo telemetry {os.path.join(TURIN, turin)}", cwd)
    claim("docs/inputs.md", "`aerovo telemetry PHOTO` on a DJI photo: `xmp          read from "
          "the photo's XMP segment` and its `xmp values`",
          code == 0 and "xmp          read from the photo's XMP segment" in out
          and re.search(r"xmp values   relative altitude [\d.]+ m", out) is not None, out)
    code, out = aerovo(f"aerovo telemetry {os.path.join(TAMPA, 'DJI_0054.JPG')}", cwd)
    claim("docs/inputs.md", "`aerovo telemetry PHOTO` on a photo without XMP values: `xmp          "
          "none (the photo has no DJI, Parrot, Pix4D Camera or senseFly XMP values)`",
          code == 0 and "xmp          none (the photo has no DJI, Parrot, Pix4D Camera or "
          "senseFly XMP values)" in out, out)


def main():
    start = time.monotonic()
    try:
        make_inputs()
        for page in PAGES:
            cwd = page_dir(page)
            os.makedirs(cwd)
            run_page_commands(page, cwd)
        run_python_pages()
        check_claims()
        for cmd, row in PLAN.items():
            if not getattr(row, "used", False):
                failed(f"PLAN has a row for `{cmd}`, which no fenced block of the docs holds "
                       "any more: remove it")
    finally:
        shutil.rmtree(WORK, ignore_errors=True)
    print(f"docs commands checked in {time.monotonic() - start:.0f} s")
    if failures:
        print("Failed:\n  " + "\n  ".join(failures))
    print(f"{results['passed']} passed, {results['failed']} failed, {results['skipped']} skipped")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
