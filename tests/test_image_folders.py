"""A folder of numbered frames as a clip (``arstream process DIR``: FFmpeg's
image-sequence demuxer, in name order), and frames whose pixels are wider
than tall enough that their square-pixel analysis frame grows along the width
(512 x 512 shown 16:9: 640 x 360), which used to stop ``process`` with a
traceback."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from arstream.errors import InputError
from arstream.imaging import scale_to
from arstream.pipeline import process
from arstream.source import VideoSource
from arstream.synth import generate


@pytest.fixture(scope="module")
def frames_dir(tmp_path_factory):
    """12 frames of a synthetic wide clip as PNG files, and its truth."""
    out = tmp_path_factory.mktemp("seq")
    generate(out / "clip", preset="wide", seed=2, frames=12, size=(640, 360))
    folder = out / "frames"
    folder.mkdir()
    with VideoSource(out / "clip" / "clip.mp4") as src:
        for f in src:
            cv2.imwrite(str(folder / f"frame_{f.index:03d}.png"), f.image)
    return folder, out / "clip"


def test_a_folder_of_frames_is_read_in_name_order(frames_dir):
    folder, clip = frames_dir
    with VideoSource(folder) as src:
        assert (src.width, src.height, src.frame_count, src.is_live) == (640, 360, 12, False)
        got = [f.image for f in src]
    assert len(got) == 12
    # in name order: each decoded frame is nearest to the file of its index (the
    # frames pass through the pipeline's I420 planes, as a video's do: close to
    # the PNG, not equal)
    files = [cv2.imread(str(folder / f"frame_{k:03d}.png")).astype(np.int16) for k in range(12)]
    for k, img in enumerate(got):
        d = [np.abs(img.astype(np.int16) - f).mean() for f in files]
        assert int(np.argmin(d)) == k, d


@pytest.mark.parametrize("ext, params", [(".png", []), (".jpg", [cv2.IMWRITE_JPEG_QUALITY, 95])])
def test_frames_of_other_pixel_formats_keep_their_levels(tmp_path, ext, params):
    # PNG decodes as rgb24, JPEG as full-range yuvj420p: both reach the pipeline
    # as limited-range I420 planes, read back as BGR at the file's own levels.
    # (Before the range was set explicitly, swscale copied full-range levels
    # into them: grey came out 1.15 x - 17, faint lines 15 % brighter against
    # the grass than in the file.)
    rng = np.random.default_rng(4)
    img = np.clip(np.full((72, 128, 3), (40, 120, 50), np.float64) + rng.normal(0, 20, (72, 128, 3)), 0, 255).astype(np.uint8)
    img = cv2.GaussianBlur(img, (5, 5), 0)  # (smooth colour: 4:2:0 chroma keeps it)
    img[30:34, :] = (230, 235, 235)  # a white line
    for k in range(2):
        cv2.imwrite(str(tmp_path / f"f_{k}{ext}"), img, params)
    ref = cv2.imread(str(tmp_path / f"f_0{ext}")).astype(np.float64)
    with VideoSource(tmp_path) as src:
        got = next(iter(src)).image.astype(np.float64)
    grey = lambda a: a @ [0.114, 0.587, 0.299]  # noqa: E731
    gain, offset = np.polyfit(grey(ref).ravel(), grey(got).ravel(), 1)
    assert abs(gain - 1) < 0.02 and abs(offset) < 2.0, (gain, offset)
    assert np.abs(got - ref).mean() < 2.5  # (rounding, 4:2:0 chroma, the decoders' upsampling)


def test_process_tracks_a_folder_of_frames(frames_dir, tmp_path):
    from arstream.evaluate import score_files

    folder, clip = frames_dir
    s = process(folder, cameras_out=tmp_path / "cams.jsonl", handle_signals=False)
    assert s.frames == 12
    sc = score_files(clip / "truth.jsonl", tmp_path / "cams.jsonl")
    # the same pictures as the clip's own frames: tracked to well under a pixel
    assert sc.coverage == 1.0 and sc.median < 1.0, sc


@pytest.mark.parametrize(
    "names, message",
    [
        ([], "is a folder without images"),
        (["a.png", "b.jpg"], "holds images of several kinds (.jpg, .png)"),
        (["frame_2.png", "frame_10.png"], "do not sort in frame order (number them with zero padding: frame_0001.png"),
    ],
)
def test_folders_that_are_no_clip(tmp_path, names, message):
    img = np.zeros((8, 8, 3), np.uint8)
    for n in names:
        cv2.imwrite(str(tmp_path / n), img)
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(")", r"\)").replace(".", r"\.")):
        VideoSource(tmp_path)


def test_scale_to_grows_an_axis_where_shrink_may_not():
    src = np.tile((np.arange(512) // 2).astype(np.uint8)[None, :], (512, 1))
    out = scale_to(src, (640, 360))
    assert out.shape == (360, 640)
    # a horizontal ramp stays one (bilinear along x, area along y)
    assert np.all(np.diff(out[180].astype(int)) >= 0)
    assert np.array_equal(scale_to(src, (256, 256)), cv2.resize(src, (256, 256), interpolation=cv2.INTER_AREA))


def test_process_on_frames_with_wide_pixels(tmp_path):
    # 512 x 512 frames shown 16:9 (the stream says so): analysed at 640 x 360
    header = generate(tmp_path / "clip", preset="wide", seed=3, frames=10, size=(512, 512), pixel_aspect=(16, 9))
    assert header["pixel_aspect"] == [16, 9]
    s = process(tmp_path / "clip" / "clip.mp4", cameras_out=tmp_path / "cams.jsonl", handle_signals=False)
    assert s.frames == 10
    recs = [json.loads(line) for line in (tmp_path / "cams.jsonl").read_text().splitlines()]
    K = [np.array(r["K"]) for r in recs if r["K"] is not None]
    assert K and all(abs(k[1, 1] / k[0, 0] - 16 / 9) < 0.02 for k in K)
