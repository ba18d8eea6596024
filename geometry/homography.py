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
from geometry.lines import _hartley_batch, _unit_lines, _zero_lines, hartley_normalization, normalize_line

__all__ = [
    "homography_from_points",
    "homography_from_lines",
    "homographies_from_lines",
    "homographies_from_four_points",
    "normalize_homography",
    "normalize_homographies",
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
    return normalize_homographies(_check_h(H)[None])[0]


def normalize_homographies(H: np.ndarray) -> np.ndarray:
    """:func:`normalize_homography`'s scale and sign for K homographies (K, 3, 3)
    (none singular)."""
    H = H / np.linalg.norm(H, axis=(1, 2), keepdims=True)
    flat = H.reshape(len(H), 9)
    ref = np.where(np.abs(H[:, 2, 2]) > 1e-12, H[:, 2, 2], flat[np.arange(len(H)), np.argmax(np.abs(flat), axis=1)])
    return H * np.where(ref < 0, -1.0, 1.0)[:, None, None]


def _dlt(X_src: np.ndarray, X_dst: np.ndarray) -> np.ndarray:
    """Homogeneous DLT on (N, 3) -> (N, 3) correspondences: H (3, 3) and the 9 singular
    values of the design matrix (zero-padded), so ``s[7]`` tells a second null vector."""
    H, s = _dlt_batch(X_src[None], X_dst[None])
    return H[0], s[0]


def _dlt_batch(X_src: np.ndarray, X_dst: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_dlt` for K problems at once: (K, N, 3) each -> (K, 3, 3), (K, 9)."""
    k, n = X_src.shape[:2]
    A = np.zeros((k, 2 * n, 9))
    Xs = X_src
    xd, yd, wd = X_dst[..., 0:1], X_dst[..., 1:2], X_dst[..., 2:3]
    A[:, 0::2, 3:6] = -wd * Xs
    A[:, 0::2, 6:9] = yd * Xs
    A[:, 1::2, 0:3] = wd * Xs
    A[:, 1::2, 6:9] = -xd * Xs
    _, s, Vt = np.linalg.svd(A, full_matrices=2 * n < 9)  # thin SVD: A is 2N x 9
    s9 = np.zeros((k, 9))
    s9[:, : s.shape[1]] = s
    return Vt[:, -1].reshape(k, 3, 3), s9


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
    """Similarities T (K, 3, 3) that condition K sets of lines (K, N, 3): Hartley on
    the feet of the perpendiculars from the origin; identity where fewer than two
    feet exist or they coincide."""
    n2 = L[..., 0] ** 2 + L[..., 1] ** 2
    has = n2 > 1e-24
    feet = -L[..., 2:3] * L[..., :2] / np.where(has, n2, 1.0)[..., None]
    T, ok = _hartley_batch(feet, has)
    T[~(ok & (has.sum(axis=1) >= 2))] = np.eye(3)
    return T


def homographies_from_lines(src_lines, dst_lines) -> tuple[np.ndarray, np.ndarray]:
    """:func:`homography_from_lines` for K sets of line correspondences at once
    (one batched SVD: for the many assignment hypotheses of a line initialiser).

    Parameters
    ----------
    src_lines : (K, N, 3) array_like, N >= 4, lines in the source frame
    dst_lines : (K, N, 3) or (N, 3) array_like, the same lines in the destination
        frame (one set shared by all K)

    Returns
    -------
    (H (K, 3, 3) float64 ``H_dst_from_src`` (unit norm, ``H[2, 2] >= 0``),
    ok (K,) bool): where ``ok`` is False the set is degenerate (concurrent or
    repeated lines) and ``H`` is meaningless.
    """
    Ls = np.asarray(src_lines, dtype=np.float64)
    if Ls.ndim != 3 or Ls.shape[2] != 3:
        raise ValueError(f"line arrays must be (K, N, 3), got {Ls.shape}")
    if Ls.shape[1] < 4:
        raise ValueError(f"a homography needs at least 4 line correspondences, got {Ls.shape[1]}")
    if len(Ls) == 0:
        return np.zeros((0, 3, 3)), np.zeros(0, bool)
    Ls = _unit_lines(Ls)
    Ld = _unit_lines(np.broadcast_to(np.asarray(dst_lines, dtype=np.float64), Ls.shape))
    Ts, Td = _line_conditioning(Ls), _line_conditioning(Ld)
    # lines in conditioned frames: l_n = T^-T l, i.e. rows l @ T^-1
    Lsn = np.einsum("kni,kij->knj", Ls, np.linalg.inv(Ts))
    Ldn = np.einsum("kni,kij->knj", Ld, np.linalg.inv(Td))
    Lsn /= np.linalg.norm(Lsn, axis=2, keepdims=True)
    Ldn /= np.linalg.norm(Ldn, axis=2, keepdims=True)
    Gn, sv = _dlt_batch(Lsn, Ldn)  # l_dst_n ~ Gn l_src_n, Gn = Hn^-T
    ok = sv[:, 7] >= 1e-8 * sv[:, 0]
    g = np.linalg.svd(Gn, compute_uv=False)
    ok &= g[:, 2] > 1e-12 * g[:, 0]
    Gn[~ok] = np.eye(3)
    Hn = np.transpose(np.linalg.inv(Gn), (0, 2, 1))
    H = np.linalg.solve(Td, Hn @ Ts)
    h = np.linalg.svd(H, compute_uv=False)
    ok &= h[:, 2] >= 1e-12 * h[:, 0]
    return normalize_homographies(H), ok


def _projective_bases(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """M (K, 3, 3) with M e_i ~ p_i (i = 1..3) and M (1, 1, 1) ~ p_4 for K sets
    of four homogeneous points (K, 4, 3): ``M = [p1 p2 p3] diag(l)``,
    ``l = [p1 p2 p3]^-1 p4``; ok (K,) False where three of the four are
    collinear (or two coincide) and M is the identity."""
    P = P / np.linalg.norm(P, axis=2, keepdims=True)
    A = np.transpose(P[:, :3], (0, 2, 1))  # columns p1 p2 p3
    ok = np.all(np.isfinite(P), axis=(1, 2))
    for i, j, k in ((0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)):
        with np.errstate(invalid="ignore"):
            ok &= np.abs(np.einsum("ki,ki->k", P[:, i], np.cross(P[:, j], P[:, k]))) > 1e-10
    A[~ok] = np.eye(3)
    lam = np.linalg.solve(A, np.where(ok[:, None], P[:, 3], 1.0)[..., None])[..., 0]
    return A * lam[:, None, :], ok


def homographies_from_four_points(src, dst) -> tuple[np.ndarray, np.ndarray]:
    """The homographies of K sets of exactly four point correspondences, in
    closed form: each set of four points in general position is the image of
    the projective basis (e1, e2, e3, (1, 1, 1)) under ``M = [p1 p2 p3]
    diag(l)``, ``l = [p1 p2 p3]^-1 p4``, so ``H = M_dst M_src^-1``. Exact as
    the DLT is for four correspondences, without its SVD per set (a line
    initialiser's many assignment hypotheses: the corners of two lines of
    each direction). Points may be at infinity; give coordinates of order
    one (conditioned) for full precision.

    Parameters
    ----------
    src, dst : (K, 4, 3) array_like, homogeneous points in the source and
        destination frames

    Returns
    -------
    (H (K, 3, 3) float64 ``H_dst_from_src`` (unit norm, ``H[2, 2] >= 0``),
    ok (K,) bool): where ``ok`` is False three points of a set are
    collinear (or two coincide) and ``H`` is meaningless.
    """
    S, D = np.asarray(src, dtype=np.float64), np.asarray(dst, dtype=np.float64)
    if S.ndim != 3 or S.shape[1:] != (4, 3) or D.shape != S.shape:
        raise ValueError(f"point arrays must both be (K, 4, 3), got {S.shape} and {D.shape}")
    if len(S) == 0:
        return np.zeros((0, 3, 3)), np.zeros(0, bool)
    Ms, oks = _projective_bases(S)
    Md, okd = _projective_bases(D)
    H = Md @ np.linalg.inv(Ms)
    ok = oks & okd
    H[~ok] = np.eye(3)
    return normalize_homographies(H), ok


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
    if _zero_lines(Ls).any() or _zero_lines(Ld).any():
        raise ValueError("line vector is zero")
    H, ok = homographies_from_lines(Ls[None], Ld[None])
    if not ok[0]:
        raise ValueError("degenerate lines (concurrent or repeated): homography undefined")
    return H[0]


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
