"""Shared fitting helpers of the calibration library (private).

* Conics as 6-vectors and Sampson distances of points to many conics at once,
  with their analytic derivative with respect to the conic entries (the
  expensive, per-point part of a Jacobian), so that a least-squares problem
  only needs finite differences of the cheap map parameters -> 3x3 conic.
* Central finite differences of small vector functions.
* Absolute orientation (Umeyama 1991 / Horn 1987) between two 3-D point sets.
* Rotation vectors <-> rotation matrices.

Conics follow ``geometry.conics``: symmetric 3x3 ``C`` with ``x^T C x = 0``.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

__all__ = [
    "conic_to_vec6",
    "vec6_to_conic",
    "sampson_with_jacobian",
    "central_difference",
    "absolute_orientation",
    "rotation_from_rotvec",
    "rotvec_from_rotation",
]

# order of the 6 unique entries: c11, c12, c22, c13, c23, c33
_IDX = ((0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2))


def conic_to_vec6(C: np.ndarray) -> np.ndarray:
    """(..., 3, 3) symmetric -> (..., 6) ``(c11, c12, c22, c13, c23, c33)``."""
    C = np.asarray(C, dtype=np.float64)
    return np.stack([C[..., i, j] for i, j in _IDX], axis=-1)


def vec6_to_conic(c: np.ndarray) -> np.ndarray:
    """(..., 6) -> (..., 3, 3) symmetric; inverse of :func:`conic_to_vec6`."""
    c = np.asarray(c, dtype=np.float64)
    C = np.empty(c.shape[:-1] + (3, 3))
    for k, (i, j) in enumerate(_IDX):
        C[..., i, j] = c[..., k]
        C[..., j, i] = c[..., k]
    return C


def sampson_with_jacobian(pts: np.ndarray, index: np.ndarray, conics: np.ndarray, *, jac: bool = True):
    """Sampson distances of points to their conics, and their derivatives.

    ``d = x^T C x / (2 |(C x)_{1:2}|)`` with ``x = (x, y, 1)``.

    Parameters
    ----------
    pts : (N, 2) float64, points (pixels)
    index : (N,) int, which conic each point belongs to
    conics : (M, 3, 3) float64, symmetric (any scale)
    jac : bool, also return the derivative

    Returns
    -------
    d : (N,) float64, signed Sampson distances (pixels)
    J : (N, 6) float64, ``dd / d(c11, c12, c22, c13, c23, c33)`` of each
        point's own conic (only if ``jac``)
    """
    x, y = pts[:, 0], pts[:, 1]
    c = conic_to_vec6(conics)[index]
    c11, c12, c22, c13, c23, c33 = c.T
    num = c11 * x * x + 2 * c12 * x * y + c22 * y * y + 2 * c13 * x + 2 * c23 * y + c33
    g1 = c11 * x + c12 * y + c13
    g2 = c12 * x + c22 * y + c23
    gn = np.maximum(np.hypot(g1, g2), 1e-300)
    d = num / (2.0 * gn)
    if not jac:
        return d
    one = np.ones_like(x)
    zero = np.zeros_like(x)
    dnum = np.stack([x * x, 2 * x * y, y * y, 2 * x, 2 * y, one], axis=1)
    dg1 = np.stack([x, y, zero, one, zero, zero], axis=1)
    dg2 = np.stack([zero, x, y, zero, one, zero], axis=1)
    dgn = (g1[:, None] * dg1 + g2[:, None] * dg2) / gn[:, None]
    J = dnum / (2.0 * gn[:, None]) - (num / (2.0 * gn * gn))[:, None] * dgn
    return d, J


def central_difference(fun, x: np.ndarray, step: np.ndarray | float = 1e-6) -> np.ndarray:
    """Jacobian ``d fun / d x`` of a small vector function by central differences.

    Parameters
    ----------
    fun : callable (P,) -> (Q,) or (B, Q) (a batch is differentiated entry-wise)
    x : (P,) float64
    step : float or (P,), absolute steps

    Returns
    -------
    (Q, P) float64, or (B, Q, P) for batched outputs.
    """
    x = np.asarray(x, dtype=np.float64)
    h = np.broadcast_to(np.asarray(step, dtype=np.float64), x.shape)
    cols = []
    for k in range(len(x)):
        e = np.zeros_like(x)
        e[k] = h[k]
        cols.append((np.asarray(fun(x + e)) - np.asarray(fun(x - e))) / (2.0 * h[k]))
    return np.stack(cols, axis=-1)


def absolute_orientation(src, dst, *, with_scale: bool = False, weights=None):
    """Least-squares similarity (or rigid) transform ``dst ~ s R src + t``.

    Umeyama (PAMI 1991), the closed form of Horn's absolute orientation.

    Parameters
    ----------
    src, dst : (N, 3) float64, corresponding points, N >= 3, not collinear
    with_scale : bool, estimate ``s`` (else ``s = 1``)
    weights : (N,) float64, optional non-negative weights

    Returns
    -------
    R : (3, 3) rotation (det +1), t : (3,), s : float

    Raises
    ------
    ValueError
        Shapes differ, fewer than 3 points, or the points are collinear.
    """
    P = np.asarray(src, dtype=np.float64)
    Q = np.asarray(dst, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3 or P.shape != Q.shape:
        raise ValueError(f"absolute orientation needs two (N, 3) point sets of equal shape, got {P.shape} and {Q.shape}")
    if len(P) < 3:
        raise ValueError(f"absolute orientation needs at least 3 points, got {len(P)}")
    w = np.ones(len(P)) if weights is None else np.asarray(weights, dtype=np.float64)
    w = w / w.sum()
    mp, mq = w @ P, w @ Q
    Pc, Qc = P - mp, Q - mq
    sv = np.linalg.svd(Pc * np.sqrt(w)[:, None], compute_uv=False)
    if sv[1] < 1e-9 * max(sv[0], 1e-300):
        raise ValueError("absolute orientation is undefined: the points are collinear")
    S = (Qc * w[:, None]).T @ Pc
    U, D, Vt = np.linalg.svd(S)
    E = np.eye(3)
    if np.linalg.det(U) * np.linalg.det(Vt) < 0:
        E[2, 2] = -1.0
    R = U @ E @ Vt
    s = 1.0
    if with_scale:
        var = (w * (Pc * Pc).sum(axis=1)).sum()
        s = float(np.trace(np.diag(D) @ E) / var)
    t = mq - s * R @ mp
    return R, t, s


def rotation_from_rotvec(r) -> np.ndarray:
    """(3,) rotation vector (radians) -> (3, 3) rotation matrix."""
    return Rotation.from_rotvec(np.asarray(r, dtype=np.float64)).as_matrix()


def rotvec_from_rotation(R) -> np.ndarray:
    """(3, 3) rotation matrix -> (3,) rotation vector (radians)."""
    return Rotation.from_matrix(np.asarray(R, dtype=np.float64)).as_rotvec()

