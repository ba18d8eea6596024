"""Compiled loops of the ridge stage (:mod:`arstream.detect.ridges`, numba): the
scan for line pixels across a thresholded ridge image, and the band centres
of smeared lines.

Compiled on first use and cached next to this file (numba's ``cache=True``);
:func:`arstream.kernels.warm_up` loads them ahead of a run.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from arstream.jit import JIT as _JIT

__all__ = ["band_scan", "ridge_scan", "warm_up"]


@nb.njit(**_JIT)
def _grow2(a, n):
    b = np.empty((2 * a.shape[0], a.shape[1]), a.dtype)
    b[:n] = a[:n]
    return b


@nb.njit(**_JIT)
def ridge_scan(th, cand, words, B, G, grass, sigma, contrast_grid, d, curvature_ratio):
    """Sub-pixel ridge centres at the candidate pixels of a top-hat image.

    A candidate is a pixel where ``cand`` is non-zero (the caller's mask of
    ``th`` above the threshold inside the region where lines may be) that is
    a maximum of ``th`` across x or across y (plateaus included), at least
    2 px from the border. At each, the Hessian of ``B`` (3x3 differences)
    gives the line's normal ``n`` (eigenvector of the most negative eigenvalue
    ``l1``); a centre needs ``l1 < 0``, an elongated profile (``l2 > l1 / 2``),
    the ridge maximum within its own pixel along ``n`` after the grass's slope
    across the line is taken out (a linear background through the samples
    ``d`` px either side, when they differ by at most half the line's
    contrast), a contrast over the brighter side of at least ``min_contrast``
    and a curvature ``-l1 >= curvature_ratio * c_B`` (``c_B``: ``B``'s
    contrast over the brighter side).

    The contrast is ``B``'s, except on a thin line: smoothed, a line narrower
    than the scale loses most of its height (a line 1 px wide keeps a third
    at ``sigma`` 1.2 px), so the far lines of a real frame, one or two pixels
    wide, would fail a threshold set for the paint's own contrast. A line is
    thin when the smoothed profile's half-height width (a Gaussian's, from
    its height over the sides' mean and ``l1``) lies between 2.17 ``sigma``
    (a line of no width, 2.355 ``sigma``, less the 3x3 differences' error)
    and 3.3 ``sigma`` (a line about 4 px wide at 1.2 px: wider ones keep 90 %
    of their height), and when its luma ``G`` (or ``B`` where brighter)
    stands ``min_contrast`` above the grass around it (``grass``: a strip of
    grass between a player's legs is a thin ridge as bright as the grass).
    Its contrast is then its own: that luma over the brighter side's ``B``.
    A thin line whose smoothed contrast is under two thirds of its own may
    have its ridge maximum up to a pixel from the candidate (a bright side
    and a dark one pull the smoothed maximum off the brightest pixel).

    Parameters
    ----------
    th : (h, w) uint8 top-hat of the luma
    cand : (h, wp) uint8 candidate mask, its rows padded with zeros to a
        multiple of 8 bytes (``wp >= w``)
    words : ``cand`` viewed as (h, wp / 8) uint64: the scan skips 8 pixels
        without a candidate at once
    B : (h, w) float32 Gaussian-smoothed luma
    G : (h, w) uint8 luma (unsmoothed)
    grass : (gh, gw) float32 the grass's local luma, on a grid that spans the
        image (pixel (x, y) reads cell (x gw / w, y gh / h), truncated)
    sigma : float, the scale of ``B``'s Gaussian (px)
    contrast_grid : (ch, cw) float32, ``min_contrast`` on a grid that spans
        the image, read as ``grass`` is (a (1, 1) grid: one contrast for all)
    d, curvature_ratio : float

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
    thin = np.float32(1.5)
    fwhm2 = np.float32(8.0 * np.log(2.0))  # a Gaussian's squared half-height width over its variance
    thin_lo = np.float32((2.17 * sigma) ** 2)
    thin_hi = np.float32((3.3 * sigma) ** 2)
    gh, gw = grass.shape
    gsx = gw / w
    gsy = gh / h
    ch, cw = contrast_grid.shape
    csx = cw / w
    csy = ch / h
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
                min_contrast = contrast_grid[min(int(y * csy), ch - 1), min(int(x * csx), cw - 1)]
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
                # a thin line's contrast is its own: its brightest pixel (the
                # candidate) over the brighter side (smoothing takes most of the
                # height of a line narrower than the scale). Thin: the smoothed
                # profile's half-height width, from its height over the sides' mean
                # and its curvature as a Gaussian's, is the scale's or a little more;
                # and the pixel is brighter than the grass around it
                top = max(np.float32(G[y, x]), c)
                own = contrast
                rise = c - half * (b1 + b2)
                fw2 = fwhm2 * rise / -l1
                if fw2 >= thin_lo and fw2 <= thin_hi and top - grass[min(int(y * gsy), gh - 1), min(int(x * gsx), gw - 1)] >= min_contrast:
                    own = top - max(b1, b2)
                slope = (b1 - b2) / d2 if abs(b1 - b2) <= half * own else np.float32(0.0)
                tt = -(gx * nx + gy * ny - slope) / l1
                ox = tt * nx
                oy = tt * ny
                # a thin line smoothed to under two thirds of its own contrast (under
                # about 2.3 px wide at sigma 1.2), between a bright and a dark side (a
                # mowing stripe, a sharpened picture's dark rim) has the smoothed
                # maximum pulled up to a pixel off its brightest pixel, toward the
                # bright side; the neighbour there is no candidate (dimmer), so the
                # line would be found only where it crosses pixel centres: dashes
                lim = np.float32(1.0) if own >= thin * contrast else half
                if not (abs(ox) <= lim and abs(oy) <= lim):
                    continue
                if not (own >= min_contrast and -l1 >= curvature_ratio * contrast):
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


def warm_up() -> None:
    """Load (or compile) this module's kernels by calling them once on tiny inputs."""
    th = np.zeros((8, 8), np.uint8)
    B = np.zeros((8, 8), np.float32)
    p = np.zeros((1, 2))
    ridge_scan(th, th, th.view(np.uint64), B, th, B, 1.2, np.full((1, 1), 5.0, np.float32), 5.5, 0.1)
    band_scan(B, p, np.ones((1, 2)), 6)
