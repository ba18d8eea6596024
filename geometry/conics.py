"""Conics: ellipse parameters, fitting, pole/polar and intersections.

Convention: a conic is a real symmetric 3x3 matrix ``C`` with ``x^T C x = 0``
for homogeneous points ``x = (x, y, w)`` on it. Every conic this module returns
is normalised by :func:`normalize_conic`: unit Frobenius norm, and the sign
that makes the trace of the upper-left 2x2 block non-negative, so that for an
ellipse ``x^T C x < 0`` inside and ``> 0`` outside. Lines are ``(a, b, c)``
with ``a x + b y + c = 0``. Coordinates are whatever frame the caller uses
(pixels for images, metres on the pitch); functions say when they care.

Round trip of the core transform:

>>> e = Ellipse(center=(320.0, 240.0), axes=(120.0, 45.0), angle=0.3)
>>> e2 = ellipse_from_conic(conic_from_ellipse(e))
>>> bool(np.allclose(e2.center, e.center) and np.allclose(e2.axes, e.axes))
True
>>> bool(np.isclose(e2.angle, e.angle))
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.optimize

from geometry.lines import eigh_sym2, hartley_normalization

__all__ = [
    "Ellipse",
    "EllipseFit",
    "DoubleContact",
    "normalize_conic",
    "conic_from_ellipse",
    "ellipse_from_conic",
    "ellipse_params_sym",
    "conic_from_circle",
    "fit_ellipse_direct",
    "direct_fit_scatter",
    "refine_ellipse",
    "fit_ellipse",
    "ellipse_distance",
    "sampson_distance",
    "polar",
    "pole",
    "intersect_line_conic",
    "intersect_conics",
    "conic_conditioning",
    "split_degenerate_conic",
    "split_degenerate_conics",
    "tangents_from_point",
    "double_contact",
    "real_points",
]

_EPS = 1e-12


@dataclass(frozen=True)
class Ellipse:
    """An ellipse by its parameters.

    Attributes
    ----------
    center : (2,) float64
        Centre ``(x, y)`` in the caller's frame (pixels for images).
    axes : (2,) float64
        Semi-axes ``(a, b)`` with ``a >= b > 0``.
    angle : float
        Direction of the major axis ``a``, radians from the +x axis toward +y,
        canonicalised to ``(-pi/2, pi/2]``.
    """

    center: tuple[float, float]
    axes: tuple[float, float]
    angle: float

    def __post_init__(self) -> None:
        c, ax = self.center, self.axes
        if not (type(c) is tuple and type(ax) is tuple and len(c) == 2 and len(ax) == 2 and all(type(v) is float for v in (*c, *ax))):
            # arrays, ints, numpy scalars: to pairs of plain floats (the fits pass
            # those already, and skip numpy's per-call cost here)
            c = np.asarray(c, dtype=np.float64)
            ax = np.asarray(ax, dtype=np.float64)
            if c.shape != (2,) or ax.shape != (2,):
                raise ValueError(f"Ellipse needs center (2,) and axes (2,), got {c.shape} and {ax.shape}")
            c, ax = (float(c[0]), float(c[1])), (float(ax[0]), float(ax[1]))
        angle = float(self.angle)
        if not all(math.isfinite(v) for v in (*c, *ax, angle)):
            raise ValueError("Ellipse parameters must be finite")
        if ax[0] <= 0 or ax[1] <= 0:
            raise ValueError(f"Ellipse axes must be positive, got {ax}")
        a, b = ax
        if b > a:
            a, b = b, a
            angle += np.pi / 2
        object.__setattr__(self, "center", c)
        object.__setattr__(self, "axes", (a, b))
        object.__setattr__(self, "angle", _wrap_half_pi(angle))

    @property
    def conic(self) -> np.ndarray:
        """(3, 3) float64 normalised conic matrix of this ellipse."""
        return conic_from_ellipse(self)

    def points(self, n: int = 100) -> np.ndarray:
        """Sample the ellipse: ``(n, 2)`` float64 points, uniformly in the parametric angle."""
        s = np.linspace(0.0, 2 * np.pi, int(n), endpoint=False)
        return self.points_at(s)

    def points_at(self, s: np.ndarray) -> np.ndarray:
        """Points at parametric angles ``s`` (``(N,)`` radians): ``(N, 2)`` float64."""
        s = np.asarray(s, dtype=np.float64)
        a, b = self.axes
        ca, sa = np.cos(self.angle), np.sin(self.angle)
        u, v = a * np.cos(s), b * np.sin(s)
        return np.stack([self.center[0] + ca * u - sa * v, self.center[1] + sa * u + ca * v], axis=-1)


@dataclass(frozen=True)
class EllipseFit:
    """Result of an ellipse fit.

    Attributes
    ----------
    ellipse : Ellipse
    conic : (3, 3) float64, normalised conic of ``ellipse``
    rms : float
        Root mean square of the geometric (orthogonal) distance of the input
        points to the ellipse, in the points' units.
    n_points : int
    """

    ellipse: Ellipse
    conic: np.ndarray
    rms: float
    n_points: int


@dataclass(frozen=True)
class DoubleContact:
    """Outcome of :func:`double_contact`.

    Attributes
    ----------
    holds : bool
        Whether the pencil ``C1 - lam C2`` contains a rank-1 member (within ``tol``).
    lam : float
        The generalised eigenvalue with the most nearly rank-1 member
        (``C1`` and ``C2`` normalised first).
    rank1_ratio : float
        ``s2 / s1`` of the singular values of that member: 0 for exact double contact.
    """

    holds: bool
    lam: float
    rank1_ratio: float


def _wrap_half_pi(angle: float) -> float:
    """Wrap an axis direction to (-pi/2, pi/2]."""
    a = (angle + np.pi / 2) % np.pi - np.pi / 2
    if a <= -np.pi / 2 + 1e-15:
        a += np.pi
    return float(a)


def _as_conic(C, name: str = "C") -> np.ndarray:
    C = np.asarray(C)
    if C.shape != (3, 3):
        raise ValueError(f"{name} must be a 3x3 conic matrix, got shape {C.shape}")
    if not np.all(np.isfinite(C)):
        raise ValueError(f"{name} has non-finite entries")
    return C


def _as_points2(pts, name: str = "pts", min_count: int = 1) -> np.ndarray:
    p = np.asarray(pts, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"{name} must have shape (N, 2), got {p.shape}")
    if len(p) < min_count:
        raise ValueError(f"{name} needs at least {min_count} points, got {len(p)}")
    if not np.all(np.isfinite(p)):
        raise ValueError(f"{name} has non-finite coordinates")
    return p


def normalize_conic(C) -> np.ndarray:
    """Symmetrise and normalise a conic.

    Parameters
    ----------
    C : (3, 3) array_like, real

    Returns
    -------
    (3, 3) float64
        ``(C + C^T) / 2`` scaled to unit Frobenius norm, sign chosen so that
        ``trace(C[:2, :2]) >= 0``.
    """
    C = _as_conic(C).astype(np.float64)
    C = 0.5 * (C + C.T)
    n = np.linalg.norm(C)
    if n < _EPS:
        raise ValueError("conic matrix is zero")
    C = C / n
    tr = C[0, 0] + C[1, 1]
    if tr < 0 or (tr == 0 and C[2, 2] > 0):
        C = -C
    return C


def conic_from_ellipse(ellipse: Ellipse) -> np.ndarray:
    """Conic matrix of an ellipse.

    Parameters
    ----------
    ellipse : Ellipse

    Returns
    -------
    (3, 3) float64, normalised (negative inside).
    """
    a, b = ellipse.axes
    ca, sa = np.cos(ellipse.angle), np.sin(ellipse.angle)
    Rm = np.array([[ca, -sa], [sa, ca]])
    M = Rm @ np.diag([1.0 / a**2, 1.0 / b**2]) @ Rm.T
    c = np.asarray(ellipse.center, dtype=np.float64)
    C = np.empty((3, 3))
    C[:2, :2] = M
    C[:2, 2] = C[2, :2] = -M @ c
    C[2, 2] = c @ M @ c - 1.0
    return normalize_conic(C)


def conic_from_circle(center, radius: float) -> np.ndarray:
    """Conic of the circle of ``radius`` about ``center`` ((2,), same units): (3, 3) float64."""
    if not radius > 0:
        raise ValueError(f"circle radius must be positive, got {radius}")
    return conic_from_ellipse(Ellipse(center=tuple(center), axes=(radius, radius), angle=0.0))


def ellipse_from_conic(C) -> Ellipse:
    """Ellipse parameters of a conic matrix.

    Parameters
    ----------
    C : (3, 3) array_like, real symmetric

    Returns
    -------
    Ellipse

    Raises
    ------
    ValueError
        If ``C`` is not a real, non-degenerate ellipse (a hyperbola, parabola,
        an imaginary ellipse or a degenerate conic).
    """
    C = normalize_conic(C)
    # on plain floats (this runs for every ellipse hypothesis the detector validates)
    (p, q, d), (_, r, e), (_, _, f) = C.tolist()
    status, cx, cy, a, b, angle = ellipse_params_sym(p, q, r, d, e, f)
    if status == 1:
        raise ValueError("conic is not an ellipse (hyperbola, parabola or degenerate)")
    if status == 2:
        raise ValueError("conic is an imaginary or degenerate (point) ellipse")
    return Ellipse(center=(cx, cy), axes=(a, b), angle=angle)


def ellipse_params_sym(p: float, q: float, r: float, d: float, e: float, f: float) -> tuple[int, float, float, float, float, float]:
    """Centre, semi-axes and major-axis direction of the normalised conic
    ``[[p, q, d], [q, r, e], [d, e, f]]`` (:func:`normalize_conic`), on plain
    floats (:func:`ellipse_from_conic`'s arithmetic; the detector's compiled
    ellipse validation runs the same function, :mod:`arstream.detect.kernels.ellipses`).

    Returns
    -------
    (status, cx, cy, a, b, angle): ``status`` 0 for a real ellipse (``a >= b > 0``,
    ``angle`` of the major axis, not yet wrapped to ``(-pi/2, pi/2]``), 1 for a
    hyperbola, parabola or degenerate conic, 2 for an imaginary or point
    ellipse (the other values are then 0).
    """
    w0, w1, vx, vy = eigh_sym2(p, q, r)  # w0 smallest -> major axis along (vx, vy)
    if w1 <= 0 or w0 <= 1e-13 * w1:
        return 1, 0.0, 0.0, 0.0, 0.0, 0.0
    det = p * r - q * q  # > 0 here (both eigenvalues positive)
    cx = (q * e - r * d) / det  # the centre: [[p, q], [q, r]] c = -(d, e)
    cy = (q * d - p * e) / det
    f0 = f + (d * cx + e * cy)  # value at the centre
    if f0 >= -1e-15:
        return 2, 0.0, 0.0, 0.0, 0.0, 0.0
    a = math.sqrt(-f0 / w0)
    b = math.sqrt(-f0 / w1)
    return 0, cx, cy, a, b, math.atan2(vy, vx)


def direct_fit_scatter(S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The direct ellipse fit (Halir-Flusser) of K point sets at once, from their
    scatter matrices (K, 6, 6) of the monomials ``[x^2, xy, y^2, x, y, 1]``.

    Returns
    -------
    (coef (K, 6) ``[A, B, C, D, E, F]`` of ``A x^2 + B xy + C y^2 + D x + E y + F``,
    valid (K,) bool): False where a set is degenerate or has no elliptical solution.
    """
    K = len(S)
    S1 = S[:, :3, :3]
    S2 = S[:, :3, 3:]
    S3 = S[:, 3:, 3:]
    try:
        T = -np.linalg.solve(S3, np.transpose(S2, (0, 2, 1)))
    except np.linalg.LinAlgError:
        # a degenerate member (too few distinct points): solve one by one
        T = np.zeros((K, 3, 3))
        for k in range(K):
            try:
                T[k] = -np.linalg.solve(S3[k], S2[k].T)
            except np.linalg.LinAlgError:
                T[k] = np.nan
    M = S1 + S2 @ T
    Mp = np.empty_like(M)
    Mp[:, 0] = 0.5 * M[:, 2]
    Mp[:, 1] = -M[:, 1]
    Mp[:, 2] = 0.5 * M[:, 0]
    fin = np.isfinite(Mp).all(axis=(1, 2))
    if not fin.all():
        Mp[~fin] = np.eye(3)
    w, V = np.linalg.eig(Mp)
    V = V.real
    cond = 4 * V[:, 0, :] * V[:, 2, :] - V[:, 1, :] ** 2  # (K, 3) per eigenvector
    cond = np.where(cond > 0, np.abs(w.real), np.inf)
    j = np.argmin(cond, axis=1)
    r = np.arange(K)
    valid = fin & np.isfinite(cond[r, j])
    a1 = V[r, :, j]  # (K, 3)
    coef = np.empty((K, 6))
    coef[:, :3] = a1
    coef[:, 3:] = (T @ a1[:, :, None])[:, :, 0]
    return coef, valid


def fit_ellipse_direct(pts, weights=None) -> Ellipse:
    """Direct least-squares ellipse fit (Fitzgibbon et al. 1999, in the
    numerically stable form of Halir & Flusser 1998), on Hartley-normalised
    coordinates.

    Parameters
    ----------
    pts : (N, 2) array_like, N >= 5, any frame (e.g. pixels)
    weights : (N,) array_like, optional
        Non-negative weights of the algebraic residuals.

    Returns
    -------
    Ellipse, in the frame of ``pts``.

    Raises
    ------
    ValueError
        Fewer than 5 points, collinear points, or no elliptical solution.
    """
    p = _as_points2(pts, min_count=5)
    if weights is not None:
        w = np.asarray(weights, dtype=np.float64)
        if w.shape != (len(p),) or np.any(w < 0) or not np.all(np.isfinite(w)):
            raise ValueError("weights must be (N,) finite and non-negative")
        if np.count_nonzero(w) < 5:
            raise ValueError("fewer than 5 points with positive weight")
    else:
        w = None
    T = hartley_normalization(p)
    q = p * T[0, 0] + T[:2, 2]
    centred = q - q.mean(axis=0)
    sv = np.linalg.svd(centred, compute_uv=False)
    if sv[1] < 1e-9 * sv[0]:
        raise ValueError("points are collinear: no ellipse through them")
    x, y = q[:, 0], q[:, 1]
    D = np.stack([x * x, x * y, y * y, x, y, np.ones_like(x)], axis=1)
    if w is not None:
        D = D * np.sqrt(w)[:, None]
    coef, valid = direct_fit_scatter((D.T @ D)[None])
    if not valid[0]:
        raise ValueError("no elliptical solution for these points (or a degenerate point set)")
    A, B, Cc, Dd, E, F = coef[0]
    Cn = np.array([[A, B / 2, Dd / 2], [B / 2, Cc, E / 2], [Dd / 2, E / 2, F]])
    return ellipse_from_conic(T.T @ Cn @ T)


def ellipse_distance(pts, ellipse: Ellipse, *, signed: bool = False) -> np.ndarray:
    """Orthogonal (shortest Euclidean) distance from points to an ellipse.

    Uses Eberly's robust bisection in the ellipse's own frame (exact to
    floating-point precision, vectorised).

    Parameters
    ----------
    pts : (N, 2) array_like, same frame as ``ellipse``
    ellipse : Ellipse
    signed : bool
        If True, distances inside the ellipse are negative.

    Returns
    -------
    (N,) float64
    """
    p = _as_points2(pts)
    a, b = ellipse.axes
    ca, sa = np.cos(ellipse.angle), np.sin(ellipse.angle)
    d = p - np.asarray(ellipse.center)
    y0 = np.abs(d[:, 0] * ca + d[:, 1] * sa)
    y1 = np.abs(-d[:, 0] * sa + d[:, 1] * ca)
    x0 = np.empty_like(y0)
    x1 = np.empty_like(y1)
    pos1 = y1 > 1e-12 * a
    pos0 = y0 > 1e-12 * a
    both = pos0 & pos1
    if np.any(both):
        z0, z1 = y0[both] / a, y1[both] / b
        g = z0 * z0 + z1 * z1 - 1.0
        r0 = (a / b) ** 2
        n0 = r0 * z0
        s0 = z1 - 1.0
        s1 = np.where(g < 0, 0.0, np.hypot(n0, z1) - 1.0)
        s = np.zeros_like(z0)
        for _ in range(80):
            s = 0.5 * (s0 + s1)
            ratio0 = n0 / (s + r0)
            ratio1 = z1 / (s + 1.0)
            gs = ratio0 * ratio0 + ratio1 * ratio1 - 1.0
            s1 = np.where(gs > 0, s1, s)
            s0 = np.where(gs > 0, s, s0)
        s = np.where(g == 0, 0.0, s)
        x0[both] = r0 * y0[both] / (s + r0)
        x1[both] = y1[both] / (s + 1.0)
    only0 = pos0 & ~pos1  # on the major axis line
    if np.any(only0):
        num = a * y0[only0]
        den = a * a - b * b
        inner = num < den
        xx = np.where(inner, a * num / np.where(den > 0, den, 1.0), a)
        xx = np.minimum(xx, a)
        x0[only0] = xx
        x1[only0] = np.where(inner, b * np.sqrt(np.clip(1 - (xx / a) ** 2, 0, None)), 0.0)
    only1 = ~pos0  # on the minor axis line (including the centre)
    if np.any(only1):
        x0[only1] = 0.0
        x1[only1] = b
    dist = np.hypot(x0 - y0, x1 - y1)
    if signed:
        inside = (y0 / a) ** 2 + (y1 / b) ** 2 < 1.0
        dist = np.where(inside, -dist, dist)
    return dist


def sampson_distance(pts, C) -> np.ndarray:
    """First-order (Sampson) distance of points to a conic.

    ``d = x^T C x / (2 |(C x)_{1:2}|)`` for ``x = (x, y, 1)``; signed (negative
    inside an ellipse with this module's sign convention).

    Parameters
    ----------
    pts : (N, 2) array_like
    C : (3, 3) array_like

    Returns
    -------
    (N,) float64
    """
    p = _as_points2(pts)
    C = normalize_conic(C)
    X = np.column_stack([p, np.ones(len(p))])
    CX = X @ C
    num = np.einsum("ij,ij->i", CX, X)
    den = 2.0 * np.hypot(CX[:, 0], CX[:, 1])
    return num / np.maximum(den, _EPS)


def refine_ellipse(
    pts,
    ellipse: Ellipse,
    *,
    residual: str = "orthogonal",
    loss: str = "linear",
    f_scale: float = 1.0,
    max_nfev: int = 200,
) -> EllipseFit:
    """Geometric refinement of an ellipse by nonlinear least squares.

    Minimises the orthogonal (or Sampson) distances of ``pts`` to the ellipse
    over its five parameters, starting from ``ellipse``.

    Parameters
    ----------
    pts : (N, 2) array_like, N >= 5
    ellipse : Ellipse, initial estimate in the frame of ``pts``
    residual : {"orthogonal", "sampson"}
    loss : str
        scipy ``least_squares`` loss ("linear", "soft_l1", "huber", "cauchy").
    f_scale : float
        Inlier scale of the robust loss, in the points' units.
    max_nfev : int

    Returns
    -------
    EllipseFit
    """
    p = _as_points2(pts, min_count=5)
    if residual not in ("orthogonal", "sampson"):
        raise ValueError(f"residual must be 'orthogonal' or 'sampson', got {residual!r}")
    scale = max(ellipse.axes[0], 1e-9)

    def unpack(x):
        return Ellipse(
            center=(x[0] * scale, x[1] * scale),
            axes=(abs(x[2]) * scale + 1e-12, abs(x[3]) * scale + 1e-12),
            angle=x[4],
        )

    def fun(x):
        e = unpack(x)
        if residual == "orthogonal":
            return ellipse_distance(p, e, signed=True) / scale
        return sampson_distance(p, e.conic) / scale

    x0 = np.array(
        [ellipse.center[0] / scale, ellipse.center[1] / scale, ellipse.axes[0] / scale, ellipse.axes[1] / scale, ellipse.angle]
    )
    res = scipy.optimize.least_squares(fun, x0, loss=loss, f_scale=f_scale / scale, max_nfev=max_nfev, x_scale="jac")
    e = unpack(res.x)
    d = ellipse_distance(p, e)
    return EllipseFit(ellipse=e, conic=e.conic, rms=float(np.sqrt(np.mean(d * d))), n_points=len(p))


def fit_ellipse(pts, weights=None, *, refine: bool = True, loss: str = "linear", f_scale: float = 1.0) -> EllipseFit:
    """Direct fit followed (optionally) by geometric refinement.

    Parameters
    ----------
    pts : (N, 2) array_like, N >= 5
    weights : (N,) array_like, optional, weights of the direct fit
    refine : bool
        Run :func:`refine_ellipse` with orthogonal distances.
    loss, f_scale : robust loss of the refinement (see :func:`refine_ellipse`).

    Returns
    -------
    EllipseFit
    """
    e = fit_ellipse_direct(pts, weights)
    if refine:
        return refine_ellipse(pts, e, loss=loss, f_scale=f_scale)
    p = np.asarray(pts, dtype=np.float64)
    d = ellipse_distance(p, e)
    return EllipseFit(ellipse=e, conic=e.conic, rms=float(np.sqrt(np.mean(d * d))), n_points=len(p))


def polar(C, point) -> np.ndarray:
    """Polar line of a point with respect to a conic: ``l = C x``.

    Parameters
    ----------
    C : (3, 3) conic
    point : (3,) homogeneous point

    Returns
    -------
    (3,) line (unit norm), same dtype kind as the inputs (complex allowed).
    """
    C = _as_conic(C)
    x = np.asarray(point)
    if x.shape != (3,):
        raise ValueError(f"point must be homogeneous (3,), got {x.shape}")
    line = C @ x
    n = np.linalg.norm(line)
    if n < _EPS:
        raise ValueError("point is a singular point of the conic: polar undefined")
    return line / n


def pole(C, line) -> np.ndarray:
    """Pole of a line with respect to a non-degenerate conic: ``x = C^-1 l``.

    Parameters
    ----------
    C : (3, 3) conic, non-degenerate
    line : (3,) homogeneous line

    Returns
    -------
    (3,) homogeneous point (unit norm).

    Raises
    ------
    ValueError
        If ``C`` is degenerate (rank < 3).
    """
    C = _as_conic(C)
    Cn = C / np.linalg.norm(C)
    sv = np.linalg.svd(Cn, compute_uv=False)
    if sv[-1] < 1e-12 * sv[0]:
        raise ValueError("conic is degenerate: pole undefined")
    line = np.asarray(line)
    if line.shape != (3,):
        raise ValueError(f"line must be homogeneous (3,), got {line.shape}")
    x = np.linalg.solve(Cn, line)
    return x / np.linalg.norm(x)


def _two_points_on_line(line: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two independent homogeneous points on a (possibly complex) line (3,)."""
    cands = [_cross(line, e) for e in np.eye(3)]
    norms = [np.linalg.norm(c) for c in cands]
    order = np.argsort(norms)[::-1]
    p, q = cands[order[0]], cands[order[1]]
    return p / norms[order[0]], q / norms[order[1]]


def intersect_line_conic(C, line, *, allow_complex: bool = False) -> np.ndarray:
    """Intersection points of a line and a conic.

    Parameters
    ----------
    C : (3, 3) conic (real or complex)
    line : (3,) line (real or complex)
    allow_complex : bool
        If False (default), complex intersections raise ``ValueError``.

    Returns
    -------
    (2, 3) homogeneous points (unit norm): float64 when real, complex128 when
    ``allow_complex`` and the points are complex. A tangent line returns the
    contact point twice.

    Raises
    ------
    ValueError
        If the line lies on the conic (degenerate conic), or misses it (complex
        points) and ``allow_complex`` is False.
    """
    C = _as_conic(C)
    line = np.asarray(line)
    if line.shape != (3,) or np.linalg.norm(line) < _EPS:
        raise ValueError("line must be a non-zero homogeneous (3,) vector")
    real_input = not np.iscomplexobj(C) and not np.iscomplexobj(line)
    T = conic_conditioning(C) if real_input else np.eye(3)
    Ti = np.linalg.inv(T)
    Cn = Ti.T @ C @ Ti
    Cn = Cn / np.linalg.norm(Cn)
    ln = Ti.T @ line
    p, q = _two_points_on_line(ln / np.linalg.norm(ln))
    a = p @ Cn @ p
    b = p @ Cn @ q
    c = q @ Cn @ q
    if max(abs(a), abs(b), abs(c)) < 1e-13:
        raise ValueError("line lies on the conic (degenerate conic): intersection undefined")
    disc = b * b - a * c
    scale = max(abs(b * b), abs(a * c), 1e-300)
    if real_input:
        if disc < -1e-9 * scale and not allow_complex:
            raise ValueError("line does not meet the conic (complex intersection)")
        if abs(disc) <= 1e-9 * scale:
            disc = 0.0  # tangent: one double point
    sq = np.sqrt(disc + 0j)
    if abs(a) >= abs(c):
        pts = [((-b + s) / a) * p + q for s in (sq, -sq)]
    else:
        pts = [p + ((-b + s) / c) * q for s in (sq, -sq)]
    out = np.array([x / np.linalg.norm(x) for x in pts]) @ Ti.T
    out /= np.linalg.norm(out, axis=1, keepdims=True)
    if real_input and np.real(disc) >= 0:
        return _real_homogeneous(out)
    if not allow_complex:
        raise ValueError("line does not meet the conic (complex intersection)")
    return out


def _real_homogeneous(x: np.ndarray) -> np.ndarray:
    """Drop a common complex phase from homogeneous rows and return the real part."""
    out = np.empty(x.shape, dtype=np.float64)
    for i, v in enumerate(np.atleast_2d(x)):
        k = np.argmax(np.abs(v))
        v = v * (np.conj(v[k]) / abs(v[k]))
        out[i] = v.real / np.linalg.norm(v.real)
    return out


def split_degenerate_conic(D) -> tuple[np.ndarray, np.ndarray]:
    """Split a degenerate conic (rank <= 2) into its two lines.

    Uses the adjugate construction (Richter-Gebert, *Perspectives on
    Projective Geometry*, sec. 11.3): for ``D = g h^T + h g^T`` the adjugate is
    ``-p p^T`` with ``p = g x h``; adding the cross-product matrix of ``p``
    makes the matrix rank 1, ``g h^T``, whose row and column give the lines.

    Parameters
    ----------
    D : (3, 3) symmetric, rank 1 or 2 (real or complex)

    Returns
    -------
    (g, h) : two (3,) lines (complex128 in general); equal for a double line.
    """
    g, h = split_degenerate_conics(np.asarray(D)[None])
    return g[0], h[0]


def split_degenerate_conics(D) -> tuple[np.ndarray, np.ndarray]:
    """:func:`split_degenerate_conic` for K conics at once.

    Parameters
    ----------
    D : (K, 3, 3) symmetric, each rank 1 or 2 (real or complex)

    Returns
    -------
    (g, h) : (K, 3) complex128 each, unit norm; ``g[k] == h[k]`` for a double line.
    """
    D = np.asarray(D, dtype=np.complex128)
    if D.ndim != 3 or D.shape[1:] != (3, 3):
        raise ValueError(f"conics must be (K, 3, 3), got {D.shape}")
    D = D / np.linalg.norm(D, axis=(1, 2))[:, None, None]
    k = np.arange(len(D))
    c0, c1, c2 = D[:, :, 0], D[:, :, 1], D[:, :, 2]
    B = np.stack([_cross(c1, c2), _cross(c2, c0), _cross(c0, c1)], axis=1)  # adjugates
    double = np.linalg.norm(B, axis=(1, 2)) < 1e-10  # rank 1: a double line
    i = np.argmax(np.abs(np.diagonal(B, axis1=1, axis2=2)), axis=1)
    beta = np.sqrt(-B[k, i, i])
    p = B[k, :, i] / np.where(double, 1.0, beta)[:, None]
    Mp = np.zeros_like(D)
    Mp[:, 0, 1], Mp[:, 0, 2], Mp[:, 1, 2] = p[:, 2], -p[:, 1], p[:, 0]
    Mp[:, 1, 0], Mp[:, 2, 0], Mp[:, 2, 1] = -p[:, 2], p[:, 1], -p[:, 0]
    R1 = D + Mp
    i, j = np.divmod(np.argmax(np.abs(R1).reshape(-1, 9), axis=1), 3)
    g, h = R1[k, i, :], R1[k, :, j]
    if double.any():
        r = np.argmax(np.abs(np.diagonal(D, axis1=1, axis2=2)), axis=1)
        g[double] = h[double] = D[k, r][double]
    return g / np.linalg.norm(g, axis=1, keepdims=True), h / np.linalg.norm(h, axis=1, keepdims=True)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product of 3-vectors along the last axis, (..., 3) each (np.cross
    is slow for single vectors and small stacks)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def conic_conditioning(*conics) -> np.ndarray:
    """Similarity ``T`` (3, 3) that conditions conics given in large coordinates
    (e.g. pixels): it moves the centre of the first real ellipse among
    ``conics`` to the origin and scales its major semi-axis to 1. Transform a
    conic with ``T^-T C T^-1`` and points with ``T x``. Identity if none of
    the conics is a real ellipse.
    """
    for C in conics:
        try:
            e = ellipse_from_conic(C)
        except ValueError:
            continue
        s = 1.0 / e.axes[0]
        return np.array([[s, 0.0, -s * e.center[0]], [0.0, s, -s * e.center[1]], [0.0, 0.0, 1.0]])
    return np.eye(3)


def _condition(T: np.ndarray, C: np.ndarray) -> np.ndarray:
    Ti = np.linalg.inv(T)
    return normalize_conic(Ti.T @ C @ Ti)


def intersect_conics(C1, C2) -> np.ndarray:
    """All four intersection points of two conics, complex ones included.

    Pencil method: a real ``lam`` with ``det(C1 - lam C2) = 0`` gives a
    degenerate member of the pencil, a pair of lines through the four common
    points; each line is then intersected with ``C1``.

    Parameters
    ----------
    C1, C2 : (3, 3) real symmetric conics, at least one non-degenerate

    Returns
    -------
    (4, 3) complex128 homogeneous points, unit norm, each with the phase
    that makes its largest entry real. Real intersections have (numerically)
    zero imaginary part; use :func:`real_points` to keep them. Tangencies
    appear as repeated points.

    Raises
    ------
    ValueError
        If both conics are degenerate or the conics are the same.
    """
    T = conic_conditioning(C1, C2)
    A = _condition(T, normalize_conic(C1))
    B = _condition(T, normalize_conic(C2))
    if min(np.linalg.norm(A - B), np.linalg.norm(A + B)) < 1e-12:
        raise ValueError("the two conics are the same: infinitely many intersections")
    sA = np.linalg.svd(A, compute_uv=False)
    sB = np.linalg.svd(B, compute_uv=False)
    degA, degB = sA[-1] < 1e-12 * sA[0], sB[-1] < 1e-12 * sB[0]
    if degA and degB:
        raise ValueError("both conics are degenerate")
    # base conic (intersected with the lines) must be non-degenerate
    base, other = (A, B) if not degA else (B, A)
    if degA or degB:
        D = other
    else:
        lams = scipy.linalg.eigvals(A, B)
        real = [lam.real for lam in lams if np.isfinite(lam) and abs(lam.imag) < 1e-9 * max(1.0, abs(lam))]
        if not real:  # cannot happen for a real cubic with finite roots; be safe
            real = [lams[np.argmin(np.abs(lams.imag))].real]
        # choose the degenerate member farthest from having a double line
        best, best_score = None, -1.0
        for lam in real:
            Dm = A - lam * B
            s = np.linalg.svd(Dm, compute_uv=False)
            score = s[1] / max(s[0], _EPS)
            if score > best_score:
                best, best_score = Dm, score
        D = best
    g, h = split_degenerate_conic(D)
    pts = []
    for line in (g, h):
        pts.extend(intersect_line_conic(base.astype(np.complex128), line, allow_complex=True))
    out = np.array(pts, dtype=np.complex128) @ np.linalg.inv(T).T
    for i, v in enumerate(out):
        k = np.argmax(np.abs(v))
        out[i] = v * (np.conj(v[k]) / abs(v[k])) / np.linalg.norm(v)
    return out


def real_points(pts, tol: float = 1e-8) -> np.ndarray:
    """Keep the real rows of complex homogeneous points.

    Parameters
    ----------
    pts : (N, 3) complex, each row with its largest entry real (as returned by
        :func:`intersect_conics`)
    tol : float, largest imaginary part (relative to unit norm) taken as real

    Returns
    -------
    (M, 3) float64
    """
    pts = np.atleast_2d(np.asarray(pts))
    keep = np.max(np.abs(pts.imag), axis=1) < tol
    return np.real(pts[keep]).astype(np.float64)


def tangents_from_point(C, point) -> np.ndarray:
    """The two tangent lines from a point to a conic.

    They join the point with the intersections of its polar and the conic.

    Parameters
    ----------
    C : (3, 3) non-degenerate conic
    point : (3,) homogeneous point

    Returns
    -------
    (2, 3) float64 lines (unit norm). A point on the conic returns its tangent twice.

    Raises
    ------
    ValueError
        If the point lies inside the conic (no real tangents).
    """
    C = normalize_conic(C)
    x = np.asarray(point, dtype=np.float64)
    if x.shape != (3,):
        raise ValueError(f"point must be homogeneous (3,), got {x.shape}")
    x = x / np.linalg.norm(x)
    l = polar(C, x)
    if abs(x @ C @ x) < 1e-12:
        return np.array([l, l])
    try:
        touch = intersect_line_conic(C, l)
    except ValueError:
        raise ValueError("point is inside the conic: no real tangent lines") from None
    out = []
    for t in touch:
        m = np.cross(x, t)
        out.append(m / np.linalg.norm(m))
    return np.array(out)


def double_contact(C1, C2, *, tol: float = 1e-6) -> DoubleContact:
    """Test whether two conics have double contact.

    Two conics touch at two points (possibly complex) exactly when their
    pencil contains a rank-1 member, the double line through the two contact
    points: ``C1 - lam C2`` has rank 1 for a (double) generalised eigenvalue.

    Parameters
    ----------
    C1, C2 : (3, 3) conics (normalised internally)
    tol : float, largest ``s2/s1`` accepted as rank 1 (measured after
        :func:`conic_conditioning`, so it does not depend on pixel scale)

    Returns
    -------
    DoubleContact
    """
    T = conic_conditioning(C1, C2)
    A = _condition(T, normalize_conic(C1))
    B = _condition(T, normalize_conic(C2))
    lams = scipy.linalg.eigvals(A, B)
    best = (np.inf, np.nan)
    for lam in lams:
        if not np.isfinite(lam):
            continue
        Dm = A - lam.real * B
        s = np.linalg.svd(Dm, compute_uv=False)
        if s[0] < _EPS:
            continue
        r = s[1] / s[0]
        if r < best[0]:
            best = (r, lam.real)
    ratio, lam = best
    return DoubleContact(holds=bool(ratio < tol), lam=float(lam), rank1_ratio=float(ratio))
