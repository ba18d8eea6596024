"""calib.one_d: Zhang's 1-D calibration and the 1-D object from two spheres (issue 8).

Synthetic round trips against exact truth, error bounds under noise with
fixed seeds, the K-free sphere geometry checked against ground truth, a table
of degenerate inputs with the exact error each must give, and the CLI.
Monte Carlo statistics live in bench/one_d_calibration.py.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from arstream.cli import main as cli_main
from calib import one_d as O
from calib import synthetic as syn
from calib.sphere import outline_conic
from geometry.conics import fit_ellipse

# Zhang's simulated camera and rod (PAMI 2004, section 5.1), general model
KZ = np.array([[1000.0, 0.0, 320.0], [0.0, 1000.0, 240.0], [0.0, 0.0, 1.0]])
A_Z = np.array([0.0, 35.0, 150.0])
L_Z = 70.0

K0 = np.array([[1000.0, 0.0, 330.0], [0.0, 1010.0, 235.0], [0.0, 0.0, 1.0]])
SIZE = (640, 480)
R = 0.1


def _zhang_dirs(rng, n):
    th = rng.uniform(np.pi / 6, 5 * np.pi / 6, n)
    ph = rng.uniform(np.pi, 2 * np.pi, n)
    return np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], axis=1)


def _zhang_views(seed, n, noise=0.0, K=KZ, ratio=0.5):
    rng = np.random.default_rng(seed)
    d = _zhang_dirs(rng, n)
    a, b, c = O.project_rod(K, A_Z, d, length=L_Z, ratio=ratio)
    if noise > 0:
        a, b, c = (p + rng.normal(0.0, noise, p.shape) for p in (a, b, c))
    return a, b, c, d


def _sphere_scene(seed, n_moved=6, noise=0.0, n_points=200, K=K0):
    rng = np.random.default_rng(seed)
    X = syn.random_sphere_centres(K, SIZE, n_moved + 1, radius=R, image_radius=(35.0, 60.0), min_separation=2.0, rng=rng)
    pts = [syn.sphere_outline_points(K, x, R, n_points, noise=noise, rng=rng) for x in X]
    if noise > 0:
        conics = [fit_ellipse(p).conic for p in pts]
    else:
        conics = [outline_conic(K, x, R) for x in X]
    return X, conics, pts


def _focal_err(Ka, Kb):
    return float(max(abs(Ka[0, 0] / Kb[0, 0] - 1), abs(Ka[1, 1] / Kb[1, 1] - 1)))


# --------------------------------------------------------------------------
# Zhang's method
# --------------------------------------------------------------------------


@pytest.mark.parametrize(
    "model, K",
    [
        ({"zero_skew": False}, np.array([[1000.0, 1.5, 320.0], [0.0, 980.0, 240.0], [0.0, 0.0, 1.0]])),
        ({"zero_skew": True}, np.array([[1000.0, 0.0, 310.0], [0.0, 1020.0, 250.0], [0.0, 0.0, 1.0]])),
        ({"square_pixels": True}, KZ),
    ],
)
@pytest.mark.parametrize("ratio", [0.5, 0.3, 1.6])
def test_zhang_exact_round_trip(model, K, ratio):
    a, b, c, d = _zhang_views(1, 8, K=K, ratio=ratio)
    for refine in (False, True):
        res = O.zhang_1d(a, b, c, length=L_Z, ratio=ratio, refine=refine, **model)
        assert np.allclose(res.K, K, rtol=0, atol=1e-6 * K[0, 0])
        assert np.allclose(res.fixed_point, A_Z, atol=1e-6)
        assert np.allclose(res.directions, d, atol=1e-8)
        assert np.allclose(res.markers, A_Z + ratio * L_Z * d, atol=1e-6)
        assert res.residual_rms < 1e-6
        assert res.stage == ("refined" if refine else "linear")


def test_zhang_noise_bound_and_refinement_helps():
    # Zhang's setup (100 orientations) at 1 px: the paper reports ~12 % (closed form) and
    # ~6 % (refined); the ML estimate here is well inside 2 %
    a, b, c, _ = _zhang_views(7, 100, noise=1.0)
    res = O.zhang_1d(a, b, c, length=L_Z, ratio=0.5, zero_skew=False)
    assert _focal_err(res.K, KZ) < 0.02
    assert abs(res.K[0, 2] - 320) < 20 and abs(res.K[1, 2] - 240) < 20
    lin = O.zhang_1d(a, b, c, length=L_Z, ratio=0.5, zero_skew=False, refine=False)
    assert res.residual_rms < lin.residual_rms
    assert 0.6 < res.residual_rms < 1.3  # about the noise level


def test_zhang_ten_views_half_pixel():
    errs = []
    for seed in range(5):
        a, b, c, _ = _zhang_views(100 + seed, 10, noise=0.5)
        errs.append(_focal_err(O.zhang_1d(a, b, c, length=L_Z, ratio=0.5).K, KZ))
    assert np.mean(errs) < 0.02


def _planar_dirs(n):
    t = np.linspace(0.3, 2.5, n)
    return np.stack([np.cos(t), np.zeros(n), -np.sin(t) * 0.5 - 0.5], axis=1)


@pytest.mark.parametrize(
    "case, match",
    [
        ("too_few", r"too few views: the zero_skew model needs at least 5, got 4"),
        ("too_few_general", r"too few views: the general model needs at least 6, got 5"),
        ("same_orientation", r"all views have the same rod orientation"),
        ("planar", r"all rod directions lie in one plane"),
        ("mismatch", r"a, b and c must have the same number of views, got 8, 7 and 8"),
        ("shape", r"b must have shape \(N, 2\)"),
        ("nan", r"c has non-finite coordinates"),
        ("ratio0", r"ratio must be finite and the marker must differ from A and B"),
        ("ratio1", r"ratio must be finite and the marker must differ from A and B"),
        ("length", r"length must be positive and finite, got -70.0"),
        ("order", r"view 0: the points are not in the order the ratio implies"),
        ("model", r"square_pixels=True requires zero_skew=True"),
    ],
)
def test_zhang_degenerate(case, match):
    a, b, c, d = _zhang_views(3, 8)
    kw = {"length": L_Z, "ratio": 0.5}
    if case == "too_few":
        a, b, c = a[:4], b[:4], c[:4]
    elif case == "too_few_general":
        a, b, c = a[:5], b[:5], c[:5]
        kw["zero_skew"] = False
    elif case == "same_orientation":
        a, b, c = O.project_rod(KZ, A_Z, np.repeat(d[:1], 8, axis=0), length=L_Z, ratio=0.5)
    elif case == "planar":
        a, b, c = O.project_rod(KZ, A_Z, _planar_dirs(8), length=L_Z, ratio=0.5)
    elif case == "mismatch":
        b = b[:7]
    elif case == "shape":
        b = b.ravel()
    elif case == "nan":
        c = c.copy()
        c[2, 0] = np.nan
    elif case == "ratio0":
        kw["ratio"] = 0.0
    elif case == "ratio1":
        kw["ratio"] = 1.0
    elif case == "length":
        kw["length"] = -70.0
    elif case == "order":
        b, c = c, b
    elif case == "model":
        kw.update(square_pixels=True, zero_skew=False)
    with pytest.raises(ValueError, match=match):
        O.zhang_1d(a, b, c, **kw)


# --------------------------------------------------------------------------
# two spheres: K-free geometry
# --------------------------------------------------------------------------


def _px(K, X):
    x = np.atleast_2d(X) @ K.T
    return x[:, :2] / x[:, 2:3]


def test_two_sphere_geometry_matches_truth():
    X, conics, _ = _sphere_scene(11, n_moved=5)
    A, B = X[0], X[1:]
    g = O.two_sphere_geometry(conics[0], conics[1:])
    assert np.allclose(g.fixed_centre, _px(K0, A)[0], atol=1e-7)
    assert np.allclose(g.free_centres, _px(K0, B), atol=1e-7)
    assert np.allclose(g.midpoints, _px(K0, 0.5 * (A + B)), atol=1e-7)
    v = (B - A) @ K0.T
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    assert np.allclose(np.abs(np.einsum("ij,ij->i", g.vanishing_points, v)), 1.0, atol=1e-10)
    assert np.allclose(g.depth_ratios, B[:, 2] / A[2], rtol=1e-9)
    # the line of centres passes through the imaged centres, midpoint and vanishing point
    for i in range(len(B)):
        pts = np.array([np.append(g.fixed_centre, 1), np.append(g.free_centres[i], 1), np.append(g.midpoints[i], 1)])
        assert np.abs(pts @ g.lines[i]).max() < 1e-7
        assert abs(g.vanishing_points[i] @ g.lines[i]) < 1e-9
    # the imaged centre is not the ellipse centre
    from geometry.conics import ellipse_from_conic

    assert np.linalg.norm(np.array(ellipse_from_conic(conics[0]).center) - g.fixed_centre) > 0.05


def test_two_sphere_geometry_is_K_free():
    # the same 3-D scene under two different cameras: each geometry matches its own camera
    rng = np.random.default_rng(5)
    X = syn.random_sphere_centres(K0, SIZE, 5, radius=R, image_radius=(35.0, 60.0), rng=rng)
    K2 = np.array([[700.0, 3.0, 300.0], [0.0, 690.0, 260.0], [0.0, 0.0, 1.0]])
    for K in (K0, K2):
        g = O.two_sphere_geometry(outline_conic(K, X[0], R), [outline_conic(K, x, R) for x in X[1:]])
        assert np.allclose(g.free_centres, _px(K, X[1:]), atol=1e-7)
        assert np.allclose(g.midpoints, _px(K, 0.5 * (X[0] + X[1:])), atol=1e-7)


# --------------------------------------------------------------------------
# two spheres: calibration
# --------------------------------------------------------------------------


@pytest.mark.parametrize("refine", [False, True])
@pytest.mark.parametrize("model", [{}, {"square_pixels": True}, {"zero_skew": False}])
def test_from_two_spheres_exact(refine, model):
    K = K0 if not model.get("square_pixels") else np.array([[1000.0, 0.0, 330.0], [0.0, 1000.0, 235.0], [0.0, 0.0, 1.0]])
    X, conics, _ = _sphere_scene(21, n_moved=5, K=K) if model.get("square_pixels") else _sphere_scene(21, n_moved=5)
    res = O.from_two_spheres(conics[0], conics[1:], radius=R, refine=refine, **model)
    assert np.allclose(res.K, K, atol=1e-6 * K[0, 0])
    assert np.allclose(res.K_linear, K, atol=1e-6 * K[0, 0])
    assert np.allclose(res.fixed_point, X[0], atol=1e-8)
    assert np.allclose(res.free_points, X[1:], atol=1e-8)
    assert np.allclose(res.markers, 0.5 * (X[0] + X[1:]), atol=1e-8)
    assert np.allclose(res.lengths, np.linalg.norm(X[1:] - X[0], axis=1), atol=1e-8)
    assert res.residual_rms < 1e-6
    assert res.method == "two_spheres"


def test_from_two_spheres_two_spheres_per_image():
    # the fixed sphere re-imaged in every view: its outlines are pooled
    X, conics, pts = _sphere_scene(31, n_moved=6, noise=0.3)
    rng = np.random.default_rng(0)
    fixed_pts = [syn.sphere_outline_points(K0, X[0], R, 200, noise=0.3, rng=rng) for _ in range(6)]
    fixed = [fit_ellipse(p).conic for p in fixed_pts]
    res = O.from_two_spheres(fixed, conics[1:], radius=R, fixed_points=fixed_pts, moving_points=pts[1:])
    assert _focal_err(res.K, K0) < 0.03
    assert len(res.per_view_rms) == 6
    assert 0.2 < res.residual_rms < 0.45


def test_from_two_spheres_noise_bound():
    # 10 moved positions spread over the image, 0.5 px edge noise, 200 points per outline
    errs, len_errs = [], []
    for seed in (41, 42, 43):
        X, conics, pts = _sphere_scene(seed, n_moved=10, noise=0.5)
        res = O.from_two_spheres(conics[0], conics[1:], radius=R, fixed_points=pts[0], moving_points=pts[1:])
        errs.append(_focal_err(res.K, K0))
        true_len = np.linalg.norm(X[1:] - X[0], axis=1)
        len_errs.append(np.max(np.abs(res.lengths / true_len - 1)))
        assert 0.4 < res.residual_rms < 0.6
    assert np.mean(errs) < 0.02
    assert np.mean(len_errs) < 0.05


def test_from_two_spheres_without_edge_points():
    X, conics, _ = _sphere_scene(51, n_moved=8, noise=0.5)
    res = O.from_two_spheres(conics[0], conics[1:], radius=R)
    assert _focal_err(res.K, K0) < 0.05
    assert res.init in ("linear", "sphere_rank1")


def _moves_along_one_line():
    A = np.array([0.0, 0.0, 2.0])
    u = np.array([1.0, 0.5, 0.3]) / np.linalg.norm([1.0, 0.5, 0.3])
    return A, [A + t * u for t in (0.3, 0.45, 0.6)]


@pytest.mark.parametrize(
    "case, match",
    [
        ("one_move", r"too few views: the 1-D object from two spheres needs at least 2 moved positions, got 1"),
        ("same_direction", r"the sphere positions and the camera centre are coplanar"),
        ("not_moved", r"moving\[1\] is the fixed sphere's outline: the sphere was not moved"),
        ("hidden", r"view 0: one sphere image lies \(almost\) inside the other"),
        ("hyperbola", r"moving\[0\] is not a real ellipse, so not the outline of a sphere"),
        ("shape", r"moving must hold 3x3 conic matrices"),
        ("points", r"moving_points must hold one \(n, 2\) array per conic: 3 conics, 2 arrays"),
        ("radius", r"radius must be positive and finite, got 0.0"),
    ],
)
def test_from_two_spheres_degenerate(case, match):
    X, conics, pts = _sphere_scene(61, n_moved=3)
    fixed, moving = conics[0], list(conics[1:])
    kw = {"radius": R}
    if case == "one_move":
        moving = moving[:1]
    elif case == "same_direction":
        A, Bs = _moves_along_one_line()
        fixed, moving = outline_conic(K0, A, R), [outline_conic(K0, B, R) for B in Bs]
    elif case == "not_moved":
        moving[1] = fixed.copy()
    elif case == "hidden":
        A = np.array([0.0, 0.0, 2.0])
        fixed = outline_conic(K0, A, R)
        moving = [outline_conic(K0, np.array([0.0, 0.02, 3.0]), R)] + moving[1:]
    elif case == "hyperbola":
        moving[0] = np.diag([1.0, -1.0, 1.0])
    elif case == "shape":
        moving = [np.eye(2)] * 3
    elif case == "points":
        kw["moving_points"] = pts[1:3]
    elif case == "radius":
        kw["radius"] = 0.0
    with pytest.raises(ValueError, match=match):
        O.from_two_spheres(fixed, moving, **kw)


# --------------------------------------------------------------------------
# CLI
# --------------------------------------------------------------------------


def test_cli_one_d_points_csv(tmp_path, capsys):
    a, b, c, _ = _zhang_views(9, 12, noise=0.2)
    path = tmp_path / "views.csv"
    rows = ["ax,ay,bx,by,cx,cy"] + [",".join(f"{v:.6f}" for v in (*a[i], *b[i], *c[i])) for i in range(12)]
    path.write_text("\n".join(rows) + "\n")
    assert cli_main(["calib", "one-d", "--points", str(path), "--length", "70", "--ratio", "0.5"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["method"] == "zhang"
    assert abs(out["K"][0][0] / 1000 - 1) < 0.03
    assert len(out["views"]) == 12


def test_cli_one_d_points_json_and_spheres(tmp_path, capsys):
    a, b, c, _ = _zhang_views(9, 8)
    pj = tmp_path / "views.json"
    pj.write_text(json.dumps({"a": a.tolist(), "b": b.tolist(), "c": c.tolist(), "length": 70.0, "ratio": 0.5}))
    assert cli_main(["calib", "one-d", "--points", str(pj), "--no-refine"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert np.allclose(out["K"], KZ, atol=1e-4) and out["stage"] == "linear"
    X, conics, _ = _sphere_scene(21, n_moved=4)
    sj = tmp_path / "spheres.json"
    sj.write_text(json.dumps({"fixed": conics[0].tolist(), "moving": [C.tolist() for C in conics[1:]]}))
    assert cli_main(["calib", "one-d", "--spheres", str(sj), "--radius", str(R)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["method"] == "two_spheres"
    assert np.allclose(out["K"], K0, atol=1e-3)
    assert np.allclose(out["fixed_point"], X[0], atol=1e-6)
    assert len(out["geometry"]["midpoints"]) == 4


@pytest.mark.parametrize(
    "args, message",
    [
        (["--points", "MISSING.csv", "--length", "1"], "file not found"),
        (["--points", "BAD.json", "--length", "1"], "not valid JSON"),
        (["--points", "SHORT.csv", "--length", "1"], "every row needs six numbers"),
        (["--points", "GOOD.csv"], "--length is required"),
        (["--spheres", "BAD.json", "--radius", "1"], "not valid JSON"),
        (["--fixed-image", "MISSING.png", "--moving-images", "MISSING.png", "MISSING.png", "--radius", "1"], "image not found"),
    ],
)
def test_cli_one_d_bad_input(tmp_path, capsys, args, message):
    (tmp_path / "BAD.json").write_text("{not json")
    (tmp_path / "SHORT.csv").write_text("1,2,3\n4,5,6\n")
    a, b, c, _ = _zhang_views(9, 8)
    (tmp_path / "GOOD.csv").write_text("\n".join(",".join(map(str, (*a[i], *b[i], *c[i]))) for i in range(8)))
    args = [str(tmp_path / x) if x.isupper() or x.endswith((".csv", ".json", ".png")) else x for x in args]
    assert cli_main(["calib", "one-d", *args]) == 2
    assert message in capsys.readouterr().err


def test_closed_form_from_any_sphere_set():
    # the K-free imaged centres + linear IAC work for any three or more sphere images
    X, conics, _ = _sphere_scene(71, n_moved=3)
    assert np.allclose(O._closed_form_K(np.array(conics), "zero_skew"), K0, atol=1e-6 * K0[0, 0])
