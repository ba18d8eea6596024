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
   Steps 1 and 2 past the top-hat and the smoothing are one compiled loop
   over the image (:func:`arstream.detect.kernels.ridge_scan`).
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

from .kernels import ridge_scan

__all__ = ["RidgePoints", "ridge_points"]

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
) -> RidgePoints:
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
    RidgePoints
    """
    h, w = gray.shape
    if bufs.get("shape") != (h, w):
        bufs.clear()
        bufs["shape"] = (h, w)
        bufs["tophat"] = np.empty((h, w), np.uint8)
        bufs["f32"] = np.empty((h, w), np.float32)
        bufs["blur"] = np.empty((h, w), np.float32)
    key = ("se", kernel)
    se = bufs.get(key)
    if se is None:
        se = bufs[key] = cv2.getStructuringElement(cv2.MORPH_RECT, (kernel, kernel))
    th = cv2.morphologyEx(gray, cv2.MORPH_TOPHAT, se, dst=bufs["tophat"])
    f = bufs["f32"]
    f[:] = gray
    k = int(2 * np.ceil(3 * sigma) + 1)
    # (always made: the detector centres the squashed pass's bands on the fine one's)
    B = cv2.GaussianBlur(f, (k, k), sigma, dst=bufs["blur"], borderType=cv2.BORDER_REPLICATE)
    # candidates (top-hat above 0.9 of the contrast, in the region, a maximum across x
    # or y) and their centres: one compiled loop (kernels.ridge_scan)
    pts, nrm, aux, n_cand = ridge_scan(th, region, B, max(min_contrast * 0.9, 2.0), float(min_contrast), 0.5 * kernel, float(curvature_ratio))
    if not len(pts):
        return RidgePoints(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), n_cand)
    c, b1, b2, l1 = aux.T
    contrast = c - np.maximum(b1, b2)
    # a band wider than the scale (a line smeared by a pan): on a step of the grass (a
    # stripe's edge) its plateau slopes and its maximum sits at the bright end; on
    # flat grass the maximum wanders over the plateau with the noise. The midpoint
    # of its two edges is the line's centre. Only for a profile at least ``bw``
    # wide by its curvature, and for a band about as wide as that curvature says
    # (a sharp line, a strip of grass, then the dark boards is not one band)
    bw = 4.0 * sigma if band_width is None else band_width
    if np.isfinite(bw):
        rise = c - 0.5 * (b1 + b2)
        fwhm = 2.355 * np.sqrt(np.maximum(rise, 0.0) / -l1)
        sel = np.flatnonzero(fwhm > bw)
        if len(sel):
            shift, width = band_centres(B, pts[sel], nrm[sel], reach=int(kernel))
            f = fwhm[sel]
            wt = np.clip((width - bw) / (2.0 * sigma), 0.0, 1.0) * np.clip((1.7 * f - width) / (0.3 * f), 0.0, 1.0)
            pts[sel] += (wt * shift)[:, None] * nrm[sel]
    return RidgePoints(pts, nrm, contrast, n_cand)


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
