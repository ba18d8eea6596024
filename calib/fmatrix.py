"""The fundamental matrix: six points with four coplanar (thesis contribution 4),
the classical 7- and 8-point baselines, gold-standard refinement, robust
estimation (plane + parallax RANSAC and plain 7/8-point RANSAC), and metrics.

Conventions
-----------
* Pixels are ``(N, 2)`` float64 arrays; ``x1[i]`` in image 1 matches ``x2[i]``
  in image 2.
* ``F`` maps points of image 1 to epipolar lines of image 2:
  ``x2^T F x1 = 0`` with ``x = (x, y, 1)``; ``F x1`` is a line of image 2 and
  ``F^T x2`` a line of image 1 (OpenCV's ``findFundamentalMat`` uses the same
  order). The epipoles are ``e1`` (``F e1 = 0``, image 1) and ``e2``
  (``F^T e2 = 0``, image 2).
* Every ``F`` returned here is canonical (:func:`normalize_fundamental`): rank
  2, unit Frobenius norm, and the sign that makes its largest-magnitude entry
  positive. Compare two ``F`` with a sign-invariant test (or with
  :func:`fmatrix_distance`, which measures pixels).
* A plane homography is named ``H2_from_1``: ``x2 ~ H2_from_1 x1`` for points
  of the plane.
* Residuals are the Sampson distance (first-order geometric error, pixels);
  the inlier threshold of :func:`estimate` is on that distance.

Six points, four coplanar
-------------------------
The four coplanar correspondences fix the plane's homography ``H`` exactly
(8 equations, 8 unknowns); each off-plane point ``k`` adds the line
``(H x1_k) x x2_k`` through the epipole ``e2``. Two such lines meet in ``e2``
and ``F = [e2]_x H`` (``method="epipolar"``, the classical solution). The
thesis' formulation (``method="projective"``) maps the four coplanar points
to the projective basis ``e1, e2, e3, (1, 1, 1)`` in both images and in space
(the plane becoming the plane at infinity), which forces both cameras into
the form ``[I | c]``; placing the first off-plane point at ``(0, 0, 0, 1)``
gives ``c1 ~ y5`` and ``c2 ~ beta y5'``; the second off-plane point gives
``beta`` from a 3x3 linear system. ``F`` then follows from the two projective
cameras through the bifocal tensor (:func:`fundamental_from_cameras`).

Both formulations solve the same *minimal* problem (24 image coordinates,
24 unknowns: 7 for ``F``, 3 for the plane, 8 + 6 for the points), whose
solution interpolates the six points exactly. They therefore return the same
``F`` up to rounding, with or without noise; the benchmark
(``bench/fmatrix_stability.py``) measures this.

>>> rng = np.random.default_rng(1)
>>> X = np.c_[rng.uniform(-1, 1, (6, 2)), np.r_[np.zeros(4), 0.8, -0.6]]   # 4 on z = 0
>>> P1 = np.c_[np.eye(3), [0.0, 0.0, 5.0]]
>>> P2 = np.c_[np.eye(3), [-1.0, 0.0, 5.0]]
>>> def proj(P, X): h = np.c_[X, np.ones(len(X))] @ P.T; return h[:, :2] / h[:, 2:]
>>> r = six_point(proj(P1, X), proj(P2, X), coplanar=[0, 1, 2, 3])
>>> bool(np.allclose(r.F, fundamental_from_cameras(P1, P2), atol=1e-9))
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.optimize

from geometry.homography import homography_from_points, normalize_homography
from geometry.lines import hartley_normalization, skew

__all__ = [
    "FundamentalResult",
    "six_point",
    "seven_point",
    "eight_point",
    "refine",
    "gold_standard",
    "estimate",
    "fundamental_from_cameras",
    "normalize_fundamental",
    "epipoles",
    "sampson_distance",
    "symmetric_epipolar_distance",
    "fmatrix_distance",
    "SIX_POINT_METHODS",
    "ROBUST_METHODS",
    "REFINE_COSTS",
]

SIX_POINT_METHODS = ("projective", "epipolar")
ROBUST_METHODS = ("plane_parallax", "ransac7", "ransac8")
REFINE_COSTS = ("sampson", "reprojection")

# Relative tolerances for exact degeneracy, on Hartley-normalised data (scale ~1).
_TOL_COLLINEAR = 1e-9
_TOL_PARALLAX = 1e-9
_TOL_LINES = 1e-9
_TOL_RANK = 1e-10


# ----------------------------------------------------------------------------------
# results
# ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class FundamentalResult:
    """An estimated fundamental matrix.

    Attributes
    ----------
    F : (3, 3) float64
        Canonical fundamental matrix, ``x2^T F x1 = 0`` (rank 2, unit norm, sign
        fixed by :func:`normalize_fundamental`).
    inliers : (N,) bool
        Which of the input correspondences the estimate accepts (all of them for
        the non-robust estimators).
    residuals : (N,) float64
        Sampson distance of every input correspondence to ``F``, pixels.
    method : str
        The estimator that produced ``F`` (e.g. ``"six_point/projective"``,
        ``"plane_parallax"``, ``"ransac7"``).
    H2_from_1 : (3, 3) float64 or None
        The plane homography used (six-point and plane + parallax estimates),
        ``x2 ~ H2_from_1 x1`` on the plane; unit norm, ``H[2, 2] >= 0``
        (``geometry.homography.normalize_homography``).
    P1, P2 : (3, 4) float64 or None
        Projective cameras consistent with ``F`` in pixel coordinates, when the
        estimator builds them (the projective six-point method).
    iterations : int
        RANSAC iterations run (0 for the direct solvers).
    """

    F: np.ndarray
    inliers: np.ndarray
    residuals: np.ndarray
    method: str
    H2_from_1: np.ndarray | None = None
    P1: np.ndarray | None = None
    P2: np.ndarray | None = None
    iterations: int = 0

    @property
    def n_inliers(self) -> int:
        """Number of inliers."""
        return int(np.count_nonzero(self.inliers))

    @property
    def rms(self) -> float:
        """RMS Sampson distance of the inliers, pixels (NaN if there are none)."""
        r = self.residuals[self.inliers]
        return float(np.sqrt(np.mean(r * r))) if r.size else float("nan")

    @property
    def e1(self) -> np.ndarray:
        """(3,) epipole in image 1 (``F e1 = 0``), homogeneous, unit norm."""
        return epipoles(self.F)[0]

    @property
    def e2(self) -> np.ndarray:
        """(3,) epipole in image 2 (``F^T e2 = 0``), homogeneous, unit norm."""
        return epipoles(self.F)[1]


# ----------------------------------------------------------------------------------
# validation and small helpers
# ----------------------------------------------------------------------------------
def _as_pair(x1, x2, *, min_count: int, who: str) -> tuple[np.ndarray, np.ndarray]:
    a = np.asarray(x1, dtype=np.float64)
    b = np.asarray(x2, dtype=np.float64)
    for name, p in (("x1", a), ("x2", b)):
        if p.ndim != 2 or p.shape[1] != 2:
            raise ValueError(f"{name} must have shape (N, 2), got {p.shape}")
        if not np.all(np.isfinite(p)):
            raise ValueError(f"{name} has non-finite coordinates")
    if a.shape != b.shape:
        raise ValueError(f"x1 and x2 must have the same shape, got {a.shape} and {b.shape}")
    if len(a) < min_count:
        raise ValueError(f"{who} needs at least {min_count} correspondences, got {len(a)}")
    return a, b


def _as_F(F, name: str = "F") -> np.ndarray:
    F = np.asarray(F, dtype=np.float64)
    if F.shape != (3, 3):
        raise ValueError(f"{name} must be 3x3, got {F.shape}")
    if not np.all(np.isfinite(F)):
        raise ValueError(f"{name} has non-finite entries")
    if np.linalg.norm(F) == 0:
        raise ValueError(f"{name} is zero")
    return F


def _hom(p: np.ndarray) -> np.ndarray:
    return np.column_stack([p, np.ones(len(p))])


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _rank2(F: np.ndarray) -> np.ndarray:
    U, s, Vt = np.linalg.svd(F)
    return (U * np.array([s[0], s[1], 0.0])) @ Vt


def _canon(F: np.ndarray) -> np.ndarray:
    F = F / np.linalg.norm(F)
    a = np.abs(F).ravel()
    k = int(np.argmax(a >= (1.0 - 1e-9) * a.max()))  # first (row-major) of the largest, ties to rounding
    return -F if F.flat[k] < 0 else F


def _denormalize(Fn: np.ndarray, T1: np.ndarray, T2: np.ndarray) -> np.ndarray:
    """F in pixels from F in Hartley-normalised coordinates (``x_n = T x``)."""
    return T2.T @ Fn @ T1


def normalize_fundamental(F) -> np.ndarray:
    """Canonical form of a fundamental matrix.

    Parameters
    ----------
    F : (3, 3) array_like, non-zero, finite

    Returns
    -------
    (3, 3) float64: the closest rank-2 matrix (Frobenius), scaled to unit
    Frobenius norm, with the sign that makes its largest-magnitude entry
    positive (the first in row-major order among entries equal in magnitude
    to 1e-9 relative).

    Raises
    ------
    ValueError
        Wrong shape, non-finite or zero ``F``, or ``F`` of rank < 2.

    >>> F = normalize_fundamental(-2.0 * np.array([[0, 0, 0], [0, 0, -1], [0, 1, 0.0]]))
    >>> np.round(F, 4).tolist()
    [[0.0, 0.0, 0.0], [0.0, 0.0, 0.7071], [0.0, -0.7071, 0.0]]
    """
    F = _as_F(F)
    s = np.linalg.svd(F, compute_uv=False)
    if s[1] < _TOL_RANK * s[0]:
        raise ValueError("F has rank < 2: not a fundamental matrix")
    return _canon(_rank2(F))


def epipoles(F) -> tuple[np.ndarray, np.ndarray]:
    """Epipoles of a fundamental matrix.

    Parameters
    ----------
    F : (3, 3) array_like, ``x2^T F x1 = 0``

    Returns
    -------
    e1, e2 : (3,) float64 homogeneous, unit norm, ``w >= 0`` (a point at
        infinity has ``w = 0`` and its largest entry positive). ``F e1 = 0``
        (image 1) and ``F^T e2 = 0`` (image 2), in the least-squares sense
        when ``F`` is not exactly rank 2.
    """
    F = _as_F(F)
    U, _, Vt = np.linalg.svd(F)

    def fix(e):
        e = _unit(e)
        ref = e[2] if abs(e[2]) > 1e-12 else e[np.argmax(np.abs(e))]
        return -e if ref < 0 else e

    return fix(Vt[2]), fix(U[:, 2])


def fundamental_from_cameras(P1, P2) -> np.ndarray:
    """Fundamental matrix of two projective cameras through the bifocal tensor.

    ``F[j, i] = (-1)^(i + j) det([P1 without row i; P2 without row j])``
    (Hartley & Zisserman, eq. 17.3), so that ``x2^T F x1 = 0`` for
    ``x1 ~ P1 X``, ``x2 ~ P2 X``.

    Parameters
    ----------
    P1, P2 : (3, 4) array_like, rank 3, distinct centres

    Returns
    -------
    (3, 3) float64, canonical (:func:`normalize_fundamental`).

    Raises
    ------
    ValueError
        Wrong shape, non-finite entries, a camera of rank < 3, or the two
        cameras share their centre (``F`` vanishes).
    """
    A = np.asarray(P1, dtype=np.float64)
    B = np.asarray(P2, dtype=np.float64)
    for name, P in (("P1", A), ("P2", B)):
        if P.shape != (3, 4):
            raise ValueError(f"{name} must be 3x4, got {P.shape}")
        if not np.all(np.isfinite(P)):
            raise ValueError(f"{name} has non-finite entries")
        s = np.linalg.svd(P, compute_uv=False)
        if s[2] < 1e-12 * s[0]:
            raise ValueError(f"{name} has rank < 3: not a camera")
    F = _bifocal(A / np.linalg.norm(A), B / np.linalg.norm(B))
    if np.linalg.norm(F) < 1e-12:
        raise ValueError("the two cameras share their centre: F is undefined")
    return normalize_fundamental(F)


def _bifocal(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    F = np.empty((3, 3))
    rows = ([1, 2], [0, 2], [0, 1])
    for i in range(3):
        for j in range(3):
            F[j, i] = (-1) ** (i + j) * np.linalg.det(np.vstack([A[rows[i]], B[rows[j]]]))
    return F


# ----------------------------------------------------------------------------------
# metrics
# ----------------------------------------------------------------------------------
def _sampson(F: np.ndarray, X1: np.ndarray, X2: np.ndarray) -> np.ndarray:
    """Sampson distance (N,) for homogeneous (N, 3) points with w = 1 (no checks)."""
    Fx1 = X1 @ F.T
    Ftx2 = X2 @ F
    num = np.einsum("ij,ij->i", X2, Fx1)
    den = Fx1[:, 0] ** 2 + Fx1[:, 1] ** 2 + Ftx2[:, 0] ** 2 + Ftx2[:, 1] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.abs(num) / np.sqrt(den)
    return np.where(den > 0, d, np.where(num == 0, 0.0, np.inf))


def sampson_distance(F, x1, x2) -> np.ndarray:
    """Sampson distance of correspondences to ``F`` (first-order geometric error).

    ``|x2^T F x1| / sqrt((F x1)_1^2 + (F x1)_2^2 + (F^T x2)_1^2 + (F^T x2)_2^2)``:
    to first order, the distance in pixels (in the joint 4-D space of both
    images) from the correspondence to the nearest one that satisfies ``F``
    exactly. With isotropic noise ``sigma`` per coordinate it is distributed
    about as ``|N(0, sigma^2)|``.

    Parameters
    ----------
    F : (3, 3) array_like
    x1, x2 : (N, 2) array_like, pixels

    Returns
    -------
    (N,) float64, pixels.
    """
    F = _as_F(F)
    a, b = _as_pair(x1, x2, min_count=0, who="sampson_distance")
    return _sampson(F, _hom(a), _hom(b))


def _sym_epi(F: np.ndarray, X1: np.ndarray, X2: np.ndarray) -> np.ndarray:
    Fx1 = X1 @ F.T
    Ftx2 = X2 @ F
    num = np.abs(np.einsum("ij,ij->i", X2, Fx1))
    with np.errstate(divide="ignore", invalid="ignore"):
        d2 = num / np.hypot(Fx1[:, 0], Fx1[:, 1])
        d1 = num / np.hypot(Ftx2[:, 0], Ftx2[:, 1])
    return np.sqrt(0.5 * (d1 * d1 + d2 * d2))


def symmetric_epipolar_distance(F, x1, x2) -> np.ndarray:
    """Symmetric epipolar distance, per correspondence.

    ``sqrt((d(x2, F x1)^2 + d(x1, F^T x2)^2) / 2)``: the RMS of the distance of
    ``x2`` from the epipolar line of ``x1`` in image 2 and of ``x1`` from the
    epipolar line of ``x2`` in image 1 (so that it reads as a per-image pixel
    distance; Hartley & Zisserman's "symmetric epipolar distance" is twice
    its square).

    Parameters
    ----------
    F : (3, 3) array_like, ``x2^T F x1 = 0``
    x1, x2 : (N, 2) array_like, pixels

    Returns
    -------
    (N,) float64, pixels (``inf`` where a point sits on an epipole).
    """
    F = _as_F(F)
    a, b = _as_pair(x1, x2, min_count=0, who="symmetric_epipolar_distance")
    return _sym_epi(F, _hom(a), _hom(b))


def _project_to_F(F: np.ndarray, x1: np.ndarray, x2: np.ndarray, iterations: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """Move correspondences (N, 2) onto the epipolar variety of ``F`` by iterated
    Sampson corrections (Gauss-Newton on the triangulation: each step linearises
    ``x2^T F x1`` at the current pair and takes the smallest move from the
    *observed* pair onto the linearised constraint); converges to the nearest
    consistent pair for near-consistent input."""
    u1, v1, u2, v2 = x1[:, 0], x1[:, 1], x2[:, 0], x2[:, 1]
    a1, b1, a2, b2 = u1, v1, u2, v2
    for _ in range(iterations):
        l2 = F[:, 0, None] * a1 + F[:, 1, None] * b1 + F[:, 2, None]  # F x1: line in image 2
        l1 = F[0, :, None] * a2 + F[1, :, None] * b2 + F[2, :, None]  # F^T x2: line in image 1
        e = a2 * l2[0] + b2 * l2[1] + l2[2]
        j0, j1, j2, j3 = l1[0], l1[1], l2[0], l2[1]  # d e / d (x1, y1, x2, y2)
        r = e - (j0 * (a1 - u1) + j1 * (b1 - v1) + j2 * (a2 - u2) + j3 * (b2 - v2))
        lam = r / np.maximum(j0 * j0 + j1 * j1 + j2 * j2 + j3 * j3, 1e-300)
        a1, b1, a2, b2 = u1 - lam * j0, v1 - lam * j1, u2 - lam * j2, v2 - lam * j3
    return np.column_stack([a1, b1]), np.column_stack([a2, b2])


def fmatrix_distance(F_a, F_b, x1, x2) -> float:
    """Distance between two fundamental matrices measured on held-out points.

    Each held-out correspondence is first moved onto the epipolar geometry of
    one matrix (iterated Sampson correction; a no-op for correspondences that
    already satisfy it exactly), then its symmetric epipolar distance under the
    other matrix is taken; the result is the mean of the two directions' RMS.
    It is symmetric, zero iff the two matrices agree on the region the points
    cover, and reads in pixels.

    Parameters
    ----------
    F_a, F_b : (3, 3) array_like
    x1, x2 : (N, 2) array_like, N >= 1, pixels; held-out correspondences
        spread over the images (noise-free ones when available).

    Returns
    -------
    float, pixels.
    """
    A = _as_F(F_a, "F_a")
    B = _as_F(F_b, "F_b")
    a, b = _as_pair(x1, x2, min_count=1, who="fmatrix_distance")
    out = []
    for P, Q in ((A, B), (B, A)):
        c1, c2 = _project_to_F(Q / np.linalg.norm(Q), a, b)
        d = _sym_epi(P, _hom(c1), _hom(c2))
        out.append(np.sqrt(np.mean(d * d)))
    return float(0.5 * (out[0] + out[1]))


# ----------------------------------------------------------------------------------
# six points, four coplanar
# ----------------------------------------------------------------------------------
def _check_indices(coplanar, n: int) -> list[int]:
    try:
        idx = [int(i) for i in coplanar]
        ok = all(float(i) == float(j) and not isinstance(j, (bool, np.bool_)) for i, j in zip(idx, coplanar))
    except (TypeError, ValueError):
        raise ValueError(f"coplanar must be a sequence of 4 integer indices, got {coplanar!r}") from None
    if not ok:
        raise ValueError(f"coplanar must be a sequence of 4 integer indices, got {coplanar!r}")
    if len(idx) != 4:
        raise ValueError(f"coplanar must hold exactly 4 indices, got {len(idx)}")
    if len(set(idx)) != 4:
        raise ValueError(f"coplanar must hold 4 distinct indices, got {idx}")
    if any(i < 0 or i >= n for i in idx):
        raise ValueError(f"coplanar indices must lie in [0, {n}), got {idx}")
    return idx


def _basis_map(Y: np.ndarray) -> np.ndarray | None:
    """B (3, 3) with ``B y_k ~ e1, e2, e3, (1, 1, 1)`` for the rows of Y (4, 3),
    or None if three of the points are collinear."""
    M = Y[:3].T
    try:
        lam = np.linalg.solve(M, Y[3])
        B = np.linalg.inv(M * lam)
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(B)):
        return None
    return B


def _collinear_triple(Y: np.ndarray) -> tuple[int, int, int] | None:
    """First triple (indices into Y (4, 3)) that is collinear, or None."""
    for tri in ((0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)):
        P = Y[list(tri)]
        d = abs(np.linalg.det(P)) / np.prod(np.linalg.norm(P, axis=1))
        if d < _TOL_COLLINEAR:
            return tri
    return None


def six_point(x1, x2, *, coplanar, method: str = "projective") -> FundamentalResult:
    """Fundamental matrix from six correspondences, four of them coplanar.

    Parameters
    ----------
    x1, x2 : (6, 2) array_like, pixels
    coplanar : sequence of 4 ints
        Indices of the four correspondences that lie on one scene plane (in
        general position: no three collinear). The other two must be off it.
    method : {"projective", "epipolar"}
        ``"projective"`` (default, the thesis): projective cameras from the
        canonical frame of the four coplanar points and the two off-plane
        points, then ``F`` through the bifocal tensor. ``"epipolar"`` (the
        classical solution): ``H`` from the four points, the epipole as the
        intersection of ``(H x1_k) x x2_k`` for the two off-plane points,
        ``F = [e2]_x H``. Both solve the same minimal problem (see the module
        notes) and agree up to rounding.

    Returns
    -------
    FundamentalResult
        ``F`` canonical; ``H2_from_1`` the plane homography; for
        ``"projective"`` also the cameras ``P1``, ``P2`` (pixels) of a
        projective reconstruction in which the plane is the plane at infinity.
        ``residuals`` are ~0: the six points are fitted exactly.

    Raises
    ------
    ValueError
        Wrong shapes or non-finite input; ``coplanar`` not 4 distinct indices in
        range; three of the coplanar points collinear (or coincident) in an
        image; an off-plane point with zero parallax (it lies on the plane, or
        the cameras share their centre); the two off-plane points on one
        epipolar plane (their parallax lines coincide, the epipole is
        undefined).
    """
    if method not in SIX_POINT_METHODS:
        raise ValueError(f"method must be one of {SIX_POINT_METHODS}, got {method!r}")
    a, b = _as_pair(x1, x2, min_count=6, who="six_point")
    if len(a) != 6:
        raise ValueError(f"six_point needs exactly 6 correspondences, got {len(a)}")
    cop = _check_indices(coplanar, 6)
    off = [i for i in range(6) if i not in cop]

    T1, T2 = hartley_normalization(a), hartley_normalization(b)
    Y1, Y2 = _hom(a) @ T1.T, _hom(b) @ T2.T
    for img, Y in ((1, Y1), (2, Y2)):
        tri = _collinear_triple(Y[cop])
        if tri is not None:
            names = tuple(cop[k] for k in tri)
            raise ValueError(
                f"coplanar points {names[0]}, {names[1]}, {names[2]} are collinear (or coincident) in image {img}: "
                "the four coplanar points must be in general position"
            )

    # plane homography in normalised coordinates (exact through the 4 points)
    Hn = T2 @ homography_from_points(a[cop], b[cop]) @ np.linalg.inv(T1)
    Hn /= np.linalg.norm(Hn)
    lines = []
    for k in off:
        hx = Hn @ Y1[k]
        par = Y2[k, :2] - hx[:2] / hx[2] if abs(hx[2]) > 1e-12 else np.full(2, np.inf)
        if np.linalg.norm(par) < _TOL_PARALLAX:
            raise ValueError(
                f"off-plane point {k} has zero parallax: it lies on the plane of the coplanar points "
                "(or the cameras share their centre), so it does not constrain the epipole"
            )
        lines.append(_unit(np.cross(hx, Y2[k])))
    e2 = np.cross(lines[0], lines[1])
    if np.linalg.norm(e2) < _TOL_LINES:
        raise ValueError(
            f"off-plane points {off[0]} and {off[1]} lie on one epipolar plane (their parallax lines "
            "coincide): the epipole is undefined"
        )

    P1 = P2 = None
    if method == "epipolar":
        Fn = skew(_unit(e2)) @ Hn
        H = np.linalg.solve(T2, Hn @ T1)
    else:
        Fn, P1n, P2n, Hc = _six_point_projective(Y1, Y2, cop, off)
        P1 = np.linalg.solve(T1, P1n)
        P2 = np.linalg.solve(T2, P2n)
        H = np.linalg.solve(T2, Hc @ T1)
    F = normalize_fundamental(_denormalize(Fn, T1, T2))
    res = _sampson(F, _hom(a), _hom(b))
    return FundamentalResult(
        F=F,
        inliers=np.ones(6, dtype=bool),
        residuals=res,
        method=f"six_point/{method}",
        H2_from_1=normalize_homography(H),
        P1=P1,
        P2=P2,
    )


def _six_point_projective(Y1, Y2, cop, off):
    """The thesis' formulation on normalised homogeneous points (6, 3).

    Returns ``(F_n, P1_n, P2_n, H_n)`` in the normalised image frames.
    """
    B1 = _basis_map(Y1[cop])
    B2 = _basis_map(Y2[cop])
    if B1 is None or B2 is None:  # excluded by the collinearity check; kept as a guard
        raise ValueError("the four coplanar points are not in general position")
    # canonical image frames: the coplanar points are e1, e2, e3, (1, 1, 1) in both images
    y5, y6 = _unit(B1 @ Y1[off[0]]), _unit(B1 @ Y1[off[1]])
    z5, z6 = _unit(B2 @ Y2[off[0]]), _unit(B2 @ Y2[off[1]])
    # space frame: coplanar points -> e1, e2, e3, (1,1,1,0); X5 -> (0,0,0,1). Then
    # P1 = [I | y5], P2 = [I | beta z5] and X6 = (Z, 1) with s y6 = Z + y5, t z6 = Z + beta z5.
    A = np.column_stack([y6, -z6, z5])
    sv = np.linalg.svd(A, compute_uv=False)
    if sv[2] < _TOL_LINES * sv[0]:
        raise ValueError(
            f"off-plane points {off[0]} and {off[1]} lie on one epipolar plane (their parallax lines "
            "coincide): the epipole is undefined"
        )
    _, _, beta = np.linalg.solve(A, y5)
    P1c = np.column_stack([np.eye(3), y5])
    P2c = np.column_stack([np.eye(3), beta * z5])
    Fc = _bifocal(P1c, P2c)
    Fn = B2.T @ Fc @ B1
    P1n = np.linalg.solve(B1, P1c)
    P2n = np.linalg.solve(B2, P2c)
    Hn = np.linalg.solve(B2, B1)
    return Fn, P1n, P2n, Hn


# ----------------------------------------------------------------------------------
# 7 and 8 points
# ----------------------------------------------------------------------------------
def _design(X1: np.ndarray, X2: np.ndarray) -> np.ndarray:
    """Rows ``kron(x2, x1)`` so that ``A f = x2^T F x1`` with ``f = F.ravel()``."""
    return np.einsum("ni,nj->nij", X2, X1).reshape(len(X1), 9)


def _adj3(A: np.ndarray) -> np.ndarray:
    return np.array(
        [
            [A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1], A[0, 2] * A[2, 1] - A[0, 1] * A[2, 2], A[0, 1] * A[1, 2] - A[0, 2] * A[1, 1]],
            [A[1, 2] * A[2, 0] - A[1, 0] * A[2, 2], A[0, 0] * A[2, 2] - A[0, 2] * A[2, 0], A[0, 2] * A[1, 0] - A[0, 0] * A[1, 2]],
            [A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0], A[0, 1] * A[2, 0] - A[0, 0] * A[2, 1], A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]],
        ]
    )


def _seven_point_core(X1n: np.ndarray, X2n: np.ndarray) -> list[np.ndarray]:
    """F candidates (normalised frames) from 7 normalised correspondences; [] if degenerate."""
    A = _design(X1n, X2n)
    _, s, Vt = np.linalg.svd(A, full_matrices=True)
    if s[6] < _TOL_RANK * s[0]:
        return []
    F1, F2 = Vt[7].reshape(3, 3), Vt[8].reshape(3, 3)
    # det(F2 + t F1) = c0 + c1 t + c2 t^2 + c3 t^3
    c0 = np.linalg.det(F2)
    c1 = np.trace(_adj3(F2) @ F1)
    c2 = np.trace(F2 @ _adj3(F1))
    c3 = np.linalg.det(F1)
    coef = np.array([c3, c2, c1, c0])
    scale = np.abs(coef).max()
    if scale == 0:
        return []
    out = []
    if abs(c3) < 1e-12 * scale:
        out.append(F1)
        coef = coef[1:]
    for r in np.roots(coef):
        if abs(r.imag) <= 1e-8 * (1.0 + abs(r.real)):
            t = r.real
            # one Newton step polishes the root
            p = np.polyval(coef, t)
            dp = np.polyval(np.polyder(coef), t)
            if dp != 0 and np.isfinite(p / dp):
                t -= p / dp
            out.append(F2 + t * F1)
    return [_rank2(F / np.linalg.norm(F)) for F in out]


def _eight_point_core(X1n: np.ndarray, X2n: np.ndarray, *, check: bool = False) -> np.ndarray | None:
    A = _design(X1n, X2n)
    _, s, Vt = np.linalg.svd(A, full_matrices=len(A) < 9)
    if check and s[7] < _TOL_RANK * s[0]:
        return None
    return _rank2(Vt[-1].reshape(3, 3))


def seven_point(x1, x2) -> list[FundamentalResult]:
    """The 7-point algorithm (Hartley-normalised): up to three exact solutions.

    The 7 constraints leave a pencil ``F2 + t F1`` of matrices; ``det = 0`` is a
    cubic in ``t`` with one or three real roots.

    Parameters
    ----------
    x1, x2 : (7, 2) array_like, pixels

    Returns
    -------
    list of FundamentalResult (1 to 3 entries), each with a canonical rank-2
    ``F`` through all 7 points, sorted by their residual RMS.

    Raises
    ------
    ValueError
        Wrong shapes, or a degenerate configuration: the constraint matrix has
        rank < 7 (e.g. all points on one plane seen from two views, repeated
        points).
    """
    a, b = _as_pair(x1, x2, min_count=7, who="seven_point")
    if len(a) != 7:
        raise ValueError(f"seven_point needs exactly 7 correspondences, got {len(a)}")
    T1, T2 = hartley_normalization(a), hartley_normalization(b)
    X1, X2 = _hom(a), _hom(b)
    cands = _seven_point_core(X1 @ T1.T, X2 @ T2.T)
    if not cands:
        raise ValueError(
            "degenerate configuration for the 7-point algorithm: the constraint matrix has rank < 7 "
            "(e.g. all points on one plane, or repeated points)"
        )
    out = []
    for Fn in cands:
        try:
            F = normalize_fundamental(_denormalize(Fn, T1, T2))
        except ValueError:
            continue
        r = _sampson(F, X1, X2)
        out.append(FundamentalResult(F=F, inliers=np.ones(7, dtype=bool), residuals=r, method="seven_point"))
    if not out:
        raise ValueError("degenerate configuration for the 7-point algorithm: no rank-2 solution")
    out.sort(key=lambda r: float(np.sqrt(np.mean(r.residuals**2))))
    return out


def eight_point(x1, x2) -> FundamentalResult:
    """The normalised 8-point algorithm (Hartley 1997), rank 2 enforced.

    Parameters
    ----------
    x1, x2 : (N, 2) array_like, N >= 8, pixels

    Returns
    -------
    FundamentalResult with the linear least-squares ``F`` (rank 2 by SVD in
    the normalised frames) and the Sampson residuals of all points.

    Raises
    ------
    ValueError
        Wrong shapes, fewer than 8 points, or a degenerate configuration: the
        constraint matrix has rank < 8 (e.g. all points on one plane seen from
        two views, or repeated points).
    """
    a, b = _as_pair(x1, x2, min_count=8, who="eight_point")
    T1, T2 = hartley_normalization(a), hartley_normalization(b)
    X1, X2 = _hom(a), _hom(b)
    Fn = _eight_point_core(X1 @ T1.T, X2 @ T2.T, check=True)
    if Fn is None:
        raise ValueError(
            "degenerate configuration for the 8-point algorithm: the constraint matrix has rank < 8 "
            "(e.g. all points on one plane, or repeated points)"
        )
    F = normalize_fundamental(_denormalize(Fn, T1, T2))
    return FundamentalResult(F=F, inliers=np.ones(len(a), dtype=bool), residuals=_sampson(F, X1, X2), method="eight_point")


# ----------------------------------------------------------------------------------
# gold standard refinement
# ----------------------------------------------------------------------------------
def _orthonormal_start(Fn: np.ndarray):
    U, s, Vt = np.linalg.svd(Fn)
    V = Vt.T
    if np.linalg.det(U) < 0:
        U[:, 2] *= -1
    if np.linalg.det(V) < 0:
        V[:, 2] *= -1
    return U, V, s[1] / s[0]


def _rodrigues(w: np.ndarray) -> np.ndarray:
    """Rotation matrix (3, 3) of a rotation vector (3,)."""
    th = math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    if th < 1e-12:
        return np.eye(3) + skew(w)
    S = skew(w / th)
    return np.eye(3) + math.sin(th) * S + (1.0 - math.cos(th)) * (S @ S)


def _F_from_params(p: np.ndarray, U0: np.ndarray, V0: np.ndarray) -> np.ndarray:
    """Orthonormal representation (Bartoli & Sturm): F = U diag(1, s, 0) V^T, 7 params."""
    U = U0 @ _rodrigues(p[0:3])
    V = V0 @ _rodrigues(p[3:6])
    return (U * np.array([1.0, p[6], 0.0])) @ V.T


def _refine_sampson(Fn, X1, X2, T1, T2, max_nfev, loss="linear", f_scale=1.0):
    """LM (or, with a robust ``loss``, scipy's trust-region ``trf``) on the Sampson
    distances in pixels over the 7 parameters of F."""
    U0, V0, s0 = _orthonormal_start(Fn)

    def fun(p):
        F = _denormalize(_F_from_params(p, U0, V0), T1, T2)
        Fx1 = X1 @ F.T
        Ftx2 = X2 @ F
        num = np.einsum("ij,ij->i", X2, Fx1)
        den = Fx1[:, 0] ** 2 + Fx1[:, 1] ** 2 + Ftx2[:, 0] ** 2 + Ftx2[:, 1] ** 2
        return num / np.sqrt(np.maximum(den, 1e-300))

    p0 = np.r_[np.zeros(6), s0]
    if loss == "linear":
        sol = scipy.optimize.least_squares(fun, p0, method="lm", max_nfev=max_nfev, xtol=1e-12, ftol=1e-12)
    else:
        sol = scipy.optimize.least_squares(
            fun, p0, method="trf", loss=loss, f_scale=f_scale, max_nfev=max_nfev, xtol=1e-12, ftol=1e-12
        )
    return _F_from_params(sol.x, U0, V0)


def _refine_reprojection(Fn, a, b, T1, T2, max_nfev):
    """Gold standard (HZ alg. 11.3) by variable projection: for each F (7 params) the
    3-D points are eliminated by moving every correspondence to the nearest pair
    consistent with F (iterated Sampson corrections, i.e. Gauss-Newton on the
    triangulation), and LM minimises the resulting reprojection errors (4N residuals)."""
    U0, V0, s0 = _orthonormal_start(Fn)

    def fun(p):
        F = _denormalize(_F_from_params(p, U0, V0), T1, T2)
        c1, c2 = _project_to_F(F / np.linalg.norm(F), a, b, iterations=4)
        return np.column_stack([c1 - a, c2 - b]).ravel()

    p0 = np.r_[np.zeros(6), s0]
    sol = scipy.optimize.least_squares(fun, p0, method="lm", max_nfev=max_nfev, xtol=1e-12, ftol=1e-12)
    return _F_from_params(sol.x, U0, V0)


def _reprojection_cost(F, a, b):
    c1, c2 = _project_to_F(F / np.linalg.norm(F), a, b, iterations=4)
    return float(np.sum((c1 - a) ** 2) + np.sum((c2 - b) ** 2))


def refine(F, x1, x2, *, cost: str = "sampson", max_iterations: int = 200) -> FundamentalResult:
    """Gold-standard refinement of ``F`` on (inlier) correspondences.

    ``F`` is parametrised minimally (7 parameters, the orthonormal
    representation ``U diag(1, s, 0) V^T`` in Hartley-normalised frames), so it
    stays rank 2.

    Parameters
    ----------
    F : (3, 3) array_like, initial estimate (e.g. from :func:`eight_point`)
    x1, x2 : (N, 2) array_like, N >= 7, pixels; all treated as inliers
    cost : {"sampson", "reprojection"}
        ``"sampson"``: Levenberg-Marquardt on the Sampson distances.
        ``"reprojection"``: the gold standard of Hartley & Zisserman (alg.
        11.3), the reprojection error in both images minimised over ``F`` and
        the corrected points; the points are eliminated (variable projection:
        for a given ``F`` each correspondence moves to the nearest consistent
        pair by iterated Sampson corrections) and LM runs over the 7
        parameters of ``F`` on the 4N residuals.
    max_iterations : int
        Cap on cost evaluations divided by the number of unknowns.

    Returns
    -------
    FundamentalResult (``method = "refine/<cost>"``, Sampson residuals).

    Raises
    ------
    ValueError
        Bad shapes, fewer than 7 points, an unknown cost, or an ``F`` of rank < 2.
    """
    if cost not in REFINE_COSTS:
        raise ValueError(f"cost must be one of {REFINE_COSTS}, got {cost!r}")
    if not (isinstance(max_iterations, (int, np.integer)) and max_iterations >= 1):
        raise ValueError(f"max_iterations must be a positive integer, got {max_iterations!r}")
    F0 = normalize_fundamental(F)
    a, b = _as_pair(x1, x2, min_count=7, who="refine")
    T1, T2 = hartley_normalization(a), hartley_normalization(b)
    F = _refine_core(F0, a, b, T1, T2, cost, max_iterations)
    return FundamentalResult(
        F=F, inliers=np.ones(len(a), dtype=bool), residuals=_sampson(F, _hom(a), _hom(b)), method=f"refine/{cost}"
    )


def _refine_core(F0, a, b, T1, T2, cost, max_iterations):
    X1, X2 = _hom(a), _hom(b)
    Fn0 = np.linalg.solve(T2.T, F0) @ np.linalg.inv(T1)
    Fn0 /= np.linalg.norm(Fn0)
    if cost == "sampson":
        Fn = _refine_sampson(Fn0, X1, X2, T1, T2, max_nfev=max_iterations * 8)
        F = normalize_fundamental(_denormalize(Fn, T1, T2))
        r0, r1 = _sampson(F0, X1, X2), _sampson(F, X1, X2)
        better = np.sum(r1 * r1) <= np.sum(r0 * r0) * (1 + 1e-12)
    else:
        Fn = _refine_reprojection(Fn0, a, b, T1, T2, max_nfev=max_iterations * 8)
        F = normalize_fundamental(_denormalize(Fn, T1, T2))
        better = _reprojection_cost(F, a, b) <= _reprojection_cost(F0, a, b) * (1 + 1e-12)
    # never return something worse than the start (a guard against a bad LM step)
    return F if better else F0


def gold_standard(x1, x2, *, cost: str = "reprojection") -> FundamentalResult:
    """Normalised 8-point initialisation followed by :func:`refine` (``cost``).

    Parameters
    ----------
    x1, x2 : (N, 2) array_like, N >= 8, pixels

    Returns
    -------
    FundamentalResult (``method = "gold_standard/<cost>"``).

    Raises
    ------
    ValueError
        As :func:`eight_point` and :func:`refine`.
    """
    init = eight_point(x1, x2)
    r = refine(init.F, x1, x2, cost=cost)
    return FundamentalResult(F=r.F, inliers=r.inliers, residuals=r.residuals, method=f"gold_standard/{cost}")


# ----------------------------------------------------------------------------------
# robust estimation
# ----------------------------------------------------------------------------------
def _n_iterations(w: float, s: int, confidence: float, cap: int) -> int:
    if w <= 0:
        return cap
    p = w**s
    if p >= 1:
        return 1
    return int(min(cap, math.ceil(math.log(1 - confidence) / math.log1p(-p))))


_BATCH = 64  # hypotheses are generated and scored in batches (vectorised numpy)


class _Data:
    """Correspondences in pixels and in Hartley-normalised frames."""

    def __init__(self, a, b):
        self.a, self.b = a, b
        self.T1, self.T2 = hartley_normalization(a), hartley_normalization(b)
        self.X1, self.X2 = _hom(a), _hom(b)
        self.X1n, self.X2n = self.X1 @ self.T1.T, self.X2 @ self.T2.T
        self.n = len(a)

    def F_pix(self, Fn):
        return _denormalize(Fn, self.T1, self.T2)

    def d(self, Fn):
        """Sampson distances (N,) in pixels of F given in normalised frames."""
        return _sampson(self.F_pix(Fn), self.X1, self.X2)

    def d_batch(self, Fn):
        """(M, N) Sampson distances in pixels for (M, 3, 3) F in normalised frames."""
        F = self.T2.T @ Fn @ self.T1
        Fx1 = self.X1 @ F.transpose(0, 2, 1)
        Ftx2 = self.X2 @ F
        num = np.einsum("nj,mnj->mn", self.X2, Fx1)
        den = Fx1[..., 0] ** 2 + Fx1[..., 1] ** 2 + Ftx2[..., 0] ** 2 + Ftx2[..., 1] ** 2
        with np.errstate(divide="ignore", invalid="ignore"):
            d = np.abs(num) / np.sqrt(den)
        return np.where(np.isfinite(d), d, np.inf)


def _cost(d: np.ndarray, t: float) -> np.ndarray:
    """MSAC cost (lower is better) from Sampson distances (..., N): sum of min(d^2, t^2)."""
    return np.minimum(d * d, t * t).sum(axis=-1)


def _draw(rng, pool: np.ndarray, s: int, B: int) -> np.ndarray:
    """(B, s) samples of ``pool`` values, without repetition inside a sample."""
    r = rng.random((B, len(pool)))
    return pool[np.argpartition(r, s - 1, axis=1)[:, :s]]


def _cofactor(A: np.ndarray) -> np.ndarray:
    """Cofactor matrices of (..., 3, 3): rows are cross products of the other rows."""
    return np.stack(
        [np.cross(A[..., 1, :], A[..., 2, :]), np.cross(A[..., 2, :], A[..., 0, :]), np.cross(A[..., 0, :], A[..., 1, :])],
        axis=-2,
    )


def _seven_point_batch(X1n, X2n, idx) -> np.ndarray:
    """(M, 3, 3) F hypotheses (normalised frames) from (B, 7) samples."""
    B = len(idx)
    A = (X2n[idx][:, :, :, None] * X1n[idx][:, :, None, :]).reshape(B, 7, 9)
    _, s, Vt = np.linalg.svd(A, full_matrices=True)
    ok = s[:, 6] > _TOL_RANK * s[:, 0]
    F1 = Vt[:, 7].reshape(B, 3, 3)
    F2 = Vt[:, 8].reshape(B, 3, 3)
    c0 = np.linalg.det(F2)
    c3 = np.linalg.det(F1)
    c1 = np.sum(_cofactor(F2) * F1, axis=(1, 2))
    c2 = np.sum(F2 * _cofactor(F1), axis=(1, 2))
    scale = np.maximum.reduce([np.abs(c0), np.abs(c1), np.abs(c2), np.abs(c3)])
    ok &= np.abs(c3) > 1e-10 * scale  # the rare near-infinite root: drop the sample
    c3s = np.where(ok, c3, 1.0)
    comp = np.zeros((B, 3, 3))
    comp[:, 0, 0] = -c2 / c3s
    comp[:, 0, 1] = -c1 / c3s
    comp[:, 0, 2] = -c0 / c3s
    comp[:, 1, 0] = 1.0
    comp[:, 2, 1] = 1.0
    comp[~ok] = np.diag([1.0, 2.0, 3.0])  # placeholder, masked out below
    roots = np.linalg.eigvals(comp)
    real = (np.abs(roots.imag) <= 1e-6 * (1.0 + np.abs(roots.real))) & ok[:, None]
    t = roots.real
    Fs = F2[:, None] + t[:, :, None, None] * F1[:, None]
    Fs = Fs[real]
    return Fs / np.linalg.norm(Fs, axis=(1, 2), keepdims=True)


def _rank2_batch(F: np.ndarray) -> np.ndarray:
    U, s, Vt = np.linalg.svd(F)
    s[:, 2] = 0.0
    return (U * s[:, None, :]) @ Vt


def _eight_point_batch(X1n, X2n, idx) -> np.ndarray:
    B, m = idx.shape
    A = (X2n[idx][:, :, :, None] * X1n[idx][:, :, None, :]).reshape(B, m, 9)
    _, s, Vt = np.linalg.svd(A, full_matrices=True)
    ok = s[:, 7] > _TOL_RANK * s[:, 0]
    return _rank2_batch(Vt[ok, 8].reshape(-1, 3, 3))


def _homography_batch(X1n, X2n, idx) -> np.ndarray:
    """(M, 3, 3) homographies (normalised frames) from (B, 4) samples, by mapping the
    four points to the projective basis in both images; degenerate samples dropped."""
    Y1, Y2 = X1n[idx], X2n[idx]
    ok = np.ones(len(idx), dtype=bool)
    for Y in (Y1, Y2):
        for tri in ((0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)):
            P = Y[:, list(tri)]
            d = np.abs(np.linalg.det(P)) / np.prod(np.linalg.norm(P, axis=2), axis=1)
            ok &= d > 1e-6
    Y1, Y2 = Y1[ok], Y2[ok]
    if not len(Y1):
        return np.zeros((0, 3, 3))

    def basis_inv(Y):  # Q with Q e_k ~ y_k, Q (1,1,1) ~ y_4
        M = Y[:, :3].transpose(0, 2, 1)
        lam = np.linalg.solve(M, Y[:, 3][..., None])[..., 0]
        return M * lam[:, None, :]

    Q1, Q2 = basis_inv(Y1), basis_inv(Y2)
    H = Q2 @ np.linalg.inv(Q1)
    return H / np.linalg.norm(H, axis=(1, 2), keepdims=True)


def _msac(gen, score, pool, s, t, confidence, max_iterations, rng, lo=None, inlier_frac=None):
    """Batched LO-MSAC loop. ``gen(idx (B, s)) -> (M, 3, 3)`` hypotheses,
    ``score(models) -> (M, N)`` distances, ``lo(model, cost, d) -> (model, cost, d)``.
    Returns (best model, its distances, iterations)."""
    best, best_cost, best_d, best_w = None, np.inf, None, 0.0
    k, it = max_iterations, 0
    while it < k:
        B = min(_BATCH, k - it)
        it += B
        models = gen(_draw(rng, pool, s, B))
        if not len(models):
            continue
        d = score(models)
        costs = _cost(d, t)
        j = int(np.argmin(costs))
        cand, cand_cost, cand_d = models[j], float(costs[j]), d[j]
        # local optimisation of every batch's best hypothesis (not only of new bests:
        # a raw noisy sample rarely beats an optimised one even when its basin is better)
        if lo is not None:
            cand, cand_cost, cand_d = lo(cand, cand_cost, cand_d)
        if cand_cost < best_cost:
            best, best_cost, best_d = cand, cand_cost, cand_d
            w = inlier_frac(best_d) if inlier_frac else np.count_nonzero(best_d <= t) / len(best_d)
            if w > best_w:
                best_w = w
                k = max(it, _n_iterations(w, s, confidence, max_iterations))
    return best, best_d, it


def _weighted_eight(D: _Data, inl: np.ndarray, Fn_prev: np.ndarray | None) -> np.ndarray:
    """8-point fit on the inliers, rows weighted by the Sampson denominators of the
    previous estimate (so the algebraic residual approximates the Sampson distance)."""
    A = _design(D.X1n[inl], D.X2n[inl])
    if Fn_prev is not None:
        F = D.F_pix(Fn_prev)
        Fx1 = D.X1[inl] @ F.T
        Ftx2 = D.X2[inl] @ F
        den = Fx1[:, 0] ** 2 + Fx1[:, 1] ** 2 + Ftx2[:, 0] ** 2 + Ftx2[:, 1] ** 2
        w = 1.0 / np.sqrt(np.maximum(den, 1e-300 + 1e-12 * den.max()))
        A = A * (w / w.max())[:, None]
    _, _, Vt = np.linalg.svd(A, full_matrices=False)
    return _rank2(Vt[-1].reshape(3, 3))


_LO_SCHEDULE = (2.0, 1.0, 1.0)


def _lo_eight(D: _Data, t: float):
    """Local optimisation: Sampson-weighted 8-point re-fits on the inliers, first
    within 2t (to grow the consensus set), then within t; keeps the lowest MSAC
    cost seen. (Wider first cuts, as in LO+, let the fit bend toward outliers in
    our trials and gave worse held-out errors.)"""

    def lo(Fn, cost, d):
        best = (Fn, cost, d)
        cur, dcur = Fn, d
        for m in _LO_SCHEDULE:
            inl = dcur <= m * t
            if inl.sum() < 8:
                break
            cur = _weighted_eight(D, inl, cur)
            dcur = D.d(cur)
            c = float(_cost(dcur, t))
            if c < best[1]:
                best = (cur, c, dcur)
        return best

    return lo


def _ransac_F(D: _Data, s: int, t: float, confidence: float, max_iterations: int, rng):
    """Plain LO-MSAC with 7- or 8-point samples; returns (F_n, iterations)."""
    gen = (lambda idx: _seven_point_batch(D.X1n, D.X2n, idx)) if s == 7 else (lambda idx: _eight_point_batch(D.X1n, D.X2n, idx))
    Fn, _, it = _msac(gen, D.d_batch, np.arange(D.n), s, t, confidence, max_iterations, rng, lo=_lo_eight(D, t))
    return Fn, it


def _ransac_H(D: _Data, t: float, confidence: float, max_iterations: int, rng):
    """LO-MSAC plane homography from 4-point samples; t on the transfer error (pixels).

    Returns (H_n in normalised frames or None, inlier mask, iterations)."""
    s2 = D.T2[0, 0]

    def score(H):
        y = D.X1n @ H.transpose(0, 2, 1)
        with np.errstate(divide="ignore", invalid="ignore"):
            p = y[..., :2] / y[..., 2:]
        e = np.linalg.norm(p - D.X2n[:, :2], axis=-1) / s2
        return np.where(np.isfinite(e), e, np.inf)

    def lo(H, cost, d):
        for _ in range(3):
            inl = d <= t
            if inl.sum() < 5:
                break
            Hl = _dlt_homography(D.X1n[inl], D.X2n[inl])
            dl = score(Hl[None])[0]
            cl = float(_cost(dl, t))
            if cl >= cost:
                break
            H, cost, d = Hl, cl, dl
        return H, cost, d

    gen = lambda idx: _homography_batch(D.X1n, D.X2n, idx)  # noqa: E731
    H, d, it = _msac(gen, score, np.arange(D.n), 4, t, confidence, max_iterations, rng, lo=lo)
    if H is None:
        return None, np.zeros(D.n, dtype=bool), it
    return H, d <= t, it


def _dlt_homography(Y1: np.ndarray, Y2: np.ndarray) -> np.ndarray:
    """Least-squares DLT homography (3, 3), unit norm, from (M, 3) -> (M, 3) points
    already in conditioned frames (a thin SVD: cheap for many points)."""
    n = len(Y1)
    A = np.zeros((2 * n, 9))
    A[0::2, 3:6] = -Y2[:, 2:3] * Y1
    A[0::2, 6:9] = Y2[:, 1:2] * Y1
    A[1::2, 0:3] = Y2[:, 2:3] * Y1
    A[1::2, 6:9] = -Y2[:, 0:1] * Y1
    _, _, Vt = np.linalg.svd(A, full_matrices=False)
    H = Vt[-1].reshape(3, 3)
    return H / np.linalg.norm(H)


_MIN_PLANE_FRACTION = 0.2

_PLANAR_SCENE = (
    "all inlier matches are consistent with one homography (a planar scene or a camera "
    "rotating about its centre): the fundamental matrix is not determined"
)


def _plane_parallax(D: _Data, t: float, confidence: float, max_iterations: int, rng, min_plane: int):
    """Plane + parallax RANSAC. Returns (F_n or None, H_n, iterations).

    The plane search stops once a plane holding ``_MIN_PLANE_FRACTION`` of the
    matches would have been found with the requested confidence: a smaller plane
    is not dominant, and the 7-point search that runs beside this one covers it."""
    cap = min(max_iterations, _n_iterations(_MIN_PLANE_FRACTION, 4, confidence, max_iterations))
    Hn, on_plane, it_h = _ransac_H(D, 2.0 * t, confidence, cap, rng)
    if Hn is None or on_plane.sum() < min_plane:
        return None, None, it_h
    L = np.cross(D.X1n @ Hn.T, D.X2n)
    nrm = np.linalg.norm(L, axis=1)
    cand = np.flatnonzero(~on_plane & (nrm > 1e-12))
    if len(cand) < 2:
        raise ValueError(_PLANAR_SCENE)
    L = L / np.maximum(nrm, 1e-300)[:, None]

    def gen(idx):
        e = np.cross(L[idx[:, 0]], L[idx[:, 1]])
        ne = np.linalg.norm(e, axis=1)
        e = e[ne > 1e-12] / ne[ne > 1e-12, None]
        return skew(e) @ Hn

    lo8 = _lo_eight(D, t)

    def lo(Fn, cost, d):
        for _ in range(3):  # epipole from the parallax lines of all off-plane inliers
            inl = (d <= t) & ~on_plane
            if inl.sum() < 3:
                break
            _, _, Vt = np.linalg.svd(L[inl])
            Fl = skew(Vt[-1]) @ Hn
            dl = D.d(Fl)
            cl = float(_cost(dl, t))
            if cl >= cost:
                break
            Fn, cost, d = Fl, cl, dl
        return lo8(Fn, cost, d)  # then free F from the plane

    frac = lambda d: np.count_nonzero(d[cand] <= t) / len(cand)  # noqa: E731
    Fn, d, it = _msac(gen, D.d_batch, cand, 2, t, confidence, max_iterations, rng, lo=lo, inlier_frac=frac)
    if Fn is None or np.count_nonzero((d <= t) & ~on_plane) < 2:
        raise ValueError(_PLANAR_SCENE)
    return Fn, Hn, it_h + it


def _polish(F, a, b, D: _Data, t: float, cost: str, max_iterations: int = 200):
    """Final refinement on the inliers; returns (F, Sampson distances (N,)).

    1. Sampson LM on the inliers (within t), repeated while the inlier set
       changes (at most 3 times).
    2. Adaptive trimming: the noise level sigma is estimated from the inliers'
       median residual (a Sampson distance is about |N(0, sigma^2)|); while
       3 sigma is below the cut, re-fit on the matches within 3 sigma. This
       lets exact (or low-noise) inliers shed an outlier that happens to lie
       inside a loose threshold.
    3. A robust pass (Cauchy loss, scale sigma) on the matches within three
       times the cut, which weighs matches near the cut smoothly.
    4. For ``cost="reprojection"``, the gold standard on the final inliers.
    """
    d = _sampson(F, D.X1, D.X2)
    for _ in range(3):
        inl = d <= t
        if inl.sum() < 8:
            break
        F = _refine_core(F, a[inl], b[inl], D.T1, D.T2, "sampson", max_iterations)
        d = _sampson(F, D.X1, D.X2)
        if np.array_equal(d <= t, inl):
            break

    cut = t
    sigma = t / 3.0
    for _ in range(12):
        inl = d <= cut
        if inl.sum() < 8:
            break
        sigma = max(float(np.median(d[inl])) / 0.6745, 1e-12 * t)
        new_cut = min(t, 3.0 * sigma)
        sel = d <= new_cut
        if new_cut >= 0.999 * cut or sel.sum() < 8:
            break
        F = _refine_core(F, a[sel], b[sel], D.T1, D.T2, "sampson", max_iterations)
        d = _sampson(F, D.X1, D.X2)
        cut = new_cut

    near = d <= 3.0 * cut
    if np.count_nonzero(d <= cut) >= 8:
        Fn0 = np.linalg.solve(D.T2.T, F) @ np.linalg.inv(D.T1)
        Fn = _refine_sampson(
            Fn0 / np.linalg.norm(Fn0), D.X1[near], D.X2[near], D.T1, D.T2,
            max_nfev=max_iterations * 8, loss="cauchy", f_scale=sigma,
        )
        F_r = normalize_fundamental(D.F_pix(Fn))
        d_r = _sampson(F_r, D.X1, D.X2)
        if np.count_nonzero(d_r <= t) >= 8:
            F, d = F_r, d_r
    if cost == "reprojection":
        inl = d <= t
        F = _refine_core(F, a[inl], b[inl], D.T1, D.T2, "reprojection", max_iterations)
        d = _sampson(F, D.X1, D.X2)
    return F, d


def estimate(
    x1,
    x2,
    *,
    method: str = "plane_parallax",
    threshold: float = 1.0,
    confidence: float = 0.999,
    max_iterations: int = 10000,
    refine_cost: str = "sampson",
    seed=0,
) -> FundamentalResult:
    """Robust fundamental matrix from many matches with outliers.

    Parameters
    ----------
    x1, x2 : (N, 2) array_like, pixels; N >= 8
    method : {"plane_parallax", "ransac7", "ransac8"}
        ``"plane_parallax"`` (default): RANSAC for the homography of the
        dominant plane (4-point samples, canonical-basis solver), then RANSAC
        for the epipole from the parallax of the points off that plane
        (2-point samples: the lines ``(H x1) x x2`` meet in ``e2``),
        ``F = [e2]_x H``, locally optimised first along the plane (epipole
        from all parallax inliers) and then freely. A plane found this way is
        not always a scene plane (far, low-parallax points also follow one
        homography), so a plain 7-point search runs beside it and the lower
        MSAC cost wins; ``method`` of the result says which.
        ``"ransac7"`` / ``"ransac8"``: plain RANSAC with 7-point (up to 3
        hypotheses per sample) or normalised 8-point samples. All score by
        MSAC and locally optimise the best hypothesis of every batch of 64
        samples (Sampson-weighted 8-point re-fits on its inliers).
    threshold : float, pixels
        Inlier threshold on the Sampson distance (about 2-3 times the noise
        standard deviation); the plane stage uses twice it on the transfer
        error. It is an upper bound: when the inliers show far less noise
        (3 sigma < threshold / 3) the search is repeated at 3 sigma, so that
        a loose threshold on clean data cannot trade a little bias for an
        extra outlier (``method`` of the result then says "re-searched").
    confidence : float in (0, 1)
        Stop when the probability of having drawn an all-inlier sample reaches it.
    max_iterations : int
        Cap on the samples of each RANSAC stage.
    refine_cost : {"sampson", "reprojection"}
        The final refinement: Sampson LM on the inliers until the inlier set
        is stable, adaptive trimming at 3 sigma (sigma from the inliers'
        median residual), a Cauchy-loss pass; with ``"reprojection"`` the gold
        standard (:func:`refine`) on the final inliers as the last step.
    seed : int, numpy Generator or None
        Randomness of the sampling (fixed by default, so results repeat).

    Returns
    -------
    FundamentalResult
        ``F``, the inlier mask, the Sampson residuals of all N matches,
        ``H2_from_1`` (plane + parallax only), ``iterations``.

    Raises
    ------
    ValueError
        Bad shapes or parameters, fewer than 8 matches, no hypothesis with 8
        inliers, or a scene whose inliers all follow one homography.
    """
    if method not in ROBUST_METHODS:
        raise ValueError(f"method must be one of {ROBUST_METHODS}, got {method!r}")
    if refine_cost not in REFINE_COSTS:
        raise ValueError(f"refine_cost must be one of {REFINE_COSTS}, got {refine_cost!r}")
    if not (np.isscalar(threshold) and np.isfinite(threshold) and threshold > 0):
        raise ValueError(f"threshold must be a positive number of pixels, got {threshold!r}")
    if not (np.isscalar(confidence) and 0 < confidence < 1):
        raise ValueError(f"confidence must lie in (0, 1), got {confidence!r}")
    if not (isinstance(max_iterations, (int, np.integer)) and max_iterations >= 1):
        raise ValueError(f"max_iterations must be a positive integer, got {max_iterations!r}")
    a, b = _as_pair(x1, x2, min_count=8, who="estimate")
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    D = _Data(a, b)
    t = float(threshold)

    F, Hn, iters, used, d = _search_and_polish(D, method, t, confidence, max_iterations, rng, refine_cost)
    # The threshold is an upper bound on the noise. When the inliers show far less
    # noise (3 sigma < t / 3), a loose threshold lets MSAC trade a little bias for an
    # extra "inlier" (a high-leverage outlier): search again at 3 sigma.
    sigma = float(np.median(d[d <= t])) / 0.6745
    t2 = max(3.0 * sigma, 1e-6 * t)
    if t2 < t / 3.0 and np.any((d > t2) & (d <= t)):
        try:
            F2, Hn2, it2, used2, d2 = _search_and_polish(D, method, t2, confidence, max_iterations, rng, refine_cost)
        except ValueError:
            it2 = 0
        else:
            if _cost(d2, t2) < _cost(d, t2):
                F, Hn, used, d = F2, Hn2, f"{used2} (re-searched at {t2:.3g} px)", d2
        iters += it2
    H = None
    if Hn is not None:
        H = normalize_homography(np.linalg.solve(D.T2, Hn @ D.T1))
    return FundamentalResult(F=F, inliers=d <= t, residuals=d, method=used, H2_from_1=H, iterations=int(iters))


def _search_and_polish(D: _Data, method: str, t: float, confidence: float, max_iterations: int, rng, refine_cost: str):
    """Hypothesis search for ``method`` at threshold t, then :func:`_polish`.
    Returns (F pixels, H_n or None, iterations, method used, distances)."""
    Hn = None
    used = method
    if method == "plane_parallax":
        Fn, Hn, iters = _plane_parallax(D, t, confidence, max_iterations, rng, min_plane=8)
        # A plane found by RANSAC is not always a scene plane: far, low-parallax points
        # also follow one homography within the threshold. The plain 7-point search
        # runs beside it and the lower MSAC cost wins (the result's method says which).
        F7, it2 = _ransac_F(D, 7, t, confidence, max_iterations, rng)
        iters += it2
        if F7 is not None and (Fn is None or _cost(D.d(F7), t) < _cost(D.d(Fn), t)):
            Fn, Hn = F7, None
            used = "plane_parallax->ransac7 (7-point hypothesis won)"
    else:
        Fn, iters = _ransac_F(D, 7 if method == "ransac7" else 8, t, confidence, max_iterations, rng)
    if Fn is None:
        raise ValueError("robust estimation failed: every sample was degenerate")
    if np.count_nonzero(D.d(Fn) <= t) < 8:
        raise ValueError(f"robust estimation found fewer than 8 inliers at threshold {t:.3g} px")
    F, d = _polish(normalize_fundamental(D.F_pix(Fn)), D.a, D.b, D, t, refine_cost)
    return F, Hn, iters, used, d
