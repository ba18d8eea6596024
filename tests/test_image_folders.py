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
