"""The pitch detector on synthetic frames, against the true projected markings."""

import json

import cv2
import numpy as np
import pytest

from arstream.cli import main
from arstream.detect import Detector, detect
from arstream.synth import SynthClip, generate
from geometry.conics import ellipse_distance
from geometry.pitch import PitchModel

PITCH = PitchModel()


def true_points(cam, name, spacing=0.25, size=(1280, 720)):
    X = PITCH[name].sample(spacing)
    px = cam.project_pitch(X)
    ok = np.all(np.isfinite(px), axis=1) & (px[:, 0] >= 0) & (px[:, 0] < size[0]) & (px[:, 1] >= 0) & (px[:, 1] < size[1])
    return px[ok]


@pytest.fixture(scope="module")
def frames():
    out = {}
    for preset, idx in (("wide", (0, 60, 120, 180)), ("zoom", (30, 150)), ("hard", (40, 160)), ("penalty", (0, 100, 200)), ("cut", (110, 115))):
        clip = SynthClip(preset, seed=21, frames=250)
        det = Detector(clip.width, clip.height)
        out[preset] = [(i, clip.truth(i), det.process(clip.render(i))) for i in idx]
    return out


def test_centre_circle_found_and_accurate_when_in_view(frames):
    n_in_view = found = 0
    errs = []
    for preset in ("wide", "zoom", "hard"):
        for i, truth, det in frames[preset]:
            if truth.circle_fraction < 0.5:
                continue
            n_in_view += 1
            px = true_points(truth.camera, "centre_circle")
            best = min((np.median(ellipse_distance(px, e.ellipse)) for e in det.ellipses), default=np.inf)
            found += best < 1.0
            errs.append(best)
    assert n_in_view >= 4 and found >= n_in_view - 1
    assert np.median(errs) <= 0.5, errs


def test_no_circle_hallucinated_without_one(frames):
    for preset in ("penalty",):
        for i, truth, det in frames[preset]:
            assert truth.circle_fraction == 0.0
            for e in det.ellipses:
                # what is found must be a real marking: the penalty arc
                arc = true_points(truth.camera, "penalty_arc_right")
                assert len(arc) > 0 and np.median(np.min(np.linalg.norm(e.points[:, None] - arc[None], axis=2), axis=1)) < 2.0


def test_no_pitch_on_the_crowd_cutaway(frames):
    for i, truth, det in frames["cut"]:
        assert not truth.visible_pitch
        assert not det.pitch_visible and not det.lines and not det.ellipses


def test_lines_lie_on_true_markings(frames):
    for preset in ("wide", "penalty"):
        for i, truth, det in frames[preset]:
            assert len(det.lines) >= 3
            pts = np.concatenate([true_points(truth.camera, n, 0.1) for n, m in PITCH.markings.items() if not hasattr(m, "radius")])
            on_marking = []
            for l in det.lines:
                # the detected line's support lies on some straight marking
                d = np.min(np.linalg.norm(l.points[::10, None] - pts[None], axis=2), axis=1)
                on_marking.append(np.median(d) < 1.0)
                if l.length > 200:
                    assert on_marking[-1], (preset, i, l.endpoints)
            # short pieces may still come from arcs or players; the solver's robust fit copes
            assert np.mean(on_marking) >= 0.75, (preset, i, on_marking)
            # line pixels: most are within 1 px of a true marking (players and kits are the rest)
            allpts = np.concatenate([true_points(truth.camera, n, 0.05) for n in PITCH.markings])
            sample = det.line_points[:: max(len(det.line_points) // 400, 1)]
            d = np.min(np.linalg.norm(sample[:, None] - allpts[None], axis=2), axis=1)
            assert np.mean(d < 1.0) > 0.75


def test_grass_mask_excludes_stands_and_graphic(frames):
    i, truth, det = frames["wide"][1]
    g = det.grass_mask
    assert g[690, 640] == 255  # near the bottom: pitch
    assert g[40, 100] == 0  # the score graphic
    assert 0.5 < np.count_nonzero(g) / g.size < 0.98


@pytest.mark.parametrize(
    "image, message",
    [
        (np.zeros((720, 1280), np.uint8), "BGR uint8"),
        (np.zeros((720, 1280, 3), np.float32), "BGR uint8"),
        (np.zeros((8, 8, 3), np.uint8), "at least 16x16"),
    ],
)
def test_bad_images(image, message):
    with pytest.raises(ValueError, match=message):
        detect(image)


def test_black_frame_has_no_pitch():
    det = detect(np.zeros((360, 640, 3), np.uint8))
    assert not det.pitch_visible and det.lines == [] and det.ellipses == []


def test_detector_rejects_a_frame_of_another_size():
    with pytest.raises(ValueError, match="expects 640x360"):
        Detector(640, 360).process(np.zeros((720, 1280, 3), np.uint8))


def test_cli_on_png_and_clip(tmp_path, capsys):
    clip = SynthClip("wide", seed=3, frames=30)
    png = tmp_path / "f.png"
    cv2.imwrite(str(png), clip.render(20))
    assert main(["detect", str(png), "--json", "--draw", str(tmp_path / "d.png")]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["pitch_visible"] and out["lines"] and np.array(out["ellipses"][0]["conic"]).shape == (3, 3)
    assert (tmp_path / "d.png").exists()
    generate(tmp_path / "c", preset="wide", seed=3, frames=6)
    assert main(["detect", str(tmp_path / "c" / "clip.mp4"), "--frame", "4"]) == 0
    assert "lines" in capsys.readouterr().out
    assert main(["detect", str(tmp_path / "none.png")]) == 2
    assert "not found" in capsys.readouterr().err
    (tmp_path / "bad.png").write_bytes(b"not an image")
    assert main(["detect", str(tmp_path / "bad.png")]) == 2
    assert "cannot read" in capsys.readouterr().err
    assert main(["detect", str(tmp_path / "c" / "clip.mp4"), "--frame", "99"]) == 2
    assert "no frame 99" in capsys.readouterr().err


def test_register_a_still_and_a_penalty_area_still(tmp_path, capsys):
    for preset, i in (("wide", 40), ("penalty", 60)):
        clip = SynthClip(preset, seed=8, frames=100)
        png = tmp_path / f"{preset}.png"
        cv2.imwrite(str(png), clip.render(i))
        assert main(["register", str(png), "--json", "--draw", str(tmp_path / "r.png")]) == 0
        rec = json.loads(capsys.readouterr().out)
        from geometry.camera import Camera

        cam = Camera.from_dict(rec)
        truth = clip.camera(i)
        assert abs(cam.focal / truth.focal - 1) < 0.03, preset
        px = true_points(truth, "touchline_far") if preset == "wide" else true_points(truth, "penalty_area_right_front")
        X = PITCH["touchline_far" if preset == "wide" else "penalty_area_right_front"].sample(0.25)
        est = cam.project_pitch(X)
        assert np.median(np.min(np.linalg.norm(est[:, None] - px[None], axis=2), axis=1)) < 2.0
