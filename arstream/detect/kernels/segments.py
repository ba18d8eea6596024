"""Compiled loops of the line stage (:mod:`arstream.detect.segments`, numba): the
Hough vote over the line pixels' normals with its peak search, and the peak
loop that takes lines out of the vote one at a time.

Compiled on first use and cached next to this file (numba's ``cache=True``);
:func:`arstream.kernels.warm_up` loads them ahead of a run.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from arstream.jit import JIT as _JIT, counting_sort

__all__ = ["hough_lines", "hough_votes", "warm_up"]


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
    min_points, min_length, max_gap, tol, max_lines, max_sagitta, max_rms, src_x, src_y,
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
    twice is not tried again. ``src_x``, ``src_y`` (at most 1): source pixels
    per working pixel of an enlarged image; the thickness and straightness
    of a line of normal (a, b) are measured in source pixels (its residuals
    times ``hypot(a src_x, b src_y)``).

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
        # straightness: a quadratic through the residuals, peak-to-peak over the
        # length (both in source pixels: an enlarged image enlarges the wobble)
        g = np.sqrt((a * src_x) ** 2 + (b * src_y) ** 2)
        curved = rms * g > max_rms
        if not curved:
            qr = 0.0
            qq = 0.0
            for k in range(nm):
                j = piece[k]
                uu = (tbuf[k] - 0.5 * (t0 + t1)) * (2.0 / length)
                q2 = uu * uu - 1.0 / 3.0
                qr += q2 * (pts[j, 0] * a + pts[j, 1] * b + cc)
                qq += q2 * q2
            curved = abs(qr / max(qq, 1e-12)) * g > max_sagitta
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
    order_t, starts = counting_sort(tb, n_th)  # the points by theta bin
    return out, order_t, starts


def warm_up() -> None:
    """Load (or compile) this module's kernels by calling them once on tiny inputs."""
    p = np.zeros((1, 2))
    z = np.zeros(1, np.int64)
    hough_lines(p, p, z, False, 1, z, np.zeros(3, np.int64), z, 2, 2, 2.0, 1.0, 0.0, 0.0, 1, 12, 1.0, 1.0, 1.0, 1, 0.5, 0.3, 1.0, 1.0)
    hough_votes(p, p, 0.0, 0.0, 1.0, 2.0, 4, 3, 1, 1.0, 4)
