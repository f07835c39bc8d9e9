#!/usr/bin/env python3
"""Time to first pose of `aerovo run` (BENCHMARKS.md "First pose within a second").

Usage: bench/first_pose.py AEROVO VIDEO OUT_DIR [run options...]
Runs `AEROVO run VIDEO --poses-jsonl - --no-report --force -o OUT_DIR [options]` and prints one
JSON line: seconds from starting the process to the first and second pose-stream lines
(first_pose_s, second_pose_s; a timer on the pipe, monotonic clock), the largest time between two
consecutive "pose" lines and the index of the pose after it (largest_gap_s, gap_before_index),
the run's wall time and CPU seconds (user + sys of the process, its threads included), and from
OUT_DIR/summary.json its fps, latency_ms max, lens_estimate (status, k, switch_frame,
caught_up_frame, wait_ms, time_ms) and, when the flight is simulated, the error against the truth
(SE(2)-aligned ATE RMSE and end-point error, percent of the distance flown).
"""
import json
import os
import resource
import subprocess
import sys
import time


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    binary, video, out = sys.argv[1:4]
    cmd = [binary, "run", video, "--poses-jsonl", "-", "--no-report", "--force", "-o", out]
    cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.monotonic()
    proc = subprocess.Popen(cmd + sys.argv[4:], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    arrivals = []
    gap, gap_index, last = 0.0, None, None
    for line in proc.stdout:
        now = time.monotonic() - t0
        if len(arrivals) < 2:
            arrivals.append(now)
        pose = json.loads(line)
        if pose.get("type") != "pose":
            continue
        if last is not None and now - last > gap:
            gap, gap_index = now - last, pose.get("index")
        last = now
    proc.wait()
    wall = time.monotonic() - t0
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)
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
        "largest_gap_s": round(gap, 3), "gap_before_index": gap_index,
        "wall_s": round(wall, 2), "cpu_s": round(cpu, 2), "fps": round(s["fps"], 1),
        "latency_max_ms": (s.get("latency_ms") or {}).get("max"),
        "lens": le.get("status"), "k": le.get("k"), "switch_frame": le.get("switch_frame"),
        "caught_up_frame": le.get("caught_up_frame"),
        "wait_ms": le.get("wait_ms"), "time_ms": le.get("time_ms"),
        "ate_rmse_percent": truth.get("ate_rmse_percent"),
        "end_point_error_percent": truth.get("end_point_error_percent")}))


if __name__ == "__main__":
    main()
