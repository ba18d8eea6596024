"""What the user tells the solver about the pictures (issue 29, items 4 and 5):
the pitch's size (``pitch=`` / ``--pitch LxW``) and the pixel aspect (the
stream's sample aspect ratio by default, ``pixel_aspect=`` /
``--pixel-aspect A`` to override), on a synthetic anamorphic SD clip with an
odd pitch and exact truth (``arstream synth --preset real-sd``: 720 x 576,
pixel aspect 64:45 written into the stream, a 100-110 x 64-75 m pitch)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from arstream.evaluate import score_files
from arstream.pipeline import process
from arstream.pipeline.stages import Analysis
from arstream.synth import generate

FRAMES = 30


@pytest.fixture(scope="module")
def sd_clip(tmp_path_factory):
    out = tmp_path_factory.mktemp("real_sd")
    header = generate(out, preset="real-sd", seed=0, frames=FRAMES)
    return out, header


def _cameras(path):
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_the_stream_s_pixel_aspect_and_the_pitch_give_the_exact_camera(sd_clip, tmp_path):
    clip, header = sd_clip
    length, width = header["pitch"]["length"], header["pitch"]["width"]
    assert (length, width) != (105.0, 68.0)
    cams = tmp_path / "cameras.jsonl"
    s = process(clip / "clip.mp4", cameras_out=cams, pitch=(length, width), handle_signals=False)
    assert s.frames == FRAMES
    recs = _cameras(cams)
    p, q = header["pixel_aspect"]
    for r in recs:
        if r["K"] is not None:
            # K's aspect is the stream's sample aspect ratio (the analysis frame's
            # square pixels mapped back exactly): to rounding of the analysis size
            K = np.array(r["K"])
            assert abs(K[1, 1] / K[0, 0] - p / q) < 2e-3 * p / q
    sc = score_files(clip / "truth.jsonl", cams)
    # as the clean presets: every frame, well under a pixel (their table: 0.2-0.3 px)
    assert sc.coverage == 1.0 and sc.median < 1.0 and sc.acc[5] == 1.0, sc


@pytest.mark.long
def test_a_wrong_pixel_aspect_or_pitch_costs_accuracy(sd_clip, tmp_path):
    # the same clip told square pixels, or told 105 x 68: the cameras no
    # longer fit (this is what the two options are for; with no size given,
    # the pitch's size is scanned for: tests/test_pitch_size.py)
    clip, header = sd_clip
    pitch = (header["pitch"]["length"], header["pitch"]["width"])
    square = tmp_path / "square.jsonl"
    process(clip / "clip.mp4", cameras_out=square, pitch=pitch, pixel_aspect=1.0, handle_signals=False)
    default = tmp_path / "default.jsonl"
    process(clip / "clip.mp4", cameras_out=default, pitch=(105, 68), handle_signals=False)
    for path in (square, default):
        sc = score_files(clip / "truth.jsonl", path)
        assert not (sc.coverage == 1.0 and sc.median < 1.0), (path.name, sc)


@pytest.mark.parametrize(
    "size, analysis_width, aspect, expect",
    [
        ((1280, 720), 640, 1.0, (640, 360)),
        ((720, 576), 640, 64 / 45, (640, 360)),  # 1024 x 576 shown: scaled to 640 wide
        ((720, 576), None, 64 / 45, (1024, 576)),  # full resolution, stretched to square pixels
        ((512, 512), None, 16 / 9, (910, 512)),
        ((512, 512), 640, 16 / 9, (640, 360)),
    ],
)
def test_analysis_frames_have_square_pixels(size, analysis_width, aspect, expect):
    an = Analysis(*size, analysis_width, pixel_aspect=aspect)
    assert (an.w, an.h) == expect
    # a frame pixel's width over its height, seen from the analysis frame
    assert abs(an.sx / an.sy - 1 / aspect) < 0.01 / aspect


@pytest.mark.parametrize("aspect", [0.0, -1.0, float("nan"), 50.0])
def test_analysis_refuses_a_nonsense_pixel_aspect(aspect):
    with pytest.raises(ValueError, match="pixel aspect must be between 0.1 and 10"):
        Analysis(720, 576, None, pixel_aspect=aspect)


def test_process_refuses_a_bad_pitch(sd_clip, tmp_path):
    clip, _ = sd_clip
    with pytest.raises(ValueError, match="pitch must be"):
        process(clip / "clip.mp4", cameras_out=tmp_path / "c.jsonl", pitch="105x68", handle_signals=False)
