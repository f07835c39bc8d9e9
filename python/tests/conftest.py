"""Shared helpers of the aerovo Python tests (run by ctest python_tests, see ../CMakeLists.txt).

Environment: PYTHONPATH holds the built module; AEROVO_CLI is the `aerovo` executable the
results are compared with (tests that need it skip with a message when it is not set).
"""
import os
import struct
import subprocess
import zlib

import numpy as np
import pytest


def box_blur(a, r):
    """Mean over a (2r+1) x (2r+1) box, reflected at the borders."""
    for axis in (0, 1):
        pad = [(r + 1, r) if i == axis else (0, 0) for i in (0, 1)]
        c = np.cumsum(np.pad(a, pad, mode="reflect"), axis=axis)
        n = c.shape[axis]
        a = (np.take(c, range(2 * r + 1, n), axis=axis) -
             np.take(c, range(0, n - 2 * r - 1), axis=axis)) / (2 * r + 1)
    return a


def texture(h, w, seed):
    """A uint8 image of blob-like texture at two scales: ~550 SURF points per 320x240 at the
    default threshold (1000)."""
    rng = np.random.default_rng(seed)
    a = box_blur(box_blur(rng.random((h, w)), 3), 3) + 0.5 * box_blur(box_blur(rng.random((h, w)), 8), 8)
    lo, hi = np.percentile(a, [1, 99])
    return np.clip((a - lo) / (hi - lo) * 255, 0, 255).astype(np.uint8)


def write_png(path, image):
    """A PNG file of a uint8 (h, w) grey or (h, w, 3) RGB array (no filtering, zlib)."""
    image = np.ascontiguousarray(image, dtype=np.uint8)
    h, w = image.shape[:2]
    colour_type = 0 if image.ndim == 2 else 2
    raw = b"".join(b"\x00" + image[y].tobytes() for y in range(h))

    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data +
                struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, colour_type, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(raw, 6)))
        f.write(chunk(b"IEND", b""))


@pytest.fixture(scope="session")
def cli():
    """Runs the aerovo CLI: cli("features", "detect", ...) -> stdout (fails on a non-zero exit)."""
    exe = os.path.abspath(os.environ.get("AEROVO_CLI", ""))
    if not os.environ.get("AEROVO_CLI") or not os.path.exists(exe):
        pytest.skip("AEROVO_CLI (the aerovo executable) is not set: run through ctest")

    def run(*args):
        p = subprocess.run([exe, *map(str, args)], capture_output=True, text=True, timeout=120)
        assert p.returncode == 0, f"aerovo {' '.join(map(str, args))} exited {p.returncode}: {p.stderr}"
        return p.stdout

    return run


@pytest.fixture(scope="session")
def run_dir(cli, tmp_path_factory):
    """The folder of `aerovo run` on a short simulated flight (test_run_folder.py, test_docs.py)."""
    work = tmp_path_factory.mktemp("flight")
    # 40 m east at 100 m above ground, 5 m per frame: 9 frames of 640x480.
    cli("simulate", "--pattern", "line", "--length-m", 40, "--speed-mps", 10, "--fps", 2,
        "--height-m", 100, "--focal-px", 500, "--width", 640, "--height", 480,
        "-o", work / "sim", "-q")
    cli("run", work / "sim" / "video.mp4", "-o", work / "run", "--no-report", "-q")
    return work / "run"
