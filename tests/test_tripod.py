"""arstream.tripod.fit_tripod: views of one tripod camera refined jointly."""

from __future__ import annotations

import numpy as np
import pytest
from cameras import looking_at

from arstream.pitch_size import size_derivatives
from arstream.solve import LineIndex, ModelSamples, seated
from arstream.tripod import fit_tripod
from geometry.pitch import PitchModel

SIZE = (1280, 720)
PITCH = PitchModel()
MODEL = ModelSamples.from_pitch(PITCH, 0.5)
TRUTH = np.array([-5.0, -60.0, 14.0])
# a long lens on the centre circle, and the same tripod turned to a penalty area
FIRST = looking_at(TRUTH, (0.0, 0.0, 0.0), 3.0 * SIZE[0], SIZE)
TURNED = looking_at(TRUTH, (-38.0, 4.0, 0.0), 1.6 * SIZE[0], SIZE)


def _markings():
    pts = PITCH.sample_points(0.05)
    return np.column_stack([pts, np.zeros(len(pts))]) if pts.shape[1] == 2 else pts


def _in_view(cam, X):
    px = cam.project(X)
    ok = np.all(np.isfinite(px), axis=1) & (px[:, 0] >= 0) & (px[:, 0] < SIZE[0]) & (px[:, 1] >= 0) & (px[:, 1] < SIZE[1])
    return px, ok


def _paint(cam):
    """Exact paint: the markings' centrelines every 5 cm, projected."""
    px, ok = _in_view(cam, _markings())
    return LineIndex(px[ok])


def _assert_exact(fit, truths):
    """A fit to exact paint found the truth to the arithmetic's floor, far
    below a millimetre: the centre, and each view's picture of the markings."""
    assert np.linalg.norm(fit.centre - TRUTH) < 1e-3, fit.centre
    X = _markings()
    for got, truth in zip(fit.cameras, truths, strict=True):
        px, ok = _in_view(truth, X)
        assert np.abs(got.project(X[ok]) - px[ok]).max() < 0.01
        assert np.allclose(got.center, fit.centre)


@pytest.mark.parametrize("along", [2.0, -3.0])
def test_two_views_started_off_along_the_first_views_axis_find_the_centre(along):
    # started metres out along the long lens's line of sight (where its focal
    # length and distance trade), each view moved there keeping its picture
    start = TRUTH + along * FIRST.R[2]
    views = [seated(c, start, MODEL, SIZE) for c in (FIRST, TURNED)]
    fit = fit_tripod(views, [_paint(FIRST), _paint(TURNED)], [SIZE, SIZE], MODEL, start, PITCH)
    _assert_exact(fit, (FIRST, TURNED))
    assert fit.rms < 0.01 and (fit.length, fit.width) == (PITCH.length, PITCH.width)
    assert fit.size_sd == (np.inf, np.inf)


def test_a_fit_is_refused_with_a_clear_error():
    paint = _paint(FIRST)
    with pytest.raises(ValueError, match="a free length or width needs the samples' size derivatives"):
        fit_tripod([FIRST], [paint], [SIZE], MODEL, TRUTH, PITCH, free=(True, False))
    with pytest.raises(ValueError, match="one line index and one frame size per view: 0 views, 0 line indices, 0 sizes"):
        fit_tripod([], [], [], MODEL, TRUTH, PITCH)
    with pytest.raises(ValueError, match="one line index and one frame size per view: 2 views, 1 line indices, 2 sizes"):
        fit_tripod([FIRST, TURNED], [paint], [SIZE, SIZE], MODEL, TRUTH, PITCH)
    # paint that is nowhere near the markings in view
    nowhere = LineIndex(np.array([[5.0, 5.0], [6.0, 5.0]]))
    with pytest.raises(ValueError, match="too few marking points matched to the views' paint"):
        fit_tripod([FIRST, TURNED], [paint, nowhere], [SIZE, SIZE], MODEL, TRUTH, PITCH)


def test_a_size_prior_holds_what_one_view_leaves_open():
    # one view of a goal end (penalty and goal areas, the goal line, a
    # touchline): moving the goal end and the camera together along the
    # touchline changes nothing in the picture. Started a metre off, the fit
    # without a prior slides along that direction (to a pitch 116 m long);
    # the prior holds it at 105 m, and the picture is the exact one
    cam = looking_at((20.0, -50.0, 16.0), (42.0, 0.0, 0.0), 1.8 * SIZE[0], SIZE)
    start = seated(cam, cam.center + (1.0, 0.5, -0.5), MODEL, SIZE)
    size_d = size_derivatives(PITCH, MODEL)
    free = dict(derivatives=size_d, free=(True, True))
    drifts = fit_tripod([start], [_paint(cam)], [SIZE], MODEL, start.center, PITCH, **free)
    assert drifts.length - PITCH.length > 5.0
    fit = fit_tripod([start], [_paint(cam)], [SIZE], MODEL, start.center, PITCH, **free, size_prior_sd=(3.0, 3.0))
    # (exact paint: the arithmetic's floor, far below a centimetre)
    assert abs(fit.length - PITCH.length) < 0.01 and abs(fit.width - PITCH.width) < 0.01
    assert np.linalg.norm(fit.centre - cam.center) < 0.01
    # the length's uncertainty is the prior's; the width is fixed by the view
    assert abs(fit.size_sd[0] - 3.0) < 0.05 and fit.size_sd[1] < 1.0
    X = _markings()
    px, ok = _in_view(cam, X)
    assert np.abs(fit.cameras[0].project(X[ok]) - px[ok]).max() < 0.01


def test_a_size_prior_gives_way_to_a_view_that_fixes_the_size():
    # a wide view of an odd pitch (the centre circle, both touchlines and a
    # penalty area): its exact paint moves the size to the truth, against the
    # prior about 105 x 68, to the association's floor
    odd = PitchModel(101.0, 72.0)
    pts = odd.sample_points(0.05)
    X = np.column_stack([pts, np.zeros(len(pts))])
    truth = looking_at((0.0, -72.0, 22.0), (8.0, 0.0, 0.0), 0.8 * SIZE[0], SIZE)
    px, ok = _in_view(truth, X)
    size_d = size_derivatives(PITCH, MODEL)
    start = seated(truth, truth.center + (0.5, 1.0, -0.5), MODEL, SIZE)
    fit = fit_tripod([start], [LineIndex(px[ok])], [SIZE], MODEL, start.center, PITCH, derivatives=size_d, free=(True, True), radii=(20.0, 8.0, 3.0, 2.0), size_prior_sd=(3.0, 3.0))
    assert abs(fit.length - odd.length) < 0.05 and abs(fit.width - odd.width) < 0.05, (fit.length, fit.width)
    assert np.linalg.norm(fit.centre - truth.center) < 0.05
    assert all(sd < 1.5 for sd in fit.size_sd)


@pytest.mark.parametrize("lens, free, prior", [(False, (False, False), None), (True, (True, True), (3.0, 3.0)), (True, (False, True), None)])
def test_the_jacobian_is_the_residuals_derivative(monkeypatch, lens, free, prior):
    # the closed-form Jacobian fit_tripod hands its solver, against central
    # differences of the residuals it hands it, at the start and at points
    # off it in every parameter (two turned views, a radial lens, the size
    # free or not). Steps of 1e-6 of each parameter (at least 1e-6) leave
    # about 2e-7 px of rounding and truncation in entries of up to 4e3 px
    # per unit: held to 1e-8 of the largest
    import arstream.tripod as tripod
    from arstream.pitch_size import size_derivatives

    seen = []
    real = tripod.least_squares

    def spy(fun, x0, **kw):
        if callable(kw.get("jac")) and not seen:
            seen.append((fun, kw["jac"], x0.copy()))
        return real(fun, x0, **kw)

    monkeypatch.setattr(tripod, "least_squares", spy)
    views = [seated(c, TRUTH + (0.5, -1.0, 0.3), MODEL, SIZE) for c in (FIRST, TURNED)]
    if lens:
        views = [type(c)(K=c.K, R=c.R, t=c.t, dist=(-0.2 * SIZE[0] / c.focal,)) for c in views]
    extra = dict(derivatives=size_derivatives(PITCH, MODEL), free=free) if any(free) else {}
    fit_tripod(views, [_paint(FIRST), _paint(TURNED)], [SIZE, SIZE], MODEL, views[0].center, PITCH, size_prior_sd=prior, **extra)
    ((fun, jac, x0),) = seen
    rng = np.random.default_rng(1)
    for x in (x0, x0 + rng.normal(0.0, 1e-3, len(x0))):
        J = jac(x).toarray()
        num = np.empty_like(J)
        for k in range(len(x)):
            e = np.zeros(len(x))
            e[k] = 1e-6 * max(1.0, abs(x[k]))
            num[:, k] = (fun(x + e) - fun(x - e)) / (2 * e[k])
        assert J.shape == num.shape and np.abs(J).max() > 1.0
        assert np.abs(J - num).max() < 1e-8 * np.abs(num).max(), (np.abs(J - num).max(), np.abs(num).max())


def test_views_with_non_square_pixels_are_fitted_too():
    # pixels 1.1 times as tall as wide (the closed-form Jacobian is for square
    # pixels; such views are fitted with finite differences): the two views,
    # started 2 m off along the first one's axis, find the centre to the
    # arithmetic's floor on exact paint, as square ones do
    from geometry.camera import Camera

    def tall(c):
        K = c.K.copy()
        K[1, 1] *= 1.1
        return Camera(K=K, R=c.R, t=c.t)

    first, turned = tall(FIRST), tall(TURNED)
    start = TRUTH + 2.0 * FIRST.R[2]
    views = [tall(seated(c, start, MODEL, SIZE)) for c in (FIRST, TURNED)]
    fit = fit_tripod(views, [_paint(first), _paint(turned)], [SIZE, SIZE], MODEL, start, PITCH)
    _assert_exact(fit, (first, turned))
