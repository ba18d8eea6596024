"""Grass keys: an HSV chroma key (:func:`green_matte`), the fine key of the
overlay's rectangles at full resolution (:func:`refine_matte` on BGR,
:class:`GrassKeyI420` on I420 frames, pixel for pixel the same).

The pipeline's detector (``arstream.detect``) makes the coarse grass matte
and :func:`refine_matte` sharpens it where graphics are drawn;
:func:`green_matte` alone is the fallback that lets ``arstream render`` key
graphics on its own. Green hue with enough saturation and brightness counts
as grass; white lines, players, the ball and the stands do not.
"""

from __future__ import annotations

import cv2
import numpy as np

from render.compositor import rect_array

__all__ = ["GRASS_HUE", "MIN_SATURATION", "MIN_VALUE", "GrassKeyI420", "green_matte", "refine_matte"]

#: OpenCV hue range (0..180) of grass: yellow-green to green-cyan
GRASS_HUE = (35, 85)
#: least saturation and value (0..255) of grass (shadows on grass stay grass)
MIN_SATURATION = 70
MIN_VALUE = 40


def green_matte(frame_bgr: np.ndarray, *, hue=GRASS_HUE, min_saturation: int = MIN_SATURATION, min_value: int = MIN_VALUE,
                out: np.ndarray | None = None) -> np.ndarray:
    """Grass matte of a BGR frame by hue.

    Parameters
    ----------
    frame_bgr : (H, W, 3) uint8, BGR
    hue : (lo, hi), OpenCV hue range (0..180) of grass; default :data:`GRASS_HUE`
    min_saturation, min_value : 0..255 thresholds; default :data:`MIN_SATURATION`, :data:`MIN_VALUE`
    out : (H, W) uint8, optional, preallocated result

    Returns
    -------
    (H, W) uint8, 255 = grass, 0 = not grass (the renderer softens its edges)
    """
    if not isinstance(frame_bgr, np.ndarray) or frame_bgr.dtype != np.uint8 or frame_bgr.ndim != 3 or frame_bgr.shape[2] != 3:
        raise ValueError(f"frame must be uint8 (H, W, 3) BGR, got {getattr(frame_bgr, 'dtype', type(frame_bgr).__name__)} {getattr(frame_bgr, 'shape', '')}")
    lo, hi = hue
    if not (0 <= lo < hi <= 180):
        raise ValueError(f"hue range must satisfy 0 <= lo < hi <= 180, got {hue}")
    hsv = cv2.cvtColor(frame_bgr, cv2.COLOR_BGR2HSV)
    return cv2.inRange(hsv, (int(lo), int(min_saturation), int(min_value)), (int(hi), 255, 255), dst=out)


def _sample(small: np.ndarray, rect, size) -> np.ndarray:
    """Nearest samples of ``small`` (a mask covering the whole frame of ``size``
    (W, H), at any resolution) at the pixels of ``rect``."""
    x0, y0, x1, y1 = rect
    W, H = size
    h, w = small.shape[:2]
    cols = np.minimum(((np.arange(x0, x1) + 0.5) * (w / W)).astype(np.intp), w - 1)
    rows = np.minimum(((np.arange(y0, y1) + 0.5) * (h / H)).astype(np.intp), h - 1)
    return small[rows][:, cols]  # two 1-D gathers: several times faster than one 2-D fancy index


def refine_matte(out: np.ndarray, rects, region_bgr, pitch: np.ndarray, *, keep: np.ndarray | None = None, keep_grow: int = 0, **green) -> np.ndarray:
    """A full-resolution grass matte, only inside ``rects``: the colour key of
    the frame there (:func:`green_matte`: players, the ball, anything not
    grass-coloured is cut out at pixel precision), or ``keep`` (pixels that
    count as grass whatever their colour, such as painted lines, so that an
    on-grass graphic is not cut by them), and only on the pitch (``pitch``,
    a coarse mask: stands and boards are not grass even where green).

    Parameters
    ----------
    out : (H, W) uint8, written inside ``rects`` (255 = grass); the rest is left as it is
    rects : iterable of (x0, y0, x1, y1) half-open pixel rectangles
    region_bgr : callable, rect -> (h, w, 3) uint8 BGR of the frame there
    pitch : (h', w') uint8 mask of the whole frame at any resolution, 255 = pitch
    keep : (h'', w'') uint8 mask of the whole frame at any resolution, optional
    keep_grow : pixels by which ``keep`` is grown (a line mask of centres: half the line width)
    green : options of :func:`green_matte`

    Returns
    -------
    ``out``
    """
    H, W = out.shape
    k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * keep_grow + 1, 2 * keep_grow + 1)) if keep_grow > 0 else None
    for rect in rects:
        x0, y0, x1, y1 = (int(v) for v in rect)
        if x1 <= x0 or y1 <= y0:
            continue
        m = green_matte(region_bgr((x0, y0, x1, y1)), **green)
        if keep is not None:
            kp = _sample(keep, (x0, y0, x1, y1), (W, H))
            if k is not None:
                kp = cv2.dilate(kp, k)
            cv2.bitwise_or(m, kp, dst=m)
        out[y0:y1, x0:x1] = cv2.bitwise_and(m, _sample(pitch, (x0, y0, x1, y1), (W, H)))
    return out


class GrassKeyI420:
    """:func:`refine_matte` (with :func:`green_matte`'s default grass colour) of
    I420 frames, without converting them to BGR: the same matte, pixel for
    pixel, in one compiled pass (:func:`render.kernels.key_i420`). One object
    per clip: it keeps the table of which colours are grass (2 MiB, filled as
    colours occur)."""

    def __init__(self):
        i = np.arange(1, 256, dtype=np.float64)  # OpenCV's 8-bit HSV divisions (round half to even, as cvRound)
        sdiv, hdiv = np.zeros(256, np.int64), np.zeros(256, np.int64)
        sdiv[1:] = np.rint(255 * 4096 / i)
        hdiv[1:] = np.rint(180 * 4096 / (6 * i))
        self._params = (int(GRASS_HUE[0]), int(GRASS_HUE[1]), int(MIN_SATURATION), int(MIN_VALUE), sdiv, hdiv)
        self._lut = np.zeros((65536, 4), np.uint64)
        self._built = np.zeros(65536, np.bool_)
        self._se: dict = {}

    def __call__(self, out: np.ndarray, yuv: np.ndarray, width: int, height: int, rects, pitch: np.ndarray, *, keep: np.ndarray | None = None, keep_grow: int = 0) -> np.ndarray:
        """Key the frame inside ``rects``.

        Parameters
        ----------
        out : (H, W) uint8, written inside ``rects`` (255 = grass)
        yuv : (H * 3 / 2, W) uint8 I420 buffer, contiguous
        width, height : int, even frame size
        rects : iterable of (x0, y0, x1, y1) half-open pixel rectangles (clipped to the frame)
        pitch : (h', w') uint8 whole-frame mask at any resolution, non-zero = pitch
        keep : (h'', w'') uint8 whole-frame mask at any resolution, optional
        keep_grow : pixels by which ``keep`` is grown (an elliptical structuring element)

        Returns
        -------
        ``out``
        """
        from render.kernels import key_i420  # (numba: loaded on first use, or by render.kernels.warm_up)

        r = rect_array(rects, width, height)
        half = self._se.get(keep_grow)
        if half is None:
            if keep_grow > 0:
                se = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * keep_grow + 1, 2 * keep_grow + 1))
                half = np.array([(np.count_nonzero(row) - 1) // 2 if row.any() else -1 for row in se], np.int64)
            else:
                half = np.zeros(1, np.int64)
            self._se[keep_grow] = half
        c = np.ascontiguousarray
        kp = np.zeros((0, 0), np.uint8) if keep is None else c(keep, np.uint8)
        key_i420(yuv.reshape(-1), int(width), int(height), r, c(pitch, np.uint8), kp, half, self._lut, self._built, *self._params, out)
        return out
