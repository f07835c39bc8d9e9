"""aerovo.read_run on the folder of a real `aerovo run` (a short simulated flight): the arrays
are frames.csv's columns, the dicts summary.json and config.json."""
import csv
import json
import math

import numpy as np
import pytest

import aerovo


def test_frames_are_the_csv_columns(run_dir):
    run = aerovo.read_run(str(run_dir))
    with open(run_dir / "frames.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    frames = run["frames"]
    assert len(rows) == 9 and len(frames["frame"]) == 9
    np.testing.assert_array_equal(frames["frame"], [int(r["frame"]) for r in rows])
    assert frames["frame"].dtype == np.int32 and frames["x_m"].dtype == np.float64
    for col in ("time_s", "x_m", "y_m", "lat_deg", "lon_deg", "gps_lat_deg", "total_ms"):
        np.testing.assert_array_equal(frames[col], [float(r[col]) for r in rows], err_msg=col)
    np.testing.assert_array_equal(frames["n_inliers"], [int(r["n_inliers"]) for r in rows])
    assert list(frames["status"]) == [r["status"] for r in rows]
    assert frames["status"][0] == "first" and set(frames["status"][1:]) == {"ok"}
    # The flight: 40 m east (ENU metres, geo-referenced by the telemetry).
    assert math.hypot(frames["x_m"][-1] - frames["x_m"][0], frames["y_m"][-1] - frames["y_m"][0]) == \
        pytest.approx(40.0, rel=0.02)
    tf = run["transforms"]
    assert tf["first_px_from_frame"].shape == (len(tf["frame"]), 2, 3)
    np.testing.assert_allclose(tf["first_px_from_frame"][0], [[1, 0, 0], [0, 1, 0]], atol=1e-9)


def test_summary_and_config_are_the_json_files(run_dir):
    run = aerovo.read_run(run_dir)  # a pathlib.Path
    assert run["summary"] == json.loads((run_dir / "summary.json").read_text())
    assert run["config"] == json.loads((run_dir / "config.json").read_text())
    assert run["dir"] == str(run_dir)


def test_a_folder_without_frames_csv_names_the_file(tmp_path):
    with pytest.raises(aerovo.InputError, match="frames.csv"):
        aerovo.read_run(str(tmp_path))
    (tmp_path / "frames.csv").write_text("frame,time_s\n0,0\n")
    with pytest.raises(aerovo.InputError, match="frames.csv"):
        aerovo.read_run(str(tmp_path))
