"""Line pixels: thin bright ridges of the luma plane on the grass.

Three steps, at the working resolution:

1. Candidates: a white top-hat of the luma (bright structure narrower than
   the kernel) above a threshold set from the grass's own brightness, inside
   the grass region. Stripe and shadow edges are steps, not ridges: the
   top-hat barely answers them.
2. Centres: Steger's sub-pixel ridge detector at the candidates. The
   Hessian of the Gaussian-smoothed luma gives the normal ``n`` of the line;
   the second-order Taylor model along ``n`` gives the offset ``t`` of the
   ridge maximum, after the grass's own slope across the line (a linear
   background through the two side samples below) is taken out, so that a
   line on the edge of a mowing stripe or a shadow is not pulled toward the
   bright side; a candidate is a centre point when that maximum falls inside
   its own pixel (``|t n| <= 0.5``). A centre must also be brighter than the
   grass on *both* sides at a distance beyond the line's half width (a step
   edge is bright on one side only) and be elongated (``|l2| < |l1|``).
3. Bands: a line smeared by a fast pan is a band as wide as the scale. On a
   stripe's edge its plateau slopes down with the step, so its maximum sits at
   the bright end (1-2 px off); on flat grass it wanders over the plateau.
   Where the curvature says the profile is that wide, the centre is the
   midpoint of the band's two edges instead (:func:`band_centres`, each edge
   cut at half the band's height above its own side).

Outputs are arrays over the accepted centre points (working-resolution
pixels): ``pts`` (N, 2), unit normals ``nrm`` (N, 2), ``contrast`` (N,).
"""

from __future__ import annotations

import cv2
import numpy as np

from arstream.imaging import sample_bilinear

__all__ = ["RidgePoints", "ridge_points"]

_KX = np.ones((1, 3), np.uint8)
_KY = np.ones((3, 1), np.uint8)


class RidgePoints:
    __slots__ = ("pts", "nrm", "contrast", "n_candidates")

    def __init__(self, pts, nrm, contrast, n_candidates):
        self.pts, self.nrm, self.contrast, self.n_candidates = pts, nrm, contrast, n_candidates

    @classmethod
    def empty(cls) -> "RidgePoints":
        z = np.zeros((0, 2))
        return cls(z, z.copy(), np.zeros(0), 0)


def ridge_points(
    gray: np.ndarray,
    region: np.ndarray,
    *,
    sigma: float,
    kernel: int,
    min_contrast: float,
    curvature_ratio: float = 0.1,
    band_width: float | None = None,
    bufs: dict,
) -> tuple[RidgePoints, np.ndarray]:
    """Sub-pixel ridge centres of bright thin lines.

    Parameters
    ----------
    gray : (h, w) uint8 luma at the working resolution
    region : (h, w) uint8, 255 where lines may be (the grass)
    sigma : Gaussian scale of the Hessian (px); at least width / (2 sqrt 3)
    kernel : top-hat kernel size (odd, px); wider than any line
    min_contrast : grey levels a line must stand above the grass on both sides
    curvature_ratio : least |l1| / contrast: flatter ridges are plateaus of lines
        too wide for ``sigma``
    band_width : profile width (px, by the curvature at the centre) from which a
        point is centred between its band's edges (:func:`band_centres`); by
        default ``4 sigma``; ``inf``: never
    bufs : dict of reusable buffers (filled on first use)

    Returns
    -------
    (RidgePoints, cand) where ``cand`` (h, w) uint8 is the candidate (line pixel) mask.
    """
    h, w = gray.shape
    if bufs.get("shape") != (h, w):
        bufs.clear()
        bufs["shape"] = (h, w)
        bufs["tophat"] = np.empty((h, w), np.uint8)
        bufs["cand"] = np.empty((h, w), np.uint8)
        bufs["f32"] = np.empty((h, w), np.float32)
        bufs["blur"] = np.empty((h, w), np.float32)
        bufs["mx"] = np.empty((h, w), np.uint8)
        bufs["my"] = np.empty((h, w), np.uint8)
    key = ("se", kernel)
    se = bufs.get(key)
    if se is None:
        se = bufs[key] = cv2.getStructuringElement(cv2.MORPH_RECT, (kernel, kernel))
    th = cv2.morphologyEx(gray, cv2.MORPH_TOPHAT, se, dst=bufs["tophat"])
    cand = bufs["cand"]
    cv2.threshold(th, max(min_contrast * 0.9, 2.0), 255, cv2.THRESH_BINARY, dst=cand)
    cv2.bitwise_and(cand, region, dst=cand)
    # a ridge centre is a maximum across the line, so along x or along y
    # (plateaus of saturated wide lines included): drop the rest early
    mx = cv2.dilate(th, _KX, dst=bufs["mx"])
    my = cv2.dilate(th, _KY, dst=bufs["my"])
    cv2.compare(th, mx, cv2.CMP_GE, dst=mx)
    cv2.compare(th, my, cv2.CMP_GE, dst=my)
    cv2.bitwise_or(mx, my, dst=mx)
    cv2.bitwise_and(cand, mx, dst=cand)
    # keep a 2 px frame free so that the 3x3 stencils and side samples stay inside
    cand[:2] = 0
    cand[-2:] = 0
    cand[:, :2] = 0
    cand[:, -2:] = 0
    f = bufs["f32"]
    f[:] = gray
    k = int(2 * np.ceil(3 * sigma) + 1)
    # (always made: the detector centres the squashed pass's bands on the fine one's)
    B = cv2.GaussianBlur(f, (k, k), sigma, dst=bufs["blur"], borderType=cv2.BORDER_REPLICATE)
    nz = cv2.findNonZero(cand)
    if nz is None:
        return RidgePoints.empty(), cand
    xy = nz.reshape(-1, 2)
    x = xy[:, 0].astype(np.intp)
    y = xy[:, 1].astype(np.intp)
    Bf = B.ravel()
    idx = y * w + x
    c = Bf[idx]
    xp, xm = Bf[idx + 1], Bf[idx - 1]
    yp, ym = Bf[idx + w], Bf[idx - w]
    gx = 0.5 * (xp - xm)
    gy = 0.5 * (yp - ym)
    gxx = xp + xm - 2.0 * c
    gyy = yp + ym - 2.0 * c
    gxy = 0.25 * (Bf[idx + w + 1] - Bf[idx + w - 1] - Bf[idx - w + 1] + Bf[idx - w - 1])
    # eigen-decomposition of [[gxx, gxy], [gxy, gyy]]: l1 <= l2
    half_tr = 0.5 * (gxx + gyy)
    root = np.sqrt(0.25 * (gxx - gyy) ** 2 + gxy * gxy)
    l1 = half_tr - root
    l2 = half_tr + root
    # eigenvector of l1: (gxy, l1 - gxx) or (l1 - gyy, gxy), the better conditioned
    ax, ay = gxy, l1 - gxx
    bx, by = l1 - gyy, gxy
    use_b = (bx * bx + by * by) > (ax * ax + ay * ay)
    nx = np.where(use_b, bx, ax)
    ny = np.where(use_b, by, ay)
    nn = np.sqrt(nx * nx + ny * ny)
    ok = (l1 < 0) & (nn > 1e-12)
    nn[~ok] = 1.0
    nx /= nn
    ny /= nn
    # elongated: the second curvature well below the first (blobs have both large)
    ok &= l2 > 0.5 * l1
    if not ok.any():
        return RidgePoints.empty(), cand
    sel = np.flatnonzero(ok)
    x, y, nx, ny, gx, gy, c, l1 = x[sel], y[sel], nx[sel], ny[sel], gx[sel], gy[sel], c[sel], l1[sel]
    # the grass on both sides, beyond the half width
    d = 0.5 * kernel
    sx1 = np.clip(np.rint(x + d * nx), 0, w - 1).astype(np.intp)
    sy1 = np.clip(np.rint(y + d * ny), 0, h - 1).astype(np.intp)
    sx2 = np.clip(np.rint(x - d * nx), 0, w - 1).astype(np.intp)
    sy2 = np.clip(np.rint(y - d * ny), 0, h - 1).astype(np.intp)
    b1 = Bf[sy1 * w + sx1]
    b2 = Bf[sy2 * w + sx2]
    # the centre, with the grass's own slope across the line taken out (a linear
    # background through the side samples): a line on the edge of a mowing
    # stripe or a shadow sits on a step, whose slope would pull the maximum
    # toward the bright side (by up to a pixel or two for a line smeared wide by
    # a pan, whose curvature is weak). The sides count as grass when they differ
    # by at most half the line's rise over the brighter one (else one is on the
    # line itself: a band wider than the scale)
    contrast = c - np.maximum(b1, b2)
    slope = np.where(np.abs(b1 - b2) <= 0.5 * contrast, (b1 - b2) / (2.0 * d), 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -(gx * nx + gy * ny - slope) / l1
    ox, oy = t * nx, t * ny
    ok = (np.abs(ox) <= 0.5) & (np.abs(oy) <= 0.5)
    px = x + ox
    py = y + oy
    # a line wider than the scale is a plateau: flat (weak curvature for its
    # contrast) with a centre anywhere on it; the coarser pass finds it
    ok &= (contrast >= min_contrast) & (-l1 >= curvature_ratio * contrast)
    if not ok.any():
        return RidgePoints.empty(), cand
    pts = np.column_stack([px[ok], py[ok]])
    nrm = np.column_stack([nx[ok], ny[ok]])
    # a band wider than the scale (a line smeared by a pan): on a step of the grass (a
    # stripe's edge) its plateau slopes and its maximum sits at the bright end; on
    # flat grass the maximum wanders over the plateau with the noise. The midpoint
    # of its two edges is the line's centre. Only for a profile at least ``bw``
    # wide by its curvature, and for a band about as wide as that curvature says
    # (a sharp line, a strip of grass, then the dark boards is not one band)
    bw = 4.0 * sigma if band_width is None else band_width
    if np.isfinite(bw):
        c, b1, b2, l1 = c[ok], b1[ok], b2[ok], l1[ok]
        rise = c - 0.5 * (b1 + b2)
        fwhm = 2.355 * np.sqrt(np.maximum(rise, 0.0) / -l1)
        sel = np.flatnonzero(fwhm > bw)
        if len(sel):
            shift, width = band_centres(B, pts[sel], nrm[sel], reach=int(kernel))
            f = fwhm[sel]
            wt = np.clip((width - bw) / (2.0 * sigma), 0.0, 1.0) * np.clip((1.7 * f - width) / (0.3 * f), 0.0, 1.0)
            pts[sel] += (wt * shift)[:, None] * nrm[sel]
    return RidgePoints(pts, nrm, contrast[ok], len(xy)), cand


def band_centres(B: np.ndarray, pts: np.ndarray, nrm: np.ndarray, *, reach: int) -> tuple[np.ndarray, np.ndarray]:
    """Edge midpoints of bright bands across their normals.

    The profile of ``B`` along each normal (bilinear samples 1 px apart, out to
    ``reach`` px each side) is cut at half the band's height above the grass on
    each side (the mean of the 3 outermost samples there), so that a band on a
    step of the grass (a mowing stripe's edge under a line smeared by a pan) has
    its two edges at the same relative height. Beyond each edge (and its smoothed
    tail) the profile must be flat, within a quarter of the band's height, out to
    those samples: grass, not the boards or a player beside the line.

    Parameters
    ----------
    B : (h, w) float32 image (smoothed luma)
    pts : (N, 2) points on the bands, pixels
    nrm : (N, 2) unit normals across the bands
    reach : samples each side (at least 6)

    Returns
    -------
    shift : (N,) offset along ``nrm`` from ``pts`` to the band's edge midpoint (0 where
        no band is found: an edge not crossed within ``reach - 4``, no flat grass
        beyond an edge, or sides that differ by more than half the band's height
        above them)
    width : (N,) distance between the edges (0 where no band is found)
    """
    n = len(pts)
    if n == 0:
        return np.zeros(0), np.zeros(0)
    r = int(reach)
    s = np.arange(-r, r + 1, dtype=np.float32)
    q = np.stack([pts[:, :1] + s * nrm[:, :1], pts[:, 1:] + s * nrm[:, 1:]], axis=-1)
    prof = sample_bilinear(B, q, border=cv2.BORDER_REPLICATE)  # (N, 2r + 1)
    # both sides at once, outward from the centre: rows 0..N-1 along +nrm, N..2N-1 along -nrm
    side = np.concatenate([prof[:, r:], prof[:, r::-1]])  # (2N, r + 1), distance 0 .. r
    base = side[:, -3:].mean(axis=1)
    b_r, b_l = base[:n], base[n:]
    rise = prof[:, r - 1 : r + 2].mean(axis=1) - 0.5 * (b_l + b_r)
    rise2 = np.concatenate([rise, rise])
    level = base + 0.5 * rise2
    below = side < level[:, None]
    below[:, 0] = False
    j = np.argmax(below, axis=1)  # the first sample below the level (0: none)
    found = (j >= 1) & (j <= r - 4)
    j = np.clip(j, 1, r - 4)
    rows = np.arange(2 * n)
    # flat beyond the edge: the spread of the samples from j + 2 out
    hi = np.maximum.accumulate(side[:, ::-1], axis=1)[:, ::-1]
    lo = np.minimum.accumulate(side[:, ::-1], axis=1)[:, ::-1]
    found &= hi[rows, j + 2] - lo[rows, j + 2] <= 0.25 * rise2
    a, b = side[rows, j - 1], side[rows, j]
    dist = j - 1 + np.clip((a - level) / np.where(a > b, a - b, 1.0), 0.0, 1.0)
    dr, dl = dist[:n], dist[n:]
    # grass on both sides: a step between them of at most half the band's height
    # (a mowing stripe's edge; not the boards beyond the far touchline)
    ok = found[:n] & found[n:] & (rise > 0) & (np.abs(b_l - b_r) <= 0.5 * rise)
    shift = np.where(ok, 0.5 * (dr - dl), 0.0).astype(np.float64)
    width = np.where(ok, dr + dl, 0.0).astype(np.float64)
    return shift, width
