"""Line pixels: thin bright ridges of the luma plane on the grass.

Two steps, both at the working resolution:

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

Outputs are arrays over the accepted centre points (working-resolution
pixels): ``pts`` (N, 2), unit normals ``nrm`` (N, 2), ``contrast`` (N,).
"""

from __future__ import annotations

import cv2
import numpy as np

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
    nz = cv2.findNonZero(cand)
    if nz is None:
        return RidgePoints.empty(), cand
    xy = nz.reshape(-1, 2)
    x = xy[:, 0].astype(np.intp)
    y = xy[:, 1].astype(np.intp)
    f = bufs["f32"]
    f[:] = gray
    k = int(2 * np.ceil(3 * sigma) + 1)
    B = cv2.GaussianBlur(f, (k, k), sigma, dst=bufs["blur"], borderType=cv2.BORDER_REPLICATE)
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
    return RidgePoints(pts, nrm, contrast[ok], len(xy)), cand
