"""Compiled loops of the ellipse stage (:mod:`arstream.detect.ellipses`, numba):
direct least-squares conic fits (one and batched), the scatter matrices of
the arcs, Hartley normalisation, the points within a band of a conic, the
geometric refinement of a fit, the screen of hypotheses by their ellipse
parameters, and the perimeter coverage of the validation.

Compiled on first use and cached next to this file (numba's ``cache=True``);
:func:`arstream.kernels.warm_up` loads them ahead of a run.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from arstream.jit import JIT as _JIT, compiled
from geometry.conics import ellipse_params_sym
from geometry.lines import eigh_sym2

__all__ = ["conic_band", "conic_counts", "direct_fit", "direct_fits", "ellipse_params", "frame_ellipse", "hartley_monomials", "label_scatters", "perimeter_bins", "refine_conic", "warm_up"]

_ellipse_params_sym = compiled(ellipse_params_sym, eigh_sym2=compiled(eigh_sym2))


@nb.njit(**_JIT)
def conic_band(coef, q, nrm, idx, band, min_cos, scatter):
    """Points near a conic, and their weighted scatter of conic monomials.

    For each point q[idx[k]] (normalised coordinates), the conic's algebraic
    value f and gradient g give the Sampson distance d = |f| / |g|. Selected:
    d < ``band`` and, when ``min_cos`` > 0, the point's normal agreeing with the
    gradient (|n . g| > min_cos |g|). With ``scatter``, the selected points'
    monomials (x^2, xy, y^2, x, y, 1) are summed as D D^T / |g|^2, scaled so
    that the weights average 1 (iteratively reweighted direct fits: the
    gradient weights make the algebraic fit nearly geometric).

    Parameters
    ----------
    coef : (6,) conic [A, B, C, D, E, F] (A x^2 + B xy + C y^2 + D x + E y + F)
    q, nrm : (N, 2) points and unit normals
    idx : (M,) int64 indices into q
    band : float, distance bound (units of q)
    min_cos : float, least |cos| between normal and gradient (0: no test)
    scatter : bool, whether to sum the scatter matrix

    Returns
    -------
    sel : (M,) bool, the selected points
    d : (M,) float64, Sampson distances (units of q)
    S : (6, 6) float64 weighted scatter (zeros when ``scatter`` is False)
    """
    A, B, C, D, E, F = coef[0], coef[1], coef[2], coef[3], coef[4], coef[5]
    m = idx.shape[0]
    sel = np.zeros(m, np.bool_)
    d = np.empty(m)
    S = np.zeros((6, 6))
    wsum = 0.0
    ns = 0
    mono = np.empty(6)
    for k in range(m):
        j = idx[k]
        x = q[j, 0]
        y = q[j, 1]
        f = A * x * x + B * x * y + C * y * y + D * x + E * y + F
        gx = 2.0 * A * x + B * y + D
        gy = B * x + 2.0 * C * y + E
        gn = np.sqrt(gx * gx + gy * gy) + 1e-12
        dk = abs(f) / gn
        d[k] = dk
        if dk < band and (min_cos <= 0.0 or abs(nrm[j, 0] * gx + nrm[j, 1] * gy) > min_cos * gn):
            sel[k] = True
            ns += 1
            if scatter:
                w = 1.0 / (gn * gn)
                wsum += w
                mono[0] = x * x
                mono[1] = x * y
                mono[2] = y * y
                mono[3] = x
                mono[4] = y
                mono[5] = 1.0
                for r in range(6):
                    wr = w * mono[r]
                    for c in range(r, 6):
                        S[r, c] += wr * mono[c]
    if scatter and ns > 0:
        scale = ns / wsum
        for r in range(6):
            for c in range(r, 6):
                S[r, c] *= scale
                S[c, r] = S[r, c]
    return sel, d, S


@nb.njit(**_JIT)
def _eigvec3(M, lam):
    """Unit eigenvector of the 3x3 ``M`` for its eigenvalue ``lam``: the largest
    cross product of two rows of M - lam I (zeros when there is none)."""
    a0 = M[0, 0] - lam
    a1 = M[0, 1]
    a2 = M[0, 2]
    b0 = M[1, 0]
    b1 = M[1, 1] - lam
    b2 = M[1, 2]
    c0 = M[2, 0]
    c1 = M[2, 1]
    c2 = M[2, 2] - lam
    best = np.zeros(3)
    bn = 0.0
    for k in range(3):
        if k == 0:
            x = a1 * b2 - a2 * b1
            y = a2 * b0 - a0 * b2
            z = a0 * b1 - a1 * b0
        elif k == 1:
            x = a1 * c2 - a2 * c1
            y = a2 * c0 - a0 * c2
            z = a0 * c1 - a1 * c0
        else:
            x = b1 * c2 - b2 * c1
            y = b2 * c0 - b0 * c2
            z = b0 * c1 - b1 * c0
        nn = x * x + y * y + z * z
        if nn > bn:
            bn = nn
            best[0] = x
            best[1] = y
            best[2] = z
    if bn > 0:
        best /= np.sqrt(bn)
    return best


@nb.njit(**_JIT)
def direct_fit(S):
    """The direct least-squares ellipse fit (Halir-Flusser) from a scatter matrix.

    With S = [[S1, S2], [S2^T, S3]] (3x3 blocks) of the monomials ``[x^2, xy,
    y^2, x, y, 1]``, the quadratic part ``a1`` is the eigenvector of
    ``C1^-1 (S1 - S2 S3^-1 S2^T)`` with ``4 A C - B^2 > 0`` (of least
    |eigenvalue| when rounding makes more than one pass), and the linear part
    ``-S3^-1 S2^T a1``. The reduced 3x3 problem has real eigenvalues (roots of
    its characteristic cubic; eigenvectors by cross products).

    Parameters
    ----------
    S : (6, 6) float64

    Returns
    -------
    coef : (6,) [A, B, C, D, E, F] (unit quadratic part; NaN when not ok)
    ok : bool, False for a degenerate scatter or no elliptical solution
    """
    coef = np.full(6, np.nan)
    # T = -S3^-1 S2^T: Gaussian elimination with partial pivoting
    A = S[3:, 3:].copy()
    R = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            R[i, j] = -S[j, 3 + i]
    scale = 0.0
    for i in range(3):
        for j in range(3):
            scale = max(scale, abs(A[i, j]))
    if not scale > 0:
        return coef, False
    for c in range(3):
        p = c
        for r in range(c + 1, 3):
            if abs(A[r, c]) > abs(A[p, c]):
                p = r
        if not abs(A[p, c]) > 1e-14 * scale:
            return coef, False
        if p != c:
            for j in range(3):
                t = A[c, j]
                A[c, j] = A[p, j]
                A[p, j] = t
                t = R[c, j]
                R[c, j] = R[p, j]
                R[p, j] = t
        for r in range(c + 1, 3):
            f = A[r, c] / A[c, c]
            for j in range(3):
                A[r, j] -= f * A[c, j]
                R[r, j] -= f * R[c, j]
    T = np.empty((3, 3))
    for c in range(2, -1, -1):
        for j in range(3):
            v = R[c, j]
            for k in range(c + 1, 3):
                v -= A[c, k] * T[k, j]
            T[c, j] = v / A[c, c]
    # M = S1 + S2 T, then C1^-1 M: rows (M[2] / 2, -M[1], M[0] / 2)
    M = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            v = S[i, j]
            for k in range(3):
                v += S[i, 3 + k] * T[k, j]
            M[i, j] = v
    Mp = np.empty((3, 3))
    for j in range(3):
        Mp[0, j] = 0.5 * M[2, j]
        Mp[1, j] = -M[1, j]
        Mp[2, j] = 0.5 * M[0, j]
    for i in range(3):
        for j in range(3):
            if not np.isfinite(Mp[i, j]):
                return coef, False
    # eigenvalues: the real roots of the characteristic cubic l^3 + a l^2 + b l + c
    a = -(Mp[0, 0] + Mp[1, 1] + Mp[2, 2])
    b = Mp[0, 0] * Mp[1, 1] - Mp[0, 1] * Mp[1, 0] + Mp[0, 0] * Mp[2, 2] - Mp[0, 2] * Mp[2, 0] + Mp[1, 1] * Mp[2, 2] - Mp[1, 2] * Mp[2, 1]
    det = (
        Mp[0, 0] * (Mp[1, 1] * Mp[2, 2] - Mp[1, 2] * Mp[2, 1])
        - Mp[0, 1] * (Mp[1, 0] * Mp[2, 2] - Mp[1, 2] * Mp[2, 0])
        + Mp[0, 2] * (Mp[1, 0] * Mp[2, 1] - Mp[1, 1] * Mp[2, 0])
    )
    c = -det
    p3 = (b - a * a / 3.0) / 3.0
    q2 = 0.5 * (2.0 * a * a * a / 27.0 - a * b / 3.0 + c)
    disc = q2 * q2 + p3 * p3 * p3
    lams = np.empty(3)
    nl = 0
    if disc <= 0.0 and p3 < 0.0:
        r = np.sqrt(-p3)
        cosv = min(max(-q2 / (r * r * r), -1.0), 1.0)
        phi = np.arccos(cosv)
        for k in range(3):
            lams[k] = 2.0 * r * np.cos((phi + 2.0 * np.pi * k) / 3.0) - a / 3.0
        nl = 3
    else:
        sd = np.sqrt(max(disc, 0.0))
        lams[0] = np.cbrt(-q2 + sd) + np.cbrt(-q2 - sd) - a / 3.0
        nl = 1
    best = np.inf
    a1 = np.zeros(3)
    for k in range(nl):
        v = _eigvec3(Mp, lams[k])
        if 4.0 * v[0] * v[2] - v[1] * v[1] > 0 and abs(lams[k]) < best:
            best = abs(lams[k])
            a1 = v
    if best == np.inf:
        return coef, False
    for i in range(3):
        coef[i] = a1[i]
        coef[3 + i] = T[i, 0] * a1[0] + T[i, 1] * a1[1] + T[i, 2] * a1[2]
    return coef, True


@nb.njit(**_JIT)
def ellipse_params(coef, s, mx, my):
    """Semi-axes and major-axis angles of conics in normalised coordinates
    ``q = s (p - m)``, in pixels ``p``: the hypotheses' screen of the ellipse
    search, one pass instead of dozens of small numpy operations.

    Parameters
    ----------
    coef : (K, 6) float64 conics ``[A, B, C, D, E, F]`` in ``q``
    s, mx, my : float, the normalisation ``q = s (p - (mx, my))``

    Returns
    -------
    a, b : (K,) semi-axes in pixels, ``a >= b`` (1 where not an ellipse)
    angle : (K,) major-axis angle in [-pi/2, pi/2)
    ok : (K,) bool, a real ellipse with finite axes (False for a zero or NaN row)
    """
    k = coef.shape[0]
    a_out, b_out, ang_out = np.ones(k), np.ones(k), np.empty(k)
    ok_out = np.zeros(k, np.bool_)
    for i in range(k):
        A, B, C, D, E, F = coef[i, 0], coef[i, 1], coef[i, 2], coef[i, 3], coef[i, 4], coef[i, 5]
        # the conic in pixels, unit norm
        A2, B2, C2 = A * s * s, B * s * s, C * s * s
        D2 = D * s - 2 * A2 * mx - B2 * my
        E2 = E * s - 2 * C2 * my - B2 * mx
        F2 = A2 * mx * mx + B2 * mx * my + C2 * my * my - D * s * mx - E * s * my + F
        nn = math.sqrt(A2 * A2 + B2 * B2 + C2 * C2 + D2 * D2 + E2 * E2 + F2 * F2)
        if not nn > 0.0:  # a zero or NaN row (a failed fit): no ellipse
            ang_out[i] = math.nan
            continue
        A, B, C, D, E, F = A2 / nn, B2 / nn, C2 / nn, D2 / nn, E2 / nn, F2 / nn
        # centre, value there, eigenvalues of [[A, B/2], [B/2, C]]
        det = 4 * A * C - B * B
        ok = det > 1e-300
        if not ok:
            det = 1.0
        xc = (B * E - 2 * C * D) / det
        yc = (B * D - 2 * A * E) / det
        f0 = F + 0.5 * (D * xc + E * yc)
        half = 0.5 * (A + C)
        root = math.sqrt(0.25 * (A - C) * (A - C) + 0.25 * B * B)
        sgn = 1.0 if half > 0 else -1.0  # make the quadratic part positive definite
        l1, l2, f0 = (half - root) * sgn, (half + root) * sgn, f0 * sgn
        l_small, l_big = (l1, l2) if l1 <= l2 else (l2, l1)
        ok = ok and l_small > 0 and f0 < 0
        if ok:
            a_out[i] = math.sqrt(-f0 / l_small)
            b_out[i] = math.sqrt(-f0 / l_big)
        ang = 0.5 * math.atan2(B * sgn, (A - C) * sgn) + 0.5 * math.pi
        ang_out[i] = (ang + 0.5 * math.pi) % math.pi - 0.5 * math.pi  # the major axis: eigenvector of l_small
        ok_out[i] = ok and math.isfinite(a_out[i]) and math.isfinite(b_out[i])
    return a_out, b_out, ang_out, ok_out


@nb.njit(**_JIT)
def refine_conic(coef0, q, nrm, idx, s, tol, first_band):
    """Iteratively reweighted direct fits of a conic on the points near it
    (:func:`arstream.detect.ellipses._refine`'s loop): the points within
    ``first_band + 1`` (working px) of the hypothesis, then three rounds, in
    bands of ``first_band``, ``tol`` and ``min(tol, 1)`` px, of
    :func:`conic_band` (normals agreeing, Sampson gradient weights) and
    :func:`direct_fit` on the selected points.

    Parameters
    ----------
    coef0 : (6,) conic in normalised coordinates q = s (p - m)
    q, nrm : (N, 2) normalised points and unit normals
    idx : (M,) int64 the candidate points
    s : float, normalised units per working pixel
    tol, first_band : float, working pixels

    Returns
    -------
    coef : (6,) the refined conic
    sel : (K,) int64 the last round's points (indices into q)
    rms : float, their RMS Sampson distance to ``coef`` (working px)
    ok : bool, False when a round keeps fewer than 10 points or a fit fails
    """
    coef = coef0.copy()
    near, _, _ = conic_band(coef, q, nrm, idx, (first_band + 1.0) * s, 0.0, False)
    cand = idx[near]
    empty = np.zeros(0, np.int64)
    if cand.shape[0] < 10:
        return coef, empty, 0.0, False
    sel = near[:0]
    for r in range(3):
        band = first_band if r == 0 else (tol if r == 1 else min(tol, 1.0))
        sel, _, S = conic_band(coef, q, nrm, cand, band * s, 0.95, True)
        if np.count_nonzero(sel) < 10:
            return coef, empty, 0.0, False
        c2, ok = direct_fit(S)
        if not ok:
            return coef, empty, 0.0, False
        coef = c2
    _, d, _ = conic_band(coef, q, nrm, cand, 0.0, 0.0, False)
    acc = 0.0
    ns = 0
    for k in range(cand.shape[0]):
        if sel[k]:
            acc += d[k] * d[k]
            ns += 1
    return coef, cand[sel], np.sqrt(acc / ns) / s, True


@nb.njit(**_JIT)
def perimeter_bins(pts, cx, cy, angle, a, b, bins, density, spacing):
    """Support of an ellipse's perimeter in bins of its parametric angle
    (the ellipse validation's coverage, :class:`arstream.detect.ellipses._PerimeterBins`).

    The perimeter is cut into ``bins`` equal steps of the parametric angle; a
    bin is covered when it holds at least ``density`` of the points expected
    along its arc length at one point per ``spacing``, and at least one.

    Parameters
    ----------
    pts : (N, 2) float64 points near the ellipse
    cx, cy, angle, a, b : float, the ellipse (centre, major-axis direction, semi-axes)
    bins : int
    density, spacing : float

    Returns
    -------
    cov : float, covered arc length over the whole perimeter
    covered : (bins,) bool
    seg : (bins,) float64 arc length of each bin
    mid : (bins, 2) float64 the perimeter point in the middle of each bin
    """
    ca = np.cos(angle)
    sa = np.sin(angle)
    cnt = np.zeros(bins, np.int64)
    k2 = bins / (2.0 * np.pi)
    for i in range(pts.shape[0]):
        dx = pts[i, 0] - cx
        dy = pts[i, 1] - cy
        u = (dx * ca + dy * sa) / a
        v = (-dx * sa + dy * ca) / b
        k = int((np.arctan2(v, u) + np.pi) * k2) % bins
        cnt[k] += 1
    covered = np.zeros(bins, np.bool_)
    seg = np.empty(bins)
    mid = np.empty((bins, 2))
    step = 2.0 * np.pi / bins
    total = 0.0
    cov = 0.0
    for k in range(bins):
        t = -np.pi + (k + 0.5) * step
        st = np.sin(t)
        ct = np.cos(t)
        seg[k] = np.hypot(a * st, b * ct) * step
        total += seg[k]
        covered[k] = cnt[k] >= max(1.0, density * seg[k] / spacing)
        if covered[k]:
            cov += seg[k]
        bx = a * ct
        by = b * st
        mid[k, 0] = cx + ca * bx - sa * by
        mid[k, 1] = cy + sa * bx + ca * by
    return cov / total, covered, seg, mid


@nb.njit(**_JIT)
def hartley_monomials(pts):
    """Hartley normalisation of points and the monomials of the result (the
    ellipse search's set-up, one pass instead of a dozen numpy calls).

    Parameters
    ----------
    pts : (N, 2) float64, N >= 1

    Returns
    -------
    q : (N, 2) ``s (pts - m)``, mean distance from the origin sqrt(2)
    D : (N, 6) ``[x^2, x y, y^2, x, y, 1]`` of ``q``
    mx, my, s : float, the centroid ``m`` and the scale
    """
    n = pts.shape[0]
    mx = 0.0
    my = 0.0
    for i in range(n):
        mx += pts[i, 0]
        my += pts[i, 1]
    mx /= n
    my /= n
    r = 0.0
    for i in range(n):
        r += math.hypot(pts[i, 0] - mx, pts[i, 1] - my)
    s = math.sqrt(2.0) / max(r / n, 1e-9)
    q = np.empty((n, 2))
    D = np.empty((n, 6))
    for i in range(n):
        x = (pts[i, 0] - mx) * s
        y = (pts[i, 1] - my) * s
        q[i, 0] = x
        q[i, 1] = y
        D[i, 0] = x * x
        D[i, 1] = x * y
        D[i, 2] = y * y
        D[i, 3] = x
        D[i, 4] = y
        D[i, 5] = 1.0
    return q, D, mx, my, s


@nb.njit(**_JIT)
def direct_fits(S):
    """:func:`direct_fit` of a stack of scatter matrices (K, 6, 6): coef (K, 6), ok (K,)."""
    K = S.shape[0]
    coef = np.empty((K, 6))
    ok = np.zeros(K, np.bool_)
    for k in range(K):
        c, good = direct_fit(S[k])
        coef[k] = c
        ok[k] = good
    return coef, ok


@nb.njit(**_JIT)
def label_scatters(D, labels, free, slot_of):
    """Scatter matrices of the monomials of several groups of points at once
    (the ellipse search's arcs): ``S[k] = sum D[i]^T D[i]`` over the free points
    ``i`` whose label has slot ``k = slot_of[labels[i]]`` (``-1``: none).

    Parameters
    ----------
    D : (N, 6) float64 monomials of the points
    labels : (N,) int, label of each point (``0 <= labels < len(slot_of)``)
    free : (N,) bool
    slot_of : (L,) int64, slot of each label or -1

    Returns
    -------
    (max(slot_of) + 1, 6, 6) float64
    """
    ns = 0
    for j in range(slot_of.shape[0]):
        ns = max(ns, slot_of[j] + 1)
    S = np.zeros((ns, 6, 6))
    for i in range(D.shape[0]):
        if not free[i]:
            continue
        k = slot_of[labels[i]]
        if k < 0:
            continue
        for a in range(6):
            da = D[i, a]
            for b in range(a, 6):
                S[k, a, b] += da * D[i, b]
    for k in range(ns):
        for a in range(6):
            for b in range(a):
                S[k, a, b] = S[k, b, a]
    return S


@nb.njit(**_JIT)
def _matmul3(A, B):
    """``A @ B`` of two 3 x 3 matrices, each entry summed over k in order."""
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            v = 0.0
            for k in range(3):
                v += A[i, k] * B[k, j]
            out[i, j] = v
    return out


@nb.njit(**_JIT)
def frame_ellipse(coef, T):
    """The ellipse of a conic given in other coordinates: the conic
    ``[A, B, C, D, E, F]`` (``A x^2 + B x y + C y^2 + D x + E y + F``) in
    coordinates ``q = T p`` pulled back to ``p`` (``T^T M T``), symmetrised and
    normalised as :func:`geometry.conics.normalize_conic`, then
    :func:`geometry.conics.ellipse_params_sym` (what
    :func:`geometry.conics.ellipse_from_conic` computes, without its numpy
    calls: the ellipse search validates several hypotheses a frame).

    Parameters
    ----------
    coef : (6,) float64
    T : (3, 3) float64, ``p`` -> ``q`` (homogeneous)

    Returns
    -------
    (status, cx, cy, a, b, angle) in ``p``: status 0 for a real ellipse, 1 for
    a hyperbola, parabola, degenerate or zero conic, 2 for an imaginary or
    point ellipse (see :func:`geometry.conics.ellipse_params_sym`).
    """
    M = np.empty((3, 3))
    M[0, 0] = coef[0]
    M[0, 1] = M[1, 0] = coef[1] / 2
    M[1, 1] = coef[2]
    M[0, 2] = M[2, 0] = coef[3] / 2
    M[1, 2] = M[2, 1] = coef[4] / 2
    M[2, 2] = coef[5]
    C = _matmul3(T.T, _matmul3(M, T))  # T^T M T
    nn = 0.0
    for i in range(3):
        for j in range(3):
            c = 0.5 * (C[i, j] + C[j, i])
            nn += c * c
    nn = math.sqrt(nn)
    if not nn >= 1e-12:  # zero or NaN
        return 1, 0.0, 0.0, 0.0, 0.0, 0.0
    p, q, r = C[0, 0] / nn, 0.5 * (C[0, 1] + C[1, 0]) / nn, C[1, 1] / nn
    d, e, f = 0.5 * (C[0, 2] + C[2, 0]) / nn, 0.5 * (C[1, 2] + C[2, 1]) / nn, C[2, 2] / nn
    tr = p + r
    if tr < 0 or (tr == 0 and f > 0):
        p, q, r, d, e, f = -p, -q, -r, -d, -e, -f
    return _ellipse_params_sym(p, q, r, d, e, f)


@nb.njit(**_JIT)
def conic_counts(coefs, q, nrm, idx, band, min_cos):
    """For each conic of ``coefs`` (K, 6), how many of the points q[idx]
    :func:`conic_band` selects (Sampson distance below ``band``, normal
    agreeing with the gradient): K conics scored in one call."""
    out = np.zeros(coefs.shape[0], np.int64)
    for k in range(coefs.shape[0]):
        sel, _, _ = conic_band(coefs[k], q, nrm, idx, band, min_cos, False)
        out[k] = np.count_nonzero(sel)
    return out


def warm_up() -> None:
    """Load (or compile) this module's kernels by calling them once on tiny inputs."""
    p = np.zeros((1, 2))
    z = np.zeros(1, np.int64)
    conic_band(np.ones(6), p, p, z, 1.0, 0.0, False)
    direct_fit(np.eye(6))
    direct_fits(np.eye(6)[None].copy())
    ellipse_params(np.ones((1, 6)), 1.0, 0.0, 0.0)
    conic_counts(np.ones((1, 6)), p, p, z, 1.0, 0.95)
    refine_conic(np.ones(6), p, p, z, 1.0, 1.5, 2.25)
    perimeter_bins(p, 0.0, 0.0, 0.0, 2.0, 1.0, 64, 0.3, 1.0)
    label_scatters(np.zeros((1, 6)), np.zeros(1, np.int32), np.ones(1, np.bool_), z)
    frame_ellipse(np.ones(6), np.eye(3))
    hartley_monomials(p)
