"""The camera solver: closed form from the centre circle, refinement, line initialiser, tracker.

These tests feed the solver what a perfect detector would report (the true
projected markings with pixel noise and occlusions, see conftest.py), to test
the geometry in isolation; tests/test_e2e*.py run it on real detections.
"""

import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import truth_detections

from arstream.evaluate import score
from arstream.solve import MIN_FOCAL_PX, LineIndex, ModelSamples, explained_share, refine_camera, solve_from_circle
from arstream.solve_lines import cameras_from_line_hypotheses
from arstream.synth import SynthClip
from arstream.initialise import initialise_camera
from arstream.track import Tracker, TrackerConfig, widest_line
from geometry.camera import PTZ, Camera, camera_from_ptz, ptz_from_camera
from geometry.conics import conic_from_ellipse, Ellipse
from geometry.homography import transfer_conic, transfer_lines
from geometry.pitch import PitchModel

PITCH = PitchModel()
MODEL = ModelSamples.from_pitch(PITCH)
SIZE = (1280, 720)


def circle_and_halfway(cam):
    H = cam.H_img_from_pitch
    E = transfer_conic(H, PITCH.circles["centre_circle"])
    lh = transfer_lines(H, PITCH["halfway_line"].line[None])[0]
    return E, lh


def views():
    """Cameras across zooms (f 1.0-3.5 x width) and pans with the circle in view."""
    out = []
    for preset, frames in (("zoom", range(0, 250, 31)), ("wide", range(0, 250, 50))):
        clip = SynthClip(preset, seed=2, frames=250)
        out += [clip.camera(i) for i in frames]
    return out


@pytest.mark.parametrize("cam", views(), ids=lambda c: f"f{c.focal:.0f}")
def test_closed_form_exact_on_noise_free_views(cam):
    E, lh = circle_and_halfway(cam)
    sols = solve_from_circle(E, lh, cam.principal_point, image_width=SIZE[0])
    best = min(sols, key=lambda s: abs(s.f - cam.focal))
    assert abs(best.f / cam.focal - 1) < 1e-7
    assert np.abs(best.camera.R - cam.R).max() < 1e-7
    assert np.linalg.norm(best.camera.center - cam.center) < 1e-4
    assert best.orthogonality < 1e-7
    assert np.allclose(best.centre_image, cam.project_pitch(np.zeros((1, 2)))[0], atol=1e-5)


def test_initialiser_rejects_the_spurious_root():
    """E and the halfway line alone admit two cameras; the other markings decide."""
    clip = SynthClip("zoom", seed=1, frames=250)
    n_two = 0
    frames = [i for i in range(0, 250, 10) if clip.truth(i).circle_fraction > 0.95]
    for i in frames[:: max(len(frames) // 4, 1)]:
        cam = clip.camera(i)
        E, lh = circle_and_halfway(cam)
        n_two += len(solve_from_circle(E, lh, cam.principal_point, image_width=SIZE[0])) == 2
        det = truth_detections(cam, seed=i)
        r = initialise_camera(det, LineIndex(det.line_points), SIZE, MODEL, principal_point=cam.principal_point, pitch=PITCH)
        assert r is not None and r.confidence > 0.9
        assert abs(r.camera.focal / cam.focal - 1) < 0.01
    assert n_two >= 1


def test_closed_form_under_noise_then_refinement():
    clip = SynthClip("wide", seed=4, frames=250)
    cam = clip.camera(120)
    E, lh = circle_and_halfway(cam)
    rng = np.random.default_rng(1)
    # perturb the ellipse by refitting noisy points
    from geometry.conics import ellipse_from_conic, fit_ellipse

    e = ellipse_from_conic(E)
    fit = fit_ellipse(e.points(200) + rng.normal(0, 0.5, (200, 2)))
    sols = solve_from_circle(fit.conic, lh, cam.principal_point, image_width=SIZE[0])
    # f from one circle is sensitive to ellipse noise (here 0.5 px): the closed form only
    # initialises; refinement against all markings gives the answer
    best = min(sols, key=lambda s: abs(s.f - cam.focal))
    assert abs(best.f / cam.focal - 1) < 0.5
    det = truth_detections(cam, seed=3)
    idx = LineIndex(det.line_points)
    r = max((refine_camera(s.camera, idx, SIZE, MODEL) for s in sols), key=lambda r: r.confidence)
    # one frame, free pose: focal length and distance trade off a little
    assert abs(r.camera.focal / cam.focal - 1) < 0.01
    pts = PITCH.sample_points(1.0)
    X = np.column_stack([pts, np.zeros(len(pts))])
    vis = cam.in_front(X)
    err = np.linalg.norm(r.camera.project(X[vis]) - cam.project(X[vis]), axis=1)
    p = cam.project(X[vis])
    inside = (p[:, 0] >= 0) & (p[:, 0] < 1280) & (p[:, 1] >= 0) & (p[:, 1] < 720)
    assert np.median(err[inside]) < 0.5


@pytest.mark.parametrize("preset", ["wide", "hard", "penalty"])
def test_refinement_recovers_a_perturbed_camera(preset):
    clip = SynthClip(preset, seed=1, frames=250)
    cam = clip.camera(130)
    det = truth_detections(cam, seed=5)
    c, p = ptz_from_camera(cam)
    init = camera_from_ptz(c, PTZ(p.pan + 0.01, p.tilt - 0.005, p.roll + 0.003, p.f * 1.03), cam.principal_point)
    r = refine_camera(init, LineIndex(det.line_points), SIZE, MODEL, center=c, estimate_k1=bool(cam.dist))
    assert r.confidence > 0.9 and r.rms < 0.5
    assert abs(r.camera.focal / cam.focal - 1) < 0.003
    if cam.dist:
        assert abs(r.camera.dist[0] - cam.dist[0]) < 0.01


@pytest.mark.parametrize("preset", ["wide", "hard"])
def test_refinement_with_the_pan_held(preset):
    # a whip pan's frame: the pan comes from the smeared bands' brightness, tilt,
    # roll and f from the line pixels at that pan. From a start off in tilt, roll
    # and f (pan right) the refinement recovers them; from a start off in pan too
    # it keeps that pan and does not move it
    clip = SynthClip(preset, seed=1, frames=250)
    cam = clip.camera(130)
    index = LineIndex(truth_detections(cam, seed=5).line_points)
    c, p = ptz_from_camera(cam)
    for d_pan in (0.0, 3.0):
        start = PTZ(p.pan + d_pan / p.f, p.tilt - 4.0 / p.f, p.roll + 3.0 / p.f, p.f * 1.02)
        init = camera_from_ptz(c, start, cam.principal_point, dist=cam.dist)
        r = refine_camera(init, index, SIZE, MODEL, center=c, fixed_pan=True, radii=(6.0, 2.5))
        _, q = ptz_from_camera(r.camera)
        assert r.params == ("tilt", "roll", "logf")
        assert abs(q.pan - start.pan) * p.f < 0.01  # held (to second order in the tilt and roll steps)
        if d_pan == 0.0:
            assert abs(q.tilt - p.tilt) * p.f < 0.3 and abs(q.roll - p.roll) * p.f < 0.3  # (from 4 and 3 px off)
            assert abs(q.f / p.f - 1) < 2e-3  # (from 2 % off)
    with pytest.raises(ValueError, match="fixed_pan needs a fixed center"):
        refine_camera(cam, index, SIZE, MODEL, fixed_pan=True)


def test_line_initialiser_on_a_penalty_area_view():
    clip = SynthClip("penalty", seed=3, frames=100)
    cam = clip.camera(50)
    assert not clip.truth(50).circle_visible
    det = truth_detections(cam, seed=1)
    hyps = cameras_from_line_hypotheses([l.line for l in det.lines[:8]], SIZE, cam.principal_point, PITCH, midpoints=np.array([l.points.mean(0) for l in det.lines[:8]]))
    assert min(np.linalg.norm(h.center - cam.center) for h in hyps) < 0.1
    r = initialise_camera(det, LineIndex(det.line_points), SIZE, MODEL, principal_point=cam.principal_point, pitch=PITCH)
    assert r.confidence > 0.9 and np.linalg.norm(r.camera.center - cam.center) < 1.0


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda E, l: (E, np.array([0.0, 1.0, -5000.0])), "does not cross"),
        (lambda E, l: (conic_from_ellipse(Ellipse((640, 360), (300, 3), 0.0)), np.array([1.0, 0.0, -640.0])), "edge-on"),
        (lambda E, l: (np.diag([1.0, -1.0, -1.0]), l), "not an ellipse"),
    ],
)
def test_degenerate_views(make, message):
    cam = SynthClip("wide", seed=1, frames=10).camera(0)
    E, lh = circle_and_halfway(cam)
    E2, l2 = make(E, lh)
    with pytest.raises(ValueError, match=message):
        solve_from_circle(E2, l2, cam.principal_point, image_width=1280)


def test_refinement_with_nothing_in_view():
    cam = SynthClip("wide", seed=1, frames=10).camera(0)
    with pytest.raises(ValueError, match="fewer than 8"):
        refine_camera(cam, LineIndex(np.zeros((0, 2))), SIZE, MODEL)


def test_a_refinement_that_diverges_raises():
    # (tests/data/refinement/README.md: captured from a still's scan of sizes,
    # where the focal length went to 0 and np.log divided by zero)
    d = np.load(Path(__file__).parent / "data" / "refinement" / "diverges.npz")
    cam = Camera(K=d["K"], R=d["R"], t=-d["R"] @ d["centre"])
    index, size, model = LineIndex(d["points"].astype(np.float64)), tuple(int(v) for v in d["size"]), ModelSamples.from_pitch(PitchModel(100.0, 68.0), 0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # (no RuntimeWarning on the way)
        with pytest.raises(ValueError, match=r"the refinement diverged \(focal length .* px\)"):
            refine_camera(cam, index, size, model, center=d["centre"], radii=(20.0, 10.0), staged=False)
        # the same camera's refinement of its whole pose, staged, starts again
        # from it after the first stage diverges, and ends as the frame allows
        with pytest.raises(ValueError, match="fewer than 8"):
            refine_camera(cam, index, size, model, radii=(20.0, 10.0, 5.0, 3.0))
        # and at the size the scan's other cameras fit, it converges
        good = refine_camera(cam, index, size, ModelSamples.from_pitch(PitchModel(110.0, 72.0), 0.5), center=d["centre"], radii=(20.0, 10.0), staged=False)
    assert MIN_FOCAL_PX < good.camera.focal < 2 * cam.focal


def run_tracker(clip, lag=0, with_images=False):
    tr = Tracker(*SIZE, fps=clip.fps, lag=lag)
    ests = []
    for i in range(clip.n):
        img = clip.render(i) if with_images else None
        ests += tr.process(i, i / clip.fps, img, truth_detections(clip.camera(i), seed=i))
    ests += tr.flush()
    truth = [clip.truth(i).to_record() for i in range(clip.n)]
    return tr, ests, score(truth, [e.to_record() for e in ests], SIZE)


def test_tracker_wide_clip_live_and_offline():
    clip = SynthClip("zoom", seed=5, frames=60)
    tr, ests, s = run_tracker(clip)
    assert [e.frame for e in ests] == list(range(60))
    # this clip starts zoomed in (f ~ 3.3 x width) where, until the tripod centre is known,
    # focal length and distance trade off: a few early frames are off by a few pixels
    assert s.coverage == 1.0 and s.median < 0.5 and s.acc[5] >= 0.95 and s.acc[10] == 1.0 and s.focal_error_median < 0.002
    assert tr.centre is not None and np.linalg.norm(tr.centre - clip.camera_center) < 0.3
    tr2, ests2, s2 = run_tracker(clip, lag=6)
    assert [e.frame for e in ests2] == list(range(60))
    assert s2.median < 0.5 and s2.jitter <= s.jitter + 0.05


def test_tracker_through_a_shot_cut():
    clip = SynthClip("cut", seed=2, frames=60)
    tr, ests, s = run_tracker(clip, with_images=True)
    truth = [clip.truth(i) for i in range(60)]
    assert s.false_estimates == 0
    back = next(i for i in range(25, 60) if truth[i].visible_pitch and not truth[i - 1].visible_pitch)
    assert all(e.status == "lost" for e in ests if not truth[e.frame].visible_pitch)
    assert ests[back + 2].status == "ok"
    assert s.coverage > 0.9 and s.median < 0.5


def test_tracker_takes_the_callers_thumbnails():
    """The shot-cut test compares consecutive thumbnails: the caller's when given
    (the pipeline's, from the decoder's luma), else made from the image."""
    from arstream.imaging import grey_thumbnail

    clip = SynthClip("wide", seed=4, frames=8)
    imgs = [clip.render(i) for i in range(8)]
    thumbs = [grey_thumbnail(im) for im in imgs]
    thumbs[5] = 255.0 - thumbs[5]  # frame 5's thumbnail looks like another shot
    for given, cuts in ((None, 0), (thumbs, 2)):  # into frame 5's "shot", and out of it
        tr = Tracker(*SIZE, fps=clip.fps, lag=0)
        for i in range(8):
            kw = {} if given is None else {"thumbnail": given[i]}
            est = tr.process(i, i / clip.fps, imgs[i], truth_detections(clip.camera(i), seed=i), **kw)[0]
            assert est.status != "lost"
        assert tr.stats["cuts"] == cuts and tr.stats["inits"] == 1 + cuts


def test_tracker_penalty_clip_end_to_end():
    clip = SynthClip("penalty", seed=1, frames=40)
    tr, ests, s = run_tracker(clip)
    assert s.coverage == 1.0 and s.median < 0.5 and s.acc[5] == 1.0


def test_explained_share_separates_right_and_wrong_cameras():
    # low recall (only the centre circle and the halfway line detected, as in a
    # motion-blurred pan): the right camera still explains every detected pixel
    cam = SynthClip("wide", seed=4, frames=10).camera(5)
    det = truth_detections(cam, seed=0)
    keep = np.zeros(len(det.line_points), bool)
    for name in ("centre_circle", "halfway_line"):
        X = PITCH[name].sample(0.05)
        px = cam.project(np.column_stack([X, np.zeros(len(X))]))
        px = px[np.all(np.isfinite(px), axis=1)]
        d = np.min(np.linalg.norm(det.line_points[:, None] - px[None], axis=2), axis=1)
        keep |= d < 1.5
    index = LineIndex(det.line_points[keep])
    assert 100 < len(index) < 0.6 * len(det.line_points)
    assert explained_share(cam, index, SIZE, MODEL) > 0.97
    c, p = ptz_from_camera(cam)
    for dpan in (0.01, -0.02, 0.05):  # 0.6 to 3 degrees of pan: 10 to 50 px
        wrong = camera_from_ptz(c, PTZ(p.pan + dpan, p.tilt, p.roll, p.f), cam.K[:2, 2])
        assert explained_share(wrong, index, SIZE, MODEL) < 0.5
    assert explained_share(cam, LineIndex(np.zeros((0, 2))), SIZE, MODEL) == 0.0


@pytest.mark.parametrize("trusted, status_at_jump, reanchored", [(1.1, "tracked", 1), (0.9, "ok", 0)])
def test_tracker_follows_a_sudden_pan(trusted, status_at_jump, reanchored):
    # from frame 20 the camera pans 0.5 degree per frame more than the motion model
    # expects (the same tripod, no cut), against a tight motion gate. A well-supported
    # measurement (above ``trusted``) is believed at once; otherwise the first is
    # gated and the second in a row, disagreeing with the filter again, restarts it
    clip = SynthClip("wide", seed=6, frames=30)
    tr = Tracker(*SIZE, fps=clip.fps, lag=0, config=TrackerConfig(trusted=trusted, gate=2.0))
    ests, cams = [], []
    for i in range(30):
        cam = clip.camera(i)
        if i >= 20:
            c, p = ptz_from_camera(cam)
            cam = camera_from_ptz(c, PTZ(p.pan + np.radians(0.5) * (i - 19), p.tilt, p.roll, p.f), cam.K[:2, 2])
        cams.append(cam)
        ests += tr.process(i, i / clip.fps, None, truth_detections(cam, seed=i))
    assert ests[20].status == status_at_jump
    assert all(e.status == "ok" for e in ests[21:])
    assert tr.stats["reanchored"] == reanchored
    X = np.array([[0.0, 0.0, 0.0], [0.0, 34.0, 0.0]])
    for e in ests[21:]:
        assert np.max(np.linalg.norm(e.camera.project(X) - cams[e.frame].project(X), axis=1)) < 2.0


def whip_pan_errors(config=None):
    """Track the hard preset's whip pan (frames 150-162: heavy horizontal blur, the
    pan accelerating past the motion model) on real detections of rendered frames,
    at the pipeline's analysis size; returns (per-frame mean errors in frame pixels
    over frames 150-165, tracker stats)."""
    import cv2

    from arstream.detect import Detector
    from arstream.evaluate import frame_error
    from arstream.pipeline.stages import Analysis

    clip = SynthClip("hard", seed=11, frames=250, size=SIZE)
    an = Analysis(*SIZE, 640)
    det, tr = Detector(an.w, an.h), Tracker(an.w, an.h, fps=clip.fps, lag=0, config=config)
    samples = PITCH.sample_points(1.0)
    errors = []
    for i in range(132, 166):
        small = cv2.resize(clip.render(i), (an.w, an.h), interpolation=cv2.INTER_AREA)
        (est,) = tr.process(i, i / clip.fps, small, det.process(small, lazy=True))
        if i >= 150:
            fe = frame_error(clip.camera(i), an.camera(est.camera), SIZE, samples, PITCH.symmetries) if est.camera is not None else None
            errors.append(fe.mean if fe is not None else np.inf)
    return np.array(errors), tr.stats


@pytest.mark.long
def test_tracker_keeps_up_with_a_whip_pan():
    # blur hides most markings and the pan outruns the constant-velocity model; the
    # pan sweep re-finds the camera, its pan set by the smeared bands' brightness
    errors, stats = whip_pan_errors()
    assert stats["swept"] >= 2
    # (at the whip's onset (frame 154) a first refinement that had not converged used
    # to settle 2.5 px off; swept frames' tilt bent to make up for a loose pan:
    # 5 px at worst before both were fixed)
    assert np.all(errors < 3.0), errors.round(1)
    assert np.median(errors) < 1.0
    # without the sweep the filter coasts behind the pan, drifting tens of pixels off
    # (80-250 px, depending on when a re-initialisation catches it)
    errors, stats = whip_pan_errors(TrackerConfig(sweep_range=0.0))
    assert stats["swept"] == 0
    assert errors.max() > 50.0


@pytest.mark.parametrize("preset", ["wide", "penalty"])
def test_pan_sweep_finds_the_pan_or_nothing(preset):
    # from predictions off in pan only, within the sweep's range (+-10 % of the
    # width) the sweep finds the camera; beyond it, it may find nothing, but never
    # a wrong camera (penalty views: many parallel lines a pan could confuse)
    from arstream.evaluate import frame_error

    clip = SynthClip(preset, seed=3, frames=250)
    tr = Tracker(*SIZE)
    X = PITCH.sample_points(1.0)
    found = 0
    for i in range(0, 250, 50):
        cam = clip.camera(i)
        c, p = ptz_from_camera(cam)
        tr.centre = c
        index = LineIndex(truth_detections(cam, seed=i).line_points)
        for off, within in ((-100, True), (-45, True), (30, True), (60, True), (-250, False), (200, False)):
            pred = camera_from_ptz(c, PTZ(p.pan + off / p.f, p.tilt, p.roll, p.f), cam.K[:2, 2], dist=cam.dist)
            r = tr._pan_sweep(pred, index)
            if r is None:
                assert not within, (i, off)
                continue
            found += 1
            assert frame_error(cam, r.camera, SIZE, X, PITCH.symmetries).worst < 2.0, (i, off)
    assert found >= 20


def _whip_frames(frames):
    """The hard preset's rendered frames ``frames`` at the pipeline's analysis size,
    with their true cameras in analysis pixels; and the Analysis."""
    import cv2

    from arstream.pipeline.stages import Analysis

    clip = SynthClip("hard", seed=11, frames=250, size=SIZE)
    an = Analysis(*SIZE, 640)
    S = np.linalg.inv(an.S)
    out = []
    for i in frames:
        small = cv2.resize(clip.render(i), (an.w, an.h), interpolation=cv2.INTER_AREA)
        cam = clip.camera(i)
        out.append((i, small, type(cam)(K=S @ cam.K, R=cam.R, t=cam.t, dist=cam.dist)))
    return out, an


def test_pan_by_brightness_centres_the_smeared_bands():
    # in the whip pan the halfway line is a band some 20-27 px wide that the ridge
    # detector misses; from a camera off in pan, the brightness along the projected
    # markings brings the pan back (analysis pixels): to within a pixel when tilt,
    # roll and zoom are right, and still close when they are off as much as a
    # blurred frame's line pixels leave them (the score's top is then a broad,
    # uneven plateau: its half-height midpoint, not its highest sample, is the pan)
    from arstream.solve import Refinement

    views, an = _whip_frames((156, 157, 159, 161))
    tr = Tracker(an.w, an.h)
    for d_roll, d_f, mean_bound, max_bound in ((0.0, 0.0, 0.5, 1.0), (4.0, 0.0, 1.0, 3.0), (0.0, 0.01, 2.5, 5.0)):
        errors = []
        for i, small, cam in views:
            c, p = ptz_from_camera(cam)
            tr.centre, tr.pp = c, cam.K[:2, 2]
            for off in (-10.0, 6.0, 12.0):
                start = PTZ(p.pan + off / p.f, p.tilt, p.roll + d_roll / p.f, p.f * (1 + d_f))
                off_cam = camera_from_ptz(c, start, cam.K[:2, 2], dist=cam.dist)
                r = tr._pan_by_brightness(Refinement(off_cam, 0.3, 1.0, 100, 50, np.eye(4)), small)
                _, q = ptz_from_camera(r.camera)
                errors.append(abs(q.pan - p.pan) * p.f)
                assert (q.tilt, q.roll, q.f) == pytest.approx((start.tilt, start.roll, start.f), abs=1e-9)
        assert np.mean(errors) < mean_bound and np.max(errors) < max_bound, (d_roll, d_f, np.round(errors, 2))


def test_hump_centre():
    from arstream.track import _hump_centre

    x = np.arange(-30.0, 31.0)
    for centre, plateau in ((3.3, 0.0), (-7.6, 20.0), (0.0, 24.0)):
        # a smeared band's profile: a trapezoid, flat over the plateau
        y = np.clip((0.5 * plateau + 6.0 - np.abs(x - centre)) / 6.0, 0.0, 1.0) + 0.2
        noisy = y + 0.05 * np.sin(3.7 * x) * (y > 0.9)  # an uneven top: its highest sample is anywhere on it
        for curve in (y, noisy):
            k = int(np.argmax(curve))
            assert _hump_centre(x, curve, k) == pytest.approx(centre, abs=0.05 if curve is y else 0.3)
    # a curve that does not fall to half on one side inside the window: no answer
    y = np.clip((40.0 - np.abs(x - 25.0)) / 20.0, 0.0, 1.0)
    assert _hump_centre(x, y, int(np.argmax(y))) is None


def test_pan_sweep_sets_only_the_pan_when_line_pixels_cannot_fix_the_rest():
    # a heavily blurred frame whose refinement is not trusted (here: never, by
    # configuration): with the frame, the sweep keeps the prediction's tilt, roll
    # and zoom and sets the pan from the smeared bands; without it, nothing
    from arstream.detect import Detector

    views, an = _whip_frames((158,))
    (i, small, cam), = views
    tr = Tracker(an.w, an.h, config=TrackerConfig(sweep_explained=1.01))
    c, p = ptz_from_camera(cam)
    tr.centre, tr.pp, tr.k1 = c, cam.K[:2, 2], cam.dist[0]  # as learnt from earlier frames
    index = LineIndex(Detector(an.w, an.h).process(small).line_points)
    pred = camera_from_ptz(c, PTZ(p.pan + 15.0 / p.f, p.tilt, p.roll, p.f), cam.K[:2, 2], dist=cam.dist)
    assert tr._pan_sweep(pred, index) is None
    r = tr._pan_sweep(pred, index, small)
    assert r is not None and tr.stats["pan_only"] == 1
    _, q = ptz_from_camera(r.camera)
    assert abs(q.pan - p.pan) * p.f < 1.0
    assert (q.tilt, q.roll, q.f) == pytest.approx((p.tilt, p.roll, p.f), abs=1e-9)


def test_panned_views_are_the_panned_cameras_views():
    # all pans at once give exactly what each panned camera sees (solve._visible)
    from arstream.solve import _visible
    from arstream.track import _panned_views

    C = np.array([3.0, -60.0, 15.0])
    pp = (319.5, 179.5)
    for dist in ((), (-0.05,)):
        cam = camera_from_ptz(C, PTZ(0.1, 0.25, 0.01, 700.0), pp, dist=dist)
        offsets = np.array([-40.0, -7.5, 0.0, 12.0, 60.0])
        px, inside = _panned_views(cam, C, offsets, MODEL.points, (640, 360))
        for j, off in enumerate(offsets):
            cj = camera_from_ptz(C, PTZ(0.1 + off / 700.0, 0.25, 0.01, 700.0), pp, dist=dist)
            want_in, want_px = _visible(cj, MODEL, (640, 360))
            assert np.array_equal(inside[j], want_in)
            assert np.abs(px[j][want_in] - want_px[want_in]).max() < 1e-9
            assert inside[j].sum() > 100


def test_tracker_predicts_over_dropped_frames():
    # a live source (--realtime) drops frames under load; the filter must predict over
    # the frames that passed, not one step: in the hard preset's early pan (16 px a
    # frame) a one-step prediction after drops fell 40 px behind, the next good
    # measurement was gated as an outlier and frame 17 coasted 39 px off
    import cv2

    from arstream.detect import Detector
    from arstream.evaluate import frame_error
    from arstream.pipeline.stages import Analysis

    clip = SynthClip("hard", seed=11, frames=250, size=SIZE)
    an = Analysis(*SIZE, 640)
    det, tr = Detector(an.w, an.h), Tracker(an.w, an.h, fps=clip.fps, lag=0)
    F1, _ = tr._motion(1)
    F3, Q3 = tr._motion(3)
    assert np.allclose(F3, F1 @ F1 @ F1) and np.all(np.linalg.eigvalsh(Q3) >= -1e-15)
    samples = PITCH.sample_points(1.0)
    drops = {1, 2, 3, 5, 10, 15, 18, 19}
    for i in range(24):
        if i in drops:
            continue
        small = cv2.resize(clip.render(i), (an.w, an.h), interpolation=cv2.INTER_AREA)
        (est,) = tr.process(i, i / clip.fps, small, det.process(small, lazy=True))
        assert est.status == "ok", (i, est.status)
        assert frame_error(clip.camera(i), an.camera(est.camera), SIZE, samples, PITCH.symmetries).mean < 2.0, i
    assert tr.stats["gated"] == 0


def test_image_motion_by_frame():
    # the sideways image motion the tracker reports per solved frame (the detector's
    # hint, asked two frames back so that threaded or not it gets the same answer)
    clip = SynthClip("hard", seed=11, frames=250)
    tr = Tracker(*SIZE, fps=clip.fps)
    assert tr.image_motion() is None and tr.image_motion(0) is None
    for i in range(12):
        tr.process(i, i / clip.fps, None, truth_detections(clip.camera(i), seed=i))
    c0, p0 = ptz_from_camera(clip.camera(10))
    c1, p1 = ptz_from_camera(clip.camera(11))
    true_motion = abs(p1.pan - p0.pan) * p1.f  # px per frame
    assert tr.image_motion() == tr.image_motion(11)
    assert abs(tr.image_motion(11) - true_motion) < 0.25 * true_motion + 1.0
    assert tr.image_motion(40) is None  # not solved
    for i in range(12, 60, 3):  # frames skipped (a live source drops some): still bounded
        tr.process(i, i / clip.fps, None, truth_detections(clip.camera(i), seed=i))
    assert tr.image_motion(3) is None and tr.image_motion(57) is not None  # long gone; the last one
    assert len(tr._motion_at) <= 17
    # the other hint: the widest painted line, from the camera solved for that frame
    tr.process(60, 60 / clip.fps, None, truth_detections(clip.camera(60), seed=60))
    assert abs(tr.line_width(60) - widest_line(clip.camera(60), SIZE, 0.12)) < 0.02 * widest_line(clip.camera(60), SIZE, 0.12)
    assert tr.line_width(3) is None and tr.line_width(40) is None and len(tr._width_at) <= 17


def test_widest_line_is_the_width_of_a_line_at_the_bottom_edge():
    # f w / depth where the pitch plane is nearest: a 12 cm segment on the pitch,
    # parallel to the image plane, at the bottom edge's corners and middle, is that
    # wide once projected; the widest of the three is the answer. A camera
    # looking up or standing below the pitch sees no such edge: None
    from render.synthetic import main_camera

    for pan, tilt, roll, hfov in ((0, 17, 0, 62), (25, 30, 0, 12), (-40, 8, 0, 40), (10, 20, 6, 30)):
        cam = main_camera(*SIZE, pan_deg=pan, tilt_deg=tilt, roll_deg=roll, hfov_deg=hfov)
        widths = []
        for u in (0.0, (SIZE[0] - 1) / 2, SIZE[0] - 1.0):
            g = cam.backproject_to_pitch(np.array([[u, SIZE[1] - 1.0]]))[0]
            # a segment parallel to the image plane keeps its depth: f w / depth across the image
            side = np.cross(cam.R[2], [0, 0, 1.0])  # on the pitch and parallel to the image plane
            side /= np.linalg.norm(side)
            ends = cam.project(np.array([[*g, 0.0], [*g, 0.0]]) + 0.06 * np.array([side, -side]))
            widths.append(np.linalg.norm(ends[0] - ends[1]))
        got = widest_line(cam, SIZE, 0.12)
        assert abs(got - max(widths)) < 1e-6 * got, (pan, tilt, roll, got, widths)
    assert widest_line(main_camera(*SIZE, tilt_deg=-15.0, hfov_deg=30), SIZE, 0.12) is None  # the bottom edge sees the sky
    assert widest_line(main_camera(*SIZE, center=(0.0, -62.0, -1.0)), SIZE, 0.12) is None  # below the pitch


@pytest.mark.parametrize("radius", [0.75, 2.5, 25.0, 1e9])  # (exact binary fractions: "exactly the radius away" is exact)
@pytest.mark.parametrize("cell", [3.0, 8.0])
def test_line_index_finds_the_nearest_point_closer_than_the_radius(radius, cell):
    # the grid search against brute force: exact nearest neighbours, strictly
    # closer than the radius (points off the grid's cells and queries far outside
    # the points' box included; rounded points make ties, which go to the lower index)
    rng = np.random.default_rng(int(radius * 10) + int(cell))
    P = np.round(rng.uniform(-20, [1300, 740], (1500, 2)))
    Q = np.vstack([rng.uniform(-60, [1340, 780], (400, 2)), P[20:80] + rng.uniform(-0.5, 0.5, (60, 2)), [[np.nan, 3.0], [np.inf, 0.0]]])
    if radius < 100:  # exactly the radius away from a point: not closer
        Q = np.vstack([Q, P[:20] + [[0.0, radius]]])
    d, q = LineIndex(P, cell=cell).nearest(Q, radius)
    D = np.hypot(Q[:, None, 0] - P[None, :, 0], Q[:, None, 1] - P[None, :, 1])
    D[~np.isfinite(D)] = np.inf
    j = np.argmin(D, axis=1)  # the lowest index among equals
    dmin = D[np.arange(len(Q)), j]
    hit = dmin < radius
    assert 0 < hit.sum() < len(Q) - 1
    np.testing.assert_array_equal(np.isfinite(d), hit)
    np.testing.assert_allclose(d[hit], dmin[hit], rtol=0, atol=1e-9)
    np.testing.assert_array_equal(q[hit], P[j[hit]])
    assert np.isnan(q[~hit]).all()


def test_line_index_edge_cases():
    d, q = LineIndex(np.zeros((0, 2))).nearest(np.array([[1.0, 2.0]]), 5.0)
    assert d[0] == np.inf and np.isnan(q).all()
    one = LineIndex(np.array([[10.0, 10.0]]))
    d, q = one.nearest(np.array([[13.0, 14.0], [10.0, 16.0], [40.0, 10.0]]), 6.0)
    np.testing.assert_allclose(d, [5.0, np.inf, np.inf])  # 6.0 away is not closer than 6
    assert one.nearest(np.zeros((0, 2)), 3.0)[0].shape == (0,)
    with pytest.raises(ValueError, match="finite"):
        LineIndex(np.array([[0.0, 0.0], [np.nan, 1.0]]))


@pytest.mark.parametrize("dist", [(), (-0.08,), (0.3, -0.2)], ids=["pinhole", "k1", "k1k2-fold"])
def test_compiled_projection_matches_camera_project(dist):
    # solve_kernels.project_points (the refinement's and the visibility test's projection)
    # against geometry.camera.Camera.project: same pixels, NaN behind the camera and
    # past the lens polynomial's fold, and the in-view test with a margin
    from arstream.solve_kernels import project_points

    rng = np.random.default_rng(3)
    cam = camera_from_ptz(np.array([0.0, -40.0, 12.0]), PTZ(0.2, 0.3, 0.02, 900.0), (640.0, 360.0), dist=dist)
    X = np.column_stack([rng.uniform(-80, 80, 4000), rng.uniform(-80, 80, 4000), rng.uniform(-2, 30, 4000)])
    want = cam.project(X)
    z = cam.to_camera(X)[:, 2]
    for min_depth, margin in ((0.0, 0.0), (0.5, 2.0), (3.0, -640.0)):
        px, inside = project_points(X, cam.R, cam.t, cam.K, np.asarray(dist, np.float64), 1280, 720, margin, min_depth)
        front = z > min_depth
        assert np.array_equal(np.isnan(px[:, 0]), ~front | np.isnan(want[:, 0]))
        ok = ~np.isnan(px[:, 0])
        assert np.abs(px[ok] - want[ok]).max() < 1e-9 * np.abs(want[ok]).max()
        with np.errstate(invalid="ignore"):
            want_in = ok & (want[:, 0] >= margin) & (want[:, 0] <= 1279 - margin) & (want[:, 1] >= margin) & (want[:, 1] <= 719 - margin)
        assert np.array_equal(inside, want_in)
    assert (z <= 0).any()  # points behind the camera occur
    if len(dist) == 2:  # and, with this lens, points past its fold
        assert (np.isnan(want[:, 0]) & (z > 0)).sum() > 10


@pytest.mark.parametrize("k1", [0.0, -0.06])
def test_marking_residuals_and_their_jacobian(k1):
    # solve_kernels.marking_residuals: residuals = normal distance of the distorted
    # projection from the matched pixel, 50 (flat) behind the camera; its Jacobian
    # (left rotation perturbation, centre, log f, k1) against central differences
    import cv2

    from arstream.solve_kernels import marking_residuals

    rng = np.random.default_rng(5)
    C = np.array([2.0, -45.0, 14.0])
    cam = camera_from_ptz(C, PTZ(0.1, 0.35, -0.01, 1100.0), (640.0, 360.0))
    X = MODEL.points[rng.choice(len(MODEL.points), 300, replace=False)]
    X = np.concatenate([X, [[2.0, -60.0, 14.0]]])  # behind the camera
    pix = cam.project(X[:-1])
    Q = np.concatenate([pix + rng.normal(0, 2, pix.shape), [[0.0, 0.0]]])
    ang = rng.uniform(0, np.pi, len(X))
    nrm = np.column_stack([np.cos(ang), np.sin(ang)])
    f, cx, cy = cam.focal, 640.0, 360.0

    def residuals(th):
        R = cv2.Rodrigues(th[:3])[0] @ cam.R
        Xc = (X - th[3:6]) @ R.T
        xn = Xc[:, :2] / Xc[:, 2:3]
        xd = xn * (1 + th[7] * (xn**2).sum(1, keepdims=True))
        r = ((np.exp(th[6]) * xd + [cx, cy] - Q) * nrm).sum(1)
        return np.where(Xc[:, 2] > 0, r, 50.0)

    th0 = np.concatenate([np.zeros(3), C, [np.log(f)], [k1]])
    r, G = marking_residuals(X, Q, nrm, cam.R, C, f, cx, cy, k1)
    assert np.allclose(r, residuals(th0), rtol=0, atol=1e-9)
    assert r[-1] == 50.0 and not G[-1].any()
    steps = np.array([1e-6] * 3 + [1e-4] * 3 + [1e-6, 1e-6])
    num = np.column_stack([(residuals(th0 + e) - residuals(th0 - e)) / (2 * e[j]) for j, e in enumerate(np.diag(steps))])
    scale = np.abs(num).max(axis=0)
    assert np.all(np.abs(G - num).max(axis=0) <= 1e-5 * scale + 1e-9)


def _pose_maps(R_ref, C):
    """(name, M, th) of the three parameterisations refine_camera uses: free
    centre, fixed centre with k1, fixed centre with the pan held (two rotation
    parameters along Bw)."""
    rng = np.random.default_rng(11)
    full = np.zeros((8, 7))
    full[:3, :3] = np.eye(3)
    full[3:6, 3:6] = np.eye(3)
    full[6, 6] = 1.0
    fixed = np.zeros((8, 5))
    fixed[:3, :3] = np.eye(3)
    fixed[6, 3] = fixed[7, 4] = 1.0
    d = R_ref[2]
    h = np.cross([0.0, 0.0, 1.0], d)
    Bw = np.column_stack([R_ref @ (h / np.linalg.norm(h)), [0.0, 0.0, 1.0]])
    pan = np.zeros((8, 3))
    pan[:3, :2] = Bw
    pan[6, 2] = 1.0
    return [
        ("free centre", full, np.concatenate([rng.normal(0, 0.01, 3), C + rng.normal(0, 0.5, 3), [np.log(1000.0)]])),
        ("fixed centre, k1", fixed, np.concatenate([rng.normal(0, 0.01, 3), [np.log(1000.0), -0.05]])),
        ("pan held", pan, np.concatenate([rng.normal(0, 0.01, 2), [np.log(1000.0)]])),
    ]


def test_pose_from_params_is_the_rodrigues_perturbation():
    import cv2

    from arstream.solve_kernels import pose_from_params

    C = np.array([2.0, -45.0, 14.0])
    R_ref = camera_from_ptz(C, PTZ(0.1, 0.35, -0.01, 1000.0), (640.0, 360.0)).R
    for name, M, th in _pose_maps(R_ref, C):
        R, Cp, f, k1 = pose_from_params(th, R_ref, M, C + 1.0, 0.02)
        assert np.allclose(R, cv2.Rodrigues(M[:3] @ th)[0] @ R_ref, rtol=0, atol=1e-14), name
        assert np.allclose(Cp, M[3:6] @ th if M[3:6].any() else C + 1.0, rtol=0, atol=0), name
        assert f == pytest.approx(np.exp(M[6] @ th), rel=1e-15) and k1 == (M[7] @ th if M[7].any() else 0.02), name
    R, _, _, _ = pose_from_params(np.zeros(7), R_ref, _pose_maps(R_ref, C)[0][1], C, 0.0)
    assert np.array_equal(R, np.eye(3) @ R_ref)  # a zero rotation is exactly the identity


@pytest.mark.parametrize("which", [0, 1, 2], ids=["free-centre", "fixed-centre-k1", "pan-held"])
def test_refine_pose_reaches_the_soft_l1_minimum_scipy_finds(which):
    # solve_kernels.refine_pose (compiled LM, soft-L1 by reweighting) against
    # scipy.optimize.least_squares(loss="soft_l1") on the same residuals, with
    # 15 % gross outliers among the matches and a start a few pixels off
    import scipy.optimize

    from arstream.solve_kernels import marking_residuals, pose_from_params, refine_pose

    rng = np.random.default_rng(which)
    C = np.array([2.0, -45.0, 14.0])
    cam = camera_from_ptz(C, PTZ(0.1, 0.35, -0.01, 1000.0), (640.0, 360.0), dist=(-0.05,))
    name, M, th_true = _pose_maps(cam.R, C)[which]
    R_ref = cam.R
    k1_fixed = -0.05 if which != 1 else 0.0
    R0, C0, f0, k0 = pose_from_params(th_true, R_ref, M, C, k1_fixed)
    Xc = (MODEL.points - C0) @ R0.T
    xn = Xc[:, :2] / Xc[:, 2:3]
    px = f0 * xn * (1 + k0 * (xn**2).sum(1, keepdims=True)) + [640.0, 360.0]
    inside = np.flatnonzero((Xc[:, 2] > 1.0) & (np.abs(px - [640.0, 360.0]) < [640.0, 360.0]).all(axis=1))  # in the frame
    pick = rng.choice(inside, 500, replace=False)
    X, px = MODEL.points[pick], px[pick]
    ang = rng.uniform(0, np.pi, len(X))
    nrm = np.column_stack([np.cos(ang), np.sin(ang)])
    Q = px - nrm * rng.normal(0, 0.5, (len(X), 1))
    bad = rng.random(len(X)) < 0.15
    Q[bad] += nrm[bad] * rng.uniform(5, 30, (bad.sum(), 1))
    th0 = th_true.copy()
    th0[:2] += 0.003  # pixels off at f = 1000
    th0[-1 if which != 1 else 3] += 0.003

    def fun(th):
        R, Cc, f, k1 = pose_from_params(th, R_ref, M, C, k1_fixed)
        return marking_residuals(X, Q, nrm, R, Cc, f, 640.0, 360.0, k1)[0]

    def jac(th):
        R, Cc, f, k1 = pose_from_params(th, R_ref, M, C, k1_fixed)
        return marking_residuals(X, Q, nrm, R, Cc, f, 640.0, 360.0, k1)[1] @ M

    def pixels(th):
        R, Cc, f, k1 = pose_from_params(th, R_ref, M, C, k1_fixed)
        xc = (X - Cc) @ R.T
        u = xc[:, :2] / xc[:, 2:3]
        return f * u * (1 + k1 * (u**2).sum(1, keepdims=True))

    x, r, J, cost, steps = refine_pose(X, Q, nrm, R_ref, M, th0, C, k1_fixed, 640.0, 360.0, 1.0, 50, 1e-12)
    ref = scipy.optimize.least_squares(fun, th0, jac=jac, loss="soft_l1", f_scale=1.0, xtol=1e-14, ftol=1e-14, gtol=1e-14)
    assert np.allclose(r, fun(x), rtol=0, atol=1e-12) and np.allclose(J, jac(x), rtol=0, atol=1e-9)  # returned at its solution
    # it stops once a step gains less than 1e-4 of the cost (scipy's cost is half the sum of
    # rho), which leaves it within a fraction of a pixel of scipy's solution along the flat
    # directions of the problem (a free centre against the focal length)
    assert cost <= 2 * ref.cost * (1 + 1e-4), name
    assert np.abs(pixels(x) - pixels(ref.x)).max() < 0.25, name
    assert np.abs(pixels(th0) - pixels(ref.x)).max() > 3.0  # (from a start pixels away)
    assert 1 <= steps <= 50


@pytest.mark.parametrize("farther", [1.25, 1.4])
def test_refinements_along_sight_leave_a_wrong_centres_basin(farther):
    # a view between the centre circle and a penalty area through a long lens
    # (3.3 widths), and the best camera about a centre 1.25 or 1.4 times as far
    # along the line of sight: freed in small steps, the refinement stays in
    # that basin, metres off (0.63 and 0.53 of the markings in view near a line
    # pixel, 14.5 and 8.1 m); started from the camera moved nearer and farther
    # along the line of sight, one reaches the view's own camera (1.00, 0.04
    # and 0.13 m)
    from cameras import looking_at

    from arstream.solve import refinements_along_sight
    from geometry.camera import camera_at_centre

    true = looking_at((24.0, -60.0, 9.5), (-20.0, 10.0, 0.0), 3.3 * SIZE[0], SIZE)

    def in_view(px):
        return np.all(np.isfinite(px), axis=1) & (px[:, 0] >= 0) & (px[:, 0] < SIZE[0]) & (px[:, 1] >= 0) & (px[:, 1] < SIZE[1])

    P = PITCH.sample_points(0.05)
    px = true.project_pitch(P)
    ok = in_view(px)
    index = LineIndex(px[ok] + np.random.default_rng(0).normal(0.0, 0.3, (ok.sum(), 2)))
    g = np.append(true.backproject_to_pitch(np.array([[639.5, 359.5]]))[0], 0.0)
    far = g + farther * (true.center - g)
    seen = PITCH.sample_points(1.0)
    wrong = refine_camera(camera_at_centre(true, far, seen[in_view(true.project_pitch(seen))]), index, SIZE, MODEL, center=far, radii=(4.0, 2.5))
    freed = refine_camera(wrong.camera, index, SIZE, MODEL, center=None, radii=(4.0, 2.5, 2.5, 2.5, 2.5))
    found = refinements_along_sight(wrong.camera, index, SIZE, MODEL)
    assert len(found) == 3
    best = max(found, key=lambda r: r.confidence)
    assert freed.confidence < 0.7 and np.linalg.norm(freed.camera.center - true.center) > 5.0, (freed.confidence, freed.camera.center)
    # (0.3 px of noise on the line pixels: a few centimetres along the line of sight)
    assert best.confidence > 0.99 and np.linalg.norm(best.camera.center - true.center) < 0.5, (best.confidence, best.camera.center)
    # no pitch under the image centre's ray: nothing to start from
    sky = looking_at((24.0, -60.0, 9.5), (-20.0, 10.0, 30.0), 3.3 * SIZE[0], SIZE)
    assert refinements_along_sight(sky, index, SIZE, MODEL) == []
