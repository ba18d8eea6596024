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
   its own pixel (``|t n| <= 0.5``; within a pixel for a line thinner than
   the scale, whose smoothed maximum a bright side and a dark one pull off
   its brightest pixel). A centre must also be brighter than the grass on
   *both* sides at a distance beyond the line's half width (a step edge is
   bright on one side only), by the smoothed contrast or, on a thin line
   (its smoothed profile about as wide as the scale) brighter than the grass
   around it, by its own (its brightest pixel's: smoothing keeps a third of a
   1 px line's height, and the far lines of a real frame are one or two
   pixels wide), and be elongated (``|l2| < |l1|``).
   Past the top-hat, the smoothing and the candidate mask (OpenCV), steps 1
   and 2 are one compiled loop over the image
   (:func:`arstream.detect.kernels.ridges.ridge_scan`).
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

from arstream.detect.kernels.ridges import band_scan, ridge_scan

__all__ = ["RidgePoints", "grass_luma", "ridge_points"]

_NEVER_THIN = np.full((1, 1), np.inf, np.float32)  # no pixel stands above it: the thin-line rule is off


class RidgePoints:
    __slots__ = ("pts", "nrm", "contrast", "n_candidates")

    def __init__(self, pts, nrm, contrast, n_candidates):
        self.pts, self.nrm, self.contrast, self.n_candidates = pts, nrm, contrast, n_candidates


def ridge_points(
    gray: np.ndarray,
    region: np.ndarray,
    *,
    sigma: float,
    kernel: int,
    min_contrast: float,
    curvature_ratio: float = 0.1,
    band_width: float | None = None,
    grass_luma: np.ndarray | None = None,
    contrast_grid: np.ndarray | None = None,
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
    contrast_grid : (ch, cw) float32, optional: ``min_contrast`` where it
        varies over the image (lower where the grass is in shadow:
        :class:`arstream.detect.Detector`'s ``shade``), on a coarser grid
        spanning the same image; ``min_contrast`` is then unused
    curvature_ratio : least |l1| / contrast: flatter ridges are plateaus of lines
        too wide for ``sigma``
    band_width : profile width (px, by the curvature at the centre) from which a
        point is centred between its band's edges (:func:`band_centres`); by
        default ``4 sigma``; ``inf``: never
    grass_luma : (gh, gw) float32, the grass's local luma on a coarser grid over
        the same image (:func:`grass_luma`): a thin line standing
        ``min_contrast`` above it is judged by its own (unsmoothed) contrast
        (step 2 above). None: every line by its smoothed contrast (the rule
        for thin lines off)
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
        bufs["blur"] = np.empty((h, w), np.float32)
        bufs["cand"] = np.zeros((h, -(-w // 8) * 8), np.uint8)  # rows padded to 8-byte words
    key = ("se", kernel)
    se = bufs.get(key)
    if se is None:
        se = bufs[key] = cv2.getStructuringElement(cv2.MORPH_RECT, (kernel, kernel))
    th = cv2.morphologyEx(gray, cv2.MORPH_TOPHAT, se, dst=bufs["tophat"])
    key = ("gauss", sigma)
    g1 = bufs.get(key)
    if g1 is None:
        g1 = bufs[key] = cv2.getGaussianKernel(int(2 * np.ceil(3 * sigma) + 1), sigma, cv2.CV_32F)
    # the Gaussian of the luma in float, straight from uint8 (the same values as
    # GaussianBlur of a float copy, without the copy); always made: the detector
    # centres the squashed pass's bands on the fine one's
    B = cv2.sepFilter2D(gray, cv2.CV_32F, g1, g1, dst=bufs["blur"], borderType=cv2.BORDER_REPLICATE)
    # candidates: top-hat above 0.9 of the contrast, in the region (OpenCV), then those
    # that are a maximum across x or y, and their centres: one compiled loop
    # (kernels.ridge_scan, which skips 8 pixels without a candidate at a time)
    cand = bufs["cand"]
    cv = cand[:, :w]
    if contrast_grid is None:
        thr = max(min_contrast * 0.9, 2.0)
        cv2.threshold(th, min(int(np.floor(thr)), 255), 255, cv2.THRESH_BINARY, dst=cv)  # th > thr for integer th
        grid = np.full((1, 1), min_contrast, np.float32)
    else:
        grid = np.ascontiguousarray(contrast_grid, np.float32)
        floor = np.floor(np.clip(np.maximum(grid * 0.9, 2.0), 0, 255)).astype(np.uint8)
        cv2.compare(th, cv2.resize(floor, (w, h), interpolation=cv2.INTER_NEAREST), cv2.CMP_GT, dst=cv)
    cv2.bitwise_and(cv, region, dst=cv)
    gl = _NEVER_THIN if grass_luma is None else np.ascontiguousarray(grass_luma, np.float32)
    pts, nrm, aux, n_cand = ridge_scan(th, cand, cand.view(np.uint64), B, gray, gl, float(sigma), grid, 0.5 * kernel, float(curvature_ratio))
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


def grass_luma(gray: np.ndarray, grass: np.ndarray, fallback: float, *, cells: int = 5) -> np.ndarray:
    """The grass's local luma: the mean luma of the grass pixels in a
    ``cells`` x ``cells`` box around each pixel (``fallback`` where the box
    has none).

    Parameters
    ----------
    gray : (h, w) uint8 luma (a small copy of the frame)
    grass : (h, w) uint8, non-zero on grass pixels (lines, players, shadows'
        dark grass: what the grass model says)
    fallback : float, grey level where no grass is near

    Returns
    -------
    (h, w) float32
    """
    m = (grass > 0).astype(np.float32)
    num = cv2.boxFilter(gray.astype(np.float32) * m, -1, (cells, cells), normalize=False, borderType=cv2.BORDER_REPLICATE)
    den = cv2.boxFilter(m, -1, (cells, cells), normalize=False, borderType=cv2.BORDER_REPLICATE)
    return np.where(den > 0.5, num / np.maximum(den, 1.0), np.float32(fallback)).astype(np.float32)


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

    One compiled loop over the points (:func:`arstream.detect.kernels.ridges.band_scan`).

    Returns
    -------
    shift : (N,) offset along ``nrm`` from ``pts`` to the band's edge midpoint (0 where
        no band is found: an edge not crossed within ``reach - 4``, no flat grass
        beyond an edge, or sides that differ by more than half the band's height
        above them)
    width : (N,) distance between the edges (0 where no band is found)
    """
    if len(pts) == 0:
        return np.zeros(0), np.zeros(0)
    B = np.ascontiguousarray(B, np.float32)
    return band_scan(B, np.ascontiguousarray(pts, np.float64), np.ascontiguousarray(nrm, np.float64), int(reach))
