"""bench/real_perturbed.py's re-encoding: area averaging in exact integer
arithmetic (the same on every processor), checked against its definition
and against OpenCV's INTER_AREA; the copies the same bytes every run."""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))

from real_perturbed import _area_weights, area_scale, linear_scale, reencode, scale_plane  # noqa: E402


@pytest.mark.parametrize("n_in, n_out", [(1280, 848), (720, 478), (640, 424), (360, 239), (7, 3), (10, 10), (9, 3)])
def test_area_weights_cover_each_output_sample_once(n_in, n_out):
    # every output sample averages exactly its span of the input: the
    # weights (in units of 1 / (n_in n_out / gcd) of a sample) sum to the
    # output sample's span, and every input sample is used in full
    idx, w, total = _area_weights(n_in, n_out)
    assert np.all(w.sum(axis=0) == total)
    used = np.bincount(idx.ravel(), weights=w.ravel(), minlength=n_in)
    np.testing.assert_array_equal(used, np.full(n_in, total * n_out // n_in))


def test_area_scale_is_the_mean_over_each_span():
    rng = np.random.default_rng(5)
    p = rng.integers(0, 256, (6, 9)).astype(np.uint8)
    # 9 -> 3 and 6 -> 2: 3 x 3 blocks, the mean rounded half up
    want = np.floor(p.reshape(2, 3, 3, 3).astype(np.float64).mean(axis=(1, 3)) + 0.5).astype(np.uint8)
    np.testing.assert_array_equal(area_scale(p, (3, 2)), want)
    np.testing.assert_array_equal(area_scale(np.full((720, 1280), 77, np.uint8), (848, 478)), 77)
    with pytest.raises(ValueError, match="only scales down"):
        area_scale(p, (10, 6))


def test_area_scale_matches_opencv_within_its_rounding():
    # OpenCV's INTER_AREA computes in float (and its kernels round
    # differently): within one level of the exact mean
    rng = np.random.default_rng(6)
    p = rng.integers(0, 256, (720, 1280)).astype(np.uint8)
    for size in ((848, 478), (640, 360), (1024, 576)):
        d = np.abs(area_scale(p, size).astype(int) - cv2.resize(p, size, interpolation=cv2.INTER_AREA).astype(int))
        assert d.max() <= 1, size


def test_linear_scale_interpolates_between_pixel_centres():
    # 2 -> 4 samples: output centres at input positions -0.25, 0.25, 0.75, 1.25
    # (the ends clamped): 10, 10 + 0.25 * 30, 10 + 0.75 * 30, 40, rounded half up
    p = np.array([[10, 40]], np.uint8).repeat(2, axis=0)
    np.testing.assert_array_equal(linear_scale(p, (4, 2)), [[10, 18, 33, 40]] * 2)
    np.testing.assert_array_equal(linear_scale(np.full((720, 1280), 77, np.uint8), (1920, 1080)), 77)
    np.testing.assert_array_equal(linear_scale(p, (2, 2)), p)  # the same size: a copy
    with pytest.raises(ValueError, match="only scales up"):
        linear_scale(p, (1, 2))


def test_linear_scale_matches_opencv_within_its_rounding():
    # OpenCV's INTER_LINEAR (same pixel-centre alignment) rounds its fixed-point
    # weights to 1/2048: within one level of the exact interpolation
    rng = np.random.default_rng(8)
    p = rng.integers(0, 256, (720, 1280)).astype(np.uint8)
    d = np.abs(linear_scale(p, (1920, 1080)).astype(int) - cv2.resize(p, (1920, 1080), interpolation=cv2.INTER_LINEAR).astype(int))
    assert d.max() <= 1


def test_scale_plane_scales_down_by_area_and_up_bilinearly():
    rng = np.random.default_rng(9)
    p = rng.integers(0, 256, (6, 9)).astype(np.uint8)
    np.testing.assert_array_equal(scale_plane(p, (3, 2)), area_scale(p, (3, 2)))
    np.testing.assert_array_equal(scale_plane(p, (18, 12)), linear_scale(p, (18, 12)))
    with pytest.raises(ValueError, match="in both directions"):
        scale_plane(p, (18, 4))


def test_reencode_makes_the_same_bytes_twice(tmp_path):
    import av

    src = tmp_path / "src.mp4"
    rng = np.random.default_rng(7)
    with av.open(str(src), "w") as out:
        st = out.add_stream("libx264", rate=25)
        st.width, st.height, st.pix_fmt = 64, 48, "yuv420p"
        for _ in range(6):
            img = rng.integers(0, 256, (48, 64, 3)).astype(np.uint8)
            for packet in st.encode(av.VideoFrame.from_ndarray(img, format="bgr24")):
                out.mux(packet)
        for packet in st.encode():
            out.mux(packet)
    a = reencode(src, tmp_path / "a.mpg", (32, 24), 500, 4, start=1, codec="mpeg2video").read_bytes()
    b = reencode(src, tmp_path / "b.mpg", (32, 24), 500, 4, start=1, codec="mpeg2video").read_bytes()
    assert a == b
    # libx264 without its AVX-512 code (which reads memory it never wrote at
    # some frame sizes): the same bytes too
    x = reencode(src, tmp_path / "x.mp4", (32, 24), 20, 4, start=1).read_bytes()
    assert x == reencode(src, tmp_path / "y.mp4", (32, 24), 20, 4, start=1).read_bytes()
    for name in ("a.mpg", "x.mp4"):
        with av.open(str(tmp_path / name)) as c:
            frames = [f for f in c.decode(video=0)]
        assert len(frames) == 4 and (frames[0].width, frames[0].height) == (32, 24), name
    with pytest.raises(ValueError, match="even"):
        reencode(src, tmp_path / "c.mp4", (31, 24), 20)
    with pytest.raises(ValueError, match="libx264 or mpeg2video"):
        reencode(src, tmp_path / "d.mp4", (32, 24), 20, codec="vp9")


@pytest.mark.parametrize("level", [None, "WARNING"])
def test_the_x264_probe_leaves_pyavs_logging_as_it_was(level):
    # the probe reads x264's report from FFmpeg's log in a child process; this
    # process's PyAV logging, left on, lets a frame-threaded decoder freed
    # while one of its threads waits to log hang the process (the suite hung
    # so after a test made an x264 copy)
    import av.logging

    from arstream.sink import x264_capabilities

    before = av.logging.get_level()
    try:
        av.logging.set_level(None if level is None else getattr(av.logging, level))
        x264_capabilities.cache_clear()
        caps = x264_capabilities()
        assert caps and all(isinstance(c, str) for c in caps)
        assert av.logging.get_level() == (None if level is None else getattr(av.logging, level))
    finally:
        av.logging.set_level(before)


def test_reference_distances_judge_the_copys_reference_frames():
    # the copy's cameras are the reference cameras themselves, scaled to its
    # size as the benchmark scales them back: distance 0 up to the
    # arithmetic; a frame without a camera is inf; a copy from frame 120
    # holds only the reference frames from 120 on
    from geometry.camera import Camera
    from real_footage import references
    from real_perturbed import reference_distances

    refs = references("israel_league_wide")
    if not refs:
        pytest.skip("no reference cameras")
    size = (854, 480)
    sx, sy = size[0] / 1280, size[1] / 720
    start, n = 120, 404 - 120
    got = [None] * n
    for k, (ref, _) in refs.items():
        if k >= start:
            got[k - start] = Camera(K=np.diag([sx, sy, 1.0]) @ ref.K, R=ref.R, t=ref.t, dist=ref.dist)
    d = reference_distances("israel_league_wide", got, size, start)
    assert len(d) == sum(k >= start for k in refs) == 12
    assert np.all(d < 1e-6), d
    got[125 - start] = None
    d = reference_distances("israel_league_wide", got, size, start)
    assert d[0] == np.inf and np.all(d[1:] < 1e-6)
    # a camera whose picture is shifted 4 px (@1280) sideways is 4 px off
    c = got[150 - start]
    got[150 - start] = Camera(K=np.array([[1.0, 0.0, 4.0 * sx], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]) @ c.K, R=c.R, t=c.t)
    assert reference_distances("israel_league_wide", got, size, start)[1] == pytest.approx(4.0, abs=1e-6)


def _numbered_clip(path, n: int, size=(64, 48)):
    """A lossless 4:2:0 clip of ``n`` frames, frame k's luma ramp offset by 10 k
    (its order readable after decoding) and brighter on its left half."""
    import av

    w, h = size
    with av.open(str(path), "w") as out:
        st = out.add_stream("libx264", rate=25)
        st.width, st.height, st.pix_fmt = w, h, "yuv420p"
        st.options = {"qp": "0"}  # (lossless)
        for k in range(n):
            img = np.full((h, w, 3), 20 + 10 * k, np.uint8)
            img[:, : w // 2] += 100
            for packet in st.encode(av.VideoFrame.from_ndarray(img, format="bgr24").reformat(format="yuv420p")):
                out.mux(packet)
        for packet in st.encode():
            out.mux(packet)
    return path


def _lumas(path) -> list[np.ndarray]:
    import av

    with av.open(str(path)) as c:
        return [f.to_ndarray(format="gray").astype(int) for f in c.decode(video=0)]


def test_reencode_mirrors_and_reverses_a_clip(tmp_path):
    # mirror: each frame's columns reversed (the bright half on the right);
    # reverse: the clip played backwards, start and frames counted on the
    # reversed clip (frames 4, 3, 2 of a 6-frame clip from its frame 1)
    src = _numbered_clip(tmp_path / "src.mp4", 6)
    level = [int(np.median(y)) for y in _lumas(src)]
    plain = _lumas(reencode(src, tmp_path / "plain.mp4", (64, 48), 0, 3, 1))
    both = _lumas(reencode(src, tmp_path / "both.mp4", (64, 48), 0, 3, 1, mirror=True, reverse=True))
    back = _lumas(reencode(src, tmp_path / "back.mp4", (64, 48), 0, None, 0, reverse=True))
    assert len(plain) == len(both) == 3 and len(back) == 6
    # (the copies at crf 0: lossless but for the colour conversion's rounding)
    for got, k in zip(plain, (1, 2, 3)):
        assert abs(np.median(got) - level[k]) <= 2 and got[:, :32].mean() > got[:, 32:].mean() + 50
    for got, k in zip(both, (4, 3, 2)):
        assert abs(np.median(got) - level[k]) <= 2 and got[:, 32:].mean() > got[:, :32].mean() + 50
    assert [int(np.median(y)) for y in back] == pytest.approx(level[::-1], abs=2)


def test_a_mirrored_and_reversed_copy_is_judged_against_its_own_reference_frames():
    # a copy of the clip flipped and played backwards, from its frame 100:
    # copy frame j shows source frame 403 - 100 - j, drawn by the mirrored
    # reference camera; a copy holding exactly those cameras is 0 px off
    # every reference frame it holds (the source's frames 0-303: 100-300)
    from real_footage import references
    from real_graphics import mirrored
    from real_perturbed import as_copy, copy_frame, reference_distances

    refs = references("israel_league_wide")
    if not refs:
        pytest.skip("no reference cameras")
    total, start = 404, 100
    assert copy_frame(300, start, reverse=True, total=total) == 3 and copy_frame(300, start) == 200
    assert as_copy(None, mirror=True) is None and as_copy(refs[100][0]) is refs[100][0]
    got = [None] * (total - start)
    for k, (ref, _) in refs.items():
        j = copy_frame(k, start, reverse=True, total=total)
        if 0 <= j < len(got):
            got[j] = mirrored(ref, 1280)
    d = reference_distances("israel_league_wide", got, (1280, 720), start, mirror=True, reverse=True, total=total)
    assert len(d) == 9 and np.all(d < 1e-6), d
    # judged as an unmirrored copy, the same cameras are far off
    assert np.all(reference_distances("israel_league_wide", got, (1280, 720), start, reverse=True, total=total) > 20)
