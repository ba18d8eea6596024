"""The pitch's size as a per-clip unknown (issue 29, item 4):
:func:`arstream.pitch_size.estimate_pitch_size` against exact views of
pitches of known odd sizes, the dimensions views leave open, bad input, and
the pipeline's estimate on a synthetic clip of an odd pitch."""

from __future__ import annotations

import numpy as np
import pytest

from arstream.pitch_size import PitchSize, PitchView, estimate_pitch_size, size_derivatives
from arstream.solve import ModelSamples
from cameras import looking_at
from geometry.pitch import PitchModel

SIZE = (1280, 720)


def _views(pitch: PitchModel, targets, centre=(0.0, -55.0, 16.0), f=1400.0) -> list[PitchView]:
    """Exact views of ``pitch``: its markings sampled every 5 cm, projected, those in the frame."""
    X = pitch.sample_points(0.05)
    X = np.column_stack([X, np.zeros(len(X))])
    out = []
    for t in targets:
        cam = looking_at(centre, (*t, 0.0), f, SIZE)
        px = cam.project(X)
        ok = np.isfinite(px).all(axis=1) & (px[:, 0] >= 0) & (px[:, 0] <= SIZE[0] - 1) & (px[:, 1] >= 0) & (px[:, 1] <= SIZE[1] - 1)
        out.append(PitchView(cam, px[ok], SIZE))
    return out


def test_size_derivatives_move_every_sample_onto_the_other_pitch_s_marking():
    # a linear change of the size moves each sample onto the same marking of the
    # pitch of the new size (to rounding): the derivatives are exact
    prior, other = PitchModel(), PitchModel(101.0, 71.0)
    model = ModelSamples.from_pitch(prior, 0.5)
    dL, dW = size_derivatives(prior, model)
    moved = model.points + dL * (other.length - prior.length) + dW * (other.width - prior.width)
    for k, name in enumerate(model.names):
        m = other[name]
        p = moved[model.marking == k, :2]
        if hasattr(m, "radius"):
            d = np.abs(np.hypot(*(p - np.asarray(m.center)).T) - m.radius)
        else:
            d = np.abs(p @ m.line[:2] + m.line[2])
        assert d.max() < 1e-9, name


@pytest.mark.parametrize("truth", [(101.0, 71.0), (108.5, 65.0), (105.0, 68.0)])
def test_the_size_comes_back_from_exact_views(truth):
    # a tripod camera beside the halfway line panning from the centre circle to a
    # penalty area: both dimensions are fixed; started from 105 x 68
    pitch = PitchModel(*truth)
    views = _views(pitch, [(0.0, 0.0), (12.0, 5.0), (25.0, 0.0), (38.0, -5.0), (45.0, 5.0)])
    got = estimate_pitch_size(views, PitchModel())
    assert got.source == "estimated" and got.views == 5 and got.constrained == (True, True)
    # exact pixels: the fit's floor is the association's (the nearest of samples 5 cm apart)
    assert abs(got.length - truth[0]) < 0.02 and abs(got.width - truth[1]) < 0.02, got.describe()
    # the uncertainty is that of a 1 px error of each marking of each view as a whole
    # (the pixels' own noise is nil here): under the 0.75 m that counts as fixed
    assert 0.05 < got.length_sd < 0.75 and 0.05 < got.width_sd < 0.75
    assert np.linalg.norm(got.centre - (0.0, -55.0, 16.0)) < 0.05
    assert "estimated from 5 views" in got.describe()


def test_the_uncertainty_grows_with_the_systematic_error_allowed():
    # exact views: the least-squares part is the systematic term alone, linear in
    # it; with none allowed, the jackknife's spread (nil for exact views) is left
    views = _views(PitchModel(101.0, 71.0), [(0.0, 0.0), (12.0, 5.0), (25.0, 0.0), (38.0, -5.0), (45.0, 5.0)])
    one = estimate_pitch_size(views, systematic_px=1.0)
    two = estimate_pitch_size(views, systematic_px=2.0)
    none = estimate_pitch_size(views, systematic_px=0.0)
    assert abs(two.length_sd / one.length_sd - 2.0) < 0.05 and abs(two.width_sd / one.width_sd - 2.0) < 0.05
    assert none.length_sd < 0.02 and none.width_sd < 0.02


def test_a_length_the_views_do_not_fix_keeps_the_prior():
    # only one penalty area in view, no halfway line or circle: moving the goal end
    # and the camera together changes nothing in the pictures
    pitch = PitchModel(101.0, 71.0)
    views = _views(pitch, [(40.0, -8.0), (42.0, 0.0), (44.0, 8.0), (41.0, 4.0)], centre=(20.0, -50.0, 16.0), f=1800.0)
    got = estimate_pitch_size(views, PitchModel())
    assert got.length_sd is None and got.length == 105.0
    assert "not constrained by the views: default kept" in got.describe()


def test_too_few_views_is_an_error():
    views = _views(PitchModel(), [(0.0, 0.0), (10.0, 0.0)])
    with pytest.raises(ValueError, match="needs at least 3 views, got 2"):
        estimate_pitch_size(views)


def test_views_without_markings_are_an_error():
    views = [PitchView(v.camera, np.zeros((0, 2)), SIZE) for v in _views(PitchModel(), [(0.0, 0.0)] * 3)]
    with pytest.raises(ValueError, match="too few marking points matched"):
        estimate_pitch_size(views)


def test_given_and_default_sizes_are_described():
    assert PitchSize(100.0, 68.0, source="given").describe() == "pitch 100.0 x 68.0 m (given)"
    assert PitchSize(105.0, 68.0).to_dict() == {"length": 105.0, "width": 68.0, "length_sd": None, "width_sd": None, "source": "default", "views": 0}


def test_the_pipeline_estimates_an_odd_pitch(tmp_path):
    # a synthetic clip of a 100.5 x 71.5 m pitch (real-sd, seed 0), pitch="auto"
    from arstream.pipeline import process
    from arstream.synth import generate

    header = generate(tmp_path / "clip", preset="real-sd", seed=0, frames=100)
    s = process(tmp_path / "clip" / "clip.mp4", cameras_out=tmp_path / "cams.jsonl", pitch="auto", handle_signals=False)
    truth = (header["pitch"]["length"], header["pitch"]["width"])
    assert truth != (105.0, 68.0)
    got = s.pitch
    assert got["source"] == "estimated" and got["views"] >= 6, s.pitch_text
    # within a metre of the truth: the tracker's views fit the detected lines to
    # about 0.3 px at 640 x 360 (the clip is 720 x 576 anamorphic, strongly compressed)
    assert abs(got["length"] - truth[0]) < 1.0 and abs(got["width"] - truth[1]) < 1.0, s.pitch_text
    assert s.to_dict()["pitch"] == got


def test_without_auto_the_size_is_the_default_and_not_estimated(tmp_path):
    from arstream.pipeline import process
    from arstream.synth import generate

    generate(tmp_path / "clip", preset="real-sd", seed=0, frames=40)
    s = process(tmp_path / "clip" / "clip.mp4", cameras_out=tmp_path / "cams.jsonl", handle_signals=False)
    assert s.pitch == {"length": 105.0, "width": 68.0, "length_sd": None, "width_sd": None, "source": "default", "views": 0}
    s = process(tmp_path / "clip" / "clip.mp4", cameras_out=tmp_path / "cams.jsonl", pitch=(100, 70), handle_signals=False)
    assert s.pitch["source"] == "given" and s.pitch_text == "pitch 100.0 x 70.0 m (given)"
