"""Homogeneous lines: fitting, intersection, vanishing points, distances.

A line is ``(a, b, c)`` with ``a x + b y + c = 0``; points are ``(x, y, w)``.
Lines returned here are normalised so that ``a^2 + b^2 = 1`` (then
``l . (x, y, 1)`` is the signed Euclidean distance), unless the line is the
line at infinity.

>>> l = line_through((0.0, 0.0, 1.0), (1.0, 1.0, 1.0))
>>> bool(np.allclose(np.abs(point_line_distance([[1.0, 0.0]], l)), np.sqrt(0.5)))
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "LineFit",
    "normalize_line",
    "line_through",
    "intersect_lines",
    "fit_line",
    "eigh_sym2",
    "vanishing_point",
    "point_line_distance",
    "to_homogeneous",
    "hartley_normalization",
    "from_homogeneous",
    "skew",
    "unskew",
]

_EPS = 1e-12


def skew(v) -> np.ndarray:
    """The cross-product matrix ``[v]x`` of each 3-vector, ``[v]x u = v x u``
    (for lines and points, the join and the meet as a matrix).

    Parameters
    ----------
    v : (..., 3) array_like

    Returns
    -------
    (..., 3, 3) float64

    >>> bool(np.allclose(skew([1.0, 2.0, 3.0]) @ [4.0, 5.0, 6.0], np.cross([1.0, 2.0, 3.0], [4.0, 5.0, 6.0])))
    True
    """
    v = np.asarray(v, dtype=np.float64)
    if v.shape[-1:] != (3,):
        raise ValueError(f"vectors must be (..., 3), got {v.shape}")
    S = np.zeros(v.shape + (3,))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S


def unskew(S) -> np.ndarray:
    """The 3-vector of each cross-product matrix (the inverse of :func:`skew`;
    of a matrix not quite skew, its skew part's).

    Parameters
    ----------
    S : (..., 3, 3) array_like

    Returns
    -------
    (..., 3) float64

    >>> unskew(skew([1.0, 2.0, 3.0])).tolist()
    [1.0, 2.0, 3.0]
    """
    S = np.asarray(S, dtype=np.float64)
    if S.shape[-2:] != (3, 3):
        raise ValueError(f"matrices must be (..., 3, 3), got {S.shape}")
    return 0.5 * np.stack([S[..., 2, 1] - S[..., 1, 2], S[..., 0, 2] - S[..., 2, 0], S[..., 1, 0] - S[..., 0, 1]], axis=-1)


@dataclass(frozen=True)
class LineFit:
    """Result of a total-least-squares line fit.

    Attributes
    ----------
    line : (3,) float64, normalised (a^2 + b^2 = 1)
    centroid : (2,) float64, weighted centroid of the points
    direction : (2,) float64, unit direction of the line
    rms : float, weighted RMS orthogonal distance of the points
    normal_sigma : float
        Standard deviation of the line's offset along its normal at the
        centroid (``rms / sqrt(effective N)``), in the points' units.
    angle_sigma : float
        Standard deviation of the line's direction, radians.
    n_points : int
    """

    line: np.ndarray
    centroid: np.ndarray
    direction: np.ndarray
    rms: float
    normal_sigma: float
    angle_sigma: float
    n_points: int


def to_homogeneous(pts) -> np.ndarray:
    """(N, 2) -> (N, 3) by appending w = 1."""
    p = np.asarray(pts, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"pts must have shape (N, 2), got {p.shape}")
    return np.column_stack([p, np.ones(len(p))])


def from_homogeneous(X) -> np.ndarray:
    """(N, 3) homogeneous -> (N, 2) Euclidean; points at infinity raise ``ValueError``."""
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 2 or X.shape[1] != 3:
        raise ValueError(f"homogeneous points must have shape (N, 3), got {X.shape}")
    w = X[:, 2]
    if np.any(np.abs(w) < _EPS * np.maximum(1.0, np.abs(X[:, :2]).max(axis=1))):
        raise ValueError("point at infinity has no Euclidean coordinates")
    return X[:, :2] / w[:, None]


def hartley_normalization(pts) -> np.ndarray:
    """Hartley's conditioning similarity for a point set.

    Parameters
    ----------
    pts : (N, 2) array_like

    Returns
    -------
    (3, 3) float64 ``T`` moving the centroid to the origin and scaling the mean
    distance from it to ``sqrt(2)``; apply as ``T @ (x, y, 1)``.

    Raises
    ------
    ValueError
        If all points coincide.
    """
    p = np.asarray(pts, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2 or len(p) == 0:
        raise ValueError(f"pts must have shape (N, 2) with N >= 1, got {p.shape}")
    T, ok = _hartley_batch(p[None], np.ones((1, len(p)), bool))
    if not ok[0]:
        raise ValueError("points are all coincident")
    return T[0]


def _hartley_batch(p: np.ndarray, valid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`hartley_normalization` of K point sets at once: points (K, N, 2), of
    which ``valid`` (K, N) count. Returns (T (K, 3, 3), ok (K,)): identity where a
    set has no valid point or they all coincide (``ok`` False)."""
    cnt = valid.sum(axis=1)
    m = np.maximum(cnt, 1)
    c = (p * valid[..., None]).sum(axis=1) / m[:, None]
    d = (np.sqrt(((p - c[:, None]) ** 2).sum(axis=2)) * valid).sum(axis=1) / m
    ok = (cnt > 0) & (d >= _EPS * np.maximum(1.0, np.abs(c).max(axis=1)))
    s = np.where(ok, np.sqrt(2.0) / np.where(ok, d, 1.0), 1.0)
    T = np.zeros((len(p), 3, 3))
    T[:, 0, 0] = T[:, 1, 1] = s
    T[:, :2, 2] = -s[:, None] * np.where(ok[:, None], c, 0.0)
    T[:, 2, 2] = 1.0
    return T, ok


def normalize_line(line) -> np.ndarray:
    """Scale a line (3,) so that ``a^2 + b^2 = 1`` (the line at infinity to unit norm)."""
    l = np.asarray(line, dtype=np.float64)
    if l.shape != (3,):
        raise ValueError(f"line must be (3,), got {l.shape}")
    if _zero_lines(l):
        raise ValueError("line vector is zero")
    return _unit_lines(l)


def _zero_lines(L: np.ndarray) -> np.ndarray:
    """Which of the lines (..., 3) are zero vectors (no line at all)."""
    return (np.hypot(L[..., 0], L[..., 1]) < _EPS * np.maximum(1.0, np.abs(L[..., 2]))) & (np.abs(L[..., 2]) < _EPS)


def _unit_lines(L: np.ndarray) -> np.ndarray:
    """Lines (..., 3) scaled as :func:`normalize_line` does, any number at once;
    zero vectors stay zero."""
    n = np.hypot(L[..., 0], L[..., 1])
    at_inf = n < _EPS * np.maximum(1.0, np.abs(L[..., 2]))
    div = np.where(at_inf, np.linalg.norm(L, axis=-1), n)
    return L / np.where(div > 0, div, 1.0)[..., None]


def line_through(p, q) -> np.ndarray:
    """Line through two homogeneous points (3,) each: ``p x q``, normalised.

    Raises ``ValueError`` if the points coincide.
    """
    p = np.asarray(p, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    if p.shape != (3,) or q.shape != (3,):
        raise ValueError("points must be homogeneous (3,) vectors")
    l = np.cross(p, q)
    if np.linalg.norm(l) < _EPS * np.linalg.norm(p) * np.linalg.norm(q):
        raise ValueError("points coincide: the line through them is undefined")
    return normalize_line(l)


def intersect_lines(l1, l2) -> np.ndarray:
    """Intersection of two lines (3,) each: homogeneous point (3,), unit norm.

    Parallel lines give a point at infinity (w = 0). Raises ``ValueError`` if the
    lines coincide.
    """
    a = np.asarray(l1, dtype=np.float64)
    b = np.asarray(l2, dtype=np.float64)
    if a.shape != (3,) or b.shape != (3,):
        raise ValueError("lines must be homogeneous (3,) vectors")
    x = np.cross(a / np.linalg.norm(a), b / np.linalg.norm(b))
    n = np.linalg.norm(x)
    if n < 1e-14:
        raise ValueError("lines coincide: intersection undefined")
    return x / n


def eigh_sym2(p: float, q: float, r: float) -> tuple[float, float, float, float]:
    """Eigen-decomposition of the real symmetric 2x2 matrix ``[[p, q], [q, r]]``
    in closed form (``numpy.linalg.eigh`` costs about 15 us of call overhead on
    a 2x2; this runs on plain floats).

    Returns
    -------
    (w0, w1, vx, vy): eigenvalues ``w0 <= w1`` and the unit eigenvector
    ``(vx, vy)`` of ``w0`` (that of ``w1`` is ``(-vy, vx)``). The eigenvalues
    are exact to within a few ulps of the matrix's norm, as LAPACK's. The
    eigenvector's sign is arbitrary (as LAPACK's); for a multiple of the
    identity it is ``(1, 0)``.
    """
    m = 0.5 * (p + r)
    d = math.hypot(0.5 * (p - r), q)
    w0, w1 = m - d, m + d
    # (S - w0 I) v = 0 from either row; the longer candidate is the better conditioned
    ax, ay = q, w0 - p
    bx, by = w0 - r, q
    na, nb = math.hypot(ax, ay), math.hypot(bx, by)
    if na >= nb:
        if na == 0.0:
            return w0, w1, 1.0, 0.0
        return w0, w1, ax / na, ay / na
    return w0, w1, bx / nb, by / nb


def fit_line(pts, weights=None) -> LineFit:
    """Weighted total-least-squares line fit (orthogonal regression).

    Parameters
    ----------
    pts : (N, 2) array_like, N >= 2
    weights : (N,) array_like, optional, non-negative

    Returns
    -------
    LineFit

    Raises
    ------
    ValueError
        Fewer than 2 points (with positive weight) or all points coincide.
    """
    p = np.asarray(pts, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"pts must have shape (N, 2), got {p.shape}")
    if len(p) < 2:
        raise ValueError(f"a line fit needs at least 2 points, got {len(p)}")
    if weights is None:  # (the common case: no weight arrays)
        n_eff = W = float(len(p))
        c = p.sum(axis=0) / W
        d = p - c
        S = d.T @ d / W
    else:
        w = np.asarray(weights, dtype=np.float64)
        if w.shape != (len(p),) or np.any(w < 0) or not np.all(np.isfinite(w)):
            raise ValueError("weights must be (N,) finite and non-negative")
        if np.count_nonzero(w) < 2:
            raise ValueError("a line fit needs at least 2 points with positive weight")
        W = w.sum()
        c = (w[:, None] * p).sum(axis=0) / W
        d = p - c
        S = (w[:, None] * d).T @ d / W
        n_eff = W * W / (w * w).sum()
    w0, w1, nx, ny = eigh_sym2(float(S[0, 0]), float(S[0, 1]), float(S[1, 1]))
    if w1 < _EPS:
        raise ValueError("points coincide: no line through them")
    cx, cy = float(c[0]), float(c[1])
    line = np.array([nx, ny, -(nx * cx + ny * cy)])
    rms = math.sqrt(max(w0, 0.0))
    spread = math.sqrt(w1)
    # noise sigma estimated as rms * sqrt(n / (n - 2)); offset std = sigma / sqrt(n)
    sigma_n = rms / math.sqrt(n_eff - 2) if n_eff > 2 else math.inf
    sigma_a = sigma_n / spread
    return LineFit(
        line=line,
        centroid=c,
        direction=np.array([-ny, nx]),
        rms=rms,
        normal_sigma=float(sigma_n),
        angle_sigma=float(sigma_a),
        n_points=len(p),
    )


def vanishing_point(lines, weights=None) -> np.ndarray:
    """Least-squares common point of a bundle of lines.

    Minimises ``sum_i w_i (l_i . v)^2`` over unit ``v`` with each line
    normalised to ``a^2 + b^2 = 1`` (so the residual is the distance of the
    point from the line, to first order for finite points).

    Parameters
    ----------
    lines : (N, 3) array_like, N >= 2
    weights : (N,) array_like, optional

    Returns
    -------
    (3,) float64 homogeneous point, unit norm (w may be 0: a point at infinity).

    Raises
    ------
    ValueError
        Fewer than 2 lines, or all lines coincide.
    """
    L = np.asarray(lines, dtype=np.float64)
    if L.ndim != 2 or L.shape[1] != 3:
        raise ValueError(f"lines must have shape (N, 3), got {L.shape}")
    if len(L) < 2:
        raise ValueError(f"a vanishing point needs at least 2 lines, got {len(L)}")
    L = np.array([normalize_line(l) for l in L])
    if weights is not None:
        w = np.asarray(weights, dtype=np.float64)
        if w.shape != (len(L),) or np.any(w < 0):
            raise ValueError("weights must be (N,) non-negative")
        L = L * np.sqrt(w)[:, None]
    # condition: scale the homogeneous coordinate
    s = max(1.0, float(np.median(np.abs(L[:, 2]))))
    Ls = L * np.array([1.0, 1.0, 1.0 / s])
    _, sv, Vt = np.linalg.svd(Ls)
    if len(sv) >= 2 and sv[1] < 1e-12 * max(sv[0], _EPS):
        raise ValueError("lines coincide: vanishing point undefined")
    v = Vt[-1] * np.array([1.0, 1.0, 1.0 / s])
    return v / np.linalg.norm(v)


def point_line_distance(pts, line) -> np.ndarray:
    """Signed Euclidean distance of points (N, 2) from a finite line (3,): (N,) float64."""
    p = np.asarray(pts, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"pts must have shape (N, 2), got {p.shape}")
    l = np.asarray(line, dtype=np.float64)
    n = np.hypot(l[0], l[1]) if l.shape == (3,) else 0.0
    if n < _EPS:
        raise ValueError("distance to the line at infinity (or a zero line) is undefined")
    return (p @ l[:2] + l[2]) / n
