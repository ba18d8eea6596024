"""calib.sphere: calibration from sphere images (issue 10).

Synthetic round trips against exact truth (forward model, sphere centres,
intrinsics, rig poses), error bounds under noise, a table of degenerate
inputs with the exact error each must give, and rendered images (shaded
balls, specular highlights, background clutter) through the full path from
pixels to K, including the CLI. Monte Carlo statistics live in
bench/sphere_calibration.py, not here.
"""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from calib import _fit
from calib import sphere as S
from calib import synthetic as syn
from geometry.camera import iac
from geometry.conics import conic_from_circle, double_contact, ellipse_distance, ellipse_from_conic, fit_ellipse, sampson_distance

K0 = np.array([[1000.0, 0.0, 330.0], [0.0, 1010.0, 235.0], [0.0, 0.0, 1.0]])
SIZE = (640, 480)
RADIUS = 0.1


def _rel(Ka, Kb) -> float:
    return float(np.abs(Ka - Kb).max() / Kb[0, 0])


def _focal_err(Ka, Kb) -> float:
    return float(max(abs(Ka[0, 0] / Kb[0, 0] - 1), abs(Ka[1, 1] / Kb[1, 1] - 1)))


def _scene(seed, K=K0, n=5, noise=0.0, n_points=200, image_radius=(40.0, 70.0)):
    rng = np.random.default_rng(seed)
    X = syn.random_sphere_centres(K, SIZE, n, radius=RADIUS, image_radius=image_radius, rng=rng)
    pts = [syn.sphere_outline_points(K, x, RADIUS, n_points, noise=noise, rng=rng) for x in X]
    if noise > 0:
        conics = [fit_ellipse(p).conic for p in pts]
    else:
        conics = [S.outline_conic(K, x, RADIUS) for x in X]
    return X, conics, pts


# --------------------------------------------------------------------------
# forward model and sphere from K and its outline
# --------------------------------------------------------------------------


@pytest.mark.parametrize(
    "X",
    [(0.0, 0.0, 3.0), (0.4, -0.3, 2.5), (-0.9, 0.6, 4.0), (1.5, 1.1, 3.0)],
)
def test_sphere_centre_round_trip(X):
    X = np.array(X)
    C = S.outline_conic(K0, X, RADIUS)
    assert np.allclose(S.sphere_centre(K0, C, RADIUS), X, rtol=1e-9, atol=1e-12)
    d, a = S.centre_direction(K0, C)
    assert np.allclose(d, X / np.linalg.norm(X), atol=1e-12)
    assert np.isclose(a, np.arcsin(RADIUS / np.linalg.norm(X)), rtol=1e-9)
    x = K0 @ X
    assert np.allclose(S.imaged_centre(K0, C), x[:2] / x[2], atol=1e-8)
    # scale and sign of the conic do not matter
    assert np.allclose(S.sphere_centre(K0, -3.0 * C, RADIUS), X, rtol=1e-9)


def test_outline_is_tangent_cone_and_double_contact_with_iac():
    X = np.array([0.5, -0.4, 3.0])
    C = S.outline_conic(K0, X, RADIUS)
    pts = syn.sphere_outline_points(K0, X, RADIUS, 100)
    assert np.abs(sampson_distance(pts, C)).max() < 1e-9
    # every outline point's ray is tangent to the sphere
    rays = np.column_stack([pts, np.ones(len(pts))]) @ np.linalg.inv(K0).T
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    dist_to_centre = np.linalg.norm(np.cross(rays, X), axis=1)
    assert np.allclose(dist_to_centre, RADIUS, rtol=1e-9)
    # the thesis' rank-1 constraint: outline and IAC have double contact
    assert double_contact(C, iac(K0)).holds


def test_synthetic_generator_keeps_outlines_inside_image():
    X = syn.random_sphere_centres(K0, SIZE, 8, radius=RADIUS, image_radius=(30, 60), margin=5, rng=3)
    assert X.shape == (8, 3)
    for x in X:
        e = ellipse_from_conic(S.outline_conic(K0, x, RADIUS))
        p = e.points(200)
        assert p.min() >= 4.5 and p[:, 0].max() <= SIZE[0] - 5.5 and p[:, 1].max() <= SIZE[1] - 5.5
        assert 29.0 < e.axes[1] and e.axes[0] < 70.0


def test_render_geometry_matches_forward_model():
    X = np.array([[0.15, 0.05, 2.0], [-0.2, -0.1, 2.5]])
    r = syn.render_spheres(K0, X, [RADIUS, 0.12], SIZE, background="plain", noise=0.0, rng=0, return_geometry=True)
    assert r.image.shape == (SIZE[1], SIZE[0], 3) and r.image.dtype == np.uint8
    hit = r.index >= 0
    assert set(np.unique(r.index)) == {-1, 0, 1}
    # hit points lie on their sphere, with outward unit normals
    P = r.points[hit]
    idx = r.index[hit]
    radii = np.array([RADIUS, 0.12])[idx]
    assert np.allclose(np.linalg.norm(P - X[idx], axis=1), radii, atol=1e-9)
    assert np.allclose(np.linalg.norm(r.normals[hit], axis=1), 1.0)
    # pixel centres inside the outline conic are exactly the hit pixels of sphere 0 (no occlusion there)
    vv, uu = np.mgrid[0 : SIZE[1], 0 : SIZE[0]]
    C = S.outline_conic(K0, X[0], RADIUS)
    Xh = np.stack([uu, vv, np.ones_like(uu)], axis=-1).astype(float)
    inside = np.einsum("hwi,ij,hwj->hw", Xh, C, Xh) < 0
    assert np.array_equal(inside & (r.index != 1), r.index == 0)


def test_absolute_orientation_round_trip():
    rng = np.random.default_rng(0)
    P = rng.normal(size=(10, 3))
    R = _fit.rotation_from_rotvec([0.3, -0.2, 0.9])
    t = np.array([0.5, -1.0, 2.0])
    R2, t2, s = _fit.absolute_orientation(P, 2.0 * P @ R.T + t, with_scale=True)
    assert np.allclose(R2, R) and np.allclose(t2, t) and np.isclose(s, 2.0)


# --------------------------------------------------------------------------
# intrinsics
# --------------------------------------------------------------------------


@pytest.mark.parametrize(
    "square_pixels, zero_skew, K",
    [
        (True, True, np.array([[900.0, 0.0, 310.0], [0.0, 900.0, 250.0], [0.0, 0.0, 1.0]])),
        (False, True, K0),
        (False, False, np.array([[1000.0, 2.0, 330.0], [0.0, 1010.0, 235.0], [0.0, 0.0, 1.0]])),
    ],
)
@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("with_edges", [False, True])
def test_intrinsics_noise_free_exact(square_pixels, zero_skew, K, seed, with_edges):
    X, conics, pts = _scene(seed, K=K, n=5)
    res = S.intrinsics_from_spheres(conics, edge_points=pts if with_edges else None, square_pixels=square_pixels, zero_skew=zero_skew)
    assert _rel(res.K, K) < 1e-6
    assert _rel(res.K_linear, K) < 1e-6
    assert _rel(res.K_rank1, K) < 1e-6
    assert res.constraint_set == ("geometric" if with_edges else "rank1")
    assert res.model == ("square_pixels" if square_pixels else "zero_skew" if zero_skew else "general")
    assert not res.weak
    assert res.n_pairs == 10
    assert res.rms < 1e-6
    assert np.allclose(res.centres(RADIUS), X, rtol=1e-6)
    assert np.allclose(res.imaged_centres, (X @ K.T)[:, :2] / (X @ K.T)[:, 2:], atol=1e-4)


def test_intrinsics_three_spheres_is_enough():
    X, conics, _ = _scene(4, n=3)
    res = S.intrinsics_from_spheres(conics)
    assert _rel(res.K, K0) < 1e-6 and res.n_pairs == 3


@pytest.mark.parametrize("seed", [11, 12, 13])
@pytest.mark.parametrize("noise, bound", [(0.5, 0.05), (1.0, 0.10)])
def test_intrinsics_error_bounds_under_noise(seed, noise, bound):
    # Monte Carlo medians (bench): 1.2 % at 0.5 px, 2.4 % at 1 px; these
    # bounds are about 4 times that, for single draws
    _, conics, pts = _scene(seed, noise=noise)
    res = S.intrinsics_from_spheres(conics, edge_points=pts)
    assert _focal_err(res.K, K0) < bound
    assert np.abs(res.K[:2, 2] - K0[:2, 2]).max() < 400 * bound
    assert abs(res.rms - noise) < 0.1 * noise  # outline residual ~ the point noise
    assert res.focal_sigma < bound and not res.weak
    assert _focal_err(res.K, K0) < 4.5 * res.focal_sigma


def test_geometric_refinement_from_truth_agrees_with_pipeline():
    _, conics, pts = _scene(21, noise=1.0)
    res = S.intrinsics_from_spheres(conics, edge_points=pts)
    ml = S.refine_intrinsics(K0, conics, pts)
    assert ml.constraint_set == "geometric" and ml.K_linear is None
    # same cost, same minimum: the pipeline reaches the maximum-likelihood estimate
    assert _rel(res.K, ml.K) < 1e-4
    assert res.rms == pytest.approx(ml.rms, rel=1e-6)


def test_near_circular_outlines_are_flagged_weak():
    # a 20000 px lens on a 640 x 480 sensor: about 1 degree field of view,
    # almost parallel projection, outlines circular to 1e-4
    Kt = np.array([[20000.0, 0.0, 320.0], [0.0, 20000.0, 240.0], [0.0, 0.0, 1.0]])
    _, conics, pts = _scene(0, K=Kt)
    res = S.intrinsics_from_spheres(conics, edge_points=pts)
    assert res.weak and res.focal_sigma > 0.5


def test_intrinsics_without_edge_points_report_rank1_residuals():
    _, conics, _ = _scene(31, noise=0.5)
    res = S.intrinsics_from_spheres(conics)
    assert res.constraint_set == "rank1"
    assert res.residuals.shape == (5,) and np.all(res.residuals < 0.2)
    assert _focal_err(res.K, K0) < 0.05


# --------------------------------------------------------------------------
# degenerate input: the exact error each must give
# --------------------------------------------------------------------------


def _collinear_conics():
    Xs = [np.array([x, 0.3 * 4, 4.0]) for x in (-1.0, 0.2, 1.1)] + [np.array([0.5, 0.3 * 3, 3.0])]
    return [S.outline_conic(K0, x, RADIUS) for x in Xs]


_GOOD = _scene(0)[1]
_HYPERBOLA = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])

DEGENERATE_INTRINSICS = [
    ("two images", lambda: S.intrinsics_from_spheres(_GOOD[:2]), r"need at least 3 sphere images, got 2"),
    ("not a sequence", lambda: S.intrinsics_from_spheres(5), r"conics must be a sequence of 3x3 conic matrices"),
    ("bad shape", lambda: S.intrinsics_from_spheres([_GOOD[0], np.eye(2), _GOOD[2]]), r"conics\[1\] must be a 3x3 conic matrix, got shape \(2, 2\)"),
    ("non-finite", lambda: S.intrinsics_from_spheres([_GOOD[0], _GOOD[1], np.full((3, 3), np.nan)]), r"conics\[2\] has non-finite entries"),
    ("hyperbola", lambda: S.intrinsics_from_spheres([_HYPERBOLA, _GOOD[1], _GOOD[2]]), r"conics\[0\] is not a real ellipse, so not the outline of a sphere"),
    ("repeated outline", lambda: S.intrinsics_from_spheres([_GOOD[0], _GOOD[1], -2 * _GOOD[1]]), r"conics\[1\] and conics\[2\] are the same outline"),
    (
        "circles (parallel projection)",
        lambda: S.intrinsics_from_spheres([conic_from_circle((100.0 + 50 * i, 200.0 + 30 * i * i), 30.0) for i in range(4)]),
        r"all sphere outlines are circles: the focal length is unobservable",
    ),
    ("collinear centres", lambda: S.intrinsics_from_spheres(_collinear_conics()), r"the imaged sphere centres are collinear"),
    ("square pixels with skew", lambda: S.intrinsics_from_spheres(_GOOD, square_pixels=True, zero_skew=False), r"square_pixels=True requires zero_skew=True"),
    ("edge point count", lambda: S.intrinsics_from_spheres(_GOOD, edge_points=[np.zeros((10, 2))] * 2), r"edge_points must hold one \(N, 2\) array per conic: 5 conics, 2 arrays"),
    ("edge point shape", lambda: S.intrinsics_from_spheres(_GOOD, edge_points=[np.zeros((10, 3))] * 5), r"edge_points\[0\] must have shape \(N, 2\), got \(10, 3\)"),
    ("too few edge points", lambda: S.intrinsics_from_spheres(_GOOD, edge_points=[np.zeros((4, 2))] * 5), r"edge_points\[0\] needs at least 5 points, got 4"),
    ("refine without points", lambda: S.refine_intrinsics(K0, _GOOD, None), r"refine_intrinsics needs edge_points"),
]


@pytest.mark.parametrize("case, call, message", DEGENERATE_INTRINSICS, ids=[c[0] for c in DEGENERATE_INTRINSICS])
def test_degenerate_intrinsics(case, call, message):
    with pytest.raises(ValueError, match=message):
        call()


DEGENERATE_SPHERE = [
    ("radius zero", lambda: S.sphere_centre(K0, _GOOD[0], 0.0), r"radius must be positive and finite, got 0.0"),
    ("radius text", lambda: S.sphere_centre(K0, _GOOD[0], "big"), r"radius must be a positive number, got 'big'"),
    ("K lower triangular", lambda: S.sphere_centre(K0.T, _GOOD[0], 1.0), r"K must be upper triangular with positive focal lengths"),
    ("K shape", lambda: S.imaged_centre(np.eye(4), _GOOD[0]), r"K must be a 3x3 calibration matrix, got shape \(4, 4\)"),
    ("camera inside sphere", lambda: S.outline_conic(K0, [0.0, 0.0, 0.05], RADIUS), r"the camera centre is inside the sphere: no outline"),
    ("sphere behind", lambda: S.outline_conic(K0, [0.0, 0.0, -2.0], RADIUS), r"the sphere must lie entirely in front of the camera \(centre z > radius\)"),
    ("not a sphere's cone", lambda: S.centre_direction(K0, np.eye(3)), r"the conic's cone K\^T C K is not that of a sphere"),
]


@pytest.mark.parametrize("case, call, message", DEGENERATE_SPHERE, ids=[c[0] for c in DEGENERATE_SPHERE])
def test_degenerate_sphere_functions(case, call, message):
    with pytest.raises(ValueError, match=message):
        call()


# --------------------------------------------------------------------------
# rig extrinsics
# --------------------------------------------------------------------------


def _rot_err_deg(Ra, Rb) -> float:
    return float(np.degrees(np.arccos(np.clip((np.trace(Ra @ Rb.T) - 1) / 2, -1, 1))))


def _dir_err_deg(a, b) -> float:
    return float(np.degrees(np.arccos(np.clip(a @ b / np.linalg.norm(a) / np.linalg.norm(b), -1, 1))))


@pytest.fixture(scope="module")
def rig():
    rng = np.random.default_rng(3)
    cams = syn.rig_cameras(3, f=1000.0, distance=3.0, spread_deg=60.0, rng=rng, jitter=0.1)
    Xw = syn.random_rig_centres(cams, 20, radius=RADIUS, box=0.8, rng=rng)
    R_true = np.array([c.R @ cams[0].R.T for c in cams])
    t_true = np.array([c.t - R_true[j] @ cams[0].t for j, c in enumerate(cams)])
    X_ref = Xw @ cams[0].R.T + cams[0].t
    return cams, Xw, R_true, t_true, X_ref


def _tracks(cams, Xw, noise, seed):
    rng = np.random.default_rng(seed)
    conics, edges = [], []
    for c in cams:
        tc, te = [], []
        for X in Xw:
            Xc = c.R @ X + c.t
            p = syn.sphere_outline_points(c.K, Xc, RADIUS, 200, noise=noise, rng=rng)
            te.append(p)
            tc.append(fit_ellipse(p, refine=False).conic if noise > 0 else S.outline_conic(c.K, Xc, RADIUS))
        conics.append(tc)
        edges.append(te)
    return conics, edges


@pytest.fixture(scope="module")
def rig_noisy(rig):
    cams, Xw = rig[:2]
    return _tracks(cams, Xw, 0.5, 1)


def test_rig_noise_free_exact(rig):
    cams, Xw, R_true, t_true, X_ref = rig
    conics, _ = _tracks(cams, Xw, 0.0, 0)
    res = S.rig_extrinsics([c.K for c in cams], conics, RADIUS)
    assert np.allclose(res.R, R_true, atol=1e-9)
    assert np.allclose(res.t, t_true, atol=1e-8)
    assert np.allclose(res.centres, X_ref, atol=1e-8)
    assert res.rms < 1e-8 and res.residuals.shape == (3, 20)


@pytest.mark.parametrize("use_edges", [False, True])
def test_rig_error_bounds_half_pixel(rig, rig_noisy, use_edges):
    cams, Xw, R_true, t_true, _ = rig
    conics, edges = rig_noisy
    res = S.rig_extrinsics([c.K for c in cams], conics, RADIUS, edge_point_tracks=edges if use_edges else None)
    for j in (1, 2):
        assert _rot_err_deg(res.R[j], R_true[j]) < 0.2
        assert _dir_err_deg(res.t[j], t_true[j]) < 0.5
        assert abs(np.linalg.norm(res.t[j]) / np.linalg.norm(t_true[j]) - 1) < 0.01
        # bundle adjustment improves on absolute orientation
        assert _rot_err_deg(res.R[j], R_true[j]) < _rot_err_deg(res.R_init[j], R_true[j])
    assert np.allclose(res.camera_centres[0], 0.0)


def test_rig_with_missing_views_and_intrinsics(rig, rig_noisy):
    cams, Xw, R_true, t_true, _ = rig
    conics, edges = [list(tr) for tr in rig_noisy[0]], [list(tr) for tr in rig_noisy[1]]
    conics[2][0] = conics[2][5] = None  # occluded in camera 2
    edges[2][0] = edges[2][5] = None
    Ks = np.array([c.K for c in cams])
    Ks_off = Ks.copy()
    Ks_off[:, 0, 0] *= 1.01
    Ks_off[:, 1, 1] *= 1.01
    res = S.rig_extrinsics(Ks_off, conics, RADIUS, edge_point_tracks=edges, refine_intrinsics=True)
    assert np.isnan(res.residuals[2, 0]) and np.isnan(res.residuals[2, 5])
    for j in (1, 2):
        assert _rot_err_deg(res.R[j], R_true[j]) < 0.3
        assert _dir_err_deg(res.t[j], t_true[j]) < 0.7
    assert np.all(np.abs(res.Ks[:, 0, 0] / Ks[:, 0, 0] - 1) < 0.01)


def _rig_tracks_for_errors():
    conic = _GOOD[0]
    return [[conic] * 4, [conic, conic, None, None]]


DEGENERATE_RIG = [
    ("one camera", lambda: S.rig_extrinsics([K0], [[_GOOD[0]] * 3], RADIUS), r"a rig needs at least 2 cameras, got 1"),
    ("Ks shape", lambda: S.rig_extrinsics(np.eye(3), [[_GOOD[0]] * 3], RADIUS), r"Ks must have shape \(N, 3, 3\), got \(3, 3\)"),
    ("track count", lambda: S.rig_extrinsics([K0, K0], [[_GOOD[0]] * 3], RADIUS), r"conic_tracks must hold one track per camera: 2 cameras, 1 tracks"),
    ("ragged tracks", lambda: S.rig_extrinsics([K0, K0], [[_GOOD[0]] * 3, [_GOOD[0]] * 4], RADIUS), r"every camera's conic track must have the same length"),
    ("two positions", lambda: S.rig_extrinsics([K0, K0], [[_GOOD[0]] * 2] * 2, RADIUS), r"rig extrinsics need at least 3 sphere positions, got 2"),
    ("unseen position", lambda: S.rig_extrinsics([K0, K0], [[_GOOD[0], None, _GOOD[1]]] * 2, RADIUS), r"sphere position 1 is seen by no camera"),
    ("too little overlap", lambda: S.rig_extrinsics([K0, K0], _rig_tracks_for_errors(), RADIUS), r"camera 1 shares only 2 sphere positions with camera 0; at least 3 are needed"),
    ("collinear positions", lambda: S.rig_extrinsics([K0, K0], [[S.outline_conic(K0, [0.1 * i, 0.0, 3.0], RADIUS) for i in range(4)]] * 2, RADIUS), r"the sphere positions camera 1 shares with camera 0 are collinear"),
    ("bad radius", lambda: S.rig_extrinsics([K0, K0], [_GOOD[:3]] * 2, -1.0), r"radius must be positive and finite, got -1.0"),
]


@pytest.mark.parametrize("case, call, message", DEGENERATE_RIG, ids=[c[0] for c in DEGENERATE_RIG])
def test_degenerate_rig(case, call, message):
    with pytest.raises(ValueError, match=message):
        call()


# --------------------------------------------------------------------------
# rendered images: pixels -> outlines -> K (and the CLI)
# --------------------------------------------------------------------------

KR = np.array([[800.0, 0.0, 320.0], [0.0, 800.0, 240.0], [0.0, 0.0, 1.0]])


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    """Six 640x480 images of a shaded ball with a specular highlight over
    background clutter (polygons, bars, lines, small discs, texture), sensor
    noise and a mild blur; their outlines fitted once for the tests below."""
    rng = np.random.default_rng(5)
    X = syn.random_sphere_centres(KR, SIZE, 6, radius=RADIUS, image_radius=(35.0, 70.0), margin=8, rng=rng)
    d = tmp_path_factory.mktemp("spheres")
    paths, outlines = [], []
    for i, x in enumerate(X):
        img = syn.render_spheres(KR, x, RADIUS, SIZE, rng=rng)
        p = d / f"sphere_{i}.png"
        cv2.imwrite(str(p), img)
        paths.append(str(p))
        outlines.append(S.fit_sphere_outline(img))
    return X, paths, outlines


def test_rendered_outlines_are_subpixel(rendered):
    X, _, outlines = rendered
    for x, o in zip(X, outlines):
        truth = ellipse_from_conic(S.outline_conic(KR, x, RADIUS))
        d = ellipse_distance(o.edge_points, truth, signed=True)
        assert abs(d.mean()) < 0.05  # no bias
        assert np.sqrt(np.mean(d * d)) < 0.3  # sub-pixel edge points
        assert np.hypot(*np.subtract(o.ellipse.center, truth.center)) < 0.1
        assert np.abs(np.subtract(o.ellipse.axes, truth.axes)).max() < 0.1
        assert o.support > 0.75 and o.rms < 0.3
        assert len(o.edge_points) > 150


def test_rendered_full_path_to_K(rendered):
    X, _, outlines = rendered
    res = S.intrinsics_from_spheres([o.conic for o in outlines], edge_points=[o.edge_points for o in outlines])
    assert res.constraint_set == "geometric" and not res.weak
    assert _focal_err(res.K, KR) < 0.03
    assert np.abs(res.K[:2, 2] - KR[:2, 2]).max() < 5.0
    centres = res.centres(RADIUS)
    assert np.all(np.linalg.norm(centres - X, axis=1) / np.linalg.norm(X, axis=1) < 0.03)


def test_rendered_two_spheres_with_roi():
    rng = np.random.default_rng(8)
    X = np.array([[-0.45, -0.1, 2.2], [0.4, 0.2, 2.0]])
    img = syn.render_spheres(KR, X, [RADIUS, 0.12], SIZE, rng=rng)
    for x, r, roi in zip(X, (RADIUS, 0.12), [(0, 0, 320, 480), (320, 0, 320, 480)]):
        o = S.fit_sphere_outline(img, roi=roi)
        truth = ellipse_from_conic(S.outline_conic(KR, x, r))
        assert np.hypot(*np.subtract(o.ellipse.center, truth.center)) < 0.1
        assert np.allclose(S.sphere_centre(KR, o.conic, r), x, rtol=0.02)


def test_rendered_outline_polarity_flips_around_the_limb():
    # side light, almost no ambient: the lit limb is brighter than the dark
    # background, the shaded limb darker; the contrast changes sign around the outline
    x = np.array([-0.12, 0.2, 1.8])
    img = syn.render_spheres(
        KR, x, RADIUS, SIZE, rng=12, background=np.full((SIZE[1], SIZE[0], 3), 25, np.float32),
        light=(1.0, 0.2, -0.3), ambient=0.05, colours=[(200, 200, 200)],
    )
    o = S.fit_sphere_outline(img)
    truth = ellipse_from_conic(S.outline_conic(KR, x, RADIUS))
    assert o.support > 0.9
    assert np.hypot(*np.subtract(o.ellipse.center, truth.center)) < 0.1
    assert np.abs(np.subtract(o.ellipse.axes, truth.axes)).max() < 0.15


def test_rendered_outline_grey_image():
    img = syn.render_spheres(KR, [0.1, 0.05, 1.5], RADIUS, SIZE, rng=9)
    o = S.fit_sphere_outline(cv2.cvtColor(img, cv2.COLOR_BGR2GRAY))
    truth = ellipse_from_conic(S.outline_conic(KR, [0.1, 0.05, 1.5], RADIUS))
    assert np.hypot(*np.subtract(o.ellipse.center, truth.center)) < 0.15


DEGENERATE_IMAGES = [
    ("blank image", lambda: S.fit_sphere_outline(np.full((240, 320, 3), 90, np.uint8)), r"no sphere outline found in the image \(or roi\)"),
    ("image shape", lambda: S.fit_sphere_outline(np.zeros((10, 10, 3, 2), np.uint8)), r"image must be H x W \(grey\) or H x W x 3 \(BGR\)"),
    ("tiny image", lambda: S.fit_sphere_outline(np.zeros((8, 8), np.uint8)), r"image is too small: 8 x 8 pixels"),
    ("roi outside", lambda: S.fit_sphere_outline(np.zeros((100, 100), np.uint8), roi=(50, 50, 80, 80)), r"roi \(50, 50, 80, 80\) must be at least 16 x 16 and lie inside the 100 x 100 image"),
    ("radius range", lambda: S.fit_sphere_outline(np.zeros((100, 100), np.uint8), radius_range=(30, 10)), r"radius_range must satisfy 2 <= min < max"),
]


@pytest.mark.parametrize("case, call, message", DEGENERATE_IMAGES, ids=[c[0] for c in DEGENERATE_IMAGES])
def test_degenerate_images(case, call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_cli_json_matches_library(rendered, capsys):
    from arstream.cli import main

    X, paths, outlines = rendered
    rc = main(["calib", "sphere", *paths[:3], "--radius", str(RADIUS), "--json"])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    # PNG is lossless: the CLI sees the same pixels, so it must give the library's answer
    lib = S.intrinsics_from_spheres([o.conic for o in outlines[:3]], edge_points=[o.edge_points for o in outlines[:3]])
    assert np.allclose(out["K"], lib.K, rtol=1e-9)
    assert out["constraint_set"] == "geometric" and out["model"] == "zero_skew"
    assert len(out["images"]) == 3
    assert np.allclose(out["images"][1]["centre"], lib.centres(RADIUS)[1], rtol=1e-9)
    assert out["images"][0]["n_points"] == len(outlines[0].edge_points)
    # JSON is the default, as for every calibration tool; --json is kept for older scripts
    assert main(["calib", "sphere", *paths[:3], "--radius", str(RADIUS)]) == 0
    assert json.loads(capsys.readouterr().out) == out


def test_cli_summary_and_errors(rendered, capsys, tmp_path):
    from arstream.cli import main

    _, paths, _ = rendered
    assert main(["calib", "sphere", *paths[3:6], "--radius", "0.1", "--square-pixels", "--summary"]) == 0
    out = capsys.readouterr().out
    assert "K (square_pixels, geometric" in out and "focal length" in out
    assert main(["calib", "sphere", *paths[3:6], "--radius", "0.1", "--summary", "--pretty"]) == 2
    assert "--summary prints text: it excludes --json and --pretty" in capsys.readouterr().err
    assert main(["calib", "sphere", paths[0], str(tmp_path / "missing.png"), paths[1], "--radius", "0.1"]) == 2
    assert "image not found" in capsys.readouterr().err
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"not an image")
    assert main(["calib", "sphere", paths[0], str(bad), paths[1], "--radius", "0.1"]) == 2
    assert "cannot read image" in capsys.readouterr().err
    assert main(["calib", "sphere", *paths[:2], "--radius", "0.1"]) == 2
    assert "at least 3 images" in capsys.readouterr().err
    assert main(["calib", "sphere", *paths[:3], "--radius", "0"]) == 2
    assert "--radius must be positive" in capsys.readouterr().err
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((120, 160, 3), 90, np.uint8))
    assert main(["calib", "sphere", paths[0], paths[1], str(blank), "--radius", "0.1"]) == 2
    assert "blank.png: no sphere outline found" in capsys.readouterr().err
