"""Round trips and degenerate inputs for geometry.lines and geometry.homography."""

import numpy as np
import pytest

from geometry import conics as gc
from geometry import homography as gh
from geometry import lines as gl


def random_homography(rng):
    H = np.eye(3) + rng.normal(0, 0.2, (3, 3))
    H[2, :2] = rng.normal(0, 1e-3, 2)
    H[:2, 2] = rng.uniform(-100, 100, 2)
    return H


@pytest.mark.parametrize("seed", range(10))
def test_fit_line_exact_and_weighted(seed):
    rng = np.random.default_rng(seed)
    theta = rng.uniform(0, np.pi)
    d = np.array([np.cos(theta), np.sin(theta)])
    p0 = rng.uniform(0, 1000, 2)
    pts = p0 + rng.uniform(-300, 300, (50, 1)) * d
    fit = gl.fit_line(pts)
    assert np.max(np.abs(gl.point_line_distance(pts, fit.line))) < 1e-9
    assert np.isclose(np.hypot(*fit.line[:2]), 1.0)
    assert abs(abs(fit.direction @ d) - 1) < 1e-12
    # an outlier with zero weight changes nothing
    pts2 = np.vstack([pts, p0 + 50 * np.array([-d[1], d[0]])])
    w = np.r_[np.ones(50), 0.0]
    fit2 = gl.fit_line(pts2, w)
    assert np.allclose(np.abs(fit2.line), np.abs(fit.line), atol=1e-9)
    # uncertainty grows with noise
    noisy = pts + rng.normal(0, 1.0, pts.shape)
    nf = gl.fit_line(noisy)
    assert 0.5 < nf.rms < 1.5
    assert 0.05 < nf.normal_sigma < 0.3 and nf.angle_sigma < 0.01



def test_eigh_sym2_matches_lapack():
    # the closed-form 2x2 symmetric eigen-decomposition (fit_line and
    # ellipse_from_conic use it) against numpy's LAPACK on random, diagonal,
    # isotropic, near-singular and badly scaled matrices
    rng = np.random.default_rng(5)
    cases = [np.eye(2), 3.0 * np.eye(2), np.diag([2.0, -1.0]), np.diag([-1.0, 2.0]), np.zeros((2, 2)), np.array([[1e4, 1e4 - 1e-3], [1e4 - 1e-3, 1e4]])]
    for k in range(3000):
        A = rng.normal(size=(2, 2)) * 10.0 ** rng.uniform(-8, 8)
        cases.append(A @ A.T if k % 2 else A + A.T)
    # Both decompositions are backward stable: their eigenvalues are within a few
    # ulps of the largest one (``scale``) of the exact ones, and evaluating a residual
    # S v - w v adds as many again. Measured against LAPACK under OpenBLAS's Haswell,
    # Sandybridge, Nehalem and Prescott kernels: up to 1.76 eps (eigenvalues) and
    # 1.72 eps (residuals) of the scale, so the bound is 8 eps (it was 4e-16 = 1.8 eps:
    # at the floor, 2 % to spare). A wrong formula, or one that cancels on the badly
    # scaled cases, is off by orders more.
    tol = 8 * np.finfo(float).eps
    for S in cases:
        w, V = np.linalg.eigh(S)
        w0, w1, vx, vy = gl.eigh_sym2(S[0, 0], S[0, 1], S[1, 1])
        scale = max(np.abs(w).max(), 1e-300)
        assert w0 <= w1
        assert abs(w0 - w[0]) <= tol * scale and abs(w1 - w[1]) <= tol * scale, (S, w, w0, w1)
        v = np.array([vx, vy])
        assert abs(np.hypot(vx, vy) - 1.0) < 1e-15  # a unit vector: hypot and the division, an ulp or two of 1
        assert np.linalg.norm(S @ v - w0 * v) <= tol * scale  # an eigenvector of w0
        u = np.array([-vy, vx])
        assert np.linalg.norm(S @ u - w1 * u) <= tol * scale  # and its perpendicular one of w1
    assert gl.eigh_sym2(2.0, 0.0, 2.0) == (2.0, 2.0, 1.0, 0.0)  # isotropic: (1, 0)

def test_line_through_and_intersect():
    p, q, r = np.array([1.0, 2.0, 1.0]), np.array([4.0, -1.0, 1.0]), np.array([0.0, 5.0, 1.0])
    l1 = gl.line_through(p, q)
    l2 = gl.line_through(p, r)
    x = gl.intersect_lines(l1, l2)
    assert np.allclose(x[:2] / x[2], p[:2])
    # parallel lines meet at infinity
    x = gl.intersect_lines([1.0, 0.0, -1.0], [1.0, 0.0, -5.0])
    assert abs(x[2]) < 1e-12


@pytest.mark.parametrize("seed", range(8))
def test_vanishing_point(seed):
    rng = np.random.default_rng(seed)
    v = np.array([*rng.uniform(-3000, 3000, 2), 1.0])
    lines = [np.cross(v, [rng.uniform(0, 1280), rng.uniform(0, 720), 1.0]) for _ in range(6)]
    got = gl.vanishing_point(np.array(lines))
    assert np.allclose(got[:2] / got[2], v[:2], rtol=1e-8)
    # parallel lines: point at infinity
    par = np.array([[0.0, 1.0, -c] for c in (10.0, 200.0, 500.0)])
    vp = gl.vanishing_point(par)
    assert abs(vp[2]) < 1e-12 and abs(abs(vp[0]) - 1) < 1e-12


def test_homogeneous_conversion_round_trip():
    p = np.random.default_rng(0).uniform(-5, 5, (7, 2))
    assert np.allclose(gl.from_homogeneous(gl.to_homogeneous(p) * 3.0), p)


@pytest.mark.parametrize("seed", range(10))
def test_homography_from_points_and_lines(seed):
    rng = np.random.default_rng(seed)
    H = random_homography(rng)
    src = rng.uniform(0, 1000, (12, 2))
    dst = gh.transfer_points(H, src)
    Hn = H / np.linalg.norm(H) * np.sign(H[2, 2])
    assert np.allclose(gh.homography_from_points(src, dst), Hn, atol=1e-9)
    assert np.allclose(gh.homography_from_points(src[:4], dst[:4]), Hn, atol=1e-8)
    L = np.array([np.cross([*src[i], 1.0], [*src[i + 1], 1.0]) for i in range(6)])
    Ld = gh.transfer_lines(H, L)
    assert np.allclose(gh.homography_from_lines(L, Ld), Hn, atol=1e-8)
    # transferred lines pass through transferred points
    for i in range(6):
        assert abs(Ld[i] @ [*dst[i], 1.0]) < 1e-8 * np.linalg.norm(dst[i])
    # conic transfer: points of the image conic are images of the conic's points
    e = gc.Ellipse(center=(500, 500), axes=(100, 40), angle=0.2)
    E2 = gh.transfer_conic(H, e.conic)
    img = gh.transfer_points(H, e.points(30))
    T = gc.conic_conditioning(E2)
    X = np.column_stack([img, np.ones(30)]) @ T.T
    Cn = gc.normalize_conic(np.linalg.inv(T).T @ E2 @ np.linalg.inv(T))
    assert np.max(np.abs(np.einsum("ij,jk,ik->i", X, Cn, X))) < 1e-9


def test_batched_line_homographies_match_one_by_one():
    rng = np.random.default_rng(3)
    src, dst, want = [], [], []
    for _ in range(6):
        H = random_homography(rng)
        pts = rng.uniform(0, 1000, (6, 2))
        L = np.array([np.cross([*pts[i], 1.0], [*pts[i + 1], 1.0]) for i in range(5)])
        src.append(L)
        dst.append(gh.transfer_lines(H, L))
        want.append(gh.homography_from_lines(L, dst[-1]))
    # a degenerate member: five lines through one point
    src.append(np.array([[1.0, 0, 0], [0, 1.0, 0], [1.0, 1.0, 0], [1.0, -1.0, 0], [2.0, 1.0, 0]]))
    dst.append(src[-1].copy())
    H, ok = gh.homographies_from_lines(np.array(src), np.array(dst))
    assert ok.tolist() == [True] * 6 + [False]
    assert np.allclose(H[:6], np.array(want), atol=1e-10)
    # one destination set shared by all
    H2, ok2 = gh.homographies_from_lines(np.array(src[:1] * 3), dst[0])
    assert ok2.all() and np.allclose(H2, want[0], atol=1e-10)
    with pytest.raises(ValueError, match="at least 4"):
        gh.homographies_from_lines(np.zeros((2, 3, 3)), np.zeros((3, 3)))
    H0, ok0 = gh.homographies_from_lines(np.zeros((0, 4, 3)), dst[0][:4])
    assert H0.shape == (0, 3, 3) and ok0.shape == (0,)


def test_four_point_homographies_in_closed_form_match_the_dlt():
    rng = np.random.default_rng(4)
    src, dst, want = [], [], []
    for _ in range(8):
        H = random_homography(rng)
        pts = rng.uniform(-1, 1, (4, 2))
        src.append(np.column_stack([pts, np.ones(4)]))
        dst.append(np.column_stack([gh.transfer_points(H, pts), np.ones(4)]) * rng.uniform(0.5, 2.0, (4, 1)))
        want.append(gh.homography_from_points(pts, gh.transfer_points(H, pts)))
    # a point at infinity (two lines parallel in the image meet there) is a point like any
    H = random_homography(rng)
    H[2] = [0.5, -0.25, -0.25]  # (1, 1) maps to infinity
    src.append(np.column_stack([[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]], np.ones(4)]))
    dst.append(np.einsum("ij,nj->ni", H, src[-1]))
    assert dst[-1][3, 2] == 0.0
    want.append(H / np.linalg.norm(H) * np.sign(H[2, 2]))
    # degenerate members: three collinear points, and two coincident ones
    src.append(np.array([[0.0, 0, 1], [1.0, 0, 1], [2.0, 0, 1], [0.0, 1, 1]]))
    dst.append(src[-1].copy())
    src.append(np.array([[0.0, 0, 1], [0.0, 0, 1], [1.0, 0, 1], [0.0, 1, 1]]))
    dst.append(np.array([[0.0, 0, 1], [1.0, 0, 1], [1.0, 1, 1], [0.0, 1, 1]]))
    Hg, ok = gh.homographies_from_four_points(np.array(src), np.array(dst))
    assert ok.tolist() == [True] * 9 + [False, False]
    assert np.allclose(Hg[:8], np.array(want[:8]), atol=1e-9)
    assert np.allclose(Hg[8], want[8], atol=1e-12)
    with pytest.raises(ValueError, match=r"\(K, 4, 3\)"):
        gh.homographies_from_four_points(np.zeros((2, 5, 3)), np.zeros((2, 5, 3)))
    H0, ok0 = gh.homographies_from_four_points(np.zeros((0, 4, 3)), np.zeros((0, 4, 3)))
    assert H0.shape == (0, 3, 3) and ok0.shape == (0,)


def test_homography_noise_is_bounded():
    rng = np.random.default_rng(1)
    H = random_homography(rng)
    src = rng.uniform(0, 1000, (40, 2))
    dst = gh.transfer_points(H, src) + rng.normal(0, 0.5, (40, 2))
    He = gh.homography_from_points(src, dst)
    err = np.linalg.norm(gh.transfer_points(He, src) - gh.transfer_points(H, src), axis=1)
    assert np.median(err) < 0.5


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: gh.homography_from_points(np.zeros((3, 2)), np.zeros((3, 2))), "at least 4"),
        (
            lambda: gh.homography_from_points(
                np.array([[0, 0], [1, 1], [2, 2], [5, 1.0]]), np.array([[0, 0], [1, 0], [0, 1], [1, 1.0]])
            ),
            "collinear",
        ),
        (lambda: gh.homography_from_points(np.ones((5, 2)), np.ones((5, 2))), "coincident"),
        (lambda: gh.homography_from_points(np.zeros((5, 2)), np.zeros((4, 2))), "same shape"),
        (lambda: gh.transfer_points(np.diag([1.0, 1.0, 0.0]), np.zeros((2, 2))), "singular"),
        (lambda: gh.transfer_conic(np.zeros((3, 3)), np.eye(3)), "singular"),
        (lambda: gh.transfer_points(np.array([[1.0, 0, 0], [0, 1, 0], [1, 0, 1]]), np.array([[-1.0, 0.0]])), "infinity"),
        (
            lambda: gh.homography_from_lines(
                np.array([[1.0, 0, 0], [0, 1.0, 0], [1.0, 1.0, 0], [1.0, -1.0, 0]]), np.eye(3)[[0, 1, 2, 2]]
            ),
            "concurrent",
        ),
        (lambda: gl.fit_line(np.zeros((1, 2))), "at least 2"),
        (lambda: gl.fit_line(np.ones((5, 2))), "coincide"),
        (lambda: gl.line_through([1.0, 2.0, 1.0], [2.0, 4.0, 2.0]), "coincide"),
        (lambda: gl.intersect_lines([1.0, 2.0, 3.0], [2.0, 4.0, 6.0]), "coincide"),
        (lambda: gl.vanishing_point(np.array([[1.0, 0, 0]])), "at least 2"),
        (lambda: gl.point_line_distance(np.zeros((1, 2)), [0.0, 0.0, 1.0]), "line at infinity"),
        (lambda: gl.from_homogeneous(np.array([[1.0, 2.0, 0.0]])), "infinity"),
    ],
)
def test_degenerate_inputs(call, message):
    with pytest.raises(ValueError, match=message):
        call()


# --- a calibrated camera from three parallel lines and one across them ---------
@pytest.mark.parametrize("axis", [0, 1])
def test_homographies_from_parallel_lines_recover_the_camera(axis):
    from geometry.camera import homographies_from_parallel_lines
    from geometry.lines import line_through

    from cameras import looking_at

    cam = looking_at((30.0, -60.0, 15.0), (40.0, 5.0, 0.0), 1500.0)

    def image_line(p, q):
        a, b = cam.project(np.array([[*p, 0.0], [*q, 0.0]]))
        return line_through((*a, 1.0), (*b, 1.0))

    if axis == 1:  # Y = const, and X = 36 across
        vals, value = [-20.16, 20.16, 33.94], 36.0
        lines = [image_line((20, y), (50, y)) for y in vals]
        across = image_line((value, -30), (value, 30))
    else:  # X = const, and Y = 20.16 across
        vals, value = [36.0, 46.98, 52.44], 20.16
        lines = [image_line((x, -25), (x, 25)) for x in vals]
        across = image_line((30, value), (52, value))
    Hs = homographies_from_parallel_lines(lines, vals, across, value, cam.principal_point, axis=axis)
    truth = cam.K @ np.column_stack([cam.R[:, 0], cam.R[:, 1], cam.t])
    truth /= np.linalg.norm(truth)
    assert 1 <= len(Hs) <= 4
    # one of them is the camera's, to rounding (unit-norm matrices, either sign)
    assert min(min(np.abs(h - truth).max(), np.abs(h + truth).max()) for h in Hs) < 1e-9


def test_homographies_from_parallel_lines_degenerate_inputs():
    from geometry.camera import homographies_from_parallel_lines

    pp = (639.5, 359.5)
    # parallel in the picture too (their vanishing point at infinity): no focal length
    flat = [np.array([0.0, 1.0, -y]) for y in (300.0, 400.0, 500.0)]
    assert len(homographies_from_parallel_lines(flat, [-20.0, 0.0, 20.0], np.array([1.0, 0.0, -600.0]), 0.0, pp, axis=1)) == 0
    # two of the values the same: no 1-D map along the transversal
    conv = [np.array([0.1, 1.0, -300.0]), np.array([0.0, 1.0, -400.0]), np.array([-0.1, 1.0, -500.0])]
    assert len(homographies_from_parallel_lines(conv, [0.0, 0.0, 20.0], np.array([1.0, 0.0, -600.0]), 0.0, pp, axis=1)) == 0


def test_homographies_from_parallel_lines_batch_is_one_call_per_transversal():
    # the batch over T transversals gives, row by row, what one call per
    # transversal gives; a degenerate transversal (through the lines' crossing
    # with the others, or parallel to them) is a row of ``ok`` False, not an error
    from geometry.camera import homographies_from_parallel_lines, homographies_from_parallel_lines_batch
    from geometry.lines import line_through

    from cameras import looking_at

    cam = looking_at((30.0, -60.0, 15.0), (40.0, 5.0, 0.0), 1500.0)

    def image_line(p, q):
        a, b = cam.project(np.array([[*p, 0.0], [*q, 0.0]]))
        return line_through((*a, 1.0), (*b, 1.0))

    vals = [36.0, 46.98, 52.44]
    lines = [image_line((x, -25), (x, 25)) for x in vals]
    values = [20.16, -20.16, 9.16, 0.0, 5.0]
    trans = [image_line((30, y), (52, y)) for y in values[:3]] + [lines[0], np.array([0.3, 1.0, -400.0])]
    H, ok = homographies_from_parallel_lines_batch(lines, vals, trans, values, cam.principal_point, axis=0)
    assert H.shape == (5, 4, 3, 3) and ok.shape == (5, 4)
    assert not ok[3].any()  # one of the three lines itself
    for k in range(5):
        one = homographies_from_parallel_lines(lines, vals, trans[k], values[k], cam.principal_point, axis=0)
        assert len(one) == ok[k].sum()
        # (the same arithmetic, but numpy's vectorised paths may round otherwise on
        # another processor: 1.3e-15 apart on an AMD EPYC, of unit-norm homographies)
        np.testing.assert_allclose(H[k][ok[k]], one, rtol=0, atol=1e-12)
