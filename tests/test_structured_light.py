"""calib.structured_light: camera + laser light plane from a sphere (issue 8).

Synthetic round trips against exact truth (forward model, double contact,
triangulation, the full calibration), error bounds under noise with fixed
seeds, stripe extraction on rendered images, a table of degenerate inputs
with the exact error each must give, and the CLI. Monte Carlo statistics live
in bench/structured_light_calibration.py.
"""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from arstream.cli import main as cli_main
from calib import structured_light as SL
from calib import synthetic as syn
from calib.sphere import outline_conic
from geometry.camera import iac
from geometry.conics import double_contact, fit_ellipse, intersect_conics, sampson_distance

K0 = np.array([[1000.0, 0.0, 330.0], [0.0, 1010.0, 235.0], [0.0, 0.0, 1.0]])
SIZE = (640, 480)
R = 0.05
PROJ = np.array([0.3, 0.0, 0.0])
PLANE = SL.LightPlane.from_point_normal(PROJ, [1.0, 0.0, 0.3])  # through the projector and (0, 0, 1)


def _centres(seed, n, K=K0, plane=PLANE, max_offset=0.7):
    """Sphere centres cut by the plane (|offset| < max_offset r), outlines inside the image."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        z = rng.uniform(0.6, 1.5)
        y = rng.uniform(-0.18, 0.18) * z
        off = rng.uniform(-max_offset, max_offset) * R
        x = (plane.d + off - plane.normal[1] * y - plane.normal[2] * z) / plane.normal[0]
        X = np.array([x, y, z])
        p = K @ X
        p = p[:2] / p[2]
        rad = K[0, 0] * R / z
        if rad + 5 < p[0] < SIZE[0] - rad - 5 and rad + 5 < p[1] < SIZE[1] - rad - 5:
            out.append(X)
    return np.array(out)


def _data(seed, n=8, noise=0.0, n_edge=200, n_stripe=100):
    rng = np.random.default_rng(seed + 1000)
    X = _centres(seed, n)
    edges = [syn.sphere_outline_points(K0, x, R, n_edge, noise=noise, rng=rng) for x in X]
    conics = [fit_ellipse(e).conic for e in edges] if noise > 0 else [outline_conic(K0, x, R) for x in X]
    stripes = [SL.stripe_points(K0, x, R, PLANE, n_stripe, projector=PROJ, noise=noise, rng=rng) for x in X]
    return X, conics, edges, stripes


# --------------------------------------------------------------------------
# plane, forward model, double contact
# --------------------------------------------------------------------------


def test_light_plane_canonical_form():
    p = SL.LightPlane(normal=[-2.0, 0.0, -0.6], d=-0.6)
    assert np.allclose(np.linalg.norm(p.normal), 1.0) and p.d > 0
    assert np.allclose(p.normal, PLANE.normal) and np.isclose(p.d, PLANE.d)
    q = SL.LightPlane.from_vector(PLANE.vector * -3.0)
    # a rescaled copy: the unit normals agree to a few ulps, so the angle is ~1e-16
    assert q.angle_to(PLANE) < 1e-14 and np.isclose(q.d, PLANE.d)
    with pytest.raises(ValueError, match="the light plane passes through the camera centre"):
        SL.LightPlane(normal=[1.0, 0.0, 0.0], d=0.0)


@pytest.mark.parametrize("angle", [1e-12, 1e-9, 1e-6, 0.3, np.pi / 2])
def test_light_plane_angle_resolves_small_angles(angle):
    # arccos(|n . n'|) cannot resolve below ~1.5e-8 rad (the spacing of doubles
    # under 1); the answer must be the rotation to a few ulps of the angle
    a, b = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    p = SL.LightPlane(normal=a, d=1.0)
    q = SL.LightPlane(normal=np.cos(angle) * a + np.sin(angle) * b, d=1.0)
    assert abs(p.angle_to(q) - angle) <= 4 * np.finfo(float).eps * max(angle, 1e-15)
    assert p.angle_to(q) == q.angle_to(p)
    # the normals' orientation does not matter: planes, not vectors
    r = SL.LightPlane(normal=-q.normal, d=-1.0)
    assert abs(p.angle_to(r) - angle) <= 4 * np.finfo(float).eps * max(angle, 1e-15)


def test_stripe_conic_double_contact_and_circular_points():
    X = _centres(1, 3)
    S = [SL.stripe_conic(K0, x, R, PLANE) for x in X]
    for x, s in zip(X, S):
        C = outline_conic(K0, x, R)
        assert double_contact(C, s).holds
        pts = SL.stripe_points(K0, x, R, PLANE, 50, projector=PROJ)
        assert np.abs(sampson_distance(pts, s)).max() < 1e-8
        assert np.all(np.abs(SL.LightPlane.distance(PLANE, SL.triangulate(K0, PLANE, pts))) < 1e-10)
    # all stripes are circles of one plane: they share the plane's imaged circular points,
    # which lie on the image of the absolute conic
    w = iac(K0)
    common = intersect_conics(S[0], S[1])
    on_w = [p for p in common if abs(p @ w @ p) < 1e-9 * np.linalg.norm(w) and np.abs(p.imag).max() > 1e-6]
    assert len(on_w) == 2
    for p in on_w:
        assert abs(p @ S[2] @ p) < 1e-9


def test_fit_stripe_conic_exact_and_noisy():
    X = _centres(2, 4)
    rng = np.random.default_rng(0)
    for x in X:
        C = outline_conic(K0, x, R)
        S = SL.stripe_conic(K0, x, R, PLANE)
        pts = SL.stripe_points(K0, x, R, PLANE, 40, projector=PROJ)
        fit = SL.fit_stripe_conic(C, pts)
        assert min(np.abs(fit.conic - S).max(), np.abs(fit.conic + S).max()) < 1e-9
        assert fit.rms < 1e-8
        noisy = SL.fit_stripe_conic(C, pts + rng.normal(0, 0.3, pts.shape))
        truth = SL.stripe_points(K0, x, R, PLANE, 200, projector=PROJ)
        assert np.abs(sampson_distance(truth, noisy.conic)).max() < 0.5


def test_triangulate_and_backproject_round_trip():
    X = _centres(3, 3)
    for x in X:
        px = SL.stripe_points(K0, x, R, PLANE, 30, projector=PROJ)
        P = SL.triangulate(K0, PLANE, px)
        assert np.allclose(np.linalg.norm(P - x, axis=1), R, atol=1e-10)
        Q = SL.backproject_to_sphere(K0, x, R, px)
        assert np.allclose(P, Q, atol=1e-10)
    # a ray parallel to the plane, and one meeting it behind the camera
    n = PLANE.normal
    ray_par = np.cross(n, [0.0, 1.0, 0.0])
    ray_par = ray_par if ray_par[2] > 0 else -ray_par
    far = K0 @ (ray_par / ray_par[2])
    behind = K0 @ np.array([-1.0, 0.0, 1.0])  # x = -z: n . X = (-0.958 + 0.287) t < 0
    P = SL.triangulate(K0, PLANE, np.array([far[:2], behind[:2] / behind[2], [330.0, 235.0]]))
    assert np.all(np.isnan(P[:2])) and np.all(np.isfinite(P[2]))


# --------------------------------------------------------------------------
# calibration
# --------------------------------------------------------------------------


@pytest.mark.parametrize("refine", [False, True])
def test_calibrate_exact(refine):
    X, conics, _, stripes = _data(4, n=6)
    res = SL.calibrate(conics, stripes, radius=R, refine=refine)
    assert np.allclose(res.K, K0, atol=1e-6 * K0[0, 0])
    assert res.plane.angle_to(PLANE) < 1e-9 and np.isclose(res.plane.d, PLANE.d, rtol=1e-9)
    assert np.allclose(res.centres, X, atol=1e-9)
    assert res.rms < 1e-6 and res.plane_rms < 1e-9
    assert res.stage == ("refined" if refine else "initial")
    for x, S in zip(X, res.stripe_conics):
        T = SL.stripe_conic(K0, x, R, PLANE)
        assert min(np.abs(S - T).max(), np.abs(S + T).max()) < 1e-6


def test_calibrate_known_K_one_sphere_and_images_without_stripe():
    X, conics, _, stripes = _data(5, n=4)
    res = SL.calibrate(conics[:1], stripes[:1], radius=R, K=K0)
    assert res.model == "fixed" and np.allclose(res.K, K0)
    assert res.plane.angle_to(PLANE) < 1e-8
    res = SL.calibrate(conics, [stripes[0], None, stripes[2], None], radius=R)
    assert np.allclose(res.K, K0, atol=1e-5 * K0[0, 0]) and res.plane.angle_to(PLANE) < 1e-8
    assert res.stripe_conics[1] is None


def test_calibrate_falls_back_to_a_focal_scan(monkeypatch):
    # when the outlines alone give no positive-definite IAC, the joint refinement
    # starts from a focal-length scan and reaches the same answer
    X, conics, edges, stripes = _data(12, n=6)

    def fail(*args, **kwargs):
        raise ValueError("forced")

    monkeypatch.setattr(SL, "intrinsics_from_spheres", fail)
    res = SL.calibrate(conics, stripes, radius=R)
    assert np.allclose(res.K, K0, atol=1e-5 * K0[0, 0]) and res.plane.angle_to(PLANE) < 1e-6


def test_calibrate_noise_bound():
    X, conics, edges, stripes = _data(6, n=10, noise=0.5)
    res = SL.calibrate(conics, stripes, radius=R, edge_points=edges)
    assert abs(res.K[0, 0] / K0[0, 0] - 1) < 0.015
    assert np.degrees(res.plane.angle_to(PLANE)) < 0.4
    assert abs(res.plane.d / PLANE.d - 1) < 0.01
    assert 0.4 < res.rms < 0.6
    # the joint refinement beats the outline-only intrinsics and the initial plane
    assert abs(res.K[0, 0] / K0[0, 0] - 1) < abs(res.K_spheres[0, 0] / K0[0, 0] - 1)
    assert res.plane.angle_to(PLANE) < res.plane_init.angle_to(PLANE)


def test_measure_sphere():
    Xt = np.array([0.02, 0.03, 0.9])
    Xt = Xt + (PLANE.d + 0.3 * 0.04 - PLANE.distance(Xt)[0] - PLANE.d) * PLANE.normal
    rt = 0.04
    C = outline_conic(K0, Xt, rt)
    px = SL.stripe_points(K0, Xt, rt, PLANE, 80, projector=PROJ)
    m = SL.measure_sphere(K0, PLANE, C, px)
    assert np.isclose(m.radius, rt, rtol=1e-9) and np.allclose(m.centre, Xt, atol=1e-9)
    rng = np.random.default_rng(1)
    e = syn.sphere_outline_points(K0, Xt, rt, 300, noise=0.5, rng=rng)
    m = SL.measure_sphere(K0, PLANE, fit_ellipse(e).conic, px + rng.normal(0, 0.5, px.shape))
    assert abs(m.radius / rt - 1) < 0.01


# --------------------------------------------------------------------------
# stripe extraction and the path from images
# --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def laser_images():
    X = _centres(8, 6)
    imgs = [SL.render_laser_image(K0, x, R, PLANE, SIZE, projector=PROJ, rng=i) for i, x in enumerate(X)]
    return X, imgs


def test_extract_stripe_subpixel(laser_images):
    X, imgs = laser_images
    errs = []
    for x, img in zip(X[:3], imgs[:3]):
        mask = SL._inside_mask(img.shape[:2], outline_conic(K0, x, R), 1.5)
        pts = SL.extract_stripe(img, mask=mask)
        assert len(pts) > 20
        errs.append(np.abs(sampson_distance(pts, SL.stripe_conic(K0, x, R, PLANE))))
    errs = np.concatenate(errs)
    assert np.median(errs) < 0.1 and np.percentile(errs, 90) < 0.5
    # nothing on an image without the laser (plain background; red clutter would be found)
    plain = syn.render_spheres(K0, X[:1], R, SIZE, colours=[[190.0, 190.0, 185.0]], background="plain", rng=0)
    assert len(SL.extract_stripe(plain)) == 0
    # with a background image (laser off) the clutter cancels
    lit = SL.render_laser_image(K0, X[0], R, PLANE, SIZE, projector=PROJ, rng=3, noise=0.0)
    off = SL.render_laser_image(K0, X[0], R, PLANE, SIZE, projector=PROJ, rng=3, noise=0.0, peak=0.0)
    pts = SL.extract_stripe(lit, background=off)
    assert len(pts) > 20 and np.median(np.abs(sampson_distance(pts, SL.stripe_conic(K0, X[0], R, PLANE)))) < 0.1


def test_calibrate_from_images(laser_images):
    X, imgs = laser_images
    res = SL.calibrate(imgs, radius=R, K=K0)
    assert np.degrees(res.plane.angle_to(PLANE)) < 1.0
    assert abs(res.plane.d / PLANE.d - 1) < 0.03
    assert res.stripe_rms < 0.5


# --------------------------------------------------------------------------
# degenerate inputs
# --------------------------------------------------------------------------


@pytest.mark.parametrize(
    "case, match",
    [
        ("two_images", r"too few sphere images: 2; the intrinsics need at least 3 \(or give K\)"),
        ("stripe_misses", r"stripe_points\[1\]: .* stripe pixels lie outside the sphere's outline: the stripe misses the sphere"),
        ("stripe_empty", r"stripe_points\[0\] has 0 points \(at least 5 needed\): the laser stripe misses the sphere"),
        ("no_stripe", r"no laser stripe in any image: the light plane is unobservable"),
        ("mismatch", r"stripe_points must hold one entry per sphere image: 4 images, 3 entries"),
        ("conics_only", r"stripe_points are required when outlines are given as conics"),
        ("hyperbola", r"sphere_images\[2\] is not a real ellipse"),
        ("radius", r"radius must be positive and finite, got -1.0"),
        ("edges", r"edge_points must hold one entry per sphere image: 4 images, 2 entries"),
    ],
)
def test_calibrate_degenerate(case, match):
    X, conics, edges, stripes = _data(9, n=4)
    kw = {"radius": R}
    if case == "two_images":
        conics, stripes = conics[:2], stripes[:2]
    elif case == "stripe_misses":
        stripes[1] = stripes[1] + np.array([300.0, 0.0])
    elif case == "stripe_empty":
        stripes[0] = np.zeros((0, 2))
    elif case == "no_stripe":
        stripes = [None] * 4
    elif case == "mismatch":
        stripes = stripes[:3]
    elif case == "conics_only":
        stripes = None
    elif case == "hyperbola":
        conics[2] = np.diag([1.0, -1.0, 1.0])
    elif case == "radius":
        kw["radius"] = -1.0
    elif case == "edges":
        kw["edge_points"] = edges[:2]
    with pytest.raises(ValueError, match=match):
        SL.calibrate(conics, stripes, **kw)


def test_forward_model_degenerate():
    with pytest.raises(ValueError, match="the light plane misses the sphere: no stripe"):
        SL.stripe_conic(K0, [0.5, 0.0, 1.0], R, PLANE)
    with pytest.raises(ValueError, match="the light plane misses the sphere: no stripe"):
        SL.stripe_points(K0, [0.5, 0.0, 1.0], R, PLANE)
    with pytest.raises(ValueError, match="the points are collinear: the plane is undetermined"):
        SL.fit_plane([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [2.0, 0.0, 1.0]])
    with pytest.raises(ValueError, match=r"pixels needs at least 3 points, got 2"):
        SL.fit_stripe_conic(outline_conic(K0, [0.0, 0.0, 1.0], R), [[330.0, 235.0], [331.0, 236.0]])


# --------------------------------------------------------------------------
# CLI
# --------------------------------------------------------------------------


def test_cli_laser_data(tmp_path, capsys):
    X, conics, edges, stripes = _data(10, n=5, noise=0.2)
    path = tmp_path / "laser.json"
    path.write_text(
        json.dumps(
            {
                "conics": [C.tolist() for C in conics],
                "stripe_points": [s.tolist() for s in stripes],
                "edge_points": [e.tolist() for e in edges],
            }
        )
    )
    assert cli_main(["calib", "laser", "--data", str(path), "--radius", str(R)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert abs(out["K"][0][0] / K0[0, 0] - 1) < 0.03
    n = np.array(out["plane"]["normal"])
    assert np.degrees(np.arccos(min(1.0, abs(n @ PLANE.normal)))) < 1.0
    kf = tmp_path / "K.json"
    kf.write_text(json.dumps({"K": K0.tolist()}))
    assert cli_main(["calib", "laser", "--data", str(path), "--radius", str(R), "--intrinsics", str(kf)]) == 0
    assert json.loads(capsys.readouterr().out)["model"] == "fixed"


def test_cli_laser_images(tmp_path, capsys, laser_images):
    X, imgs = laser_images
    paths = []
    for i, img in enumerate(imgs[:3]):
        p = tmp_path / f"l{i}.png"
        cv2.imwrite(str(p), img)
        paths.append(str(p))
    kf = tmp_path / "K.json"
    kf.write_text(json.dumps({"K": K0.tolist()}))
    assert cli_main(["calib", "laser", *paths, "--radius", str(R), "--intrinsics", str(kf)]) == 0
    out = json.loads(capsys.readouterr().out)
    n = np.array(out["plane"]["normal"])
    assert np.degrees(np.arccos(min(1.0, abs(n @ PLANE.normal)))) < 2.0


@pytest.mark.parametrize(
    "args, message",
    [
        (["--data", "MISSING.json", "--radius", "1"], "file not found"),
        (["--data", "BAD.json", "--radius", "1"], "not valid JSON"),
        (["--data", "EMPTY.json", "--radius", "1"], "expected {\"conics\""),
        (["MISSING.png", "--radius", "1"], "image not found"),
        (["--radius", "1"], "give either images or --data FILE"),
    ],
)
def test_cli_laser_bad_input(tmp_path, capsys, args, message):
    (tmp_path / "BAD.json").write_text("[1, 2")
    (tmp_path / "EMPTY.json").write_text("{}")
    args = [str(tmp_path / x) if x.endswith((".json", ".png")) else x for x in args]
    assert cli_main(["calib", "laser", *args]) == 2
    assert message in capsys.readouterr().err
