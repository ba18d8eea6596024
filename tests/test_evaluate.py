"""The scorer: 0 px for truth against itself, the expected error for known perturbations."""

import json

import numpy as np
import pytest

from arstream.cli import main
from arstream.evaluate import frame_error, score
from arstream.sink import JsonlWriter
from arstream.synth import SynthClip
from geometry.camera import Camera
from geometry.pitch import PitchModel

SIZE = (1280, 720)


@pytest.fixture(scope="module")
def truth():
    clip = SynthClip("cut", seed=2, frames=60, size=SIZE)
    return [clip.truth(i).to_record() for i in range(clip.n)]


def shifted(rec, dx):
    """The same camera with the principal point moved by dx pixels: every point moves by dx."""
    if rec["K"] is None:
        return dict(rec)
    cam = Camera.from_dict(rec)
    K = cam.K.copy()
    K[0, 2] += dx
    return {**rec, **Camera(K=K, R=cam.R, t=cam.t, dist=cam.dist).to_dict()}


def test_truth_against_itself_is_perfect(truth):
    s = score(truth, truth, SIZE)
    assert s.coverage == 1.0 and s.median == 0.0 and s.p95 == 0.0
    assert s.acc == {5: 1.0, 10: 1.0, 20: 1.0}
    assert s.focal_error_median == 0.0 and s.jitter < 1e-9
    assert s.no_pitch_frames > 0 and s.false_estimates == 0


def test_known_shift_gives_known_error(truth):
    # without distortion, moving the principal point by 7 px moves every projection by exactly 7 px
    s = score(truth, [shifted(r, 7.0) for r in truth], SIZE)
    assert np.isclose(s.median, 7.0, atol=1e-6) and np.isclose(s.p95, 7.0, atol=1e-6)
    assert s.acc[5] == 0.0 and s.acc[10] == 1.0
    assert s.jitter < 1e-9  # a constant offset has no second difference


def test_focal_error_and_mirrored_solution(truth):
    rec = next(r for r in truth if r["visible_pitch"])
    cam = Camera.from_dict(rec)
    K = cam.K.copy()
    K[0, 0] *= 1.02
    K[1, 1] *= 1.02
    s = score([rec], [{**rec, **Camera(K=K, R=cam.R, t=cam.t).to_dict()}], SIZE)
    assert np.isclose(s.focal_error_median, 0.02)
    assert 0 < s.median < 40
    # a camera that sees the pitch mirrored (half turn about the centre spot) scores 0 via the symmetries
    S = np.diag([-1.0, -1.0, 1.0])
    mirrored = Camera(K=cam.K, R=cam.R @ S, t=cam.t)
    fe = frame_error(cam, mirrored, SIZE, PitchModel().sample_points(0.25), PitchModel().symmetries)
    assert fe.mean < 1e-9 and fe.symmetry == 3


def test_missing_and_false_estimates(truth):
    pred = [r for r in truth if r["frame"] % 2 == 0 and r["visible_pitch"]]
    # an estimate on a frame without a pitch
    nopitch = next(r for r in truth if not r["visible_pitch"])
    pitchy = next(r for r in truth if r["visible_pitch"])
    pred.append({**pitchy, "frame": nopitch["frame"]})
    s = score(truth, pred, SIZE)
    assert 0.45 < s.coverage < 0.55
    assert s.false_estimates == 1
    assert s.acc[20] == pytest.approx(s.coverage)


def test_jitter_measures_shake(truth):
    rng = np.random.default_rng(0)
    noisy = [shifted(r, rng.normal(0, 1.0)) for r in truth]
    s = score(truth, noisy, SIZE)
    # second difference of iid N(0, 1) has variance 6 in x, 0 in y
    assert 1.8 < s.jitter < 3.2


def test_cli_eval(tmp_path, truth, capsys):
    t = tmp_path / "truth.jsonl"
    p = tmp_path / "pred.jsonl"
    for path, recs in ((t, truth), (p, [shifted(r, 3.0) for r in truth])):
        with JsonlWriter(path) as w:
            for r in recs:
                w.write(r)
    (tmp_path / "header.json").write_text(json.dumps({"size": list(SIZE)}))
    assert main(["eval", "--truth", str(t), "--pred", str(p), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["median"] == pytest.approx(3.0) and out["acc"]["@5"] == 1.0
    assert main(["eval", "--truth", str(t), "--pred", str(p)]) == 0
    assert "acc@10" in capsys.readouterr().out
    assert main(["eval", "--truth", str(tmp_path / "none.jsonl"), "--pred", str(p)]) == 2
    assert "not found" in capsys.readouterr().err
    (tmp_path / "bad.jsonl").write_text("{not json\n")
    assert main(["eval", "--truth", str(t), "--pred", str(tmp_path / "bad.jsonl")]) == 2
    assert "not valid JSON" in capsys.readouterr().err


def test_a_camera_made_at_another_size_is_judged_on_its_own_markings():
    # a camera looking down on the centre circle: the circle and the halfway
    # line do not move with the pitch's length, so the truth's own camera
    # made at another length draws them where they are painted (0 px); at
    # another width the halfway line's samples slide along it (the same
    # fraction of a longer line) and the score counts that
    from arstream.pitch_size import corresponding_samples
    from cameras import looking_at

    cam = looking_at((0.0, -30.0, 40.0), (0.0, 0.0, 0.0), f=1400.0, size=SIZE)
    painted = PitchModel(105.0, 68.0)
    for other, zero in ((PitchModel(110.0, 68.0), True), (PitchModel(105.0, 72.0), False)):
        pts, moved = corresponding_samples(painted, other)
        fe = frame_error(cam, cam, SIZE, pts, painted.symmetries[:1], moved)
        assert (fe.mean < 1e-9) == zero, (other, fe)
        assert frame_error(cam, cam, SIZE, pts, painted.symmetries[:1]).mean < 1e-9
    rec = [{"frame": 0, "status": "ok", **cam.to_dict()}]
    assert score(rec, rec, SIZE, painted, pred_pitch=PitchModel(110.0, 68.0)).median < 1e-9
    assert score(rec, rec, SIZE, painted, pred_pitch=PitchModel(105.0, 72.0)).median > 1.0


def test_distance_1280_between_a_camera_and_its_reference():
    # the real material's measure: the mean distance over the reference's
    # markings in view, in px of the frame shown 1280 wide with square pixels
    from arstream.evaluate import distance_1280
    from cameras import looking_at

    ref = looking_at((0.0, -30.0, 40.0), (0.0, 0.0, 0.0), f=1400.0, size=SIZE)
    pitch = PitchModel()
    K = ref.K.copy()
    K[0, 2] += 7.0  # (every projection moves 7 px right)
    moved = Camera(K=K, R=ref.R, t=ref.t, dist=ref.dist)
    assert distance_1280(ref, ref, SIZE, pitch) < 1e-9
    assert np.isclose(distance_1280(ref, moved, SIZE, pitch), 7.0, atol=1e-6)
    # a 640-wide frame: 7 px there are 14 px of a 1280-wide one
    assert np.isclose(distance_1280(ref, moved, (640, 360), pitch), 14.0, atol=1e-6)
    # pixels twice as wide as high: shown with square pixels the shift is 14 px of a 2560-wide frame
    assert np.isclose(distance_1280(ref, moved, SIZE, pitch, pixel_aspect=2.0), 7.0, atol=1e-6)
    # the truth's camera made at another length draws the circle and halfway line where they are painted
    assert distance_1280(ref, ref, SIZE, pitch, PitchModel(110.0, 68.0)) < 1e-9
    away = looking_at((0.0, -30.0, 40.0), (0.0, -300.0, 40.0), f=1400.0, size=SIZE)
    assert np.isnan(distance_1280(away, ref, SIZE, pitch))
