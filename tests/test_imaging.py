"""arstream.imaging: the fast anti-aliased downscale of the analysis path, and bilinear sampling."""

import cv2
import numpy as np
import pytest

from arstream.imaging import pooled, shrink


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


def test_sample_bilinear_matches_the_formula():
    # any batch shape, more points than one remap map may hold (32767), and the
    # border mode for samples off the image
    from arstream.imaging import sample_bilinear

    rng = np.random.default_rng(0)
    img = rng.uniform(0, 255, (37, 53)).astype(np.float32)
    q = rng.uniform(0, [52, 36], (200, 201, 2))  # 40200 points
    x0, y0 = np.floor(q[..., 0]).astype(int), np.floor(q[..., 1]).astype(int)
    fx, fy = q[..., 0] - x0, q[..., 1] - y0
    x1, y1 = np.minimum(x0 + 1, 52), np.minimum(y0 + 1, 36)
    ref = (img[y0, x0] * (1 - fx) + img[y0, x1] * fx) * (1 - fy) + (img[y1, x0] * (1 - fx) + img[y1, x1] * fx) * fy
    out = sample_bilinear(img, q)
    assert out.shape == (200, 201) and out.dtype == np.float32
    assert np.abs(out - ref).max() < 0.05  # (remap's 1/32 px interpolation grid)
    off = np.array([[-5.0, 10.0], [60.0, 3.0]])
    assert np.all(sample_bilinear(img, off) == 0)
    assert np.allclose(sample_bilinear(img, off, border=cv2.BORDER_REPLICATE), [img[10, 0], img[3, 52]])
    assert sample_bilinear(img, np.zeros((0, 2))).shape == (0,)


def test_grey_thumbnail_of_the_luma_plane_matches_the_bgr_frames():
    # an I420 frame with smooth colours that stay inside BGR's range: the thumbnail
    # of its luma plane (video range) is that of the frame in BGR, within rounding
    # (the BGR path rounds at the colour conversion, at each halving and at grey)
    from arstream.imaging import THUMBNAIL_SIZE, grey_thumbnail

    H, W = 360, 640
    y, x = np.mgrid[0:H, 0:W]
    Y = (80 + 90 * (x / W) + 25 * np.sin(y / 17.0)).astype(np.uint8)
    U = (128 + 12 * np.cos(x[::2, ::2] / 40.0)).astype(np.uint8)
    V = (128 + 10 * np.sin(y[::2, ::2] / 30.0)).astype(np.uint8)
    yuv = np.concatenate([Y.ravel(), U.ravel(), V.ravel()]).reshape(H * 3 // 2, W)
    bgr = cv2.cvtColor(yuv, cv2.COLOR_YUV2BGR_I420)
    assert 0 < bgr.min() and bgr.max() < 255
    a, b = grey_thumbnail(Y, video_range=True), grey_thumbnail(bgr)
    assert a.shape == b.shape == THUMBNAIL_SIZE[::-1] and a.dtype == b.dtype == np.float32
    assert np.abs(a - b).max() < 2.5 and np.abs(a - b).mean() < 0.6
    assert np.abs(grey_thumbnail(Y) - b).max() > 10  # (the video range is not full range)
    # a frame smaller than the thumbnail keeps its size
    assert grey_thumbnail(np.zeros((20, 30), np.uint8)).shape == (20, 30)


# --- the picture inside black bars -------------------------------------------------
def _with_bars(top=0, bottom=0, left=0, right=0, size=(160, 90), noise=0):
    rng = np.random.default_rng(3)
    W, H = size
    img = rng.integers(40, 220, (H, W, 3)).astype(np.uint8)
    img[:top] = 0
    img[H - bottom :] = 0
    img[:, :left] = 0
    img[:, W - right :] = 0
    if noise:
        img = np.clip(img.astype(int) + rng.integers(0, noise + 1, img.shape), 0, 255).astype(np.uint8)
    return img


@pytest.mark.parametrize(
    "bars, expect",
    [
        ({}, (0, 0, 160, 90)),
        ({"top": 11, "bottom": 11}, (0, 11, 160, 79)),  # letterbox
        ({"left": 20, "right": 20}, (20, 0, 140, 90)),  # pillarbox
        ({"top": 6, "bottom": 6, "left": 10, "right": 10}, (10, 6, 150, 84)),  # a window box
        ({"left": 20, "right": 20, "noise": 20}, (20, 0, 140, 90)),  # bars with compression noise
        ({"left": 2, "right": 2}, (0, 0, 160, 90)),  # a thin black edge is a border, not a bar
        ({"left": 70, "right": 70}, (0, 0, 160, 90)),  # a dark frame, not bars
    ],
)
def test_active_area(bars, expect):
    from arstream.imaging import active_area

    assert active_area(_with_bars(**bars)) == expect


def test_active_area_bad_input():
    from arstream.imaging import active_area

    with pytest.raises(ValueError, match=r"image must be a non-empty uint8 array \(H, W\) or \(H, W, 3\), got float32 \(9, 16, 3\)"):
        active_area(np.zeros((9, 16, 3), np.float32))


def test_pooled_keeps_a_one_pixel_line_whole():
    # a line one pixel wide at 1280 x 720, on odd and even rows and columns:
    # max-pooled to 640 x 360 it is set on every analysis pixel it crosses,
    # where averaging the picture down halves its contrast
    for dtype in (np.uint8, bool):
        m = np.zeros((720, 1280), np.uint8)
        m[301, :] = 255  # a row (odd)
        m[:, 640] = 255  # a column (even)
        m[100:103, 1001] = 255
        if dtype is bool:
            m = m > 0
        p = pooled(m, (640, 360))
        assert p.dtype == m.dtype and p.shape == (360, 640)
        on = p > 0
        assert on[150].all() and on[:, 320].all()  # (301 -> 150, 640 -> 320)
        assert on[50:52, 500].all() and not on[52, 500] and not on[49, 500]
        assert on.sum() == 640 + 360 - 1 + 2 - 0  # nothing else set (the crossing counted once)
    # a factor that is not whole: an output pixel covering part of a set pixel is set
    m = np.zeros((576, 1024), np.uint8)
    m[:, 513] = 255
    assert np.array_equal(np.nonzero(pooled(m, (640, 360))[0])[0], [320, 321])


@pytest.mark.parametrize("size", [(1281, 720), (640, 0), (0, 360)])
def test_pooled_only_shrinks(size):
    with pytest.raises(ValueError, match="pooled: target"):
        pooled(np.zeros((720, 1280), np.uint8), size)
