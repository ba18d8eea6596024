"""A simple grass key: an HSV chroma key for when no grass detector is at hand.

The pipeline's detector (``arstream.detect``) makes the real grass matte; this
is the fallback that lets ``arstream render`` key graphics on its own. Green
hue with enough saturation and brightness counts as grass; white lines,
players, the ball and the stands do not.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["green_matte"]


def green_matte(frame_bgr: np.ndarray, *, hue=(35, 85), min_saturation: int = 70, min_value: int = 40,
                out: np.ndarray | None = None) -> np.ndarray:
    """Grass matte of a BGR frame by hue.

    Parameters
    ----------
    frame_bgr : (H, W, 3) uint8, BGR
    hue : (lo, hi), OpenCV hue range (0..180) of grass; default 35..85 (yellow-green to green-cyan)
    min_saturation, min_value : 0..255 thresholds (shadows on grass stay grass down to ``min_value``)
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
