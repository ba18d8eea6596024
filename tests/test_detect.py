"""The pitch detector on synthetic frames, against the true projected markings.

Frames come straight from ``SynthClip.render`` (no encoding) except in the
decoded-video checks. "Found" means the best ellipse lies within 1 px
(median) of the true projected centre circle.
"""

import json

import cv2
import numpy as np
import pytest

from arstream.cli import main
from arstream.detect import Detector, detect, draw_detections
from arstream.source import VideoSource
from arstream.synth import SynthClip, generate
from geometry.conics import Ellipse, ellipse_distance
from geometry.pitch import Arc, PitchModel

PITCH = PitchModel()
SIZE = (1280, 720)


def true_points(cam, name, spacing=0.1, size=SIZE):
    """Projected (with distortion) samples of a marking's centreline inside the frame."""
    X = PITCH[name].sample(spacing)
    XYZ = np.column_stack([X, np.zeros(len(X))])
    px = cam.project(XYZ)
    ok = cam.in_front(XYZ) & np.all(np.isfinite(px), axis=1)
    ok &= (px[:, 0] >= 0) & (px[:, 0] <= size[0] - 1) & (px[:, 1] >= 0) & (px[:, 1] <= size[1] - 1)
    return px[ok]


def nearest(a, b):
    """Distance from each point of a (N, 2) to the nearest of b (M, 2)."""
    if len(b) == 0:
        return np.full(len(a), np.inf)
    d = np.full(len(a), np.inf)
    for k in range(0, len(b), 2000):
        d = np.minimum(d, np.min(np.linalg.norm(a[:, None] - b[None, k : k + 2000], axis=2), axis=1))
    return d


# preset -> frame indices (sequential per preset: one detector per clip)
FRAMES = {"wide": range(0, 60, 6), "zoom": range(0, 150, 15), "hard": range(0, 240, 12), "penalty": range(0, 100, 10), "cut": range(95, 125, 5)}


@pytest.fixture(scope="module")
def runs():
    out = {}
    for preset, idx in FRAMES.items():
        clip = SynthClip(preset, seed=21, frames=250, size=SIZE)
        det = Detector(*SIZE)
        rows = []
        for i in idx:
            d = det.process(clip.render(i))
            # keep copies: the detector reuses its buffers
            rows.append((i, clip.truth(i), d, d.grass_mask.copy(), d.line_mask.copy()))
        out[preset] = rows
    return out


def test_centre_circle_found_and_accurate_when_half_in_view(runs):
    n_in_view = found = 0
    errs = []
    for preset in ("wide", "zoom", "hard"):
        for i, truth, det, *_ in runs[preset]:
            if truth.circle_fraction < 0.5:
                continue
            n_in_view += 1
            cc = true_points(truth.camera, "centre_circle")
            if det.ellipses and det.ellipses[0].kind == "circle":
                err = float(np.median(ellipse_distance(cc, det.ellipses[0].ellipse)))
                found += err < 1.0
                errs.append(err)
    assert n_in_view >= 15
    assert found >= n_in_view - 1, (found, n_in_view)
    assert np.median(errs) <= 0.5, errs


def test_no_ellipse_hallucinated(runs):
    """Every reported ellipse is a real circle marking; no centre circle where it is out of view."""
    for preset, rows in runs.items():
        for i, truth, det, *_ in rows:
            if truth.camera is None:
                assert not det.ellipses
                continue
            for e in det.ellipses:
                d = min(np.median(nearest(e.points[::4], true_points(truth.camera, n))) for n in ("centre_circle", "penalty_arc_left", "penalty_arc_right"))
                assert d < 2.0, (preset, i, e.ellipse)
                if truth.circle_fraction == 0.0:
                    assert e.kind == "arc", (preset, i, e.kind)
            assert 0 <= len(det.ellipses) <= 3


def test_penalty_arcs_split_from_the_centre_circle(runs):
    arcs = 0
    for i, truth, det, *_ in runs["penalty"]:
        assert truth.circle_fraction == 0.0
        for e in det.ellipses:
            assert e.kind == "arc"
            assert np.median(nearest(e.points, true_points(truth.camera, "penalty_arc_right"))) < 1.0
            arcs += 1
    assert arcs >= len(runs["penalty"]) // 2


def test_no_pitch_on_the_crowd_cutaway(runs):
    cut = [r for r in runs["cut"] if r[1].camera is None]
    assert len(cut) >= 3
    for i, truth, det, grass, lines in cut:
        assert not det.pitch_visible and not det.lines and not det.ellipses and len(det.line_points) == 0
        assert np.count_nonzero(grass) < 0.1 * grass.size and not lines.any()
    back = [r for r in runs["cut"] if r[1].camera is not None]
    assert back and all(r[2].pitch_visible for r in back)


def test_lines_lie_on_true_straight_markings(runs):
    straight = [n for n, m in PITCH.markings.items() if not isinstance(m, Arc)]
    for preset in ("wide", "penalty", "zoom"):
        for i, truth, det, *_ in runs[preset]:
            if truth.camera is None:
                continue
            allpts = np.concatenate([true_points(truth.camera, n, 0.02) for n in straight])
            on = []
            for l in det.lines:
                assert np.isclose(np.hypot(*l.line[:2]), 1.0)
                assert l.points.shape[1] == 2 and len(l.points) >= 12 and l.length > 0
                assert 0 < l.normal_sigma < 1.0 and 0 < l.angle_sigma < 0.05
                on.append(np.median(nearest(l.points[::5], allpts)) < 1.0)
                # long lines are markings; short ones may be goal posts (white, straight)
                assert on[-1] or l.length < 100, (preset, i, l.endpoints)
            assert not on or np.mean(on) >= 0.75, (preset, i, on)
            if preset == "wide":
                # recall: every long straight marking in view is found
                for n in straight:
                    px = true_points(truth.camera, n, 0.1)
                    if len(px) > 1 and np.linalg.norm(px[-1] - px[0]) > 400:
                        assert any(np.median(nearest(px[::10], l.points)) < 1.5 for l in det.lines), (preset, i, n)


def test_line_points_are_on_markings(runs):
    for preset in ("wide", "zoom", "penalty"):
        for i, truth, det, *_ in runs[preset][::3]:
            allpts = np.concatenate([true_points(truth.camera, n, 0.01) for n in PITCH.markings])
            sample = det.line_points[:: max(len(det.line_points) // 400, 1)]
            d = nearest(sample, allpts)
            assert np.mean(d < 1.0) > 0.8, (preset, i)
            assert np.median(d) < 0.35, (preset, i)


def test_grass_mask_excludes_stands_and_graphic(runs):
    i, truth, det, grass, lines = runs["wide"][2]
    H, W = grass.shape
    assert grass.dtype == np.uint8 and (H, W) == (SIZE[1], SIZE[0]) and set(np.unique(grass)) <= {0, 255}
    assert grass[700, 640] == 255  # near the bottom: pitch
    assert grass[45, 150] == 0  # the score graphic
    # players standing on the pitch are inside the mask
    s = 1 / 0.12
    assert 0.5 < np.count_nonzero(grass) / grass.size < 0.98
    # the far boards and the stands are outside: above the projected far touchline
    far = true_points(truth.camera, "touchline_far", 1.0)
    if len(far):
        x, y = far[len(far) // 2]
        assert grass[max(int(y) - 40, 0), int(x)] == 0 or y < 45
    assert s > 0


def test_decoded_video(tmp_path):
    generate(tmp_path, preset="zoom", seed=4, frames=8)
    clip = SynthClip("zoom", seed=4, frames=8)
    with VideoSource(tmp_path / "clip.mp4") as src:
        det = Detector(src.width, src.height)
        for f in src:
            d = det.process(f.image)
            truth = clip.truth(f.index)
            if truth.circle_fraction >= 0.5:
                assert d.ellipses and d.ellipses[0].kind == "circle"
                cc = true_points(truth.camera, "centre_circle")
                assert np.median(ellipse_distance(cc, d.ellipses[0].ellipse)) < 0.5
            assert d.timings.keys() >= {"grass", "line_pixels", "lines", "ellipses"}


def test_json_and_drawing(runs):
    i, truth, det, *_ = runs["wide"][3]
    js = json.loads(json.dumps(det.to_json()))
    assert js["pitch_visible"] and len(js["lines"]) == len(det.lines) and len(js["ellipses"]) == len(det.ellipses)
    for e in js["ellipses"]:
        C = np.array(e["conic"])
        assert C.shape == (3, 3) and np.isclose(np.linalg.norm(C), 1.0) and np.allclose(C, C.T)
        assert e["kind"] in ("circle", "arc")
    for l in js["lines"]:
        assert np.isclose(np.hypot(*l["line"][:2]), 1.0)
    clip = SynthClip("wide", seed=21, frames=250)
    img = clip.render(i)
    d = detect(img)
    out = draw_detections(img, d)
    assert out.shape == img.shape and out.dtype == np.uint8 and not np.array_equal(out, img)


def test_detector_reuses_its_buffers():
    clip = SynthClip("wide", seed=2, frames=4)
    det = Detector(*SIZE)
    a = det.process(clip.render(0))
    g1 = a.grass_mask
    b = det.process(clip.render(1))
    assert b.grass_mask is g1  # same buffer, new content: copy to keep


@pytest.mark.parametrize(
    "image, message",
    [
        (np.zeros((720, 1280), np.uint8), "BGR uint8"),
        (np.zeros((720, 1280, 3), np.float32), "BGR uint8"),
        (np.zeros((720, 1280, 4), np.uint8), "BGR uint8"),
        ([[0, 0, 0]], "BGR uint8"),
        (np.zeros((8, 8, 3), np.uint8), "at least 16x16"),
    ],
)
def test_bad_images(image, message):
    with pytest.raises(ValueError, match=message):
        detect(image)


@pytest.mark.parametrize(
    "args, kwargs, message",
    [
        ((8, 720), {}, "at least 16x16"),
        ((1280, 720), {"work_width": 4}, "work_width"),
        ((1280, 720), {"ridge_threshold": 0}, "ridge_threshold"),
        ((1280, 720), {"tau": -1}, "tau"),
        ((1280, 720), {"min_grass": 1.5}, "min_grass"),
        (("wide", 720), {}, "integers"),
        ((1024, 576), {"enlarged": (0.0, 1.0)}, "enlarged must be two positive numbers"),
        ((1024, 576), {"enlarged": (float("nan"), 1.0)}, "enlarged must be two positive numbers"),
        ((1024, 576), {"enlarged": 1.42}, "enlarged must be two numbers"),
    ],
)
def test_bad_detector_options(args, kwargs, message):
    with pytest.raises(ValueError, match=message):
        Detector(*args, **kwargs)


def test_detector_rejects_a_frame_of_another_size():
    with pytest.raises(ValueError, match="expects 640x360"):
        Detector(640, 360).process(np.zeros((720, 1280, 3), np.uint8))


def _staircase_line(amp, W=720, H=576, seed=0):
    """A 720 x 576 frame of grass with a near-vertical 3 px white line whose
    centre steps ``amp`` px left and right every 8 rows (a compressed line's
    block staircase), and its centre x at each row."""
    rng = np.random.default_rng(seed)
    img = np.clip(np.array([40, 130, 60]) + rng.normal(0, 2, (H, W, 3)), 0, 255)
    ys = np.arange(H)
    xc = 250 + 0.15 * ys + amp * np.where((ys // 8) % 2 == 0, 1.0, -1.0)
    prof = np.clip(1.5 - np.abs(np.arange(W)[None, :] - xc[:, None]), 0, 1)[..., None]
    return np.clip(img * (1 - prof) + 235.0 * prof, 0, 255).astype(np.uint8), xc


@pytest.mark.parametrize("amp, found", [(0.25, True), (0.3, True), (0.35, False)])
def test_a_stretched_line_is_judged_straight_in_its_source_s_pixels(amp, found):
    # an anamorphic SD still (720 x 576, pixel aspect 64:45) is registered on
    # square pixels, stretched to 1024 x 576: the stretch widens a compressed
    # line's wobble along x with the line, and a halfway line that is straight
    # within the 0.3 px allowed at 720 x 576 was, stretched, no line (a
    # ``real-sd`` still of a centre circle and the halfway line was lost).
    # Told the enlargement, the detector judges it in the source's pixels: the
    # same lines as at the source's size, no more
    img, xc = _staircase_line(amp)
    ex = 1024 / 720
    wide = cv2.resize(img, (1024, 576), interpolation=cv2.INTER_CUBIC)
    assert bool(detect(img).lines) == found
    assert detect(wide).lines == []  # (enlarged, unannounced: over the limit)
    lines = detect(wide, enlarged=(ex, 1.0)).lines
    assert bool(lines) == found
    if found:
        (line,) = lines
        ys = np.arange(20, 556, 8.0)
        x_true = (250 + 0.15 * ys + 0.5) * ex - 0.5  # (the staircase's mid-line, in the stretched frame)
        a, b, c = line.line
        assert np.max(np.abs(a * x_true + b * ys + c)) < 0.5


def test_the_source_s_pixels_relax_only_the_stretched_direction():
    # group_lines' limits in source pixels: a line's wobble along its normal
    # is divided by the enlargement along that normal. Stretched along x, a
    # near-vertical line's sideways wobble (0.35 stretched px, 0.25 of the
    # source's) passes; a near-horizontal line's (0.35 px along y, unstretched)
    # does not, nor does a chord of a circle (a curve in any pixels)
    from arstream.detect.segments import group_lines

    t = np.arange(0.0, 400.0, 0.5)
    wobble = 0.35 * np.where((t // 8) % 2 == 0, 1.0, -1.0)
    src = (1 / 1.42, 1.0)

    def found(pts, nrm, **kw):
        groups, _ = group_lines(pts, nrm, (1024, 576), min_length=50.0, max_gap=30.0, **kw)
        return len(groups)

    vertical = np.column_stack([300 + wobble, 80 + t]), np.tile([1.0, 0.0], (len(t), 1))
    horizontal = np.column_stack([300 + t, 280 + wobble]), np.tile([0.0, 1.0], (len(t), 1))
    assert found(*vertical) == 0 and found(*vertical, source=src) == 1
    assert found(*horizontal) == 0 and found(*horizontal, source=src) == 0
    phi = np.linspace(-0.35, 0.35, 800)  # (a 280 px chord of a 400 px circle: sagitta 24 px)
    arc = np.column_stack([500 + 400 * np.sin(phi), 800 - 400 * np.cos(phi)])
    assert found(arc, np.column_stack([np.sin(phi), -np.cos(phi)]), source=src) == 0
    with pytest.raises(ValueError, match="positive"):
        group_lines(*vertical, (1024, 576), min_length=50.0, max_gap=30.0, source=(0.0, 1.0))


@pytest.mark.parametrize("fill", [(0, 0, 0), (128, 128, 128), (255, 255, 255)])
def test_frames_without_grass_have_no_pitch(fill):
    det = detect(np.full((360, 640, 3), fill, np.uint8))
    assert not det.pitch_visible and det.lines == [] and det.ellipses == [] and len(det.line_points) == 0
    assert not det.grass_mask.any() and not det.line_mask.any()


def test_plain_grass_has_no_markings():
    rng = np.random.default_rng(0)
    img = np.clip(np.array([40, 130, 60]) + rng.normal(0, 3, (360, 640, 3)), 0, 255).astype(np.uint8)
    det = detect(img)
    assert det.pitch_visible and det.lines == [] and det.ellipses == []
    assert det.grass_mask.all()


def test_other_sizes():
    for size in ((1920, 1080), (960, 540)):
        clip = SynthClip("wide", seed=5, frames=30, size=size)
        i = next(i for i in range(0, 30, 3) if clip.truth(i).circle_fraction > 0.9)
        d = Detector(*size).process(clip.render(i))
        cc = true_points(clip.truth(i).camera, "centre_circle", size=size)
        assert d.ellipses and np.median(ellipse_distance(cc, d.ellipses[0].ellipse)) < 0.5 * size[0] / 1280


def test_cli_on_png_and_clip(tmp_path, capsys):
    clip = SynthClip("wide", seed=3, frames=30)
    png = tmp_path / "f.png"
    cv2.imwrite(str(png), clip.render(20))
    assert main(["detect", str(png), "--json", "--draw", str(tmp_path / "d.png")]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["pitch_visible"] and out["lines"] and np.array(out["ellipses"][0]["conic"]).shape == (3, 3)
    assert cv2.imread(str(tmp_path / "d.png")).shape == (720, 1280, 3)
    assert main(["detect", str(png)]) == 0
    assert "lines" in capsys.readouterr().out
    generate(tmp_path / "c", preset="wide", seed=3, frames=6)
    assert main(["detect", str(tmp_path / "c" / "clip.mp4"), "--frame", "4", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["width"] == 1280
    assert main(["detect", str(tmp_path / "none.png")]) == 2
    assert "not found" in capsys.readouterr().err
    (tmp_path / "bad.png").write_bytes(b"not an image")
    assert main(["detect", str(tmp_path / "bad.png")]) == 2
    assert "cannot read" in capsys.readouterr().err
    assert main(["detect", str(tmp_path / "c" / "clip.mp4"), "--frame", "99"]) == 2
    assert "no frame 99" in capsys.readouterr().err
    assert main(["detect", str(png), "--draw", str(tmp_path / "x.unknown")]) == 2
    assert "cannot write" in capsys.readouterr().err


def test_register_a_still_and_a_penalty_area_still(tmp_path, capsys):
    """The solver's single-still registration works from these detections."""
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
        name = "touchline_far" if preset == "wide" else "penalty_area_right_front"
        px = true_points(truth, name, 0.25)
        est = cam.project_pitch(PITCH[name].sample(0.25))
        assert np.median(nearest(est, px)) < 2.0
        # no size given: the size the view constrains, estimated from 105 x 68,
        # stays at this 105 x 68 pitch's (it does not drift)
        made_at = rec["pitch"]
        assert made_at["source"] in ("estimated", "default") and abs(made_at["length"] - 105.0) < 1.0 and abs(made_at["width"] - 68.0) < 1.0, made_at
        # the record, written to a file, is a cameras.jsonl that eval --video judges
        assert rec["frame"] == 0
        (tmp_path / "r.jsonl").write_text(json.dumps(rec) + "\n")
        assert main(["eval", "--video", str(png), "--pred", str(tmp_path / "r.jsonl")]) == 0
        table = capsys.readouterr().out
        assert "coverage" in table and "100.0 %" in table and "warning" not in table, table
    assert main(["register", str(png), "--pitch", "105x68"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("ok  f=") and "pitch 105.0 x 68.0 m (given)" in out


@pytest.mark.parametrize(
    "args, message",
    [
        (["--workers", "0"], "argument --workers: expected a positive int, got '0'"),
        (["--workers", "two"], "argument --workers: expected a positive int, got 'two'"),
        (["--pixel-aspect", "0"], "argument --pixel-aspect: expected a positive float, got '0'"),
    ],
)
def test_register_usage_errors(args, message, capsys):
    with pytest.raises(SystemExit) as e:
        main(["register", "still.png", *args])
    assert e.value.code == 2
    assert capsys.readouterr().err.strip().splitlines()[-1].endswith(f"error: {message}")


def test_lazy_detection_matches_eager():
    # lazy: lines and ellipses computed on first access, from private copies, so
    # resolving after the next frame (or on another thread) gives the same result
    clip = SynthClip("wide", seed=3, frames=8)
    eager, lazy = Detector(*SIZE), Detector(*SIZE)
    pending = []
    for i in range(6):
        img = clip.render(i)
        e = eager.process(img)
        lz = lazy.process(img, lazy=True)
        assert not lz.resolved and "deferred" in repr(lz)
        assert np.array_equal(lz.line_points, e.line_points)
        pending.append((lz, [l.line.copy() for l in e.lines], [el.conic.copy() for el in e.ellipses]))
        if i >= 1:  # resolve the previous frame's after this frame's process()
            lz_prev, lines, conics = pending[i - 1]
            assert len(lz_prev.lines) == len(lines) >= 2 and len(lz_prev.ellipses) == len(conics) >= 1
            for a, b in zip(lz_prev.lines, lines):
                assert np.allclose(a.line, b)
            for a, b in zip(lz_prev.ellipses, conics):
                assert np.allclose(a.conic, b)
            assert lz_prev.resolved and "lines" in lz_prev.timings


def test_halfway_line_found_in_a_fast_pan():
    # the hard preset's fast pan smears the near-vertical halfway line sideways
    # into a wide faint band; the horizontally squashed ridge pass recovers it
    clip = SynthClip("hard", seed=11, frames=250, size=SIZE)
    det = Detector(*SIZE)
    found = 0
    for i in range(20, 40, 2):
        d = det.process(clip.render(i))
        px = true_points(clip.truth(i).camera, "halfway_line")
        assert len(px) > 300
        found += any(np.median(np.abs(px @ l.line[:2] + l.line[2])) < 5.0 and l.length > 100 for l in d.lines)
    assert found >= 4


def _line_on_step(step: float, blur: float, size=(100, 300)) -> np.ndarray:
    """Grey image: a 2 px vertical line (grey 250) centred at x = 150.5 on grass (grey
    90) that is ``step`` brighter right of the line (a mowing stripe's edge), smeared
    horizontally by a box of ``blur`` px (a pan)."""
    h, w = size
    g = np.full((h, w), 90.0, np.float32)
    g[:, 151:] += step
    g[:, 150:152] = 250.0
    if blur > 1:
        g = cv2.blur(g, (int(blur), 1))
    return np.clip(np.rint(g), 0, 255).astype(np.uint8)


@pytest.mark.parametrize(
    "step, blur, scale, bound",
    [
        (0.0, 0.0, 1, 0.01),  # a line on flat grass: exact
        (0.0, 5.0, 1, 0.02),
        (20.0, 0.0, 1, 0.09),  # on a stripe's edge: the step's slope is taken out
        (10.0, 5.0, 1, 0.15),
        (20.0, 5.0, 1, 0.25),
        (10.0, 9.0, 2, 0.35),  # smeared wider than the fine scale: the coarse pass
    ],
)
def test_ridge_centres_on_a_stripe_edge(step, blur, scale, bound):
    # the centre of a line on a step of the grass's brightness (a mowing stripe's or a
    # shadow's edge) is pulled less toward the bright side: with the step's slope
    # left in, the biases of the last four are 0.12, 0.19, 0.38 and 0.59 px
    from arstream.detect.ridges import ridge_points

    g = _line_on_step(step, blur)
    if scale > 1:
        g = cv2.resize(g, (g.shape[1] // scale, g.shape[0] // scale), interpolation=cv2.INTER_AREA)
    rp = ridge_points(g, np.full(g.shape, 255, np.uint8), sigma=1.2 if scale == 1 else 1.3, kernel=11, min_contrast=10, bufs={})
    assert len(rp.pts) >= 0.8 * (g.shape[0] - 4)
    x = (rp.pts[:, 0] + 0.5) * scale - 0.5  # working pixel -> image pixel
    assert abs(np.mean(x) - 150.5) < bound, np.mean(x) - 150.5
    assert np.all(np.abs(rp.nrm[:, 0]) > 0.99)


def _smeared_band_on_step(step: float, smear: int, width: int, size=(60, 300)) -> np.ndarray:
    """A ``width`` px line (grey 210) centred at x = 150.5 (width 2) or 151 (width 3)
    on grass (grey 100) that is ``step`` darker from x = 151 on (a mowing stripe's
    edge), the whole smeared by a ``smear`` px box (a fast pan): a faint band as wide
    as the fine scale, whose plateau slopes down with the step."""
    h, w = size
    g = np.full((h, w), 100.0, np.float32)
    g[:, 151:] -= step
    g[:, 150 : 150 + width] = 210.0
    g = cv2.blur(g, (smear, 1))
    return np.clip(np.rint(g), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("step, smear, width", [(8.0, 7, 2), (13.0, 7, 2), (13.0, 9, 3)])
def test_smeared_band_is_centred_between_its_edges(step, smear, width):
    # a line smeared as wide as the fine scale sits on a plateau that slopes down
    # with the stripe's step: its maximum is at the bright end (1-1.5 px off; on the
    # hard preset's halfway line too), the midpoint of its edges is the line's centre
    from arstream.detect.ridges import ridge_points

    g = _smeared_band_on_step(step, smear, width)
    centre = 149.5 + 0.5 * width
    region = np.full(g.shape, 255, np.uint8)
    rp = ridge_points(g, region, sigma=1.2, kernel=11, min_contrast=10, bufs={})
    assert len(rp.pts) >= 0.8 * (g.shape[0] - 4)
    assert abs(np.mean(rp.pts[:, 0]) - centre) < 0.25, np.mean(rp.pts[:, 0]) - centre
    # the ridge maximum alone (no band centres) is pulled toward the bright side
    ridge = ridge_points(g, region, sigma=1.2, kernel=11, min_contrast=10, band_width=np.inf, bufs={})
    assert np.mean(ridge.pts[:, 0]) - centre < -1.0


@pytest.mark.parametrize(
    "column",
    [  # the hard preset's far touchline (frame 17, 640 px wide): boards (grey 42), a strip of grass, the line, the pitch
        [41, 44, 42, 43, 42, 43, 42, 43, 52, 55, 58, 58, 58, 55, 70, 104, 55, 50, 50, 50, 50, 51, 52, 53, 51, 54, 52, 52, 51, 53],
        [42, 42, 42, 42, 43, 42, 42, 34, 49, 51, 52, 53, 53, 52, 57, 106, 56, 52, 51, 52, 51, 50, 51, 51, 51, 52, 51, 50, 53, 52],
        [41, 42, 43, 43, 42, 42, 42, 48, 55, 57, 59, 61, 60, 59, 82, 101, 55, 53, 50, 51, 52, 50, 52, 52, 51, 54, 52, 52, 53, 53],
    ],
)
def test_a_sharp_line_beside_the_boards_is_not_a_band(column):
    # line + grass strip rise above the dark boards like one wide band; its edges'
    # midpoint is 1.5-2 px off the line. The band is wider than the line's
    # curvature allows, so the ridge centre stays
    from arstream.detect.ridges import ridge_points

    img = cv2.GaussianBlur(np.repeat(np.array(column, np.uint8)[:, None], 80, axis=1), (3, 3), 0.7)
    region = np.full(img.shape, 255, np.uint8)
    rp = ridge_points(img, region, sigma=1.2, kernel=11, min_contrast=6, bufs={})
    ridge = ridge_points(img, region, sigma=1.2, kernel=11, min_contrast=6, band_width=np.inf, bufs={})
    assert len(rp.pts) == len(ridge.pts) >= 70
    assert abs(np.median(rp.pts[:, 1]) - np.median(ridge.pts[:, 1])) < 0.1
    assert abs(np.median(rp.pts[:, 1]) - 14.8) < 0.3


def test_smeared_halfway_line_points_are_unbiased_in_a_fast_pan():
    # the hard preset's fast pan: the halfway line smeared ~19 px across a stripe's
    # edge. Its line points (from the fine pass and from the squashed frame) must lie
    # on the true line; centred on the band's bright end they were 2-3 px off, which
    # the lens term k1 absorbed (2-3 x too strong)
    clip = SynthClip("hard", seed=11, frames=250, size=SIZE)
    det = Detector(*SIZE)
    for i in (8, 17):
        d = det.process(clip.render(i))
        truth = true_points(clip.truth(i).camera, "halfway_line", spacing=0.02)
        P = d.line_points
        near = nearest(P, truth) < 6.0
        # signed offsets along x (the line is near vertical)
        k = np.argmin(np.abs(P[near][:, 1][:, None] - truth[None, :, 1]), axis=1)
        dx = P[near][:, 0] - truth[k, 0]
        assert near.sum() > 100
        assert abs(np.median(dx)) < 0.4, (i, np.median(dx))


@pytest.mark.parametrize("ratio, ok", [(0.06, False), (0.09, False), (0.12, True), (0.17, True), (0.5, True), (0.9, False)])
def test_ellipse_shape_bounds(ratio, ok):
    # a circle on the pitch seen from a broadcast camera: b/a at least 0.1 (about 6
    # degrees above the pitch; the flattest true circle or arc on the presets is
    # 0.17). The tip of a flatter ellipse fits the corner where two lines meet (the
    # goal area's, on the decoded penalty clip: b/a 0.06, reported as an arc)
    from arstream.detect.ellipses import _validate

    a = 380.0
    e = Ellipse((640.0, 400.0), (a, ratio * a), 0.2)
    t = np.linspace(0, 2 * np.pi, 2000, endpoint=False)
    c, s_ = np.cos(e.angle), np.sin(e.angle)
    x, y = a * np.cos(t), ratio * a * np.sin(t)
    P = np.column_stack([640 + c * x - s_ * y, 400 + s_ * x + c * y])
    res = _validate(e, P, 0.1, (1280, 720), lambda p: np.ones(len(p), bool), None, s_full=2.0, min_points=30, min_coverage=0.15, min_visible=0.55, max_rms=0.8)
    assert res[0] is ok


def test_squashed_pass_is_skipped_only_when_the_image_moves_slowly():
    # the pass over the horizontally squashed frame finds the halfway line smeared by
    # a fast pan (hard preset, frame 30: ~16 px per frame at 720p); a caller that
    # knows the image moves slowly (a tracker's pan rate) may skip it, one that
    # knows it moves fast, or does not know, may not
    clip = SynthClip("hard", seed=11, frames=250, size=SIZE)
    img = clip.render(30)
    truth = true_points(clip.truth(30).camera, "halfway_line", spacing=0.05)
    near = {}
    for motion in (None, 20.0, 2.0):
        d = Detector(*SIZE).process(img, motion=motion)
        near[motion] = int(np.sum(nearest(d.line_points, truth) < 3.0))
    assert near[None] == near[20.0] > near[2.0] + 20



def test_coarse_pass_is_skipped_only_when_every_line_is_thin(monkeypatch):
    # a caller that knows the image moves slowly and no painted line is wider than
    # the fine pass sees (a tracker's camera: arstream.track.widest_line) may skip
    # the coarse pass, at no loss on frames with thin lines; on a close view
    # (lines 9 px wide at 640 px) the true hint keeps it, and it is what finds them
    from arstream.detect import detector as D
    from arstream.track import widest_line
    from render.synthetic import main_camera, pitch_frame

    calls = []
    real = D.ridge_points
    monkeypatch.setattr(D, "ridge_points", lambda *a, **k: calls.append(a[0].shape) or real(*a, **k))
    size = (640, 360)
    clip = SynthClip("zoom", seed=11, frames=250, size=size)
    for i in (0, 120):  # lines 2.4 and 3.9 px wide
        img, lw = clip.render(i), widest_line(clip.truth(i).camera, size, 0.12)
        assert lw <= D.FINE_WIDTH  # (working pixels: a 640 px frame is worked on as it is)
        calls.clear()
        hinted = Detector(*size).process(img, motion=1.0, line_width=lw)
        assert calls == [(360, 640)]  # the fine pass alone
        calls.clear()
        full = Detector(*size).process(img, motion=1.0)
        assert calls == [(360, 640), (180, 320)]  # fine and coarse (no squashed pass: slow)
        np.testing.assert_array_equal(hinted.line_points, full.line_points)
        calls.clear()
        Detector(*size).process(img, motion=20.0, line_width=lw)  # a fast pan: all three
        assert len(calls) == 3
    cam = main_camera(*size, tilt_deg=24.0, hfov_deg=10.0)
    img, _ = pitch_frame(cam, *size)
    lw = widest_line(cam, size, 0.12)
    assert lw > 2 * D.FINE_WIDTH
    hinted = Detector(*size).process(img, motion=1.0, line_width=lw)
    full = Detector(*size).process(img, motion=1.0)
    np.testing.assert_array_equal(hinted.line_points, full.line_points)
    assert len(hinted.line_points) > 200 and hinted.lines
    wrong = Detector(*size).process(img, motion=1.0, line_width=2.0)  # a false "thin" hint
    assert len(wrong.line_points) < 0.2 * len(hinted.line_points)


def _thin_line(width: float, rim: float, size=(60, 300)) -> tuple[np.ndarray, np.ndarray]:
    """A far line as a real frame shows it at the working resolution (the penalty
    area's front line of ``israel_league_wide`` frame 175 at 640 px wide: luma
    117-119 above, 150-157 on the line, 101-105 in a sharpened picture's dark rim
    below, 106-107 beyond): a ``width`` px line 40 levels above the grass (118 above
    it, 106 below: a stripe's edge along it), with a 1 px rim ``rim`` levels darker
    below it, rising 6 px over the 300 columns (it crosses the pixel rows), area
    sampled. Returns the image and the line's centre row at each column."""
    h, w = size
    ys, xs = np.arange(h)[:, None] + 0.0, np.arange(w)[None, :]
    yc = 30.2 + 0.02 * xs

    def share(a, b):  # of each pixel row [y - 0.5, y + 0.5] inside [a, b]
        return np.clip(np.minimum(ys + 0.5, b) - np.maximum(ys - 0.5, a), 0.0, None)

    g = np.where(ys < yc, 118.0, 106.0) + 40.0 * share(yc - width / 2, yc + width / 2) - rim * share(yc + width / 2, yc + width / 2 + 1)
    return np.clip(np.rint(g), 0, 255).astype(np.uint8), yc[0]


@pytest.mark.parametrize("width, rim, columns", [(1.0, 0.0, 0.95), (1.0, 14.0, 0.7), (1.5, 14.0, 0.9), (2.0, 14.0, 0.95), (3.0, 14.0, 0.95)])
def test_a_thin_far_line_is_found_along_its_length(width, rim, columns):
    # smoothed at the fine scale (1.2 px) a 1 px line keeps a third of its height, so
    # its contrast over the brighter side is judged at its brightest pixel; and the
    # bright side and the dark rim pull the smoothed maximum up to a pixel off that
    # pixel, where the line is thin. Judged on the smoothed profile alone, with the
    # maximum held to its own pixel, the columns with a point were 0, 0, 0, 0.83 and
    # 0.98 of these (12.7 levels: the detector's threshold for this grass's luma)
    from arstream.detect.ridges import grass_luma, ridge_points

    g, yc = _thin_line(width, rim)
    region = np.full(g.shape, 255, np.uint8)
    # the grass's luma as the detector measures it: the grass model leaves the
    # line's own pixels out (none is 10 levels above the brighter side's 118)
    gl = grass_luma(g, np.where(g < 128, 255, 0).astype(np.uint8), 112.0)
    rp = ridge_points(g, region, sigma=1.2, kernel=11, min_contrast=12.7, grass_luma=gl, bufs={})
    col = np.rint(rp.pts[:, 0]).astype(int)
    off = rp.pts[:, 1] - yc[col]
    assert np.all(np.abs(off) < 1.0), off  # every point within a pixel of the centre
    found = np.zeros(g.shape[1], bool)
    found[col] = True
    assert found[5:-5].mean() >= columns
    # pulled toward the bright side (up) by the step along the line, as the wider
    # lines' centres are (the step's smoothed slope is not the linear background
    # the slope term takes out): 0.50 px for a 1 px line without a rim, 0.74 with it
    assert -0.9 < np.mean(off) < 0.0
    if width < 2.0:  # the rule off (no grass_luma): the smoothed contrast alone misses the line
        assert len(ridge_points(g, region, sigma=1.2, kernel=11, min_contrast=12.7, bufs={}).pts) == 0


def test_the_detector_keeps_a_thin_far_line_whole_with_thin_lines_on():
    # a 1 px line 40 levels brighter than noisy grass (sigma 3), crossing the pixel
    # rows (area sampled), at the working resolution: by the smoothed contrast alone
    # it comes out in dashes, where it crosses pixel centres (0.6 of the columns);
    # judged by its own contrast over the grass around it, whole
    rng = np.random.default_rng(0)
    h, w = 360, 640
    ys, xs = np.arange(h)[:, None] + 0.0, np.arange(w)[None, :]
    yc = 120.3 + 0.03 * xs
    share = np.clip(np.minimum(ys + 0.5, yc + 0.5) - np.maximum(ys - 0.5, yc - 0.5), 0.0, None)
    img = np.array([50.0, 130.0, 60.0]) + rng.normal(0, 3, (h, w, 1)) + share[..., None] * np.array([45.0, 40.0, 45.0])
    img = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    columns = {}
    for thin in (False, True):
        d = Detector(w, h, thin_lines=thin).process(img)
        p = d.line_points
        assert np.all(np.abs(p[:, 1] - (120.3 + 0.03 * p[:, 0])) < 1.0)  # every point on the line
        found = np.zeros(w, bool)
        found[np.clip(np.rint(p[:, 0]).astype(int), 0, w - 1)] = True
        columns[thin] = found[10:-10].mean()
        assert len(d.lines) == 1
    assert columns[False] < 0.75 and columns[True] >= 0.98, columns


def _legs(gap: float, size=(60, 300)) -> np.ndarray:
    """Pairs of dark legs (5 px wide, 70 levels under the grass's 110) ``gap`` px
    apart, every 20 columns over rows 10-49, area sampled: the strip of grass
    between two legs is a thin ridge over them, no brighter than the grass."""
    xs = np.arange(size[1]) + 0.0
    row = np.full(size[1], 110.0)
    for x0 in range(10, size[1] - 20, 20):
        for a in (x0, x0 + 5 + gap):
            row -= 70.0 * np.clip(np.minimum(xs + 0.5, a + 5) - np.maximum(xs - 0.5, a), 0.0, None)
    g = np.full(size, 110, np.uint8)
    g[10:50] = np.clip(np.rint(row), 0, 255).astype(np.uint8)
    return g


@pytest.mark.parametrize("gap", [2.5, 3.0])
def test_grass_between_legs_is_not_judged_as_a_thin_line(gap):
    # judged by its own contrast over the legs (a thin line's rule with no grass
    # below it: -inf), the strip between two legs passed where its smoothed contrast
    # did not: 1120 and 1172 points, against 560 and 472 by the smoothed contrast
    # alone. With the grass's luma around it known, a strip no brighter than the
    # grass is judged as any wide line is: exactly the points of the rule off
    from arstream.detect.ridges import grass_luma, ridge_points

    g = _legs(gap)
    region = np.full(g.shape, 255, np.uint8)

    def count(grass):
        return len(ridge_points(g, region, sigma=1.2, kernel=11, min_contrast=12.0, grass_luma=grass, bufs={}).pts)

    gl = grass_luma(g, np.where(g >= 105, 255, 0).astype(np.uint8), 110.0)
    rule_off = count(None)
    assert count(gl) == rule_off
    assert count(np.full((1, 1), -np.inf, np.float32)) > 1.5 * rule_off


def test_grass_luma_is_the_mean_of_the_grass_pixels_around_each_pixel():
    from arstream.detect.ridges import grass_luma

    rng = np.random.default_rng(3)
    g = rng.integers(0, 256, (12, 16)).astype(np.uint8)
    grass = (rng.random((12, 16)) < 0.5).astype(np.uint8) * 255
    grass[:, 12:] = 0  # no grass in the last four columns: the fallback beyond column 13
    gl = grass_luma(g, grass, 77.0, cells=5)
    assert gl.dtype == np.float32 and gl.shape == g.shape
    pad_g = np.pad(g.astype(float), 2, mode="edge")
    pad_m = np.pad(grass > 0, 2, mode="edge")
    for y in range(12):
        for x in range(16):
            m = pad_m[y : y + 5, x : x + 5]
            want = pad_g[y : y + 5, x : x + 5][m].mean() if m.any() else 77.0
            assert gl[y, x] == pytest.approx(want, rel=1e-5), (y, x)
    assert np.all(gl[:, 14:] == 77.0)


def _shadowed_lines(seed: int = 0) -> tuple[np.ndarray, tuple]:
    """A 640 x 360 frame of sunlit grass with four faint far lines (2 px wide,
    28 levels above the grass in every channel), the upper two under a
    stand's shadow (red and green 0.45, blue 0.55 of the sunlit level, a
    slanted edge with a 3 px penumbra): (image, the lines' rows at x = 20)."""
    rng = np.random.default_rng(seed)
    H, W = 360, 640
    img = np.empty((H, W, 3), np.float32)
    img[:] = (55, 140, 70)
    rows = (50, 90, 260, 300)
    for y in rows:
        cv2.line(img, (20, y), (620, y + 8), (83, 168, 98), 2)
    img += rng.normal(0, 2, img.shape)
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float32)
    lit = np.clip((yy - (150 - 40 * xx / (W - 1))) / 3 + 0.5, 0, 1)[..., None]
    shade = np.array([0.55, 0.45, 0.45], np.float32)
    return np.clip(img * (shade + (1 - shade) * lit), 0, 255).astype(np.uint8), rows


def test_lines_in_a_stand_s_shadow_are_found_as_those_in_the_sun():
    # a shadow across part of the pitch halves the paint's contrast there; a
    # contrast threshold set from the whole frame's grass (mostly sunlit) left
    # the shaded lines out entirely (0 % of their columns; the sunlit ones
    # 39-42 %): asked of each line in its own grass's share, they are found
    # (``shade``: on for a still, detect(); a clip's Detector leaves it off)
    g, rows = _shadowed_lines()

    def found(d):
        P = d.line_points
        out = []
        for y in rows:
            on = np.abs(P[:, 1] - (y + 8 * (P[:, 0] - 20) / 600)) < 2.0
            out.append(len(np.unique(np.rint(P[on, 0]).astype(int))) / 600)
        return out, P

    (shaded, sunlit), P = np.reshape(found(detect(g))[0], (2, 2)), found(detect(g))[1]
    assert min(sunlit) >= 0.3, (shaded, sunlit)
    assert min(shaded) >= min(sunlit), (shaded, sunlit)
    # and no line along the shadow's edge
    edge = np.abs(P[:, 1] - (150 - 40 * P[:, 0] / 639)) < 4.0
    assert edge.sum() <= 5, P[edge]
    off, _ = found(Detector(640, 360).process(g))
    assert max(off[:2]) == 0.0 and min(off[2:]) >= 0.3, off


def test_a_contrast_grid_asks_each_part_of_the_frame_its_own_contrast():
    # ridge_points with one contrast everywhere, and with a grid of contrasts:
    # a line of contrast 10 is found where the grid asks 8 and not where it
    # asks 12; a grid of one value is the scalar
    from arstream.detect.ridges import ridge_points

    g = np.full((120, 200), 100, np.uint8)
    g[29:33, 10:190] = 110  # 4 px wide: smoothing keeps most of its 10 levels
    g[89:93, 10:190] = 110
    region = np.full(g.shape, 255, np.uint8)

    def rows(**kw):
        p = ridge_points(g, region, sigma=1.2, kernel=11, min_contrast=12.0, bufs={}, **kw).pts
        return sorted({int(round(y)) for y in p[:, 1]})

    assert rows() == []
    assert rows(contrast_grid=np.full((1, 1), 12.0, np.float32)) == []
    top_low = np.array([[8.0], [12.0]], np.float32)  # the upper half asks 8, the lower 12
    got = rows(contrast_grid=top_low)
    assert got and all(25 <= y <= 35 for y in got), got


def test_the_kernels_warm_up_with_the_signatures_detection_uses():
    # numba compiles a kernel again for every new argument type signature (some
    # seconds each): the warm-up that every Detector starts must load exactly
    # the signatures detection, tracking, keying and the renderer's footprint
    # call, so that nothing compiles mid-clip
    from arstream import kernels

    kernels.warm_up()
    names = [(m, n) for m in kernels.MODULES for n in m.__all__ if not n.startswith("warm_up")]
    before = {n: len(getattr(m, n).signatures) for m, n in names}
    assert all(v >= 1 for v in before.values()), before
    clip = SynthClip("penalty", seed=3, frames=30, size=(640, 360))
    det = Detector(640, 360)
    for i in (0, 10, 20):
        d = det.process(clip.render(i))
        assert d.lines  # the Hough loop and the ellipse refinement ran
    clip = SynthClip("hard", seed=3, frames=250, size=(640, 360))
    for i in (150, 160):  # the whip pan: smeared bands, centred between their edges
        d = det.process(clip.render(i)).resolve()
    # the tracker's nearest-line-pixel lookups
    from arstream.solve import LineIndex

    LineIndex(d.line_points).nearest(d.line_points[:50] + 1.0, 4.0)
    # the tracker's refinements (tripod, with the pan held, full pose) and the fine key
    import cv2

    from render.keying import GrassKeyI420
    from arstream.solve import ModelSamples, refine_camera

    cam, model, index = clip.camera(160), ModelSamples.from_pitch(), LineIndex(d.line_points)
    for kw in ({"center": cam.center, "estimate_k1": True}, {"center": cam.center, "fixed_pan": True}, {}):
        refine_camera(cam, index, (640, 360), model, radii=(4.0,), **kw)
    yuv = cv2.cvtColor(clip.render(160), cv2.COLOR_BGR2YUV_I420)
    GrassKeyI420()(np.zeros((360, 640), np.uint8), yuv, 640, 360, [(0, 100, 640, 360)], d.grass_small, keep=d.line_small, keep_grow=2)
    # the renderer's footprint, with a pinhole and a distorted lens
    from render import Renderer, default_scene
    from render.synthetic import main_camera

    with Renderer(640, 360, default_scene()) as r:
        for dist in ((), (-0.2,)):
            r.render(main_camera(640, 360, dist=dist))
    after = {n: len(getattr(m, n).signatures) for m, n in names}
    assert after == before


@pytest.mark.parametrize("reach", [1, 3])
def test_chains_are_the_connected_components_of_the_dilated_cells(reach):
    # points.chains links points whose cells are within `reach` along both axes:
    # reach 1 is the 8-connectivity of the occupied cells, reach 3 that of the
    # cells dilated by a 3x3 square (what the detector's chain tests used before)
    from arstream.detect.kernels import points

    rng = np.random.default_rng(reach)
    h, w = 60, 90
    xi = rng.integers(0, w, 400)
    yi = rng.integers(0, h, 400)
    grid = np.full((h, w), -1, np.int32)
    labels, ext_x, ext_y = points.chains(xi, yi, reach, grid)
    assert (grid == -1).all()  # the scratch is left as it came
    img = np.zeros((h, w), np.uint8)
    img[yi, xi] = 255
    if reach == 3:
        img = cv2.dilate(img, np.ones((3, 3), np.uint8))
    _, lab = cv2.connectedComponents(img, connectivity=8)
    ref = lab[yi, xi]
    # the same partition of the points, numbered 1..K
    pairs = set(zip(labels.tolist(), ref.tolist()))
    assert len(pairs) == len(set(labels.tolist())) == len(set(ref.tolist())) > 5
    assert set(labels.tolist()) == set(range(1, labels.max() + 1))
    for k in set(labels.tolist()):
        m = labels == k
        assert (ext_x[m] == np.ptp(xi[m])).all() and (ext_y[m] == np.ptp(yi[m])).all()


def test_grid_clear_is_the_dilated_occupancy_test():
    from arstream.detect.kernels import points

    rng = np.random.default_rng(5)
    h, w = 40, 70
    pts = rng.uniform(-2, [w + 2, h + 2], (150, 2))
    ep = rng.uniform(-2, [w + 2, h + 2], (300, 2))
    grid = np.zeros((h, w), np.uint8)
    for rint, rx, ry in [(True, 2, 0), (False, 2, 2)]:
        keep = points.grid_clear(pts, ep, 1.0, 1.0, rint, rx, ry, grid)
        assert not grid.any()
        cell = (lambda p: np.rint(p).astype(int)) if rint else (lambda p: p.astype(int))
        occ = np.zeros((h, w), np.uint8)
        occ[np.clip(cell(pts[:, 1]), 0, h - 1), np.clip(cell(pts[:, 0]), 0, w - 1)] = 255
        occ = cv2.dilate(occ, np.ones((2 * ry + 1, 2 * rx + 1), np.uint8))
        ref = occ[np.clip(cell(ep[:, 1]), 0, h - 1), np.clip(cell(ep[:, 0]), 0, w - 1)] == 0
        assert 20 < keep.sum() < len(ep) - 20
        np.testing.assert_array_equal(keep, ref)


def test_compiled_direct_fit_matches_the_geometry_core():
    # ellipses.direct_fit (one scatter matrix, compiled) against
    # geometry.conics.direct_fit_scatter on arcs of known ellipses, and the
    # degenerate scatters it must refuse
    from arstream.detect.kernels import ellipses
    from geometry.conics import direct_fit_scatter

    rng = np.random.default_rng(7)
    for _ in range(200):
        a, b, ang = rng.uniform(0.5, 2.0), rng.uniform(0.1, 0.5), rng.uniform(-1, 1)
        t = rng.uniform(0, rng.uniform(0.8, 2 * np.pi), 150)
        x, y = a * np.cos(t), b * np.sin(t)
        X = np.column_stack([x * np.cos(ang) - y * np.sin(ang) + 0.3, x * np.sin(ang) + y * np.cos(ang) - 0.2])
        X += rng.normal(0, 0.01, X.shape)
        D = np.column_stack([X[:, 0] ** 2, X[:, 0] * X[:, 1], X[:, 1] ** 2, X[:, 0], X[:, 1], np.ones(len(X))])
        S = D.T @ D
        coef, ok = ellipses.direct_fit(S)
        ref, ok_ref = direct_fit_scatter(S[None])
        assert ok and ok_ref[0]
        u, v = coef / np.linalg.norm(coef), ref[0] / np.linalg.norm(ref[0])
        assert min(np.abs(u - v).max(), np.abs(u + v).max()) < 1e-7
        assert 4 * coef[0] * coef[2] - coef[1] ** 2 > 0  # an ellipse
    line = np.column_stack([np.linspace(0, 1, 50), np.linspace(0, 2, 50)])
    D = np.column_stack([line[:, 0] ** 2, line[:, 0] * line[:, 1], line[:, 1] ** 2, line[:, 0], line[:, 1], np.ones(50)])
    for S in (np.zeros((6, 6)), D.T @ D, np.full((6, 6), np.nan)):
        coef, ok = ellipses.direct_fit(S)
        assert not ok and np.isnan(coef).all()



def test_compiled_ellipse_screen_matches_numpy():
    # ellipses.ellipse_params (the ellipse search's screen of its hypotheses: the
    # conics of normalised coordinates in pixels, then their axes and angles)
    # against the same formulas in numpy, digit for digit, and against
    # geometry.conics.ellipse_from_conic on real ellipses
    from arstream.detect.kernels import ellipses
    from geometry.conics import conic_from_ellipse, ellipse_from_conic

    rng = np.random.default_rng(4)
    s, m = 0.01, np.array([320.0, 180.0])
    Tn = np.array([[s, 0.0, -s * m[0]], [0.0, s, -s * m[1]], [0.0, 0.0, 1.0]])
    Ti = np.linalg.inv(Tn)
    coefs, truth = [], []
    for _ in range(300):
        e = Ellipse(tuple(rng.uniform(0, 640, 2)), (rng.uniform(20, 300), rng.uniform(5, 19)), rng.uniform(-1.5, 1.5))
        Cq = Ti.T @ conic_from_ellipse(e) @ Ti  # the conic in q = s (p - m)
        c = np.array([Cq[0, 0], 2 * Cq[0, 1], Cq[1, 1], 2 * Cq[0, 2], 2 * Cq[1, 2], Cq[2, 2]])
        coefs.append(c * rng.choice([-1.0, 1.0]) * rng.uniform(0.1, 10))
        truth.append(e)
    coefs += [np.array([1.0, 0.0, -1.0, 0.0, 0.0, -1.0]), np.array([1.0, 0.0, 1.0, 0.0, 0.0, 1.0]), np.zeros(6), np.full(6, np.nan)]  # hyperbola, imaginary, zero, NaN
    coef = np.array(coefs)
    a, b, ang, ok = ellipses.ellipse_params(coef, s, m[0], m[1])

    # numpy: the conics in pixels, unit norm, then their parameters
    with np.errstate(invalid="ignore", divide="ignore"):
        A, B, C, D, E, F = coef.T
        A2, B2, C2 = A * s * s, B * s * s, C * s * s
        D2 = D * s - 2 * A2 * m[0] - B2 * m[1]
        E2 = E * s - 2 * C2 * m[1] - B2 * m[0]
        F2 = A2 * m[0] * m[0] + B2 * m[0] * m[1] + C2 * m[1] * m[1] - D * s * m[0] - E * s * m[1] + F
        P = np.column_stack([A2, B2, C2, D2, E2, F2])
        A, B, C, D, E, F = (P / np.linalg.norm(P, axis=1, keepdims=True)).T
        det = 4 * A * C - B * B
        ok_ref = det > 1e-300
        det = np.where(ok_ref, det, 1.0)
        xc, yc = (B * E - 2 * C * D) / det, (B * D - 2 * A * E) / det
        f0 = F + 0.5 * (D * xc + E * yc)
        half, root = 0.5 * (A + C), np.sqrt(0.25 * (A - C) ** 2 + 0.25 * B * B)
        sgn = np.where(half > 0, 1.0, -1.0)
        l1, l2, f0 = (half - root) * sgn, (half + root) * sgn, f0 * sgn
        ok_ref &= (np.minimum(l1, l2) > 0) & (f0 < 0)
        a_ref = np.where(ok_ref, np.sqrt(-f0 / np.minimum(l1, l2)), 1.0)
        b_ref = np.where(ok_ref, np.sqrt(-f0 / np.maximum(l1, l2)), 1.0)
        ang_ref = (0.5 * np.arctan2(B * sgn, (A - C) * sgn) + np.pi) % np.pi - 0.5 * np.pi
    # the axes: + - * / and sqrt only, each correctly rounded on every SIMD path, in
    # the same order (the six-term norm too): equal to the last bit on any CPU
    np.testing.assert_array_equal(ok, ok_ref & np.isfinite(a_ref) & np.isfinite(b_ref))
    np.testing.assert_array_equal(a[ok], a_ref[ok])
    np.testing.assert_array_equal(b[ok], b_ref[ok])
    # the angle: the kernel's atan2 is libm's, numpy's is SVML's on CPUs with AVX-512
    # (up to 4 ulp of pi apart, numpy issue 23523), halved; the kernel then adds pi/2
    # twice where numpy adds pi once (1 ulp of 2 pi apart on any CPU, 8.9e-16): all
    # within 4 ulp of 2 pi (the bound was 1e-15, 11 % above the second alone)
    np.testing.assert_allclose(ang[ok], ang_ref[ok], rtol=0, atol=4 * np.spacing(2 * np.pi))
    assert ok[:300].all() and not ok[300:].any()
    for k, e in enumerate(truth):
        g = ellipse_from_conic(conic_from_ellipse(e))
        assert abs(a[k] - e.axes[0]) < 1e-9 * e.axes[0] and abs(b[k] - e.axes[1]) < 1e-9 * e.axes[0]
        assert abs(np.sin(ang[k] - g.angle)) < 1e-9


def test_compiled_cut_and_visibility_tests_match_numpy():
    # points.cut_by_line (is an arc cut off by a straight line, with its support
    # beyond it: a penalty arc) and points.mask_at (the ellipse search's
    # "visible" test) against numpy formulas, on random ellipses, lines and masks
    from arstream.detect.kernels import points

    rng = np.random.default_rng(9)
    hits = 0
    for trial in range(400):
        cx, cy, a, b, ang = *rng.uniform(100, 500, 2), rng.uniform(50, 200), rng.uniform(10, 49), rng.uniform(-1, 1)
        th = rng.uniform(0, np.pi, rng.integers(1, 6))
        n = np.column_stack([np.cos(th), np.sin(th)])
        ca, sa = np.cos(ang), np.sin(ang)
        reach = np.hypot(a * (n[:, 0] * ca + n[:, 1] * sa), b * (n[:, 1] * ca - n[:, 0] * sa))
        dc = rng.choice([-1.0, 1.0], len(th)) * rng.uniform(0.0, 1.2, len(th)) * reach  # centre's distance from each line
        L = np.column_stack([n, dc - n @ [cx, cy]])
        # support on the ellipse; on odd trials only (or mostly) beyond the first line
        t = rng.uniform(0, 2 * np.pi, 400)
        x, y = a * np.cos(t), b * np.sin(t)
        P = np.column_stack([cx + x * ca - y * sa, cy + x * sa + y * ca])
        if trial % 2:
            beyond = np.sign(P @ n[0] + L[0, 2]) != np.sign(dc[0])
            P = np.vstack([P[beyond], P[~beyond][: rng.integers(1, 3)]])[: rng.integers(1, 60)]
        else:
            P = P[: rng.integers(1, 60)]
        # numpy: lines cutting the ellipse away from its centre, with > 95 % of the support beyond
        cut = (np.abs(dc) < 0.95 * reach) & (np.abs(dc) >= 0.2 * reach)
        ref = bool(cut.any() and (np.mean(np.sign(P @ n[cut].T + L[cut, 2]) != np.sign(dc[cut]), axis=0) > 0.95).any())
        assert points.cut_by_line(np.ascontiguousarray(P), np.ascontiguousarray(L), cx, cy, a, b, ang, 0.95) is ref
        hits += ref
    assert 20 < hits < 380  # both answers occur

    mask = (rng.random((90, 160)) > 0.5).astype(np.uint8) * 255
    W, H = 1280, 720
    p = np.vstack([rng.uniform(-50, [W + 50, H + 50], (2000, 2)), [[0, 0], [W - 1, H - 1], [W - 0.5, 3], [np.nan, 5]]])
    fx, fy = 160 / W, 90 / H
    ok = (p[:, 0] >= 0) & (p[:, 0] <= W - 1) & (p[:, 1] >= 0) & (p[:, 1] <= H - 1)
    ref = np.zeros(len(p), bool)
    ref[ok] = mask[np.clip((p[ok, 1] * fy).astype(int), 0, 89), np.clip((p[ok, 0] * fx).astype(int), 0, 159)] > 0
    np.testing.assert_array_equal(points.mask_at(p, mask, fx, fy, W - 1.0, H - 1.0), ref)

def test_component_stats_are_opencvs():
    from arstream.detect.kernels import grass

    rng = np.random.default_rng(3)
    total = 0
    for t in range(40):
        img = (cv2.GaussianBlur(rng.random((90, 160)).astype(np.float32), (0, 0), rng.uniform(0.5, 5)) > rng.uniform(0.3, 0.7)).astype(np.uint8) * 255
        for conn in (4, 8):
            n, lab, st, _ = cv2.connectedComponentsWithStats(img, connectivity=conn)
            mine = grass.component_stats(lab, n)
            total += n - 1
            np.testing.assert_array_equal(mine[1:], st[1:])
            if st[0, cv2.CC_STAT_AREA]:
                np.testing.assert_array_equal(mine[0], st[0])
    assert total > 500  # many components, of all shapes


def test_compiled_line_fits_are_fit_line():
    # points.fit_lines (the detector's final fit of its line groups, all at
    # once) against geometry.lines.fit_line of each group: the line, its
    # uncertainties and its extreme points; too few or coincident points give NaN
    from arstream.detect.kernels import points
    from geometry.lines import fit_line

    rng = np.random.default_rng(12)
    P = rng.uniform(0, 1280, (3000, 2))
    groups = []
    for k in range(60):
        n = int(rng.integers(2, 80))
        th, c = rng.uniform(0, np.pi), rng.uniform(0, 1280, 2)
        t = rng.uniform(-300, 300, n)
        pts = c + t[:, None] * [np.cos(th), np.sin(th)] + rng.normal(0, rng.uniform(0, 2), n)[:, None] * [-np.sin(th), np.cos(th)]
        idx = rng.choice(len(P), n, replace=False)
        P[idx] = pts
        groups.append(idx)
    groups += [np.array([5]), np.array([], np.int64)]  # one point, none
    P[[7, 8, 9]] = [100.0, 200.0]
    groups.append(np.array([7, 8, 9]))  # coincident
    offsets = np.cumsum([0] + [len(g) for g in groups])
    line, rms, sig_n, sig_a, ends, length = points.fit_lines(P, np.concatenate(groups).astype(np.int64), offsets)
    for k, g in enumerate(groups[:60]):
        f = fit_line(P[g])
        s = np.sign(line[k] @ f.line)  # (either orientation of the normal)
        np.testing.assert_allclose(s * line[k], f.line, rtol=0, atol=1e-12 * 1280)
        assert abs(rms[k] - f.rms) <= 1e-9 * (1 + f.rms)
        assert sig_n[k] == pytest.approx(f.normal_sigma, rel=1e-9, abs=1e-12) and sig_a[k] == pytest.approx(f.angle_sigma, rel=1e-9, abs=1e-15)
        t = P[g] @ [-line[k, 1], line[k, 0]]
        assert ends[k, 0] == np.argmin(t) and ends[k, 1] == np.argmax(t) and length[k] == pytest.approx(np.ptp(t), abs=1e-9)
    assert np.isnan(line[60:]).all() and np.isnan(rms[60:]).all()


def test_compiled_frame_ellipse_is_ellipse_from_conic():
    # ellipses.frame_ellipse (a hypothesis of the ellipse search, a conic in
    # normalised coordinates, as an ellipse in frame pixels) against
    # geometry.conics.ellipse_from_conic of the pulled-back conic, with the
    # non-ellipses it must refuse (status 1: hyperbola, parabola, zero, NaN;
    # 2: imaginary or a point)
    from arstream.detect.kernels import ellipses
    from geometry.conics import conic_from_ellipse, ellipse_from_conic

    rng = np.random.default_rng(21)
    for _ in range(300):
        s, m, sw = rng.uniform(0.002, 0.05), rng.uniform(0, 640, 2), rng.uniform(1, 3)
        T = np.array([[s / sw, 0.0, -s * m[0]], [0.0, s / sw, -s * m[1]], [0.0, 0.0, 1.0]])  # frame -> q
        a = rng.uniform(20, 600)  # (the shapes the search validates: b / a in 0.1-0.85)
        e = Ellipse(tuple(rng.uniform(0, 1280, 2)), (a, a * rng.uniform(0.1, 0.85)), rng.uniform(-1.5, 1.5))
        Ti = np.linalg.inv(T)
        Cq = Ti.T @ conic_from_ellipse(e) @ Ti
        coef = np.array([Cq[0, 0], 2 * Cq[0, 1], Cq[1, 1], 2 * Cq[0, 2], 2 * Cq[1, 2], Cq[2, 2]]) * rng.choice([-1.0, 1.0]) * rng.uniform(0.1, 10)
        status, cx, cy, a, b, ang = ellipses.frame_ellipse(coef, T)
        ref = ellipse_from_conic(T.T @ np.array([[coef[0], coef[1] / 2, coef[3] / 2], [coef[1] / 2, coef[2], coef[4] / 2], [coef[3] / 2, coef[4] / 2, coef[5]]]) @ T)
        got = Ellipse((cx, cy), (a, b), ang)
        assert status == 0
        # (the same arithmetic after the pull-back, whose sums run in another order)
        np.testing.assert_allclose(got.center, ref.center, rtol=0, atol=1e-9 * ref.axes[0])
        np.testing.assert_allclose(got.axes, ref.axes, rtol=1e-9)
        assert abs(np.sin(got.angle - ref.angle)) < 1e-9
        np.testing.assert_allclose(got.center, e.center, rtol=0, atol=1e-6 * e.axes[0])
        np.testing.assert_allclose(got.axes, e.axes, rtol=1e-6)
    T = np.eye(3)
    for coef, status in [
        ([1.0, 0.0, -1.0, 0.0, 0.0, -1.0], 1),  # hyperbola
        ([0.0, 0.0, 1.0, -1.0, 0.0, 0.0], 1),  # parabola
        ([1.0, 0.0, 1.0, 0.0, 0.0, 1.0], 2),  # imaginary
        ([1.0, 0.0, 1.0, 0.0, 0.0, 0.0], 2),  # a point
        ([0.0] * 6, 1),
        ([np.nan] * 6, 1),
    ]:
        assert ellipses.frame_ellipse(np.array(coef), T)[0] == status, coef
        if status and np.isfinite(coef).all() and any(coef):
            with pytest.raises(ValueError, match="not an ellipse" if status == 1 else "imaginary"):
                ellipse_from_conic(np.array([[coef[0], coef[1] / 2, coef[3] / 2], [coef[1] / 2, coef[2], coef[4] / 2], [coef[3] / 2, coef[4] / 2, coef[5]]]))


def test_compiled_ellipse_search_set_up_matches_numpy():
    # ellipses.hartley_monomials (normalised points and their monomials) and
    # ellipses.label_scatters (the scatter matrix of each arc's free points)
    # against the numpy expressions they replace
    from arstream.detect.kernels import ellipses

    rng = np.random.default_rng(5)
    pts = rng.uniform(0, [640, 360], (2500, 2))
    q, D, mx, my, s = ellipses.hartley_monomials(pts)
    m = pts.mean(axis=0)
    s_ref = np.sqrt(2.0) / np.mean(np.hypot(*(pts - m).T))
    assert abs(mx - m[0]) < 1e-12 * 640 and abs(my - m[1]) < 1e-12 * 640 and s == pytest.approx(s_ref, rel=1e-13)
    np.testing.assert_allclose(q, (pts - m) * s_ref, rtol=0, atol=1e-12)
    x, y = q.T
    np.testing.assert_array_equal(D, np.column_stack([x * x, x * y, y * y, x, y, np.ones_like(x)]))
    assert abs(np.mean(np.hypot(x, y)) - np.sqrt(2)) < 1e-12
    labels = rng.integers(0, 12, len(pts)).astype(np.int32)
    free = rng.random(len(pts)) > 0.3
    slot_of = np.full(12, -1, np.int64)
    slot_of[[7, 2, 9, 0]] = [0, 1, 2, 3]
    S = ellipses.label_scatters(D, labels, free, slot_of)
    assert S.shape == (4, 6, 6)
    for k, lab in enumerate([7, 2, 9, 0]):
        Dk = D[free & (labels == lab)]
        # two sums of the same n products in different orders (BLAS's depends on its
        # kernel and threads): each within n eps |D|^T |D| of the exact one
        np.testing.assert_array_less(np.abs(S[k] - Dk.T @ Dk), 2 * len(Dk) * np.finfo(float).eps * (np.abs(Dk).T @ np.abs(Dk)) + 1e-300)
        np.testing.assert_array_equal(S[k], S[k].T)


def test_compiled_full_rows_match_numpy():
    # grass.full_rows (the screen-graphics test: rows of a component's box
    # that it fills) against the numpy rows count it replaces
    from arstream.detect.kernels import grass

    rng = np.random.default_rng(8)
    seen = 0
    for t in range(40):
        img = (cv2.GaussianBlur(rng.random((90, 160)).astype(np.float32), (0, 0), rng.uniform(0.5, 4)) > rng.uniform(0.3, 0.7)).astype(np.uint8) * 255
        if t % 4 == 0:
            img[5:12, 20:90] = 255  # a solid box
        n, lab = cv2.connectedComponents(img, connectivity=4)
        st = grass.component_stats(lab, n)
        ks = np.arange(1, n, dtype=np.int64)
        got = grass.full_rows(lab, st, ks, 0.9)
        for k, (cnt, first, last) in zip(ks, got):
            x, y, bw, bh, _ = st[k]
            full = np.flatnonzero(np.count_nonzero(lab[y : y + bh, x : x + bw] == k, axis=1) >= 0.9 * bw)
            assert cnt == len(full)
            assert (first, last) == ((full[0], full[-1]) if len(full) else (-1, -1))
            seen += len(full) >= 2
    assert seen > 20


def test_compiled_settling_of_line_points_matches_numpy():
    # points.settle_points (the line points with grass beside them, in chains
    # long enough; their mask and frame coordinates) against the sequence of
    # numpy steps and kernels it replaces
    from arstream.detect.kernels import points

    rng = np.random.default_rng(2)
    w, h, wc, hc = 640, 360, 320, 180
    for t in range(20):
        pts = np.vstack([rng.uniform(0, [w, h], (300, 2))] + [c + np.outer(np.linspace(0, rng.uniform(2, 80), 60), [np.cos(a), np.sin(a)]) for c, a in zip(rng.uniform(0, [w, h], (8, 2)), rng.uniform(0, np.pi, 8))])
        pts = np.clip(pts, 0, [w - 1, h - 1])
        nrm = rng.normal(size=pts.shape)
        nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
        mask = (cv2.GaussianBlur(rng.random((90, 160)).astype(np.float32), (0, 0), 3) > 0.45).astype(np.uint8) * 255
        fx, fy = 160 / w, 90 / h
        grid = np.full((hc, wc), -1, np.int32)
        lm = np.full((h, w), 7, np.uint8)
        sel, labels, full = points.settle_points(pts, nrm, 9.5, mask, fx, fy, wc / w, hc / h, grid, 5.0, lm, 2.0, 0.5, 2.0, 0.5)
        keep = points.beside_grass(pts, nrm, 9.5, mask, fx, fy)
        idx = np.flatnonzero(keep)
        cxi = np.clip((pts[idx, 0] * (wc / w)).astype(np.int64), 0, wc - 1)
        cyi = np.clip((pts[idx, 1] * (hc / h)).astype(np.int64), 0, hc - 1)
        lab, ex, ey = points.chains(cxi, cyi, 1, np.full((hc, wc), -1, np.int32))
        k2 = np.maximum(ex, ey) + 1 >= 5.0
        np.testing.assert_array_equal(sel, idx[k2])
        np.testing.assert_array_equal(labels, lab[k2])
        np.testing.assert_array_equal(full, pts[sel] * 2.0 + 0.5)
        ref = np.zeros((h, w), np.uint8)
        ref[np.clip(np.rint(pts[sel, 1]).astype(int), 0, h - 1), np.clip(np.rint(pts[sel, 0]).astype(int), 0, w - 1)] = 255
        np.testing.assert_array_equal(lm, ref)
        assert (grid == -1).all() and 0 < len(sel) < len(pts)


def test_ellipse_search_refuses_a_rotated_working_frame():
    from arstream.detect.ellipses import find_ellipses

    for n in (50, 5):  # (also with too few points to search)
        pts = np.random.default_rng(0).uniform(0, 100, (n, 2))
        A = np.array([[2.0, 0.1, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1.0]])
        with pytest.raises(ValueError, match="scale and shift each axis"):
            find_ellipses(pts, np.tile([1.0, 0.0], (n, 1)), (100, 100), A, full_size=(200, 200), visible=None, grid_buf=np.full((100, 100), -1, np.int32))
