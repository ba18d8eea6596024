"""Compiled per-pixel and per-point loops of detection and tracking (numba).

The detector's stages are whole-image OpenCV operations followed by work on
the few thousand line pixels they leave. Written as numpy expressions, that
work is dozens of passes over small arrays, each paying numpy's per-call
overhead, and it holds the GIL between them; here each is one compiled loop
that releases the GIL (the pipeline runs detection on its own thread). The
tracker's nearest-line-pixel lookups (:class:`arstream.solve.LineIndex`) are
a grid of the points and a compiled search over it: building a k-d tree
cost more per frame than all its queries. Its refinement projects the pitch
model (:func:`project_points`) and fits the camera to the line pixels
(:func:`refine_pose`, a robust Levenberg-Marquardt over
:func:`marking_residuals`) in compiled loops too. The pipeline's I420 composite
and its fine grass key are one pass each here too (:func:`composite_i420`,
:func:`key_i420`).

Compiled on first use and cached next to this file (numba's ``cache=True``;
the first run after an install takes some seconds more). Loading the cached
code still costs about 0.5 s per process, most of it numba's one-off set-up of
its code generator on the first call: :func:`warm_up_async` (called by every
``Detector``) does that on a background thread, overlapping the caller's own
start-up (the GIL is released while LLVM loads the code).
"""

from __future__ import annotations

import math
import threading
import types

import numba as nb
import numpy as np

from geometry.conics import ellipse_params_sym
from geometry.lines import eigh_sym2


__all__ = ["band_scan", "beside_grass", "chains", "component_stats", "composite_i420", "conic_band", "conic_counts", "cut_by_line", "direct_fit", "direct_fits", "ellipse_params", "fit_lines", "frame_ellipse", "full_rows", "grid_clear", "grid_nearest", "hartley_monomials", "hough_lines", "hough_votes", "key_i420", "label_scatters", "marking_residuals", "mask_at", "perimeter_bins", "point_grid", "pose_from_params", "project_points", "refine_conic", "refine_pose", "ridge_scan", "settle_points", "warm_up", "warm_up_async", "warm_up_compositor"]

_JIT = dict(cache=True, nogil=True, fastmath=False, boundscheck=False)


def _compiled(fn, **deps):
    """A plain-float helper of :mod:`geometry` compiled for the kernels to call
    (the same arithmetic as in Python), with the helpers it calls in turn
    (``deps``: name -> compiled version) in place of its module's Python ones.
    numba's cache keys on this file only: after editing such a helper, touch
    this file (or clear ``__pycache__``) to recompile the kernels that call it."""
    scope = dict(fn.__globals__, **deps)
    return nb.njit(nogil=True)(types.FunctionType(fn.__code__, scope, fn.__name__, fn.__defaults__, fn.__closure__))


_eigh_sym2 = _compiled(eigh_sym2)
_ellipse_params_sym = _compiled(ellipse_params_sym, eigh_sym2=_eigh_sym2)


@nb.njit(**_JIT)
def _grow2(a, n):
    b = np.empty((2 * a.shape[0], a.shape[1]), a.dtype)
    b[:n] = a[:n]
    return b


@nb.njit(**_JIT)
def ridge_scan(th, cand, words, B, min_contrast, d, curvature_ratio):
    """Sub-pixel ridge centres at the candidate pixels of a top-hat image.

    A candidate is a pixel where ``cand`` is non-zero (the caller's mask of
    ``th`` above the threshold inside the region where lines may be) that is
    a maximum of ``th`` across x or across y (plateaus included), at least
    2 px from the border. At each, the Hessian of ``B`` (3x3 differences)
    gives the line's normal ``n`` (eigenvector of the most negative eigenvalue
    ``l1``); a centre needs ``l1 < 0``, an elongated profile (``l2 > l1 / 2``),
    the ridge maximum within its own pixel along ``n`` after the grass's slope
    across the line is taken out (a linear background through the samples
    ``d`` px either side, when they differ by at most half the contrast), a
    contrast over the brighter side of at least ``min_contrast`` and a
    curvature ``-l1 >= curvature_ratio * contrast``.

    Parameters
    ----------
    th : (h, w) uint8 top-hat of the luma
    cand : (h, wp) uint8 candidate mask, its rows padded with zeros to a
        multiple of 8 bytes (``wp >= w``)
    words : ``cand`` viewed as (h, wp / 8) uint64: the scan skips 8 pixels
        without a candidate at once
    B : (h, w) float32 Gaussian-smoothed luma
    min_contrast, d, curvature_ratio : float

    Returns
    -------
    pts : (N, 2) float64 centres (x, y), pixels, in raster order of their candidates
    nrm : (N, 2) float32 unit normals
    aux : (N, 4) float32 per centre: B at the candidate, the two side samples, l1
    n_candidates : int
    """
    h, w = th.shape
    cap = 2048
    pts = np.empty((cap, 2))
    nrm = np.empty((cap, 2), np.float32)
    aux = np.empty((cap, 4), np.float32)
    n = 0
    ncand = 0
    half = np.float32(0.5)
    two = np.float32(2.0)
    quarter = np.float32(0.25)
    d2 = np.float32(2.0 * d)
    nw = words.shape[1]
    for y in range(2, h - 2):
        trow = th[y]
        crow = cand[y]
        wrow = words[y]
        for kw in range(nw):
            if wrow[kw] == 0:
                continue
            for x in range(max(8 * kw, 2), min(8 * kw + 8, w - 2)):
                if crow[x] == 0:
                    continue
                t = trow[x]
                if not ((t >= trow[x - 1] and t >= trow[x + 1]) or (t >= th[y - 1, x] and t >= th[y + 1, x])):
                    continue
                ncand += 1
                c = B[y, x]
                xp = B[y, x + 1]
                xm = B[y, x - 1]
                yp = B[y + 1, x]
                ym = B[y - 1, x]
                gx = half * (xp - xm)
                gy = half * (yp - ym)
                gxx = xp + xm - two * c
                gyy = yp + ym - two * c
                gxy = quarter * (B[y + 1, x + 1] - B[y + 1, x - 1] - B[y - 1, x + 1] + B[y - 1, x - 1])
                ht = half * (gxx + gyy)
                root = np.sqrt(quarter * (gxx - gyy) * (gxx - gyy) + gxy * gxy)
                l1 = ht - root
                l2 = ht + root
                if not (l1 < 0 and l2 > half * l1):
                    continue
                # eigenvector of l1: (gxy, l1 - gxx) or (l1 - gyy, gxy), the better conditioned
                nx = gxy
                ny = l1 - gxx
                bx = l1 - gyy
                if bx * bx + gxy * gxy > nx * nx + ny * ny:
                    nx = bx
                    ny = gxy
                nn = np.sqrt(nx * nx + ny * ny)
                if not nn > 1e-12:
                    continue
                nx = nx / nn
                ny = ny / nn
                # the grass on both sides, beyond the half width
                sx1 = min(max(int(np.rint(x + d * nx)), 0), w - 1)
                sy1 = min(max(int(np.rint(y + d * ny)), 0), h - 1)
                sx2 = min(max(int(np.rint(x - d * nx)), 0), w - 1)
                sy2 = min(max(int(np.rint(y - d * ny)), 0), h - 1)
                b1 = B[sy1, sx1]
                b2 = B[sy2, sx2]
                contrast = c - max(b1, b2)
                slope = (b1 - b2) / d2 if abs(b1 - b2) <= half * contrast else np.float32(0.0)
                tt = -(gx * nx + gy * ny - slope) / l1
                ox = tt * nx
                oy = tt * ny
                if not (abs(ox) <= 0.5 and abs(oy) <= 0.5):
                    continue
                if not (contrast >= min_contrast and -l1 >= curvature_ratio * contrast):
                    continue
                if n == pts.shape[0]:
                    pts = _grow2(pts, n)
                    nrm = _grow2(nrm, n)
                    aux = _grow2(aux, n)
                pts[n, 0] = x + ox
                pts[n, 1] = y + oy
                nrm[n, 0] = nx
                nrm[n, 1] = ny
                aux[n, 0] = c
                aux[n, 1] = b1
                aux[n, 2] = b2
                aux[n, 3] = l1
                n += 1
    return pts[:n].copy(), nrm[:n].copy(), aux[:n].copy(), ncand


@nb.njit(**_JIT)
def _tls(pts, idx, n):
    """Total-least-squares line of pts[idx[:n]]: (a, b, c, ux, uy, rms), the line
    a x + b y + c = 0 with unit normal (a, b) = (-uy, ux) and direction (ux, uy)."""
    sx = 0.0
    sy = 0.0
    sxx = 0.0
    sxy = 0.0
    syy = 0.0
    for k in range(n):
        x = pts[idx[k], 0]
        y = pts[idx[k], 1]
        sx += x
        sy += y
        sxx += x * x
        sxy += x * y
        syy += y * y
    cx = sx / n
    cy = sy / n
    sxx -= n * cx * cx
    sxy -= n * cx * cy
    syy -= n * cy * cy
    phi = 0.5 * np.arctan2(2 * sxy, sxx - syy)
    ux = np.cos(phi)
    uy = np.sin(phi)
    half = 0.5 * (sxx + syy)
    lmin = half - np.sqrt(max(half * half - (sxx * syy - sxy * sxy), 0.0))
    rms = np.sqrt(max(lmin, 0.0) / n)
    return -uy, ux, uy * cx - ux * cy, ux, uy, rms


@nb.njit(**_JIT)
def _top_label(labels, idx, n, counts):
    """The most frequent label of labels[idx[:n]] (the smallest on ties) and its
    count; ``counts`` (zeros, one per label) is left zeroed."""
    top = 0
    best = -1
    for k in range(n):
        counts[labels[idx[k]]] += 1
    for k in range(n):
        lab = labels[idx[k]]
        cnt = counts[lab]
        if cnt > best or (cnt == best and lab < top):
            best = cnt
            top = lab
    for k in range(n):
        counts[labels[idx[k]]] = 0
    return top, best


@nb.njit(**_JIT)
def hough_lines(
    pts, nrm, labels, has_labels, n_labels, order_t, starts, cand, n_th, n_rho, rho_bin, rmax, cx, cy, half_bins,
    min_points, min_length, max_gap, tol, max_lines, max_sagitta, max_rms,
):
    """The peak loop of :func:`arstream.detect.segments.group_lines`.

    Peaks ``cand`` (flat indices into the (n_th, n_rho) accumulator, strongest
    first) in turn gather the unassigned points of the ``half_bins`` orientation
    bins either side (``order_t`` sorts the points by orientation bin,
    ``starts`` (n_th + 1,) are the bins' offsets in it) within 2.5 px of the
    peak's line, refit by total least squares, keep the points within ``tol``
    whose normal agrees (|cos| > 0.985), keep the longest piece between gaps
    over ``max_gap``, and pass when long enough, dense enough (0.4 points per
    px), thin enough (rms <= ``max_rms``) and straight (sagitta of a quadratic
    through the residuals <= ``max_sagitta``). A chain (``labels``) that fails
    twice is not tried again.

    Returns
    -------
    members : (M,) int64, the groups' point indices, group after group
    offsets : (G + 1,) int64, group k is members[offsets[k]:offsets[k + 1]]
    geo : (G, 8) float64 per group: line (a, b, c), direction (ux, uy), rms, t0, t1
    used : (N,) bool, the points taken
    """
    n = pts.shape[0]
    used = np.zeros(n, np.bool_)
    claimed = np.zeros((n_th, n_rho), np.bool_)
    curved_hits = np.zeros(max(n_labels, 1), np.int32)
    counts = np.zeros(max(n_labels, 1), np.int64)
    members = np.empty(n, np.int64)
    offsets = np.zeros(max_lines + 1, np.int64)
    geo = np.empty((max_lines, 8))
    idx = np.empty(n, np.int64)
    sel = np.empty(n, np.int64)
    tbuf = np.empty(n)
    piece = np.empty(n, np.int64)
    n_groups = 0
    n_members = 0
    any_curved = False
    for c in cand:
        ti = c // n_rho
        ri = c - ti * n_rho
        if claimed[ti, ri]:
            continue
        # the unassigned points of the nearby orientation bins (wrapping at pi)
        m = 0
        for tb in range(ti - half_bins, ti + half_bins + 1):
            tw = tb % n_th
            for k in range(starts[tw], starts[tw + 1]):
                j = order_t[k]
                if not used[j]:
                    idx[m] = j
                    m += 1
        if m < min_points:
            continue
        th0 = (ti + 0.5) * (np.pi / n_th)
        r0 = (ri + 0.5) * rho_bin - rmax
        n0x = np.cos(th0)
        n0y = np.sin(th0)
        off = r0 + cx * n0x + cy * n0y
        ns = 0
        for k in range(m):
            j = idx[k]
            if abs(pts[j, 0] * n0x + pts[j, 1] * n0y - off) <= 2.5:
                sel[ns] = j
                ns += 1
        if ns < min_points:
            continue
        if any_curved:
            top, cnt = _top_label(labels, sel, ns, counts)
            if top != 0 and curved_hits[top] >= 2 and cnt > 0.7 * ns:
                continue
        a, b, cc, ux, uy, rms = _tls(pts, sel, ns)
        ns = 0
        for k in range(m):
            j = idx[k]
            if abs(pts[j, 0] * a + pts[j, 1] * b + cc) <= tol and abs(nrm[j, 0] * a + nrm[j, 1] * b) > 0.985:
                sel[ns] = j
                ns += 1
        if ns < min_points:
            continue
        a, b, cc, ux, uy, rms = _tls(pts, sel, ns)
        for k in range(ns):
            tbuf[k] = pts[sel[k], 0] * ux + pts[sel[k], 1] * uy
        o = np.argsort(tbuf[:ns], kind="mergesort")
        # the longest piece between gaps over max_gap (extent + half its point count)
        best = -np.inf
        b0 = 0
        b1 = ns
        s0 = 0
        gapped = False
        for k in range(1, ns + 1):
            if k == ns or tbuf[o[k]] - tbuf[o[k - 1]] > max_gap:
                if k < ns:
                    gapped = True
                ext = tbuf[o[k - 1]] - tbuf[o[s0]] + 0.5 * (k - s0)
                if ext > best:
                    best = ext
                    b0 = s0
                    b1 = k
                s0 = k
        if gapped:
            nm = b1 - b0
            for k in range(nm):
                piece[k] = sel[o[b0 + k]]
            if nm < min_points:
                continue
            a, b, cc, ux, uy, rms = _tls(pts, piece, nm)
            for k in range(nm):
                tbuf[k] = pts[piece[k], 0] * ux + pts[piece[k], 1] * uy
        else:
            nm = ns
            for k in range(nm):
                piece[k] = sel[k]
        t0 = np.inf
        t1 = -np.inf
        for k in range(nm):
            t0 = min(t0, tbuf[k])
            t1 = max(t1, tbuf[k])
        length = t1 - t0
        if length < min_length or nm < 0.4 * length:
            continue
        # the chord of a gentle curve (or a smeared band) is too thick; else
        # straightness: a quadratic through the residuals, peak-to-peak over the length
        curved = rms > max_rms
        if not curved:
            qr = 0.0
            qq = 0.0
            for k in range(nm):
                j = piece[k]
                uu = (tbuf[k] - 0.5 * (t0 + t1)) * (2.0 / length)
                q2 = uu * uu - 1.0 / 3.0
                qr += q2 * (pts[j, 0] * a + pts[j, 1] * b + cc)
                qq += q2 * q2
            curved = abs(qr / max(qq, 1e-12)) > max_sagitta
        if curved:
            if has_labels:
                top, cnt = _top_label(labels, piece, nm, counts)
                curved_hits[top] += 1
                any_curved = True
            continue
        for k in range(nm):
            used[piece[k]] = True
            members[n_members + k] = piece[k]
        n_members += nm
        geo[n_groups, 0] = a
        geo[n_groups, 1] = b
        geo[n_groups, 2] = cc
        geo[n_groups, 3] = ux
        geo[n_groups, 4] = uy
        geo[n_groups, 5] = rms
        geo[n_groups, 6] = t0
        geo[n_groups, 7] = t1
        n_groups += 1
        offsets[n_groups] = n_members
        claimed[max(ti - 1, 0) : ti + 2, max(ri - 2, 0) : ri + 3] = True
        if n_groups >= max_lines:
            break
    return members[:n_members].copy(), offsets[: n_groups + 1].copy(), geo[:n_groups].copy(), used


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
def _bilinear_replicate(B, x, y):
    """Bilinear sample of the float image B at (x, y), border replicated."""
    h, w = B.shape
    x = min(max(x, 0.0), w - 1.0)
    y = min(max(y, 0.0), h - 1.0)
    x0 = min(int(x), w - 2) if w > 1 else 0
    y0 = min(int(y), h - 2) if h > 1 else 0
    fx = x - x0
    fy = y - y0
    x1 = min(x0 + 1, w - 1)
    y1 = min(y0 + 1, h - 1)
    top = B[y0, x0] + fx * (B[y0, x1] - B[y0, x0])
    bot = B[y1, x0] + fx * (B[y1, x1] - B[y1, x0])
    return top + fy * (bot - top)


@nb.njit(**_JIT)
def _band_edge(prof, r, sign, base, rise):
    """Distance from the centre sample to where one side of the profile ``prof``
    (2r + 1 samples; ``sign`` +1: outward along +n, -1: along -n) falls below
    half the band's height over that side's grass level ``base``, and whether
    the grass beyond it is flat (-1.0 when no edge or no flat grass)."""
    level = base + 0.5 * rise
    j = 0
    for k in range(1, r + 1):
        if prof[r + sign * k] < level:
            j = k
            break
    if j < 1 or j > r - 4:
        return -1.0
    hi = -np.inf
    lo = np.inf
    for k in range(j + 2, r + 1):
        v = prof[r + sign * k]
        hi = max(hi, v)
        lo = min(lo, v)
    if not hi - lo <= 0.25 * rise:
        return -1.0
    a = prof[r + sign * (j - 1)]
    b = prof[r + sign * j]
    frac = (a - level) / (a - b) if a > b else (a - level)
    return j - 1 + min(max(frac, 0.0), 1.0)


@nb.njit(**_JIT)
def band_scan(B, pts, nrm, r):
    """:func:`arstream.detect.ridges.band_centres` for every point: the profile
    of ``B`` along the normal (bilinear samples 1 px apart out to ``r`` px each
    side, border replicated), each edge cut at half the band's height over its
    own side's grass (the mean of the 3 outermost samples), flat grass beyond
    each edge, sides within half the band's height of each other.

    Returns
    -------
    shift : (N,) offset along the normal to the edges' midpoint (0: no band)
    width : (N,) distance between the edges (0: no band)
    """
    n = pts.shape[0]
    shift = np.zeros(n)
    width = np.zeros(n)
    prof = np.empty(2 * r + 1)
    for i in range(n):
        px = pts[i, 0]
        py = pts[i, 1]
        nx = nrm[i, 0]
        ny = nrm[i, 1]
        for k in range(2 * r + 1):
            s = k - r
            prof[k] = _bilinear_replicate(B, px + s * nx, py + s * ny)
        b_r = (prof[2 * r] + prof[2 * r - 1] + prof[2 * r - 2]) / 3.0
        b_l = (prof[0] + prof[1] + prof[2]) / 3.0
        rise = (prof[r - 1] + prof[r] + prof[r + 1]) / 3.0 - 0.5 * (b_l + b_r)
        if not (rise > 0 and abs(b_l - b_r) <= 0.5 * rise):
            continue
        dr = _band_edge(prof, r, 1, b_r, rise)
        dl = _band_edge(prof, r, -1, b_l, rise)
        if dr < 0 or dl < 0:
            continue
        shift[i] = 0.5 * (dr - dl)
        width[i] = dr + dl
    return shift, width


@nb.njit(**_JIT)
def _cell(v, scale, rint, n):
    """Grid cell of a coordinate: ``v * scale`` rounded (``rint``) or truncated, clamped to [0, n)."""
    c = v * scale
    i = int(np.rint(c)) if rint else int(c)
    return min(max(i, 0), n - 1)


@nb.njit(**_JIT)
def grid_clear(pts, ep, sx, sy, rint, rx, ry, grid):
    """Which points ``ep`` have no point of ``pts`` near them on a grid.

    Each point (x, y) falls in the cell (x ``sx``, y ``sy``), rounded
    (``rint``) or truncated, clamped to the grid. A point of ``ep`` is clear
    when no point of ``pts`` lies within ``rx`` cells across and ``ry`` cells
    down of its own (what dilating the occupied cells by a (2 ry + 1) x
    (2 rx + 1) rectangle and testing its cell does).

    Parameters
    ----------
    pts : (N, 2) float64 points (x, y)
    ep : (M, 2) float64 points to test
    sx, sy : float, cells per unit of x and y
    rint : bool, round to the nearest cell (else truncate)
    rx, ry : int, reach in cells
    grid : (gh, gw) uint8 scratch, zero on entry and on return

    Returns
    -------
    (M,) bool
    """
    gh, gw = grid.shape
    n = pts.shape[0]
    for i in range(n):
        grid[_cell(pts[i, 1], sy, rint, gh), _cell(pts[i, 0], sx, rint, gw)] = 1
    m = ep.shape[0]
    keep = np.ones(m, np.bool_)
    for i in range(m):
        cy = _cell(ep[i, 1], sy, rint, gh)
        cx = _cell(ep[i, 0], sx, rint, gw)
        for y in range(max(cy - ry, 0), min(cy + ry + 1, gh)):
            for x in range(max(cx - rx, 0), min(cx + rx + 1, gw)):
                if grid[y, x]:
                    keep[i] = False
                    break
            if not keep[i]:
                break
    for i in range(n):
        grid[_cell(pts[i, 1], sy, rint, gh), _cell(pts[i, 0], sx, rint, gw)] = 0
    return keep


@nb.njit(**_JIT)
def _root(parent, i):
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@nb.njit(**_JIT)
def chains(xi, yi, reach, grid):
    """Connected chains of points on an integer grid.

    Two points are linked when their cells (``xi``, ``yi``) are at most
    ``reach`` cells apart along both axes; a chain is a connected set of
    links. (Reach 1 is 8-connectivity of the occupied cells; reach 3 is
    8-connectivity after dilating them by a 3 x 3 square.)

    Parameters
    ----------
    xi, yi : (N,) int64 cells, inside the grid
    reach : int
    grid : (gh, gw) int32 scratch, -1 on entry and on return

    Returns
    -------
    labels : (N,) int32 chain of each point, 1..K in the raster order of the
        chains' first cells
    ext_x, ext_y : (N,) int64 the width and height (max - min of the cells)
        of each point's chain
    """
    gh, gw = grid.shape
    n = xi.shape[0]
    parent = np.arange(n)
    # one representative point per occupied cell
    for i in range(n):
        r = grid[yi[i], xi[i]]
        if r < 0:
            grid[yi[i], xi[i]] = i
        else:
            parent[i] = r
    # links are symmetric: each cell looks back only (the rows above within
    # reach, and its own row's cells to its left). A chain's root is its lowest
    # index, whatever the order of the links
    for i in range(n):
        cy, cx = yi[i], xi[i]
        if grid[cy, cx] != i:
            continue
        a = _root(parent, i)
        for y in range(max(cy - reach, 0), cy + 1):
            x_end = min(cx + reach + 1, gw) if y < cy else cx
            for x in range(max(cx - reach, 0), x_end):
                j = grid[y, x]
                if j >= 0:
                    b = _root(parent, j)
                    if b < a:
                        parent[a] = b
                        a = b
                    elif b > a:
                        parent[b] = a
    first = np.full(n, gh * gw)
    x0 = np.full(n, gw)
    x1 = np.full(n, -1)
    y0 = np.full(n, gh)
    y1 = np.full(n, -1)
    for i in range(n):
        r = _root(parent, i)
        parent[i] = r
        first[r] = min(first[r], yi[i] * gw + xi[i])
        x0[r] = min(x0[r], xi[i])
        x1[r] = max(x1[r], xi[i])
        y0[r] = min(y0[r], yi[i])
        y1[r] = max(y1[r], yi[i])
        grid[yi[i], xi[i]] = -1
    roots = np.flatnonzero(first < gh * gw)
    rank = np.empty(n, np.int32)
    o = np.argsort(first[roots])
    for k in range(o.shape[0]):
        rank[roots[o[k]]] = k + 1
    labels = np.empty(n, np.int32)
    ext_x = np.empty(n, np.int64)
    ext_y = np.empty(n, np.int64)
    for i in range(n):
        r = parent[i]
        labels[i] = rank[r]
        ext_x[i] = x1[r] - x0[r]
        ext_y[i] = y1[r] - y0[r]
    return labels, ext_x, ext_y


@nb.njit(**_JIT)
def _on_mask(mask, x, y, fx, fy):
    """Whether point (x, y), scaled by (``fx``, ``fy``) to the cells of ``mask``
    (truncated, clamped), falls on a non-zero cell."""
    return mask[_cell(y, fy, False, mask.shape[0]), _cell(x, fx, False, mask.shape[1])] > 0


@nb.njit(**_JIT)
def beside_grass(pts, nrm, d, mask, fx, fy):
    """Which points have grass on at least one side: ``mask`` (a small image,
    non-zero on grass) at ``pts`` +- ``d`` ``nrm`` scaled by (``fx``, ``fy``) to
    its cells (truncated, clamped).

    Parameters
    ----------
    pts, nrm : (N, 2) float64 points and unit normals
    d : float, distance either side (units of pts)
    mask : (mh, mw) uint8
    fx, fy : float, mask cells per unit of x and y

    Returns
    -------
    (N,) bool
    """
    n = pts.shape[0]
    keep = np.empty(n, np.bool_)
    for i in range(n):
        ok = False
        for sgn in (1.0, -1.0):
            if _on_mask(mask, pts[i, 0] + sgn * d * nrm[i, 0], pts[i, 1] + sgn * d * nrm[i, 1], fx, fy):
                ok = True
        keep[i] = ok
    return keep


@nb.njit(**_JIT)
def settle_points(pts, nrm, d, mask, fx, fy, cell_x, cell_y, grid, min_extent, lm, sx, tx, sy, ty):
    """The detector's last pass over its line points: those with grass beside
    them (:func:`beside_grass`) that lie in connected chains (:func:`chains`,
    reach 1, on the grid of cells ``(x cell_x, y cell_y)``, truncated and
    clamped) at least ``min_extent`` cells long or high; their mask and their
    frame coordinates.

    Parameters
    ----------
    pts, nrm : (N, 2) float64 working-pixel points and unit normals
    d, mask, fx, fy : as :func:`beside_grass`
    cell_x, cell_y : float, grid cells per working pixel
    grid : (gh, gw) int32 scratch, -1 on entry and on return
    min_extent : float
    lm : (h, w) uint8, set to 255 at the kept points (rounded, clamped) and 0 elsewhere
    sx, tx, sy, ty : float, working -> frame pixels ``(sx x + tx, sy y + ty)``

    Returns
    -------
    sel : (M,) int64 indices of the kept points, in order
    labels : (M,) int32 their chains (as :func:`chains` numbers them)
    full : (M, 2) float64 their frame coordinates
    """
    keep = beside_grass(pts, nrm, d, mask, fx, fy)
    idx = np.flatnonzero(keep)
    m = idx.shape[0]
    gh, gw = grid.shape
    cxi = np.empty(m, np.int64)
    cyi = np.empty(m, np.int64)
    for k in range(m):
        i = idx[k]
        cxi[k] = min(max(int(pts[i, 0] * cell_x), 0), gw - 1)
        cyi[k] = min(max(int(pts[i, 1] * cell_y), 0), gh - 1)
    lab, ext_x, ext_y = chains(cxi, cyi, 1, grid)
    long = np.empty(m, np.bool_)
    for k in range(m):
        long[k] = max(ext_x[k], ext_y[k]) + 1 >= min_extent
    cnt = int(long.sum())
    sel = np.empty(cnt, np.int64)
    labels = np.empty(cnt, np.int32)
    full = np.empty((cnt, 2))
    lm[:, :] = 0
    h, w = lm.shape
    j = 0
    for k in range(m):
        if long[k]:
            i = idx[k]
            x = pts[i, 0]
            y = pts[i, 1]
            sel[j] = i
            labels[j] = lab[k]
            full[j, 0] = x * sx + tx
            full[j, 1] = y * sy + ty
            lm[min(max(int(np.rint(y)), 0), h - 1), min(max(int(np.rint(x)), 0), w - 1)] = 255
            j += 1
    return sel, labels, full


@nb.njit(**_JIT)
def mask_at(pts, mask, fx, fy, xmax, ymax):
    """Which points lie in ``[0, xmax] x [0, ymax]`` on a non-zero cell of
    ``mask`` (a small image), the points scaled by (``fx``, ``fy``) to its
    cells (truncated, clamped).

    Parameters
    ----------
    pts : (N, 2) float64 points
    mask : (mh, mw) uint8
    fx, fy : float, mask cells per unit of x and y
    xmax, ymax : float, the points' extent

    Returns
    -------
    (N,) bool
    """
    n = pts.shape[0]
    out = np.zeros(n, np.bool_)
    for i in range(n):
        x, y = pts[i, 0], pts[i, 1]
        if 0.0 <= x <= xmax and 0.0 <= y <= ymax:
            out[i] = _on_mask(mask, x, y, fx, fy)
    return out


@nb.njit(**_JIT)
def _counting_sort(keys, n_keys):
    """Indices 0..N-1 sorted by ``keys`` (N,) int64 in [0, n_keys), stable:
    (order (N,), starts (n_keys + 1,)); key k's indices are order[starts[k]:starts[k + 1]]."""
    n = keys.shape[0]
    starts = np.zeros(n_keys + 1, np.int64)
    for i in range(n):
        starts[keys[i] + 1] += 1
    for k in range(n_keys):
        starts[k + 1] += starts[k]
    fill = starts[:-1].copy()
    order = np.empty(n, np.int64)
    for i in range(n):
        order[fill[keys[i]]] = i
        fill[keys[i]] += 1
    return order, starts


@nb.njit(**_JIT)
def cut_by_line(P, L, cx, cy, a, b, angle, min_share):
    """Whether a line of ``L`` cuts an ellipse with (nearly) all of its support
    beyond the line, on the side away from the ellipse's centre.

    A line cuts the ellipse "away from its centre" when its distance from the
    centre is between 0.2 and 0.95 of the ellipse's half-width along the
    line's normal (the support function ``sqrt((a n_u)^2 + (b n_v)^2)``, with
    ``(n_u, n_v)`` the normal in the ellipse's axes).

    Parameters
    ----------
    P : (N, 2) float64 support points (pixels)
    L : (K, 3) float64 lines with unit normals ``(a, b)`` (``a x + b y + c = 0``)
    cx, cy, a, b, angle : the ellipse (centre, semi-axes, major-axis angle)
    min_share : float, the share of ``P`` that must lie on the far side

    Returns
    -------
    bool: for some cutting line, more than ``min_share`` of ``P`` lies on it
    or beyond it (not on the centre's side)
    """
    ca, sa = math.cos(angle), math.sin(angle)
    n = P.shape[0]
    for k in range(L.shape[0]):
        nx, ny, c = L[k, 0], L[k, 1], L[k, 2]
        dc = nx * cx + ny * cy + c
        nu = nx * ca + ny * sa
        nv = ny * ca - nx * sa
        reach = math.sqrt((a * nu) ** 2 + (b * nv) ** 2)
        if not (abs(dc) < 0.95 * reach and abs(dc) >= 0.2 * reach):
            continue
        sc = 1.0 if dc > 0 else (-1.0 if dc < 0 else 0.0)
        far = 0
        for i in range(n):
            sd = nx * P[i, 0] + ny * P[i, 1] + c
            ss = 1.0 if sd > 0 else (-1.0 if sd < 0 else 0.0)
            if ss != sc:
                far += 1
        if n > 0 and far / n > min_share:
            return True
    return False


@nb.njit(**_JIT)
def point_grid(pts, cell, max_side):
    """Points bucketed by the cells of a grid over their bounding box (a
    counting sort), for :func:`grid_nearest`.

    The cell of (x, y) is (floor((x - x0) / cell), floor((y - y0) / cell)),
    (x0, y0) the least coordinates; the cell grows where the box would be
    more than ``max_side`` cells a side.

    Parameters
    ----------
    pts : (N, 2) float64 finite points, N >= 1
    cell : float, cell size (units of pts)
    max_side : int

    Returns
    -------
    order : (N,) int64 point indices, cell after cell (raster order of the cells)
    starts : (gw gh + 1,) int64, cell c holds order[starts[c]:starts[c + 1]]
    grid : (x0, y0, cell, gw, gh)
    """
    n = pts.shape[0]
    x0 = np.inf
    y0 = np.inf
    x1 = -np.inf
    y1 = -np.inf
    for i in range(n):
        x0 = min(x0, pts[i, 0])
        x1 = max(x1, pts[i, 0])
        y0 = min(y0, pts[i, 1])
        y1 = max(y1, pts[i, 1])
    cell = max(cell, max(x1 - x0, y1 - y0) / max_side)
    gw = int((x1 - x0) / cell) + 1
    gh = int((y1 - y0) / cell) + 1
    cid = np.empty(n, np.int64)
    for i in range(n):
        cx = int(min((pts[i, 0] - x0) / cell, gw - 1.0))
        cy = int(min((pts[i, 1] - y0) / cell, gh - 1.0))
        cid[i] = cy * gw + cx
    order, starts = _counting_sort(cid, gw * gh)
    return order, starts, (x0, y0, cell, gw, gh)


@nb.njit(**_JIT)
def grid_nearest(pts, order, starts, x0, y0, cell, gw, gh, q, radius):
    """The nearest point of ``pts`` to each query, searched on its
    :func:`point_grid` ring by ring over the cells within ``radius`` (exact;
    ties go to the lower index).

    Parameters
    ----------
    pts : (N, 2) float64 points; order, starts, x0, y0, cell, gw, gh : their grid
    q : (M, 2) float64 queries (a non-finite query finds nothing)
    radius : float, only points closer than this (strictly) count

    Returns
    -------
    d : (M,) float64 distances (inf where none is closer than ``radius``)
    idx : (M,) int64 indices into ``pts`` (-1 where none)
    """
    m = q.shape[0]
    d = np.full(m, np.inf)
    idx = np.full(m, -1, np.int64)
    k = int(min(np.ceil(radius / cell), max(gw, gh)))
    r2 = radius * radius
    for i in range(m):
        qx = q[i, 0]
        qy = q[i, 1]
        if not (np.isfinite(qx) and np.isfinite(qy)):
            continue
        cx = int(min(max((qx - x0) / cell, 0.0), gw - 1.0))
        cy = int(min(max((qy - y0) / cell, 0.0), gh - 1.0))
        best = r2
        bj = -1
        # rings of cells outwards; the points of ring rr are at least (rr - 1) cells away
        for rr in range(k + 1):
            lim = (rr - 1) * cell
            if rr > 1 and best < lim * lim:
                break
            for y in range(max(cy - rr, 0), min(cy + rr + 1, gh)):
                edge = y == cy - rr or y == cy + rr
                step = 1 if edge else 2 * rr
                for x in range(cx - rr, cx + rr + 1, max(step, 1)):
                    if x < 0 or x >= gw:
                        continue
                    c = y * gw + x
                    for t in range(starts[c], starts[c + 1]):
                        j = order[t]
                        dx = pts[j, 0] - qx
                        dy = pts[j, 1] - qy
                        dd = dx * dx + dy * dy
                        if dd < best or (dd == best and bj >= 0 and j < bj):
                            best = dd
                            bj = j
        if bj >= 0:
            d[i] = np.sqrt(best)
            idx[i] = bj
    return d, idx


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
def hough_votes(pts, nrm, cx, cy, rmax, rho_bin, n_th, n_rho, pad, thr, max_cand):
    """The vote of :func:`arstream.detect.segments.group_lines`: each point votes
    once, in the (theta, rho) cell of its own normal (theta in [0, pi), rho
    measured from (``cx``, ``cy``)); the rows within ``pad`` of either end are
    voted again wrapped (theta near pi is theta near 0 with rho negated). The
    votes are summed over 3 x 3 cells; peaks are cells of at least ``thr`` that
    are maxima of their 3 x 3 neighbourhood (plateaus included).

    Parameters
    ----------
    pts, nrm : (N, 2) float64 points and unit normals
    cx, cy, rmax, rho_bin : float
    n_th, n_rho, pad : int
    thr : float
    max_cand : int

    Returns
    -------
    cand : (K,) int64 the strongest peaks (flat indices into (n_th, n_rho)),
        strongest first (ties: lower index first), at most ``max_cand``
    order_t : (N,) int64 the points sorted by theta bin (stable)
    starts : (n_th + 1,) int64 bin t's points are order_t[starts[t]:starts[t + 1]]
    """
    n = pts.shape[0]
    rows = n_th + 2 * pad
    acc = np.zeros((rows, n_rho), np.int32)
    tb = np.empty(n, np.int64)
    kth = n_th / np.pi
    for i in range(n):
        th = np.arctan2(nrm[i, 1], nrm[i, 0])
        sgn = 1.0
        if th < 0:
            th += np.pi
            sgn = -1.0
        rho = ((pts[i, 0] - cx) * nrm[i, 0] + (pts[i, 1] - cy) * nrm[i, 1]) * sgn
        t = min(int(th * kth), n_th - 1)
        tb[i] = t
        r = min(max(int((rho + rmax) * (1.0 / rho_bin)), 0), n_rho - 1)
        acc[t + pad, r] += 1
        if t < pad or t >= n_th - pad:
            te = t + n_th if t < pad else t - n_th
            re = min(max(int((-rho + rmax) * (1.0 / rho_bin)), 0), n_rho - 1)
            acc[te + pad, re] += 1
    # 3 x 3 sums (zero beyond the accumulator) over the core rows: across rho,
    # then across theta
    hs = np.zeros((n_th + 2, n_rho), np.int32)
    for t in range(n_th + 2):
        rr = t + pad - 1
        if rr < 0 or rr >= rows:
            continue
        row = acc[rr]
        for r in range(n_rho):
            v = row[r]
            if r > 0:
                v += row[r - 1]
            if r + 1 < n_rho:
                v += row[r + 1]
            hs[t, r] = v
    core = np.empty((n_th, n_rho), np.int32)
    for t in range(n_th):
        for r in range(n_rho):
            core[t, r] = hs[t, r] + hs[t + 1, r] + hs[t + 2, r]
    cnt = 0
    cand = np.empty(n_th * n_rho, np.int64)
    vals = np.empty(n_th * n_rho)
    for t in range(n_th):
        for r in range(n_rho):
            v = core[t, r]
            if v < thr:
                continue
            peak = True
            for dt in range(-1, 2):
                tt = t + dt
                if tt < 0 or tt >= n_th:
                    continue
                for dr in range(-1, 2):
                    c = r + dr
                    if 0 <= c < n_rho and core[tt, c] > v:
                        peak = False
            if peak:
                cand[cnt] = t * n_rho + r
                vals[cnt] = -v
                cnt += 1
    o = np.argsort(vals[:cnt], kind="mergesort")
    k = min(cnt, max_cand)
    out = np.empty(k, np.int64)
    for i in range(k):
        out[i] = cand[o[i]]
    order_t, starts = _counting_sort(tb, n_th)  # the points by theta bin
    return out, order_t, starts


@nb.njit(**_JIT)
def component_stats(labels, n):
    """Bounding boxes and areas of the components of a label image, in
    OpenCV's layout (``cv2.connectedComponentsWithStats``: columns
    ``CC_STAT_LEFT, TOP, WIDTH, HEIGHT, AREA``), in one pass over the pixels
    (OpenCV's own statistics, centroids included, cost twice its labelling
    on the detector's small masks).

    Parameters
    ----------
    labels : (h, w) int32 labels 0..n-1 (0: background, counted like the others)
    n : int, number of labels

    Returns
    -------
    (n, 5) int32 stats (a label without pixels, such as the background of a
    full mask: zeros, where OpenCV leaves sentinels)
    """
    h, w = labels.shape
    x0 = np.full(n, w, np.int32)
    y0 = np.full(n, h, np.int32)
    x1 = np.full(n, -1, np.int32)
    y1 = np.full(n, -1, np.int32)
    area = np.zeros(n, np.int32)
    for y in range(h):
        row = labels[y]
        x = 0
        while x < w:  # one run of a label at a time
            k = row[x]
            start = x
            x += 1
            while x < w and row[x] == k:
                x += 1
            area[k] += x - start
            if start < x0[k]:
                x0[k] = start
            if x - 1 > x1[k]:
                x1[k] = x - 1
            if y < y0[k]:
                y0[k] = y
            y1[k] = y
    stats = np.zeros((n, 5), np.int32)
    for k in range(n):
        if area[k]:
            stats[k, 0] = x0[k]
            stats[k, 1] = y0[k]
            stats[k, 2] = x1[k] - x0[k] + 1
            stats[k, 3] = y1[k] - y0[k] + 1
            stats[k, 4] = area[k]
    return stats


@nb.njit(**_JIT)
def full_rows(labels, stats, ks, share):
    """Rows of components that their label fills (the screen-graphics test of
    :func:`arstream.detect.grass.grass_masks`): for each label ``k`` of ``ks``,
    the rows of its bounding box (``stats`` as :func:`component_stats`) where
    it covers at least ``share`` of the box's width.

    Returns
    -------
    (len(ks), 3) int64: the number of such rows, the first and the last (box
    rows counted from the box's top; -1 when there are none)
    """
    out = np.full((ks.shape[0], 3), -1, np.int64)
    for i in range(ks.shape[0]):
        k = ks[i]
        x, y, bw, bh = stats[k, 0], stats[k, 1], stats[k, 2], stats[k, 3]
        cnt = 0
        for r in range(bh):
            row = labels[y + r]
            c = 0
            for xx in range(x, x + bw):
                if row[xx] == k:
                    c += 1
            if c >= share * bw:
                if cnt == 0:
                    out[i, 1] = r
                out[i, 2] = r
                cnt += 1
        out[i, 0] = cnt
    return out


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
def fit_lines(P, members, offsets):
    """Total-least-squares lines of groups of points, one pass for all
    (:func:`geometry.lines.fit_line` of each group, unweighted: the detector's
    final fit of its line groups in frame pixels).

    Parameters
    ----------
    P : (N, 2) float64 points
    members : (M,) int, the groups' point indices, one group after the other
    offsets : (K + 1,) int, group ``k`` is ``members[offsets[k]:offsets[k + 1]]``

    Returns
    -------
    line : (K, 3) ``a x + b y + c = 0`` with unit normal ``(a, b)`` (NaN for a
        group with fewer than 2 distinct points)
    rms : (K,) RMS distance of the group's points from its line
    normal_sigma, angle_sigma : (K,) offset (px) and direction (rad)
        uncertainties, as :func:`geometry.lines.fit_line`
    ends : (K, 2) int64, positions within the group (first and last along the
        direction ``(-b, a)``) of its extreme points
    length : (K,) distance between them along the line
    """
    K = offsets.shape[0] - 1
    line = np.full((K, 3), np.nan)
    rms = np.full(K, np.nan)
    sig_n = np.full(K, np.nan)
    sig_a = np.full(K, np.nan)
    ends = np.zeros((K, 2), np.int64)
    length = np.zeros(K)
    for k in range(K):
        o0, o1 = offsets[k], offsets[k + 1]
        n = o1 - o0
        if n < 2:
            continue
        cx = 0.0
        cy = 0.0
        for j in range(o0, o1):
            cx += P[members[j], 0]
            cy += P[members[j], 1]
        cx /= n
        cy /= n
        sxx = 0.0
        sxy = 0.0
        syy = 0.0
        for j in range(o0, o1):
            dx = P[members[j], 0] - cx
            dy = P[members[j], 1] - cy
            sxx += dx * dx
            sxy += dx * dy
            syy += dy * dy
        w0, w1, nx, ny = _eigh_sym2(sxx / n, sxy / n, syy / n)
        if w1 < 1e-12:  # the points coincide
            continue
        line[k, 0] = nx
        line[k, 1] = ny
        line[k, 2] = -(nx * cx + ny * cy)
        r = math.sqrt(max(w0, 0.0))
        rms[k] = r
        sig_n[k] = r / math.sqrt(n - 2) if n > 2 else math.inf
        sig_a[k] = sig_n[k] / math.sqrt(w1)
        tmin = math.inf
        tmax = -math.inf
        for j in range(o0, o1):
            t = -ny * P[members[j], 0] + nx * P[members[j], 1]
            if t < tmin:
                tmin = t
                ends[k, 0] = j - o0
            if t > tmax:
                tmax = t
                ends[k, 1] = j - o0
        length[k] = tmax - tmin
    return line, rms, sig_n, sig_a, ends, length


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


@nb.njit(**_JIT)
def composite_i420(yuv, width, height, bgra, rects, ky, ku, kv):
    """Premultiplied "over" of a BGRA overlay onto an I420 frame, in place,
    inside ``rects`` (:func:`arstream.pipeline.composite_i420`): luma per
    pixel, chroma per 2 x 2 block from the block's mean premultiplied colour
    and mean alpha (what "over" followed by 4:2:0 subsampling gives), in
    floating point with one rounding per output sample (half up: the values
    are never negative once clamped).

    Parameters
    ----------
    yuv : (H * W * 3 / 2,) uint8 I420 samples, modified in place
    width, height : int, even frame size
    bgra : (H, W, 4) uint8 premultiplied B, G, R, A
    rects : (R, 4) int64 (x0, y0, x1, y1), even, inside the frame, half-open
    ky, ku, kv : (4,) float64 rows of the BGRA -> premultiplied Y, U, V map
        (the offsets in the alpha column)
    """
    n = width * height
    w2 = width // 2
    u0 = n
    v0 = n + n // 4
    inv255 = 1.0 / 255.0
    ky0, ky1, ky2, ky3 = ky[0], ky[1], ky[2], ky[3]
    ku0, ku1, ku2, ku3 = ku[0], ku[1], ku[2], ku[3]
    kv0, kv1, kv2, kv3 = kv[0], kv[1], kv[2], kv[3]
    for r in range(rects.shape[0]):
        x0, y0, x1, y1 = rects[r, 0], rects[r, 1], rects[r, 2], rects[r, 3]
        for y in range(y0, y1, 2):
            for x in range(x0, x1, 2):
                su = 0.0
                sv = 0.0
                sa = 0.0
                drawn = False
                for dy in range(2):
                    yy = y + dy
                    for dx in range(2):
                        xx = x + dx
                        ia = bgra[yy, xx, 3]
                        ib = bgra[yy, xx, 0]
                        ig = bgra[yy, xx, 1]
                        ir = bgra[yy, xx, 2]
                        if ia == 0 and ib == 0 and ig == 0 and ir == 0:
                            continue  # nothing drawn here
                        b = float(ib)
                        g = float(ig)
                        rr = float(ir)
                        a = float(ia)
                        k = yy * width + xx
                        val = yuv[k] * (1.0 - a * inv255) + ky0 * b + ky1 * g + ky2 * rr + ky3 * a
                        yuv[k] = min(max(int(val + 0.5), 0), 255)
                        su += ku0 * b + ku1 * g + ku2 * rr + ku3 * a
                        sv += kv0 * b + kv1 * g + kv2 * rr + kv3 * a
                        sa += a
                        drawn = True
                if not drawn:
                    continue
                c = (y // 2) * w2 + x // 2
                keep = 1.0 - 0.25 * sa * inv255
                yuv[u0 + c] = min(max(int(yuv[u0 + c] * keep + 0.25 * su + 0.5), 0), 255)
                yuv[v0 + c] = min(max(int(yuv[v0 + c] * keep + 0.25 * sv + 0.5), 0), 255)


@nb.njit(**_JIT)
def project_points(P, R, t, K, dist, width, height, margin, min_depth):
    """Pinhole projection with a radial lens, and which points land in view.

    The same model as :meth:`geometry.camera.Camera.project`: camera
    coordinates ``Xc = R X + t``, normalised ``x = Xc[:2] / Xc[2]`` bent by
    ``(1 + k1 r^2 + k2 r^4 + ...)``, then ``K``. A point past the radius
    where the lens polynomial stops growing (``d r_d / d r <= 0``) gets no
    pixel, as one at depth ``<= min_depth``.

    Parameters
    ----------
    P : (N, 3) float64 world points (metres)
    R : (3, 3), t : (3,) world -> camera
    K : (3, 3) intrinsic matrix
    dist : (k,) float64 radial coefficients (may be empty)
    width, height : frame size (pixels)
    margin : float, pixels inside the frame's edge pixels (negative: beyond them)
    min_depth : float, least camera-frame depth (metres)

    Returns
    -------
    px : (N, 2) float64 pixels, NaN where none
    inside : (N,) bool, a pixel within ``[margin, size - 1 - margin]`` on both axes
    """
    n = P.shape[0]
    px = np.empty((n, 2))
    inside = np.zeros(n, np.bool_)
    nd = dist.shape[0]
    xmax = width - 1 - margin
    ymax = height - 1 - margin
    for i in range(n):
        X0, X1, X2 = P[i, 0], P[i, 1], P[i, 2]
        z = R[2, 0] * X0 + R[2, 1] * X1 + R[2, 2] * X2 + t[2]
        if not z > min_depth:
            px[i, 0] = np.nan
            px[i, 1] = np.nan
            continue
        x = (R[0, 0] * X0 + R[0, 1] * X1 + R[0, 2] * X2 + t[0]) / z
        y = (R[1, 0] * X0 + R[1, 1] * X1 + R[1, 2] * X2 + t[1]) / z
        if nd:
            r2 = x * x + y * y
            factor = 1.0
            slope = 1.0
            rp = 1.0
            for k in range(nd):
                rp *= r2
                factor += dist[k] * rp
                slope += (2 * k + 3) * dist[k] * rp
            if not slope > 0:
                px[i, 0] = np.nan
                px[i, 1] = np.nan
                continue
            x *= factor
            y *= factor
        u = K[0, 0] * x + K[0, 1] * y + K[0, 2]
        v = K[1, 0] * x + K[1, 1] * y + K[1, 2]
        px[i, 0] = u
        px[i, 1] = v
        inside[i] = u >= margin and u <= xmax and v >= margin and v <= ymax
    return px, inside


@nb.njit(**_JIT)
def marking_residuals(X, Q, nrm, R, C, f, cx, cy, k1):
    """Residuals and Jacobian of a camera against matched line pixels.

    The residual of model point ``X_i`` is the signed distance along the
    image normal ``nrm_i`` of its projection from its matched line pixel
    ``Q_i``: ``r_i = n_i . (f x_d + c - Q_i)``, with ``x_d`` the normalised
    point ``(Xc_x, Xc_y) / Xc_z`` of ``Xc = R (X - C)`` bent by
    ``(1 + k1 r^2)``; a point behind the camera has the constant residual
    50 px (and no derivative).

    Parameters
    ----------
    X : (N, 3) model points (metres); Q : (N, 2) matched pixels;
    nrm : (N, 2) unit image normals of the projected markings
    R : (3, 3) rotation, C : (3,) centre (world -> camera ``R (X - C)``)
    f : focal length (px); cx, cy : principal point; k1 : radial coefficient

    Returns
    -------
    r : (N,) residuals (px)
    G : (N, 8) their derivatives by (w_x, w_y, w_z: a left rotation
        perturbation ``R <- exp([w]x) R``, C_x, C_y, C_z, log f, k1)
    """
    n = X.shape[0]
    r = np.empty(n)
    G = np.empty((n, 8))
    for i in range(n):
        d0, d1, d2 = X[i, 0] - C[0], X[i, 1] - C[1], X[i, 2] - C[2]
        x = R[0, 0] * d0 + R[0, 1] * d1 + R[0, 2] * d2
        y = R[1, 0] * d0 + R[1, 1] * d1 + R[1, 2] * d2
        z = R[2, 0] * d0 + R[2, 1] * d1 + R[2, 2] * d2
        if not z > 0:
            r[i] = 50.0
            for j in range(8):
                G[i, j] = 0.0
            continue
        iz = 1.0 / z
        u, v = x * iz, y * iz
        r2 = u * u + v * v
        s = 1.0 + k1 * r2
        n0, n1 = nrm[i, 0], nrm[i, 1]
        r[i] = n0 * (f * u * s + cx - Q[i, 0]) + n1 * (f * v * s + cy - Q[i, 1])
        # d(pixel)/d(u, v) through the lens, contracted with the normal
        a = f * (s + 2 * k1 * u * u)
        b = f * (2 * k1 * u * v)
        c = f * (s + 2 * k1 * v * v)
        gu = n0 * a + n1 * b
        gv = n0 * b + n1 * c
        # dr/dXc
        e0, e1, e2 = gu * iz, gv * iz, -(gu * u + gv * v) * iz
        # left rotation perturbation: dXc/dw = -[Xc]x
        G[i, 0] = e2 * y - e1 * z
        G[i, 1] = e0 * z - e2 * x
        G[i, 2] = e1 * x - e0 * y
        # dXc/dC = -R
        G[i, 3] = -(e0 * R[0, 0] + e1 * R[1, 0] + e2 * R[2, 0])
        G[i, 4] = -(e0 * R[0, 1] + e1 * R[1, 1] + e2 * R[2, 1])
        G[i, 5] = -(e0 * R[0, 2] + e1 * R[1, 2] + e2 * R[2, 2])
        G[i, 6] = f * s * (n0 * u + n1 * v)
        G[i, 7] = f * r2 * (n0 * u + n1 * v)
    return r, G


@nb.njit(**_JIT)
def _rotation_exp(w):
    """``exp([w]x)`` (3, 3) of a rotation vector (3,), as ``cv2.Rodrigues``."""
    th = math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    R = np.eye(3)
    if th < 2.220446049250313e-16:
        return R
    c, s = math.cos(th), math.sin(th)
    c1 = 1.0 - c
    x, y, z = w[0] / th, w[1] / th, w[2] / th
    R[0, 0], R[0, 1], R[0, 2] = c + c1 * x * x, c1 * x * y - s * z, c1 * x * z + s * y
    R[1, 0], R[1, 1], R[1, 2] = c1 * x * y + s * z, c + c1 * y * y, c1 * y * z - s * x
    R[2, 0], R[2, 1], R[2, 2] = c1 * x * z - s * y, c1 * y * z + s * x, c + c1 * z * z
    return R


@nb.njit(**_JIT)
def pose_from_params(th, R_ref, M, C_fixed, k1_fixed):
    """The camera of a parameter vector of :func:`refine_pose`.

    Parameters
    ----------
    th : (k,) parameters
    R_ref : (3, 3) rotation they perturb
    M : (8, k) map from ``th`` to (w (3): a left rotation perturbation
        ``R = exp([w]x) R_ref``, C (3), log f, k1); the centre rows all zero
        for a fixed centre, the k1 row zero for a fixed k1
    C_fixed : (3,) the centre when it is fixed; k1_fixed : k1 when it is fixed

    Returns
    -------
    R (3, 3), C (3,), f, k1
    """
    k = th.shape[0]
    v = np.zeros(8)
    free_c = False
    free_k = False
    for i in range(8):
        for j in range(k):
            v[i] += M[i, j] * th[j]
            if M[i, j] != 0.0:
                if 3 <= i < 6:
                    free_c = True
                elif i == 7:
                    free_k = True
    E = _rotation_exp(v[:3])
    R = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            R[i, j] = E[i, 0] * R_ref[0, j] + E[i, 1] * R_ref[1, j] + E[i, 2] * R_ref[2, j]
    C = v[3:6].copy() if free_c else C_fixed.copy()
    return R, C, math.exp(v[6]), (v[7] if free_k else k1_fixed)


@nb.njit(**_JIT)
def _pose_residuals(th, X, Q, nrm, R_ref, M, C_fixed, k1_fixed, cx, cy):
    R, C, f, k1 = pose_from_params(th, R_ref, M, C_fixed, k1_fixed)
    r, G = marking_residuals(X, Q, nrm, R, C, f, cx, cy, k1)
    n, k = G.shape[0], M.shape[1]
    J = np.zeros((n, k))
    for i in range(n):
        for a in range(8):
            g = G[i, a]
            if g != 0.0:
                for j in range(k):
                    J[i, j] += g * M[a, j]
    return r, J


@nb.njit(**_JIT)
def _soft_l1(r, s2):
    c = 0.0
    for i in range(r.shape[0]):
        c += 2.0 * (math.sqrt(1.0 + r[i] * r[i] / s2) - 1.0)
    return c


@nb.njit(**_JIT)
def _solve_spd(A, b):
    """Solve ``A x = b`` for a symmetric positive definite (k, k) ``A`` (Cholesky);
    (x, False) when a pivot is not positive."""
    k = A.shape[0]
    L = np.zeros((k, k))
    x = np.zeros(k)
    for j in range(k):
        d = A[j, j]
        for m in range(j):
            d -= L[j, m] * L[j, m]
        if not d > 0.0:
            return x, False
        L[j, j] = math.sqrt(d)
        for i in range(j + 1, k):
            v = A[i, j]
            for m in range(j):
                v -= L[i, m] * L[j, m]
            L[i, j] = v / L[j, j]
    y = np.zeros(k)
    for i in range(k):
        v = b[i]
        for m in range(i):
            v -= L[i, m] * y[m]
        y[i] = v / L[i, i]
    for i in range(k - 1, -1, -1):
        v = y[i]
        for m in range(i + 1, k):
            v -= L[m, i] * x[m]
        x[i] = v / L[i, i]
    return x, True


@nb.njit(**_JIT)
def refine_pose(X, Q, nrm, R_ref, M, th0, C_fixed, k1_fixed, cx, cy, f_scale, max_iter, tol):
    """Levenberg-Marquardt with the soft-L1 loss (iteratively reweighted least
    squares) of a camera against matched line pixels.

    Minimises ``sum 2 (sqrt(1 + (r_i / s)^2) - 1)`` over the residuals of
    :func:`marking_residuals` (``s`` = ``f_scale``) for the camera
    :func:`pose_from_params` makes of the parameters: the problem of scipy's
    ``least_squares(loss="soft_l1")``, compiled, because for the few
    parameters of a camera (4-8) and a few hundred residuals the per-call
    overhead of any Python loop is most of the per-frame cost of tracking.
    Damping starts at 1e-3 of the diagonal, shrinks 5x after a step that
    lowers the cost and grows 10x after one that does not; it stops after
    ``max_iter`` steps, when no step lowers the cost, when a step is below
    ``tol`` relative to the parameters, or when the cost fell by less than
    1e-4 of itself.

    Parameters
    ----------
    X, Q, nrm : as :func:`marking_residuals`
    R_ref, M, C_fixed, k1_fixed : as :func:`pose_from_params`
    th0 : (k,) initial parameters
    cx, cy : principal point; f_scale : soft-L1 scale (px)
    max_iter : int; tol : float

    Returns
    -------
    x (k,), residuals (N,) and Jacobian (N, k) at ``x``, cost, steps taken
    """
    s2 = f_scale * f_scale
    k = th0.shape[0]
    x = th0.copy()
    r, J = _pose_residuals(x, X, Q, nrm, R_ref, M, C_fixed, k1_fixed, cx, cy)
    cost = _soft_l1(r, s2)
    lam = 1e-3
    steps = 0
    n = r.shape[0]
    A = np.zeros((k, k))
    g = np.zeros(k)
    B = np.zeros((k, k))
    for it in range(1, max_iter + 1):
        steps = it
        cost_prev = cost
        A[:] = 0.0
        g[:] = 0.0
        for i in range(n):
            w = 1.0 / math.sqrt(1.0 + r[i] * r[i] / s2)
            for a in range(k):
                wa = w * J[i, a]
                g[a] += wa * r[i]
                for b in range(a + 1):
                    A[a, b] += wa * J[i, b]
        for a in range(k):
            for b in range(a):
                A[b, a] = A[a, b]
        improved = False
        dx = np.zeros(k)
        while lam < 1e8:
            for a in range(k):
                for b in range(k):
                    B[a, b] = A[a, b]
                B[a, a] += lam * max(A[a, a], 1e-12)
            dx, ok = _solve_spd(B, -g)
            if not ok:
                lam *= 10.0
                continue
            xn = x + dx
            rn, Jn = _pose_residuals(xn, X, Q, nrm, R_ref, M, C_fixed, k1_fixed, cx, cy)
            cn = _soft_l1(rn, s2)
            if cn < cost:
                x, r, J, cost = xn, rn, Jn, cn
                lam = max(lam * 0.2, 1e-9)
                improved = True
                break
            lam *= 10.0
        if not improved:
            break
        if math.sqrt(np.sum(dx * dx)) < tol * (math.sqrt(np.sum(x * x)) + tol) or cost_prev - cost < 1e-4 * cost_prev:
            break
    return x, r, J, cost, steps


@nb.njit(**_JIT)
def _nearest_indices(i0, i1, scale, n):
    """Indices (i1 - i0,) of the nearest samples of a length-``n`` axis for pixels
    ``i0 .. i1 - 1`` (``scale`` = n / frame size), as :func:`render.keying._sample`
    takes them."""
    out = np.empty(i1 - i0, np.int64)
    for i in range(i0, i1):
        out[i - i0] = min(int((i + 0.5) * scale), n - 1)
    return out


@nb.njit(**_JIT)
def _grass_bits(u, v, hue_lo, hue_hi, min_s, min_v, sdiv, hdiv, bits):
    """Set ``bits`` (4,) uint64: bit ``y`` where the I420 sample (y, u, v) is grass
    (OpenCV's BT.601 I420 -> BGR in fixed point, then its 8-bit HSV within
    ``[hue_lo, hue_hi] x [min_s, 255] x [min_v, 255]``)."""
    uu = np.int64(u) - 128
    vv = np.int64(v) - 128
    ruv = 524288 + 1673527 * vv
    guv = 524288 - 852492 * vv - 409993 * uu
    buv = 524288 + 2116026 * uu
    for k in range(4):
        bits[k] = 0
    for y in range(256):
        yv = max(y - 16, 0) * 1220542
        rr = min(max((yv + ruv) >> 20, 0), 255)
        gg = min(max((yv + guv) >> 20, 0), 255)
        bb = min(max((yv + buv) >> 20, 0), 255)
        vmax = max(bb, gg, rr)
        if vmax < min_v:
            continue
        diff = vmax - min(bb, gg, rr)
        if (diff * sdiv[vmax] + 2048) >> 12 < min_s:
            continue
        if vmax == rr:
            hh = gg - bb
        elif vmax == gg:
            hh = bb - rr + 2 * diff
        else:
            hh = rr - gg + 4 * diff
        hh = (hh * hdiv[diff] + 2048) >> 12
        if hh < 0:
            hh += 180
        if hue_lo <= hh <= hue_hi:
            bits[y >> 6] |= np.uint64(1) << np.uint64(y & 63)


@nb.njit(**_JIT)
def key_i420(yuv, width, height, rects, pitch, keep, se_half, lut, built, hue_lo, hue_hi, min_s, min_v, sdiv, hdiv, out):
    """Full-resolution grass key of an I420 frame inside rectangles.

    The compiled form of :func:`render.keying.refine_matte` on an I420 frame,
    pixel for pixel: a pixel is grass (255) where the pitch mask says pitch and
    either its colour is grass (OpenCV's BT.601 I420 -> BGR, then its 8-bit
    HSV within ``[hue_lo, hue_hi] x [min_s, 255] x [min_v, 255]``, as
    :func:`render.keying.green_matte`) or the keep mask, sampled at full
    resolution inside the rectangle and dilated there by the structuring
    element, is set. Whether a colour is grass comes from a table over the
    chroma pair (256 bits, one per luma), each row filled the first time
    its chroma occurs (:func:`_grass_bits`); the caller keeps the table for
    the next frames (the thresholds must stay the same).

    Parameters
    ----------
    yuv : (H * W * 3 / 2,) uint8 I420 frame, flat
    width, height : frame size (even)
    rects : (R, 4) int64 half-open (x0, y0, x1, y1), inside the frame
    pitch : (h', w') uint8 whole-frame mask at any resolution (nearest samples)
    keep : (h'', w'') uint8 whole-frame mask at any resolution, or (0, 0)
    se_half : (2 g + 1,) int64 half-widths of the structuring element's rows
        (-1: an empty row), centred
    lut : (65536, 4) uint64 grass bits by chroma (u * 256 + v), filled on demand
    built : (65536,) bool, the rows of ``lut`` filled so far
    hue_lo, hue_hi, min_s, min_v : int thresholds (OpenCV hue 0..180)
    sdiv, hdiv : (256,) int64 OpenCV's 8-bit HSV division tables
        (``round(255 * 4096 / v)``, ``round(180 * 4096 / (6 d))``, 0 at 0)
    out : (H, W) uint8, written inside the rectangles only
    """
    n = width * height
    u0 = n
    v0 = n + n // 4
    w2 = width // 2
    ph, pw = pitch.shape
    kh, kw = keep.shape
    g = (se_half.shape[0] - 1) // 2
    if rects.shape[0] == 0:
        return
    for r in range(rects.shape[0]):
        x0, y0, x1, y1 = rects[r, 0], rects[r, 1], rects[r, 2], rects[r, 3]
        if x1 <= x0 or y1 <= y0:
            continue
        w, h = x1 - x0, y1 - y0
        pcol = _nearest_indices(x0, x1, pw / width, pw)
        prow = _nearest_indices(y0, y1, ph / height, ph)
        # the keep mask's nearest samples in the rectangle, dilated within it
        kp = np.zeros((h, w), np.uint8)
        if kh > 0:
            kcol = _nearest_indices(x0, x1, kw / width, kw)
            krow = _nearest_indices(y0, y1, kh / height, kh)
            for yy in range(h):
                ks = keep[krow[yy]]
                xx = 0
                while xx < w:  # each run [a, b) of set samples: its rows of the element at once
                    if ks[kcol[xx]] == 0:
                        xx += 1
                        continue
                    a = xx
                    while xx < w and ks[kcol[xx]] != 0:
                        xx += 1
                    for dy in range(-g, g + 1):
                        hw = se_half[dy + g]
                        ty = yy + dy
                        if hw < 0 or ty < 0 or ty >= h:
                            continue
                        kp[ty, max(a - hw, 0) : min(xx + hw, w)] = 255
        for yy in range(h):
            y = y0 + yy
            orow = out[y]
            prow_ = pitch[prow[yy]]
            krow_ = kp[yy]
            luma = yuv[y * width : (y + 1) * width]
            cu = yuv[u0 + (y // 2) * w2 : u0 + (y // 2 + 1) * w2]
            cv = yuv[v0 + (y // 2) * w2 : v0 + (y // 2 + 1) * w2]
            for xx in range(w):
                x = x0 + xx
                if prow_[pcol[xx]] == 0:
                    orow[x] = 0
                elif krow_[xx] != 0:
                    orow[x] = 255
                else:
                    uc, vc = cu[x >> 1], cv[x >> 1]
                    uv = (np.int64(uc) << 8) | np.int64(vc)
                    if not built[uv]:
                        _grass_bits(uc, vc, hue_lo, hue_hi, min_s, min_v, sdiv, hdiv, lut[uv])
                        built[uv] = True
                    yl = luma[x]
                    orow[x] = np.uint8(255) if (lut[uv, yl >> 6] >> np.uint64(yl & 63)) & np.uint64(1) else np.uint8(0)


def warm_up() -> None:
    """Load (or compile) every kernel by calling it once on tiny inputs."""
    th = np.zeros((8, 8), np.uint8)
    B = np.zeros((8, 8), np.float32)
    p = np.zeros((1, 2))
    z = np.zeros(1, np.int64)
    ridge_scan(th, th, th.view(np.uint64), B, 5.0, 5.5, 0.1)
    band_scan(B, p, np.ones((1, 2)), 6)
    conic_band(np.ones(6), p, p, z, 1.0, 0.0, False)
    direct_fit(np.eye(6))
    direct_fits(np.eye(6)[None].copy())
    ellipse_params(np.ones((1, 6)), 1.0, 0.0, 0.0)
    conic_counts(np.ones((1, 6)), p, p, z, 1.0, 0.95)
    refine_conic(np.ones(6), p, p, z, 1.0, 1.5, 2.25)
    perimeter_bins(p, 0.0, 0.0, 0.0, 2.0, 1.0, 64, 0.3, 1.0)
    label_scatters(np.zeros((1, 6)), np.zeros(1, np.int32), np.ones(1, np.bool_), z)
    frame_ellipse(np.ones(6), np.eye(3))
    fit_lines(p, z, np.zeros(2, np.int64))
    hough_lines(p, p, z, False, 1, z, np.zeros(3, np.int64), z, 2, 2, 2.0, 1.0, 0.0, 0.0, 1, 12, 1.0, 1.0, 1.0, 1, 0.5, 0.3)
    hough_votes(p, p, 0.0, 0.0, 1.0, 2.0, 4, 3, 1, 1.0, 4)
    grid_clear(p, p, 1.0, 1.0, True, 2, 0, np.zeros((2, 2), np.uint8))
    chains(z, z, 1, np.full((2, 2), -1, np.int32))
    beside_grass(p, p, 1.0, th, 1.0, 1.0)
    settle_points(p, p, 1.0, th, 1.0, 1.0, 1.0, 1.0, np.full((2, 2), -1, np.int32), 1.0, th, 1.0, 0.0, 1.0, 0.0)
    cut_by_line(p, np.ones((1, 3)), 0.0, 0.0, 2.0, 1.0, 0.0, 0.95)
    mask_at(p, th, 1.0, 1.0, 1.0, 1.0)
    component_stats(np.zeros((2, 2), np.int32), 1)
    full_rows(np.zeros((2, 2), np.int32), np.zeros((1, 5), np.int32), z, 0.9)
    hartley_monomials(p)
    order, starts, grid = point_grid(p, 8.0, 1024)
    grid_nearest(p, order, starts, *grid, p, 2.5)
    P3, I3 = np.zeros((1, 3)), np.eye(3)
    project_points(P3, I3, np.zeros(3), I3, np.zeros(0), 2, 2, 0.0, 0.5)
    marking_residuals(P3, p, p, I3, np.zeros(3), 1.0, 0.0, 0.0, 0.0)
    refine_pose(P3 + [0.0, 0.0, 1.0], p, p + [1.0, 0.0], I3, np.eye(8, 4), np.zeros(4), np.zeros(3), 0.0, 0.0, 0.0, 1.0, 12, 1e-10)
    pose_from_params(np.zeros(4), I3, np.eye(8, 4), np.zeros(3), 0.0)  # (also called on its own, not only inside refine_pose)
    warm_up_compositor()


def warm_up_compositor() -> None:
    """Load (or compile) the render stage's kernels alone (:func:`composite_i420`,
    :func:`key_i420`, and the renderer's own, :mod:`render.kernels`): what
    drawing with known cameras needs (``arstream render``), without the
    detector's kernels."""
    k4 = np.zeros(4)
    yuv = np.zeros(6, np.uint8)
    rect = np.zeros((1, 4), np.int64)
    composite_i420(yuv, 2, 2, np.zeros((2, 2, 4), np.uint8), rect, k4, k4, k4)
    m = np.zeros((2, 2), np.uint8)
    t = np.zeros(256, np.int64)
    key_i420(yuv, 2, 2, rect, m, m, np.zeros(1, np.int64), np.zeros((1, 4), np.uint64), np.zeros(1, np.bool_), 35, 85, 70, 40, t, t, m)
    from render.kernels import warm_up as warm_up_renderer

    warm_up_renderer()  # the renderer's footprint


_warm_thread: threading.Thread | None = None
_warm_lock = threading.Lock()


def warm_up_async() -> None:
    """:func:`warm_up` on a daemon thread, once per process (later calls return
    at once; a kernel called meanwhile waits for numba's compiler lock)."""
    global _warm_thread
    with _warm_lock:
        if _warm_thread is None:
            _warm_thread = threading.Thread(target=warm_up, name="arstream-kernels", daemon=True)
            _warm_thread.start()


if __name__ == "__main__":  # python -m arstream.kernels: compile (or load) them all now
    import time

    t0 = time.perf_counter()
    warm_up()
    print(f"arstream kernels ready ({time.perf_counter() - t0:.1f} s)")
