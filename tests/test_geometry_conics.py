"""Round trips and degenerate inputs for geometry.conics."""

import numpy as np
import pytest

from geometry import conics as gc
from geometry.homography import transfer_conic


def random_ellipse(rng, scale=500.0):
    a = rng.uniform(20, 300)
    b = rng.uniform(5, a)
    return gc.Ellipse(center=tuple(rng.uniform(0, scale * 2, 2)), axes=(a, b), angle=rng.uniform(-np.pi, np.pi))


def rel(a, b):
    return np.linalg.norm(np.asarray(a) - np.asarray(b)) / max(np.linalg.norm(b), 1e-12)


@pytest.mark.parametrize("seed", range(10))
def test_ellipse_conic_round_trip(seed):
    rng = np.random.default_rng(seed)
    e = random_ellipse(rng)
    C = gc.conic_from_ellipse(e)
    assert np.isclose(np.linalg.norm(C), 1.0)
    e2 = gc.ellipse_from_conic(C)
    assert np.allclose(e2.center, e.center, atol=1e-6)
    assert np.allclose(e2.axes, e.axes, rtol=1e-9)
    # axis direction is defined modulo pi; near-circles leave it free
    d = abs(np.angle(np.exp(2j * (e2.angle - e.angle)))) / 2
    assert d < 1e-6 or e.axes[0] - e.axes[1] < 1e-6
    # points on the ellipse satisfy the conic; the centre is inside (negative)
    pts = e.points(40)
    X = np.column_stack([pts, np.ones(len(pts))])
    T = gc.conic_conditioning(C)
    Xn = X @ T.T
    Cn = np.linalg.inv(T).T @ C @ np.linalg.inv(T)
    assert np.max(np.abs(np.einsum("ij,jk,ik->i", Xn, Cn, Xn))) < 1e-10 * np.linalg.norm(Cn)
    c = np.array([*e.center, 1.0])
    assert c @ C @ c < 0


def test_ellipse_canonical_form():
    e = gc.Ellipse(center=(0, 0), axes=(2.0, 5.0), angle=0.1)
    assert e.axes == (5.0, 2.0)
    assert np.isclose(e.angle, 0.1 + np.pi / 2 - np.pi)
    assert -np.pi / 2 < gc.Ellipse(center=(0, 0), axes=(5, 2), angle=3.0).angle <= np.pi / 2


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("arc", [2 * np.pi, np.pi])
def test_fit_ellipse_exact_and_noisy(seed, arc):
    rng = np.random.default_rng(100 + seed)
    e = random_ellipse(rng)
    s = np.linspace(0, arc, 200, endpoint=False)
    pts = e.points_at(s)
    direct = gc.fit_ellipse_direct(pts)
    assert np.allclose(direct.center, e.center, atol=1e-6 * e.axes[0])
    assert np.allclose(direct.axes, e.axes, rtol=1e-7)
    noisy = pts + rng.normal(0, 0.5, pts.shape)
    fit = gc.fit_ellipse(noisy)
    assert fit.rms < 0.6
    # the refined fit never has a larger orthogonal residual than the direct fit
    d_direct = gc.ellipse_distance(noisy, gc.fit_ellipse_direct(noisy))
    assert fit.rms <= np.sqrt(np.mean(d_direct**2)) + 1e-9
    # true ellipse within a few pixels at its own points
    assert np.max(gc.ellipse_distance(e.points(100), fit.ellipse)) < (2.0 if arc > 4 else 6.0)


def test_refine_ellipse_sampson_and_robust():
    rng = np.random.default_rng(5)
    e = gc.Ellipse(center=(400, 300), axes=(150, 60), angle=0.4)
    pts = e.points(150) + rng.normal(0, 0.3, (150, 2))
    pts[:15] += rng.uniform(20, 40, (15, 2))  # outliers
    init = gc.Ellipse(center=(405, 296), axes=(140, 65), angle=0.35)
    robust = gc.refine_ellipse(pts, init, loss="cauchy", f_scale=1.0)
    assert np.allclose(robust.ellipse.center, e.center, atol=0.5)
    samp = gc.refine_ellipse(pts[15:], init, residual="sampson")
    assert np.allclose(samp.ellipse.axes, e.axes, rtol=0.01)


def test_ellipse_distance_against_dense_sampling():
    rng = np.random.default_rng(3)
    e = gc.Ellipse(center=(10, -4), axes=(7, 2), angle=0.7)
    pts = rng.uniform(-15, 15, (300, 2)) + e.center
    pts = np.vstack([pts, [e.center], [[e.center[0] + 3 * np.cos(0.7), e.center[1] + 3 * np.sin(0.7)]]])
    dense = e.points(200000)
    brute = np.min(np.linalg.norm(pts[:, None, :] - dense[None, ::1, :][:, ::50], axis=2), axis=1)
    exact = gc.ellipse_distance(pts, e)
    assert np.all(exact <= brute + 1e-9)
    fine = np.array([np.min(np.linalg.norm(dense - p, axis=1)) for p in pts])
    assert np.allclose(exact, fine, atol=1e-5)
    signed = gc.ellipse_distance(pts, e, signed=True)
    inside = gc.sampson_distance(pts, e.conic) < 0
    assert np.all(np.sign(signed[np.abs(signed) > 1e-6]) == np.where(inside, -1, 1)[np.abs(signed) > 1e-6])


def test_sampson_distance_first_order():
    e = gc.Ellipse(center=(0, 0), axes=(100, 50), angle=0.0)
    pts = np.array([[101.0, 0.0], [0.0, 49.5], [70.0, 70.0]])
    s = gc.sampson_distance(pts, e.conic)
    o = gc.ellipse_distance(pts, e, signed=True)
    assert np.allclose(s[:2], o[:2], atol=0.02)
    assert np.sign(s[2]) == np.sign(o[2])


@pytest.mark.parametrize("seed", range(10))
def test_pole_polar_round_trip(seed):
    rng = np.random.default_rng(seed)
    C = random_ellipse(rng).conic
    x = np.array([*rng.uniform(-500, 1500, 2), 1.0])
    l = gc.polar(C, x)
    x2 = gc.pole(C, l)
    assert abs(abs(x2 @ x) / np.linalg.norm(x) - 1) < 1e-9
    # the polar of a point on the conic is its tangent
    e = gc.ellipse_from_conic(C)
    p = np.array([*e.points(7)[3], 1.0])
    t = gc.polar(C, p)
    assert abs(t @ p) / np.linalg.norm(p) < 1e-9


@pytest.mark.parametrize("seed", range(10))
def test_intersect_line_conic(seed):
    rng = np.random.default_rng(seed)
    e = random_ellipse(rng)
    p, q = e.points_at(rng.uniform(0, 2 * np.pi, 2))
    l = np.cross([*p, 1.0], [*q, 1.0])
    X = gc.intersect_line_conic(e.conic, l)
    got = X[:, :2] / X[:, 2:]
    for target in (p, q):
        assert np.min(np.linalg.norm(got - target, axis=1)) < 1e-6 * e.axes[0]


@pytest.mark.parametrize("seed", range(12))
def test_intersect_conics_real_and_complex(seed):
    rng = np.random.default_rng(seed)
    e1, e2 = random_ellipse(rng), random_ellipse(rng)
    C1, C2 = e1.conic, e2.conic
    X = gc.intersect_conics(C1, C2)
    assert X.shape == (4, 3)
    T = gc.conic_conditioning(C1)
    Ti = np.linalg.inv(T)
    for C in (C1, C2):
        Cn = gc.normalize_conic(Ti.T @ C @ Ti)
        Xn = X @ T.T
        Xn /= np.linalg.norm(Xn, axis=1, keepdims=True)
        assert np.max(np.abs(np.einsum("ij,jk,ik->i", Xn, Cn, Xn))) < 1e-8
    # complex points come in conjugate pairs; the real ones lie on both ellipses
    real = gc.real_points(X)
    assert len(real) in (0, 2, 4)
    for x in real:
        pt = x[:2] / x[2]
        assert gc.ellipse_distance(pt[None], e1)[0] < 1e-5 * e1.axes[0]
        assert gc.ellipse_distance(pt[None], e2)[0] < 1e-5 * e2.axes[0]


def test_intersect_conics_projective_invariance():
    """Circular points: a circle meets the absolute conic's dual partner, the line at
    infinity, in I, J; after a homography they lie on the image of the circle."""
    C = gc.conic_from_circle((0, 0), 9.15)
    H = np.array([[900.0, -200.0, 640.0], [50.0, 100.0, 500.0], [0.02, 0.3, 1.0]])
    E = transfer_conic(H, C)
    # another circle, concentric: meets C only at I and J (twice each)
    C2 = gc.conic_from_circle((0, 0), 20.0)
    X = gc.intersect_conics(E, transfer_conic(H, C2))
    IJ = np.array([[1, 1j, 0], [1, -1j, 0]]) @ H.T
    for ij in IJ:
        ij = ij / np.linalg.norm(ij)
        assert min(abs(abs(np.vdot(ij, x)) - 1) for x in X) < 1e-6


def test_split_degenerate_conic():
    g = np.array([1.0, 2.0, -3.0])
    h = np.array([0.5, -1.0, 4.0])
    D = np.outer(g, h) + np.outer(h, g)
    a, b = gc.split_degenerate_conic(D)
    got = {tuple(np.round(np.real(v / v[np.argmax(np.abs(v))]), 9)) for v in (a, b)}
    want = {tuple(np.round(v / v[np.argmax(np.abs(v))], 9)) for v in (g, h)}
    assert got == want


def _same_line(u, v) -> bool:
    """u ~ v as projective lines (complex allowed): |<u, v>| = |u| |v|."""
    return abs(abs(np.vdot(u, v)) - np.linalg.norm(u) * np.linalg.norm(v)) < 1e-9 * np.linalg.norm(u) * np.linalg.norm(v)


def test_split_degenerate_conics_batch():
    rng = np.random.default_rng(3)
    g_real, h_real = rng.normal(size=3), rng.normal(size=3)
    z = rng.normal(size=3) + 1j * rng.normal(size=3)  # a complex-conjugate pair (a real point)
    pairs = [(g_real, h_real), (z, np.conj(z)), (g_real, g_real), (np.array([0.0, 1.0, -2.0]), np.array([1.0, 0.0, -5.0]))]
    D = np.array([np.outer(g, h) + np.outer(h, g) for g, h in pairs])
    gs, hs = gc.split_degenerate_conics(D * np.array([1.0, 3.0, -2.0, 1e-6])[:, None, None])  # any scale
    assert gs.shape == hs.shape == (4, 3)
    for k, (g, h) in enumerate(pairs):
        assert (_same_line(gs[k], g) and _same_line(hs[k], h)) or (_same_line(gs[k], h) and _same_line(hs[k], g))
        assert np.allclose(np.linalg.norm(gs[k]), 1.0) and np.allclose(np.linalg.norm(hs[k]), 1.0)
        a, b = gc.split_degenerate_conic(D[k])  # the single-conic form agrees
        assert _same_line(a, gs[k]) and _same_line(b, hs[k])
    with pytest.raises(ValueError, match=r"\(K, 3, 3\)"):
        gc.split_degenerate_conics(np.eye(3))


@pytest.mark.parametrize("seed", range(6))
def test_tangents_from_point(seed):
    rng = np.random.default_rng(seed)
    e = random_ellipse(rng)
    x = np.array([e.center[0] + 3 * e.axes[0], e.center[1] + 2 * e.axes[0], 1.0])
    T = gc.tangents_from_point(e.conic, x)
    for l in T:
        assert abs(l @ x) < 1e-9 * np.linalg.norm(x)
        # a tangent meets the conic in one (double) point
        pts = gc.intersect_line_conic(e.conic, l)
        assert np.allclose(pts[0] / pts[0][2], pts[1] / pts[1][2], atol=1e-3)


def test_double_contact():
    e = gc.Ellipse(center=(320, 240), axes=(120, 45), angle=0.3)
    inner = gc.Ellipse(center=(320, 240), axes=(45, 45), angle=0.0)  # touches at the minor-axis ends
    assert gc.double_contact(e.conic, inner.conic).holds
    other = gc.Ellipse(center=(330, 260), axes=(100, 60), angle=1.0)
    dc = gc.double_contact(e.conic, other.conic)
    assert not dc.holds and dc.rank1_ratio > 1e-3
    # double contact survives a homography
    H = np.array([[1.1, 0.2, 10], [-0.1, 0.9, 4], [1e-4, 2e-4, 1]])
    assert gc.double_contact(transfer_conic(H, e.conic), transfer_conic(H, inner.conic)).holds


# ---- degenerate inputs: the exact error each gives --------------------------------
LINE = np.array([0.0, 1.0, -1000.0])  # y = 1000, misses the ellipse below
ELL = gc.Ellipse(center=(320, 240), axes=(120, 45), angle=0.3)


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: gc.fit_ellipse_direct(np.random.default_rng(0).uniform(0, 10, (4, 2))), "at least 5 points"),
        (lambda: gc.fit_ellipse_direct(np.column_stack([np.arange(10.0), 2 * np.arange(10.0)])), "collinear"),
        (lambda: gc.fit_ellipse_direct(np.ones((6, 2))), "coincident"),
        (lambda: gc.fit_ellipse_direct(np.array([[0, 0], [1, 0], [2, 0], [0, 1], [np.nan, 0]])), "non-finite"),
        (lambda: gc.fit_ellipse_direct(np.zeros((6, 3))), r"shape \(N, 2\)"),
        (lambda: gc.intersect_line_conic(ELL.conic, LINE), "does not meet the conic"),
        (lambda: gc.ellipse_from_conic(np.diag([1.0, -1.0, -1.0])), "not an ellipse"),
        (lambda: gc.ellipse_from_conic(np.diag([1.0, 1.0, 1.0])), "imaginary"),
        (lambda: gc.ellipse_from_conic(np.zeros((3, 3))), "zero"),
        (lambda: gc.pole(np.diag([1.0, 1.0, 0.0]), np.array([1.0, 0, 0])), "degenerate"),
        (lambda: gc.tangents_from_point(ELL.conic, np.array([320.0, 240.0, 1.0])), "inside the conic"),
        (lambda: gc.intersect_conics(ELL.conic, ELL.conic), "the same"),
        (lambda: gc.intersect_conics(np.diag([1.0, 0, 0]), np.diag([0, 1.0, 0])), "both conics are degenerate"),
        (lambda: gc.Ellipse(center=(0, 0), axes=(1.0, -1.0), angle=0.0), "positive"),
        (lambda: gc.conic_from_circle((0, 0), 0.0), "positive"),
        (lambda: gc.refine_ellipse(ELL.points(20), ELL, residual="algebraic"), "orthogonal"),
    ],
)
def test_degenerate_inputs(call, message):
    with pytest.raises(ValueError, match=message):
        call()


@pytest.mark.parametrize(
    "center, axes, angle, match",
    [
        ((0.0, 0.0), (1.0, -2.0), 0.0, "axes must be positive"),
        ((0.0, 0.0), (0.0, 2.0), 0.0, "axes must be positive"),
        ((float("nan"), 0.0), (1.0, 2.0), 0.0, "must be finite"),
        ((0.0, 0.0), (1.0, float("inf")), 0.0, "must be finite"),
        ((0.0, 0.0), (1.0, 2.0), float("nan"), "must be finite"),
        ((0.0, 0.0, 1.0), (1.0, 2.0), 0.0, r"needs center \(2,\)"),
    ],
)
def test_ellipse_rejects_bad_parameters(center, axes, angle, match):
    # plain floats and numpy values: the same errors
    with pytest.raises(ValueError, match=match):
        gc.Ellipse(center=center, axes=axes, angle=angle)
    with pytest.raises(ValueError, match=match):
        gc.Ellipse(center=np.array(center), axes=np.array(axes), angle=np.float64(angle))


def test_ellipse_normalises_the_same_from_floats_and_arrays():
    rng = np.random.default_rng(4)
    for _ in range(200):
        c, ax, ang = rng.uniform(-50, 50, 2), rng.uniform(0.1, 10, 2), float(rng.uniform(-7, 7))
        e1 = gc.Ellipse(center=tuple(float(v) for v in c), axes=tuple(float(v) for v in ax), angle=ang)
        e2 = gc.Ellipse(center=c, axes=ax, angle=np.float64(ang))
        assert e1 == e2
        assert e1.axes[0] >= e1.axes[1] and -np.pi / 2 < e1.angle <= np.pi / 2
        assert all(type(v) is float for v in (*e1.center, *e1.axes, e1.angle))
