"""The correspondence stage from Python: the shift between two crops of one texture, and the
same transforms and inlier counts as the C++ `aerovo correspondence` on the same files."""
import re

import numpy as np
import pytest

import aerovo
from conftest import texture, write_png

SHIFT = (12.0, -7.0)  # content motion prev -> curr, px (u right, v down)


@pytest.fixture(scope="module")
def pair():
    ground = texture(400, 500, seed=11)
    prev = ground[60:300, 80:400]
    curr = ground[67:307, 68:388]  # the camera moved 12 px left and 7 px down
    return prev, curr


def test_shift_between_two_crops(pair):
    prev, curr = pair
    r = aerovo.correspondence(prev, curr)
    assert r.success and r.method_used == "clustered"
    t = r.curr_from_prev
    assert t.shape == (3, 3)
    np.testing.assert_allclose(t[:2, 2], SHIFT, atol=0.05)
    np.testing.assert_allclose(t[:2, :2], np.eye(2), atol=1e-3)
    assert r.matches.shape == (len(r.inlier_mask), 2) and r.inlier_mask.dtype == bool
    assert r.num_inliers == int(r.inlier_mask.sum()) >= 100
    # The inliers are true correspondences: curr point = prev point + shift.
    prev_xy = r.prev_features.xy[r.matches[r.inlier_mask, 0]]
    curr_xy = r.curr_features.xy[r.matches[r.inlier_mask, 1]]
    np.testing.assert_allclose(curr_xy - prev_xy, np.broadcast_to(SHIFT, prev_xy.shape), atol=1.5)
    standard = aerovo.correspondence(prev, curr, method="standard")
    assert standard.method_used == "standard" and standard.cell_row == -1
    np.testing.assert_allclose(standard.curr_from_prev[:2, 2], SHIFT, atol=0.05)


def parse_cli(text, name):
    m = re.search(name + r": success .*?; (\d+) inliers / (\d+) matches.*?curr_from_prev = \[([^\]]*)\]",
                  text, re.S)
    assert m, f"no {name} result in: {text}"
    rows = [list(map(float, row.split())) for row in m.group(3).split(";")]
    return int(m.group(1)), int(m.group(2)), np.array(rows)


def test_same_result_as_the_cli(cli, tmp_path, pair):
    prev, curr = pair
    write_png(tmp_path / "prev.png", prev)
    write_png(tmp_path / "curr.png", curr)
    out = cli("correspondence", tmp_path / "prev.png", tmp_path / "curr.png")
    # What the CLI does: default SURF, default stage, standard twice (warm-up), then clustered
    # with zero motion.
    surf = aerovo.Surf()
    fp = surf.detect_and_describe(prev).features
    fc = surf.detect_and_describe(curr).features
    assert f"{len(fp)} SURF points" in out and f"{len(fc)} SURF points" in out
    stage = aerovo.CorrespondenceStage()
    stage.standard(fp, fc)
    results = {"standard": stage.standard(fp, fc),
               "clustered": stage.clustered(fp, fc, prev.shape[1], prev.shape[0])}
    for name, r in results.items():
        inliers, matches, m = parse_cli(out, name)
        assert (r.num_inliers, len(r.matches)) == (inliers, matches), name
        np.testing.assert_allclose(r.curr_from_prev[:2, :2], m[:2, :2], atol=1e-6)
        np.testing.assert_allclose(r.curr_from_prev[:2, 2], m[:2, 2], atol=1e-3)
    run = stage.run(fp, fc, prev.shape[1], prev.shape[0])  # no previous step: zero motion
    np.testing.assert_array_equal(run.curr_from_prev, results["clustered"].curr_from_prev)


def test_transform_arguments_are_checked(pair):
    prev, curr = pair
    with pytest.raises(ValueError, match="last_curr_from_prev must be a 2x3 or 3x3"):
        aerovo.correspondence(prev, curr, last_curr_from_prev=np.eye(2))
    r = aerovo.correspondence(prev, curr, last_curr_from_prev=[[1, 0, 12], [0, 1, -7]])
    assert r.success
    np.testing.assert_allclose(r.curr_from_prev[:2, 2], SHIFT, atol=0.05)
