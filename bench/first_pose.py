#!/usr/bin/env python3
"""Time to first pose of `aerovo run` (BENCHMARKS.md "First pose within a second").

Usage: bench/first_pose.py AEROVO VIDEO OUT_DIR [run options...]
Runs `AEROVO run VIDEO --poses-jsonl - --no-report --force -o OUT_DIR [options]` and prints one
JSON line: seconds from starting the process to the first and second pose-stream lines
(first_pose_s, second_pose_s; a timer on the pipe, monotonic clock), the run's wall time, and
from OUT_DIR/summary.json its fps, lens_estimate (status, k, switch_frame, wait_ms, time_ms) and
the end-point error against the truth when the flight is simulated.
"""
import json
import os
import subprocess
import sys
import time


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    binary, video, out = sys.argv[1:4]
    cmd = [binary, "run", video, "--poses-jsonl", "-", "--no-report", "--force", "-o", out]
    t0 = time.monotonic()
    proc = subprocess.Popen(cmd + sys.argv[4:], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    arrivals = []
    for _ in proc.stdout:
        if len(arrivals) < 2:
            arrivals.append(time.monotonic() - t0)
    proc.wait()
    wall = time.monotonic() - t0
    if proc.returncode != 0:
        sys.exit(f"{binary} run {video}: exit {proc.returncode}")
    with open(os.path.join(out, "summary.json")) as f:
        s = json.load(f)
    le = s.get("lens_estimate") or {}
    truth = (s.get("truth_evaluation") or {}).get("se2") or {}
    print(json.dumps({
        "binary": binary, "video": video,
        "first_pose_s": round(arrivals[0], 3) if arrivals else None,
        "second_pose_s": round(arrivals[1], 3) if len(arrivals) > 1 else None,
        "wall_s": round(wall, 2), "fps": round(s["fps"], 1),
        "lens": le.get("status"), "k": le.get("k"), "switch_frame": le.get("switch_frame"),
        "wait_ms": le.get("wait_ms"), "time_ms": le.get("time_ms"),
        "end_point_error_percent": truth.get("end_point_error_percent")}))


if __name__ == "__main__":
    main()
