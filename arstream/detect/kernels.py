"""Compiled per-pixel and per-point loops of the detector (numba).

The detector's stages are whole-image OpenCV operations followed by work on
the few thousand line pixels they leave. Written as numpy expressions, that
work is dozens of passes over small arrays, each paying numpy's per-call
overhead, and it holds the GIL between them; here each is one compiled loop
that releases the GIL (the pipeline runs detection on its own thread).

Compiled on first use and cached next to this file (numba's ``cache=True``;
the first run after an install takes some seconds more).
"""

from __future__ import annotations

import numba as nb
import numpy as np

__all__ = ["ridge_scan"]

_JIT = dict(cache=True, nogil=True, fastmath=False, boundscheck=False)


@nb.njit(**_JIT)
def _grow2(a, n):
    b = np.empty((2 * a.shape[0], a.shape[1]), a.dtype)
    b[:n] = a[:n]
    return b


@nb.njit(**_JIT)
def ridge_scan(th, region, B, thr, min_contrast, d, curvature_ratio):
    """Sub-pixel ridge centres at the candidate pixels of a top-hat image.

    A candidate is a pixel of ``th`` above ``thr`` inside ``region`` that is a
    maximum of ``th`` across x or across y (plateaus included), at least 2 px
    from the border. At each, the Hessian of ``B`` (3x3 differences) gives the
    line's normal ``n`` (eigenvector of the most negative eigenvalue ``l1``);
    a centre needs ``l1 < 0``, an elongated profile (``l2 > l1 / 2``), the
    ridge maximum within its own pixel along ``n`` after the grass's slope
    across the line is taken out (a linear background through the samples
    ``d`` px either side, when they differ by at most half the contrast), a
    contrast over the brighter side of at least ``min_contrast`` and a
    curvature ``-l1 >= curvature_ratio * contrast``.

    Parameters
    ----------
    th : (h, w) uint8 top-hat of the luma
    region : (h, w) uint8, non-zero where lines may be
    B : (h, w) float32 Gaussian-smoothed luma
    thr : float, candidate threshold on ``th`` (strictly above)
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
    ithr = min(int(np.floor(thr)) + 1, 256)  # th > thr for integer th
    half = np.float32(0.5)
    two = np.float32(2.0)
    quarter = np.float32(0.25)
    d2 = np.float32(2.0 * d)
    for y in range(2, h - 2):
        trow = th[y]
        rrow = region[y]
        for x in range(2, w - 2):
            t = trow[x]
            if t < ithr or rrow[x] == 0:
                continue
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
