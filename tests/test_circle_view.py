"""Centre-circle views whose ellipse does not fix the focal length: a low
camera far away sees the circle nearly edge-on, and the frame's edge or the
players leave a short arc of it (the first 88 frames of the shared
``israel_league_wide`` clip). The closed form takes f from the ellipse alone;
:func:`arstream.solve.cameras_along_circle` gives the one-parameter family the
arc and the halfway line leave, and the rest of the pitch picks its member
(:func:`arstream.initialise.circle_view_cameras`)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from cameras import grass_seen, looking_at
from scipy.spatial import cKDTree

from arstream.detect import detect
from arstream.evaluate import frame_error
from arstream.detect.results import DetectedEllipse
from arstream.initialise import circle_view_cameras, initialise_from_paint, paint_view, register_frame
from arstream.solve import cameras_along_circle, solve_from_circle
from geometry.conics import conic_from_circle, conic_from_ellipse, fit_ellipse
from geometry.homography import transfer_conic, transfer_lines
from geometry.pitch import PitchModel

PITCH = PitchModel()
SIZE = (1280, 720)
R = PITCH["centre_circle"].radius


def _low_far_camera(size=SIZE):
    # about the shared clip's: 9.5 m up, 60 m from the halfway line's middle, a
    # long lens (3.3 widths), looking left of the circle: a third of it is in view
    return looking_at((24.0, -60.0, 9.5), (-24.0, 10.0, 0.0), 3.3 * size[0], size)


def _in_view(px, size):
    return np.all(np.isfinite(px), axis=1) & (px[:, 0] >= 0) & (px[:, 0] <= size[0] - 1) & (px[:, 1] >= 0) & (px[:, 1] <= size[1] - 1)


def _exact_primitives(cam, size=SIZE):
    """The circle's conic and the halfway line's image, and their pixels in view."""
    H = cam.H_img_from_pitch
    E = transfer_conic(H, PITCH.circles["centre_circle"])
    lh = transfer_lines(H, PITCH["halfway_line"].line[None])[0]
    th = np.linspace(0, 2 * np.pi, 720, endpoint=False)
    arc = cam.project_pitch(np.column_stack([R * np.cos(th), R * np.sin(th)]))
    arc = arc[_in_view(arc, size)]
    y = np.linspace(-PITCH.width / 2, PITCH.width / 2, 400)
    half = cam.project_pitch(np.column_stack([np.zeros_like(y), y]))
    return E, lh, arc, half[_in_view(half, size)]


def test_the_view_shows_a_short_arc_only():
    cam = _low_far_camera()
    _, _, arc, half = _exact_primitives(cam)
    assert 0.25 < len(arc) / 720 < 0.45 and len(half) > 30  # what the tests below stand on


def test_cameras_along_circle_give_the_camera_at_its_focal_length():
    cam = _low_far_camera()
    E, lh, arc, half = _exact_primitives(cam)
    (got,) = cameras_along_circle(E, lh, arc, half, cam.principal_point, image_width=SIZE[0], focals=[cam.focal])
    # exact pixels: the robust fit's stopping tolerance (1e-6 relative) is what is left
    assert np.linalg.norm(got.center - cam.center) < 0.01
    assert np.abs(got.R - cam.R).max() < 1e-5
    assert got.focal == cam.focal


@pytest.mark.parametrize("offset", [0.0, 3.0])
def test_the_circle_view_fits_jacobian_is_the_residuals_derivative(offset):
    # the exact Jacobian the fit is given, against central differences of its
    # residuals, 2 mrad and 2 cm (twice) about the low far camera's rotation
    # and centre; with an offset, the line X = 3 m stands for the halfway
    # line (the pixels then lie 3 m off it: any residuals will do). (At the
    # rotation vector 0 itself, OpenCV's Rodrigues Jacobian is good to 1e-6.)
    from scipy.optimize._numdiff import approx_derivative

    from arstream.solve import _CircleViewFit

    cam = _low_far_camera()
    _, _, arc, half = _exact_primitives(cam)
    A, B = np.column_stack([arc, np.ones(len(arc))]), np.column_stack([half, np.ones(len(half))])
    fit = _CircleViewFit(cam.K, cam.R, A, B, np.diag([1.0, 1.0, -R * R]), offset)
    rng = np.random.default_rng(3)
    for _ in range(2):
        x = np.concatenate([np.zeros(3), cam.center]) + np.concatenate([rng.normal(0, 2e-3, 3), rng.normal(0, 0.02, 3)])
        J, num = fit.jacobian(x), approx_derivative(fit.residuals, x, method="3-point", rel_step=1e-5)
        assert J.shape == (len(A) + len(B), 6)
        # (relative to each parameter's column: central differences at this
        # step are good to about 4e-7 of it here, their truncation and
        # rounding errors about equal)
        assert np.all(np.abs(J - num).max(axis=0) <= 2e-6 * np.abs(num).max(axis=0)), np.abs(J - num).max(axis=0) / np.abs(num).max(axis=0)


def test_the_family_fits_the_arc_at_every_focal_length_and_the_far_touchline_tells_them_apart():
    cam = _low_far_camera()
    E, lh, arc, half = _exact_primitives(cam)
    focals = cam.focal * np.array([0.8, 1.0, 1.25])
    fam = cameras_along_circle(E, lh, arc, half, cam.principal_point, image_width=SIZE[0], focals=focals)
    assert len(fam) == 3
    th = np.linspace(0, 2 * np.pi, 7200, endpoint=False)
    circle = np.column_stack([R * np.cos(th), R * np.sin(th)])
    x = np.linspace(-60, 60, 2400)
    touchline = np.column_stack([x, np.full_like(x, PITCH.width / 2)])

    def off(c, curve):
        """distance (px) of the true picture of ``curve``'s samples in view to ``c``'s picture of it"""
        truth = cam.project_pitch(curve)
        truth = truth[_in_view(truth, SIZE)][::10]
        return cKDTree(c.project_pitch(curve)).query(truth)[0]

    for f, c in zip(focals, fam):
        # every member lays the seen arc on its pixels (a short arc seen edge-on
        # fixes little); only the true focal length puts the far touchline on its own
        assert np.median(off(c, circle)) < 1.0, (f, np.median(off(c, circle)))
        if f == cam.focal:
            assert off(c, touchline).max() < 0.1
        else:
            assert np.median(off(c, touchline)) > 5.0, (f, np.median(off(c, touchline)))


def test_the_grass_tells_a_member_too_far_back_whose_far_markings_the_stands_back():
    # a member of the family 1.6 times too far lays its far touchline and
    # penalty area up in the stands; where the frame's bright pixels are the
    # markings and every pixel off the grass (seats and boards, at their
    # brightest), its line support rises from 0.22 to 0.66 while the right
    # camera's stays 1.0, but its markings leave the grass (0.56 of them on
    # it; the member 1.25 times too far, 0.86, lays few on paint: 0.17)
    from arstream.support import ON_GRASS, grass_region, line_support, marking_points, on_grass

    cam = _low_far_camera()
    E, lh, arc, half = _exact_primitives(cam)
    (far,) = cameras_along_circle(E, lh, arc, half, cam.principal_point, image_width=SIZE[0], focals=[1.6 * cam.focal])
    W, H = SIZE
    uv = np.floor(cam.project(marking_points()) + 0.5)
    q = uv[_in_view(uv, SIZE)].astype(int)
    paint = np.zeros((H, W), np.uint8)
    paint[q[:, 1], q[:, 0]] = 1
    paint = cv2.dilate(paint, np.ones((5, 5), np.uint8)) > 0  # (the support's 2 px reach)
    grass = grass_seen(cam, SIZE)
    stands = cv2.resize(grass, SIZE, interpolation=cv2.INTER_NEAREST) == 0
    assert line_support(cam, paint | stands).share == 1.0 and line_support(far, paint).share < 0.3
    assert line_support(far, paint | stands).share > 0.6
    region = grass_region(grass)
    assert on_grass(cam, region, SIZE) == 1.0 and on_grass(far, region, SIZE) < ON_GRASS


def test_cameras_along_circle_bad_input():
    cam = _low_far_camera()
    E, lh, arc, half = _exact_primitives(cam)
    pp = cam.principal_point
    with pytest.raises(ValueError, match="need at least 6 arc and 2 halfway-line pixels, got 5 and"):
        cameras_along_circle(E, lh, arc[:5], half, pp, image_width=SIZE[0], focals=[cam.focal])
    with pytest.raises(ValueError, match="need at least 6 arc and 2 halfway-line pixels, got .* and 1"):
        cameras_along_circle(E, lh, arc, half[:1], pp, image_width=SIZE[0], focals=[cam.focal])
    with pytest.raises(ValueError, match="the halfway line does not cross the centre-circle ellipse"):
        cameras_along_circle(E, np.array([0.0, 1.0, 5000.0]), arc, half, pp, image_width=SIZE[0], focals=[cam.focal])
    with pytest.raises(ValueError, match="not an ellipse"):
        cameras_along_circle(np.diag([1.0, -1.0, 1.0]), lh, arc, half, pp, image_width=SIZE[0], focals=[cam.focal])
    # a circle of 10 px around the principal point, with a line far from it
    assert cameras_along_circle(conic_from_circle(pp, 10.0), np.array([1.0, 0.0, -pp[0]]), arc, half, pp, image_width=SIZE[0], focals=[]) == []


def _frame(cam, size=SIZE, seed=0):
    """Grass with the pitch's white markings (2 px) drawn through ``cam``, a few
    players on the arc, and JPEG compression."""
    W, H = size
    rng = np.random.default_rng(seed)
    img = np.clip(np.full((H, W, 3), (40, 120, 50), np.float64) + rng.normal(0, 3, (H, W, 3)), 0, 255).astype(np.uint8)
    for poly in PITCH.polylines(0.1):
        px = cam.project_pitch(poly)
        ok = np.all(np.isfinite(px), axis=1) & np.all(np.abs(px) < 4 * W, axis=1)
        if ok.sum() >= 2:
            cv2.polylines(img, [np.rint(px[ok] * 16).astype(np.int32)], False, (215, 220, 220), 2, cv2.LINE_AA, shift=4)
    th = np.linspace(0, 2 * np.pi, 9, endpoint=False)
    for p in cam.project_pitch(np.column_stack([R * np.cos(th), R * np.sin(th)])):
        if np.all(np.isfinite(p)) and 0 <= p[0] < W and 0 <= p[1] < H:
            x, y = int(p[0]), int(p[1])
            cv2.rectangle(img, (x - 9, y - 60), (x + 9, y + 4), (30, 30, 160), -1)  # a player in red
    ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, 70])
    return cv2.imdecode(buf, cv2.IMREAD_COLOR)


def test_register_a_low_far_centre_circle_view():
    cam = _low_far_camera()
    img = _frame(cam)
    det = detect(img)
    assert det.ellipses and det.lines
    pts = PITCH.sample_points(0.5)
    est = register_frame(det, SIZE, image=img)
    assert est.status == "ok", est.info
    err = frame_error(cam, est.camera, SIZE, pts, PITCH.symmetries)
    assert err.mean < 2.0, err.mean
    # the circle view's hypotheses alone: one of them is the camera's member of
    # the family on the focal lengths' grid (18 from 0.4 to 10 widths: 20 % apart)
    view = paint_view(img, det)
    hyps = circle_view_cameras(view, SIZE, principal_point=cam.principal_point, pitch=PITCH, circles=det.ellipses, lines=det.lines)
    step = np.log(10.0 / 0.4) / 17
    assert hyps and min(abs(np.log(h.focal / cam.focal)) for h in hyps) <= step / 2 + 1e-9


def test_circle_view_cameras_need_an_ellipse_and_a_line_through_it():
    cam = _low_far_camera()
    img = _frame(cam)
    det = detect(img)
    view = paint_view(img, det)
    kw = dict(principal_point=cam.principal_point, pitch=PITCH)
    assert circle_view_cameras(view, SIZE, circles=[], lines=det.lines, **kw) == []
    # a line that misses the ellipse is no halfway line; the paint's own lines are tried too
    far = type(det.lines[0])(line=np.array([0.0, 1.0, -2.0]), endpoints=np.array([[0.0, 2.0], [1279.0, 2.0]]), points=np.array([[x, 2.0] for x in range(0, 1280, 8)], float), length=1279.0, normal_sigma=0.1, angle_sigma=1e-4, rms=0.5)
    hyps = circle_view_cameras(view, SIZE, circles=det.ellipses, lines=[far], **kw)
    assert all(np.isfinite(h.center).all() for h in hyps)


def _bent_arc_ellipse(cam):
    """The circle's arc in view as the detector might report it: its pixels
    bent by 1 px (the middle out, the ends in: a compressed 2 px line's centre
    is off by that much), and the ellipse fitted to them."""
    _, _, arc, _ = _exact_primitives(cam)
    t = np.linspace(-1.0, 1.0, len(arc))
    n = arc - arc.mean(axis=0)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    pts = arc + (1.0 * (t**2 - 1 / 3))[:, None] * n
    fit = fit_ellipse(pts)
    return DetectedEllipse(ellipse=fit.ellipse, conic=conic_from_ellipse(fit.ellipse), points=pts, rms=fit.rms, coverage=len(arc) / 720, score=1.0, kind="circle")


def test_a_short_arc_bent_by_a_pixel_moves_the_closed_forms_focal_length():
    """Why the family: from the ellipse of a third of the circle, bent by 1 px,
    the pole-polar f is off by more than 10 %."""
    cam = _low_far_camera()
    ell = _bent_arc_ellipse(cam)
    _, lh, _, _ = _exact_primitives(cam)
    sols = solve_from_circle(ell.conic, lh, cam.principal_point, image_width=SIZE[0])
    assert min(abs(np.log(s.f / cam.focal)) for s in sols) > 0.1


def test_the_paint_initialiser_finds_the_view_from_the_bent_arc():
    cam = _low_far_camera()
    img = _frame(cam)
    det = detect(img)
    view = paint_view(img, det)
    r, sup = initialise_from_paint(view, SIZE, principal_point=cam.principal_point, pitch=PITCH, circles=[_bent_arc_ellipse(cam)], lines=det.lines)
    assert r is not None and sup >= 0.9
    err = frame_error(cam, r.camera, SIZE, PITCH.sample_points(0.5), PITCH.symmetries)
    assert err.mean < 2.0, err.mean
