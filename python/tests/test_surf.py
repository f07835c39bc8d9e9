"""SURF from Python: the keypoints are those of the C++ `aerovo features detect` on the same
image file, exactly; images of every accepted layout give the same grey; bad input raises."""
import json
import math

import numpy as np
import pytest

import aerovo
from conftest import texture, write_png


def cli_keypoints(cli, tmp_path, image, *flags):
    png = tmp_path / "image.png"
    out = tmp_path / "keypoints.json"
    write_png(png, image)
    cli("features", "detect", png, "--json", out, *flags)
    return json.loads(out.read_text())


def assert_same_keypoints(py_kps, cpp):
    assert len(py_kps) == len(cpp["keypoints"])
    for name in ("x", "y", "scale", "response", "laplacian", "octave"):
        # JSON numbers of the C++ floats read back exactly as the same doubles.
        np.testing.assert_array_equal(py_kps[name].astype(np.float64),
                                      [k[name] for k in cpp["keypoints"]], err_msg=name)
    orientation_deg = [float(o) * 180.0 / 3.14159265358979323846 for o in py_kps["orientation"]]
    np.testing.assert_array_equal(orientation_deg, [k["orientation_deg"] for k in cpp["keypoints"]])


def test_keypoints_equal_to_the_cli(cli, tmp_path):
    image = texture(240, 320, seed=1)
    cpp = cli_keypoints(cli, tmp_path, image)
    r = aerovo.surf(image)
    assert len(r) > 300
    assert_same_keypoints(r.keypoints, cpp)
    assert r.descriptors.shape == (len(r), 64) and r.descriptors.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(r.descriptors, axis=1), 1.0, atol=1e-5)
    # Strongest first, positions inside the image.
    assert np.all(np.diff(r.keypoints["response"]) <= 0)
    assert np.all((r.features.xy >= 0) & (r.features.xy <= [319, 239]))


def test_keypoints_equal_to_the_cli_with_options(cli, tmp_path):
    image = texture(200, 260, seed=2)
    cpp = cli_keypoints(cli, tmp_path, image, "--surf-threshold", 400, "--octaves", 4, "--levels", 5,
                        "--upright", "--extended", "--max", 200)
    options = aerovo.SurfOptions(hessian_threshold=400, num_octaves=4, num_scale_levels=5,
                                 upright=True, extended=True, max_keypoints=200)
    r = aerovo.Surf(options).detect_and_describe(image)
    assert len(r) == 200
    assert_same_keypoints(r.keypoints, cpp)
    assert cpp["descriptor_size"] == 128 and r.descriptors.shape == (200, 128)
    assert np.all(r.keypoints["orientation"] == 0)
    # Keyword arguments are the same options.
    kw = aerovo.surf(image, hessian_threshold=400, num_octaves=4, num_scale_levels=5,
                     upright=True, extended=True, max_keypoints=200)
    np.testing.assert_array_equal(kw.keypoints, r.keypoints)
    np.testing.assert_array_equal(kw.descriptors, r.descriptors)


def test_colour_is_grey_as_the_cpp_reader(tmp_path):
    rgb = np.stack([texture(120, 160, s) for s in (3, 4, 5)], axis=2)
    png = tmp_path / "rgb.png"
    write_png(png, rgb)
    grey_cpp = aerovo.read_image(png)  # a str or a pathlib.Path  # frames' ReadGrayImage: decoded as BGR, cvtColor
    grey = aerovo.to_gray(rgb)
    np.testing.assert_array_equal(grey, grey_cpp)
    np.testing.assert_array_equal(aerovo.to_gray(rgb[:, :, ::-1], channels="bgr"), grey)
    rgba = np.concatenate([rgb, np.full((120, 160, 1), 7, np.uint8)], axis=2)
    np.testing.assert_array_equal(aerovo.to_gray(rgba), grey)
    # 0.299 R + 0.587 G + 0.114 B, rounded (OpenCV's fixed point: within one level).
    expected = rgb.astype(np.float64) @ [0.299, 0.587, 0.114]
    assert np.max(np.abs(grey - expected)) <= 1.0
    np.testing.assert_array_equal(aerovo.surf(rgb).keypoints, aerovo.surf(grey_cpp).keypoints)


def test_non_contiguous_and_single_channel_arrays():
    image = texture(240, 320, seed=6)
    flipped = image[:, ::-1]
    assert not flipped.flags.c_contiguous
    np.testing.assert_array_equal(aerovo.surf(flipped).keypoints,
                                  aerovo.surf(np.ascontiguousarray(flipped)).keypoints)
    strided = texture(480, 320, seed=7)[::2]
    np.testing.assert_array_equal(aerovo.surf(strided).keypoints,
                                  aerovo.surf(strided.copy()).keypoints)
    np.testing.assert_array_equal(aerovo.surf(image[:, :, None]).keypoints, aerovo.surf(image).keypoints)


def test_bad_images_raise_clear_errors():
    image = texture(64, 64, seed=8)
    with pytest.raises(TypeError, match="dtype uint8.*float64"):
        aerovo.surf(image.astype(np.float64))
    with pytest.raises(TypeError, match="numpy array"):
        aerovo.surf(image.tolist())
    with pytest.raises(ValueError, match=r"shape \(64,\)"):
        aerovo.surf(image[0])
    with pytest.raises(ValueError, match=r"shape \(64, 64, 2\)"):
        aerovo.surf(np.zeros((64, 64, 2), np.uint8))
    with pytest.raises(ValueError, match="empty"):
        aerovo.surf(np.zeros((0, 64), np.uint8))
    with pytest.raises(ValueError, match="channels"):
        aerovo.surf(image, channels="hsv")
    with pytest.raises(ValueError):  # smaller than the smallest filter: the C++ InvalidArgument
        aerovo.surf(np.zeros((4, 4), np.uint8))
    with pytest.raises(aerovo.InputError, match="no-such.png"):
        aerovo.read_image("no-such.png")
