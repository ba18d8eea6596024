"""Plane homographies: normalised DLT from points or lines, and transfer of
points, lines and conics.

A homography ``H_dst_from_src`` (3, 3) maps homogeneous points
``x_dst ~ H x_src``; lines then map as ``l_dst ~ H^-T l_src`` and conics as
``C_dst ~ H^-T C_src H^-1``. Homographies returned here have unit Frobenius
norm and ``H[2, 2] >= 0``.

>>> H = np.array([[1.2, 0.1, 5.0], [-0.05, 0.9, -3.0], [1e-3, 2e-3, 1.0]])
>>> src = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 80.0], [0.0, 80.0], [40.0, 30.0]])
>>> H2 = homography_from_points(src, transfer_points(H, src))
>>> bool(np.allclose(H2, H / np.linalg.norm(H)))
True
"""

from __future__ import annotations

import numpy as np

from geometry.conics import normalize_conic
from geometry.lines import hartley_normalization, normalize_line

__all__ = [
    "homography_from_points",
    "homography_from_lines",
    "normalize_homography",
    "transfer_points",
    "transfer_lines",
    "transfer_conic",
]


def _check_h(H) -> np.ndarray:
    H = np.asarray(H, dtype=np.float64)
    if H.shape != (3, 3):
        raise ValueError(f"homography must be 3x3, got {H.shape}")
    if not np.all(np.isfinite(H)):
        raise ValueError("homography has non-finite entries")
    s = np.linalg.svd(H, compute_uv=False)
    if s[0] == 0 or s[-1] < 1e-12 * s[0]:
        raise ValueError("homography is singular")
    return H


def normalize_homography(H) -> np.ndarray:
    """Scale (3, 3) ``H`` to unit Frobenius norm with ``H[2, 2] >= 0`` (sign of
    the largest entry when ``H[2, 2]`` is 0). Raises ``ValueError`` if singular."""
    H = _check_h(H)
    H = H / np.linalg.norm(H)
    ref = H[2, 2] if abs(H[2, 2]) > 1e-12 else H.flat[np.argmax(np.abs(H))]
    return -H if ref < 0 else H


def _dlt(X_src: np.ndarray, X_dst: np.ndarray) -> np.ndarray:
    """Homogeneous DLT on (N, 3) -> (N, 3) correspondences: H (3, 3) and the 9 singular
    values of the design matrix (zero-padded), so ``s[7]`` tells a second null vector."""
    n = len(X_src)
    A = np.zeros((2 * n, 9))
    x, y, w = X_src[:, 0:1], X_src[:, 1:2], X_src[:, 2:3]
    xd, yd, wd = X_dst[:, 0:1], X_dst[:, 1:2], X_dst[:, 2:3]
    Xs = np.hstack([x, y, w])
    A[0::2, 3:6] = -wd * Xs
    A[0::2, 6:9] = yd * Xs
    A[1::2, 0:3] = wd * Xs
    A[1::2, 6:9] = -xd * Xs
    _, s, Vt = np.linalg.svd(A, full_matrices=len(A) < 9)  # thin SVD: A is 2N x 9
    s9 = np.zeros(9)
    s9[: len(s)] = s
    return Vt[-1].reshape(3, 3), s9


def _as_pts(p, name):
    p = np.asarray(p, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"{name} must have shape (N, 2), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError(f"{name} has non-finite coordinates")
    return p


def homography_from_points(src, dst) -> np.ndarray:
    """Normalised DLT homography from point correspondences.

    Parameters
    ----------
    src : (N, 2) array_like, N >= 4, points in the source frame
    dst : (N, 2) array_like, the same points in the destination frame

    Returns
    -------
    (3, 3) float64 ``H_dst_from_src`` (unit norm).

    Raises
    ------
    ValueError
        Fewer than 4 points, mismatched shapes, or a degenerate configuration
        (three of four points collinear, repeated points).
    """
    src = _as_pts(src, "src")
    dst = _as_pts(dst, "dst")
    if src.shape != dst.shape:
        raise ValueError(f"src and dst must have the same shape, got {src.shape} and {dst.shape}")
    if len(src) < 4:
        raise ValueError(f"a homography needs at least 4 point correspondences, got {len(src)}")
    try:
        Ts, Td = hartley_normalization(src), hartley_normalization(dst)
    except ValueError:
        raise ValueError("degenerate points (all coincident): homography undefined") from None
    Xs = np.column_stack([src, np.ones(len(src))]) @ Ts.T
    Xd = np.column_stack([dst, np.ones(len(dst))]) @ Td.T
    Hn, s = _dlt(Xs, Xd)
    if s[7] < 1e-8 * s[0]:
        raise ValueError("degenerate points (collinear or repeated): homography undefined")
    H = np.linalg.solve(Td, Hn @ Ts)
    try:
        return normalize_homography(H)
    except ValueError:
        raise ValueError("degenerate points (collinear or repeated): homography undefined") from None


def _line_conditioning(L: np.ndarray) -> np.ndarray:
    """Similarity T (3, 3) that conditions lines (N, 3): Hartley on the feet of the
    perpendiculars from the origin; identity if they coincide."""
    feet = []
    for l in L:
        n2 = l[0] ** 2 + l[1] ** 2
        if n2 > 1e-24:
            feet.append(-l[2] * l[:2] / n2)
    if len(feet) < 2:
        return np.eye(3)
    try:
        return hartley_normalization(np.array(feet))
    except ValueError:
        return np.eye(3)


def homography_from_lines(src_lines, dst_lines) -> np.ndarray:
    """Normalised DLT homography from line correspondences.

    Lines transform contravariantly (``l_dst ~ H^-T l_src``); the DLT is run
    on the lines as dual points in conditioned frames and inverted-transposed.

    Parameters
    ----------
    src_lines : (N, 3) array_like, N >= 4, lines in the source frame
    dst_lines : (N, 3) array_like, the same lines in the destination frame

    Returns
    -------
    (3, 3) float64 ``H_dst_from_src`` mapping *points* (unit norm).

    Raises
    ------
    ValueError
        Fewer than 4 lines, or a degenerate set (three of four concurrent,
        repeated lines).
    """
    Ls = np.asarray(src_lines, dtype=np.float64)
    Ld = np.asarray(dst_lines, dtype=np.float64)
    if Ls.ndim != 2 or Ls.shape[1] != 3 or Ls.shape != Ld.shape:
        raise ValueError(f"line arrays must both be (N, 3), got {Ls.shape} and {Ld.shape}")
    if len(Ls) < 4:
        raise ValueError(f"a homography needs at least 4 line correspondences, got {len(Ls)}")
    Ls = np.array([normalize_line(l) for l in Ls])
    Ld = np.array([normalize_line(l) for l in Ld])
    Ts, Td = _line_conditioning(Ls), _line_conditioning(Ld)
    # lines in conditioned frames: l_n = T^-T l
    Lsn = Ls @ np.linalg.inv(Ts)
    Ldn = Ld @ np.linalg.inv(Td)
    Lsn /= np.linalg.norm(Lsn, axis=1, keepdims=True)
    Ldn /= np.linalg.norm(Ldn, axis=1, keepdims=True)
    Gn, s = _dlt(Lsn, Ldn)  # l_dst_n ~ Gn l_src_n, Gn = Hn^-T
    if s[7] < 1e-8 * s[0]:
        raise ValueError("degenerate lines (concurrent or repeated): homography undefined")
    try:
        Hn = np.linalg.inv(Gn).T
    except np.linalg.LinAlgError:
        raise ValueError("degenerate lines (concurrent or repeated): homography undefined") from None
    H = np.linalg.solve(Td, Hn @ Ts)
    return normalize_homography(H)


def transfer_points(H_dst_from_src, pts) -> np.ndarray:
    """Map points (N, 2) through ``H_dst_from_src``: (N, 2) float64.

    Raises ``ValueError`` if ``H`` is singular or a point maps to infinity.
    """
    H = _check_h(H_dst_from_src)
    p = _as_pts(pts, "pts")
    X = p @ H[:, :2].T + H[:, 2]
    w = X[:, 2]
    if np.any(np.abs(w) < 1e-12 * np.maximum(1.0, np.abs(X[:, :2]).max(axis=1))):
        raise ValueError("a point maps to infinity under this homography")
    return X[:, :2] / w[:, None]


def transfer_lines(H_dst_from_src, lines) -> np.ndarray:
    """Map lines (N, 3) through ``H_dst_from_src``: ``l' ~ H^-T l``, (N, 3) normalised."""
    H = _check_h(H_dst_from_src)
    L = np.asarray(lines, dtype=np.float64)
    if L.ndim != 2 or L.shape[1] != 3:
        raise ValueError(f"lines must have shape (N, 3), got {L.shape}")
    Lp = L @ np.linalg.inv(H)  # rows: (H^-T l)^T = l^T H^-1
    return np.array([normalize_line(l) for l in Lp])


def transfer_conic(H_dst_from_src, C) -> np.ndarray:
    """Map a conic (3, 3) through ``H_dst_from_src``: ``C' ~ H^-T C H^-1``, normalised."""
    H = _check_h(H_dst_from_src)
    Hi = np.linalg.inv(H)
    C = np.asarray(C, dtype=np.float64)
    if C.shape != (3, 3):
        raise ValueError(f"conic must be 3x3, got {C.shape}")
    return normalize_conic(Hi.T @ C @ Hi)
