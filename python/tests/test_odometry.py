"""VisualOdometry from Python, frame by frame, on a synthetic nadir flight: crops of one
texture moving by known whole pixels, so the truth is exact."""
import os
import subprocess
import threading

import numpy as np
import pytest

import aerovo
from conftest import texture, write_png

FOCAL_PX, HEIGHT_M = 500.0, 50.0  # ground sampling distance 0.1 m/px
STEP_PX = (10, 4)                 # camera motion per frame in the ground image: right, down
FRAMES = 12


@pytest.fixture(scope="module")
def flight():
    ground = texture(320, 480, seed=21)
    frames = [ground[20 + i * STEP_PX[1]:260 + i * STEP_PX[1], 30 + i * STEP_PX[0]:350 + i * STEP_PX[0]]
              for i in range(FRAMES)]
    gsd = HEIGHT_M / FOCAL_PX
    # The VO frame: x = first image right, y = first image up (metres).
    truth = [(i * STEP_PX[0] * gsd, -i * STEP_PX[1] * gsd) for i in range(FRAMES)]
    return frames, np.array(truth)


def test_positions_follow_the_truth(flight):
    frames, truth = flight
    vo = aerovo.VisualOdometry(focal_px=FOCAL_PX, default_height_m=HEIGHT_M)
    results = [vo.process(f, time_s=i / 10.0) for i, f in enumerate(frames)]
    assert [r.status for r in results] == ["first"] + ["ok"] * (FRAMES - 1)
    positions = np.array([r.position_m for r in results])
    # Within 2 cm (0.2 px) of the truth at every frame, 1.1 m ... 11.9 m from the start.
    np.testing.assert_allclose(positions, truth, atol=0.02)
    last = results[-1]
    assert last.index == FRAMES - 1 and last.time_s == pytest.approx(1.1)
    assert last.gsd_m_per_px == pytest.approx(0.1) and abs(last.heading_rad) < 1e-3
    np.testing.assert_allclose(last.curr_from_prev[:2, 2], [-STEP_PX[0], -STEP_PX[1]], atol=0.05)
    assert last.n_inliers >= 50 and last.to_dict()["status"] == "ok"
    assert vo.stats == {"frames": FRAMES, "ok": FRAMES, "reacquired": 0, "bridged": 0}  # ok counts the first


def test_height_per_frame_and_errors(flight):
    frames, truth = flight
    vo = aerovo.VisualOdometry(aerovo.OdometryOptions(focal_px=FOCAL_PX))
    with pytest.raises(aerovo.InputError, match="height"):
        vo.process(frames[0], 0.0)  # metric run without a height
    vo = aerovo.VisualOdometry(focal_px=FOCAL_PX)
    # Twice the height: twice the metres per pixel.
    r = [vo.process(f, i / 10.0, height_m=2 * HEIGHT_M) for i, f in enumerate(frames[:4])]
    np.testing.assert_allclose(r[-1].position_m, 2 * truth[3], atol=0.04)
    with pytest.raises(aerovo.InputError, match="size"):
        vo.process(frames[4][:200], 0.4, height_m=HEIGHT_M)
    with pytest.raises(ValueError, match="max_scale_change must be"):
        aerovo.VisualOdometry(max_scale_change=2.0)


def test_values_that_are_not_finite_raise_and_the_track_goes_on(flight):
    """A NaN yaw (heading_from_yaw), time or attitude, or a height of 1e308 m, raises naming the
    frame; before, the positions became NaN or inf with status 'ok'. Refused frames are not
    counted: the next good one continues the track."""
    frames, truth = flight
    vo = aerovo.VisualOdometry(focal_px=FOCAL_PX, default_height_m=HEIGHT_M, heading_from_yaw=True)
    assert vo.process(frames[0], 0.0, yaw_deg=0.0).status == "first"
    with pytest.raises(ValueError, match="frame 1: yaw_deg = nan is not finite"):
        vo.process(frames[1], 0.1, yaw_deg=float("nan"))
    with pytest.raises(ValueError, match="frame 1: time_s = inf is not finite"):
        vo.process(frames[1], float("inf"))
    with pytest.raises(aerovo.InputError, match="frame 1: no valid height above ground"):
        vo.process(frames[1], 0.1, height_m=1e308)
    results = [vo.process(f, i / 10.0, yaw_deg=0.0) for i, f in enumerate(frames[1:4], start=1)]
    assert [r.index for r in results] == [1, 2, 3]
    np.testing.assert_allclose(results[-1].position_m, truth[3], atol=0.02)


def test_two_threads_share_one_engine(flight):
    frames, _ = flight
    surf = aerovo.Surf()
    expected = surf.detect_and_describe(frames[0]).keypoints
    out = [None, None]

    def work(k):
        out[k] = [surf.detect_and_describe(frames[0]).keypoints for _ in range(3)]

    threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for per_thread in out:
        for kps in per_thread:
            np.testing.assert_array_equal(kps, expected)


def test_same_track_as_the_cpp_example(flight, tmp_path):
    """examples/odometry_frames.cc (VisualOdometry from C++, default options) on the same
    frames as PNG files prints the same statuses, SURF and inlier counts and positions."""
    exe = os.environ.get("AEROVO_EXAMPLE_ODOMETRY")
    if not exe or not os.path.exists(exe):
        pytest.skip("AEROVO_EXAMPLE_ODOMETRY (examples' odometry_frames) is not set: run through "
                    "ctest with AEROVO_BUILD_EXAMPLES")
    frames, _ = flight
    paths = []
    for i, f in enumerate(frames):
        paths.append(tmp_path / f"frame_{i:02d}.png")
        write_png(paths[-1], f)
    out = subprocess.run([exe, str(FOCAL_PX), str(HEIGHT_M), "10", *map(str, paths)],
                         capture_output=True, text=True, timeout=120, check=True).stdout
    lines = out.strip().splitlines()
    assert len(lines) == FRAMES
    vo = aerovo.VisualOdometry(focal_px=FOCAL_PX, default_height_m=HEIGHT_M)
    for i, (f, line) in enumerate(zip(frames, lines)):
        r = vo.process(f, i / 10.0)
        expected = (f"frame {r.index} t {r.time_s:.2f} s: x {r.position_m[0]:.2f} m, "
                    f"y {r.position_m[1]:.2f} m, {r.status}, {r.n_surf} SURF points, "
                    f"{r.n_inliers} inliers")
        assert line == expected
