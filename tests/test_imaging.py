"""arstream.imaging.shrink: the fast anti-aliased downscale of the analysis path."""

import cv2
import numpy as np
import pytest

from arstream.imaging import shrink


def test_exact_halving_is_area_resampling():
    img = (np.random.default_rng(0).random((720, 1280, 3)) * 255).astype(np.uint8)
    assert np.array_equal(shrink(img, (640, 360)), cv2.resize(img, (640, 360), interpolation=cv2.INTER_AREA))


@pytest.mark.parametrize("src_size, size", [((1920, 1080), (640, 360)), ((1366, 768), (640, 360)), ((3840, 2160), (640, 360)), ((960, 540), (640, 360))])
def test_sizes_dst_and_flat_images(src_size, size):
    W, H = src_size
    img = np.full((H, W), 77, np.uint8)
    dst = np.zeros((size[1], size[0]), np.uint8)
    out = shrink(img, size, dst=dst)
    assert out is dst
    assert np.all(dst == 77)


def test_lines_keep_their_position():
    # a 1080p line (Gaussian profile) at sub-pixel positions over a whole 3-pixel
    # period: its peak in the 640-px image, mapped back (u -> 3 u + 1), is unbiased
    # and within the phase error of a plain 3x3 area resampling
    xs = np.arange(1920, dtype=np.float64)
    errors = []
    for c in np.arange(900.0, 906.0, 0.25):
        img = np.tile(np.exp(-0.5 * ((xs - c) / 1.2) ** 2).astype(np.float32), (12, 1))
        row = cv2.GaussianBlur(shrink(img, (640, 4))[2][None].astype(np.float64), (9, 1), 1.2)[0]
        k = int(np.argmax(row))
        a, b, d = row[k - 1], row[k], row[k + 1]
        errors.append(3 * (k + 0.5 * (a - d) / (a - 2 * b + d)) + 1 - c)
    errors = np.array(errors)
    assert abs(errors.mean()) < 0.02
    assert np.abs(errors).max() < 0.25


def test_refuses_to_enlarge():
    with pytest.raises(ValueError, match="shrink: target 800x600 is larger than the image 640x480"):
        shrink(np.zeros((480, 640), np.uint8), (800, 600))
