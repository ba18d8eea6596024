"""Composite a premultiplied BGRA overlay onto a BGR or an I420 frame, in place.

BGR (:class:`Compositor`):

``out = overlay_bgr + frame * (255 - alpha) / 255`` (premultiplied "over"),
8-bit, rounded to nearest, only inside the overlay's rectangles (see
:class:`render.renderer.Overlay`): the cost follows the drawn area, never the
whole frame. No float conversion of the frame; scratch buffers are
preallocated; all the arithmetic is OpenCV's SIMD kernels.

I420 (:func:`composite_i420`): the same "over" straight into the Y, U and V
planes of a decoded frame, inside the same rectangles, so that frames of even
size go from decoder to encoder without a BGR round trip (one compiled pass,
:func:`render.kernels.composite_i420`).
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["Compositor", "composite_i420", "composite_over", "rect_array"]


class Compositor:
    """Premultiplied "over" of an overlay onto BGR frames of one size.

    Parameters
    ----------
    width, height : int, frame size in pixels
    """

    def __init__(self, width: int, height: int):
        if int(width) <= 0 or int(height) <= 0:
            raise ValueError(f"frame size must be positive, got {width}x{height}")
        self.width, self.height = int(width), int(height)
        n = self.width * self.height
        self._bgr = np.empty(n * 3, np.uint8)
        self._inv = np.empty(n, np.uint8)
        self._inv3 = np.empty(n * 3, np.uint8)

    def composite(self, frame: np.ndarray, overlay) -> np.ndarray:
        """Blend ``overlay`` over ``frame`` in place.

        Parameters
        ----------
        frame : (H, W, 3) uint8 BGR (OpenCV order), modified in place; rows may
            be strided (a crop of a larger array) but pixels must be packed
        overlay : :class:`render.renderer.Overlay` (``bgra`` (H, W, 4) uint8
            premultiplied, ``rects`` outside which it is zero)

        Returns
        -------
        ``frame``
        """
        H, W = self.height, self.width
        if not isinstance(frame, np.ndarray) or frame.dtype != np.uint8 or frame.shape != (H, W, 3):
            got = f"{frame.dtype} {frame.shape}" if isinstance(frame, np.ndarray) else type(frame).__name__
            raise ValueError(f"frame must be uint8 ({H}, {W}, 3) BGR, got {got}")
        if frame.strides[2] != 1 or frame.strides[1] != 3:
            raise ValueError("frame pixels must be packed BGR (strides (row, 3, 1)); pass np.ascontiguousarray(frame)")
        if not frame.flags.writeable:
            raise ValueError("frame is read-only; composite writes into it (pass a writable copy)")
        ov = overlay.bgra
        if ov.shape != (H, W, 4) or ov.dtype != np.uint8:
            raise ValueError(f"overlay must be uint8 ({H}, {W}, 4), got {ov.dtype} {ov.shape}")
        rects = overlay.rects
        if not rects:
            return frame
        r = np.asarray(rects)
        bx0, by0, bx1, by1 = int(r[:, 0].min()), int(r[:, 1].min()), int(r[:, 2].max()), int(r[:, 3].max())
        area = int(((r[:, 2] - r[:, 0]) * (r[:, 3] - r[:, 1])).sum())
        if area >= 0.6 * (bx1 - bx0) * (by1 - by0):
            rects = ((bx0, by0, bx1, by1),)  # one call over the union is cheaper than many
        for x0, y0, x1, y1 in rects:
            self._over(frame[y0:y1, x0:x1], ov[y0:y1, x0:x1])
        return frame

    def _over(self, dst: np.ndarray, src: np.ndarray) -> None:
        h, w = dst.shape[:2]
        n = h * w
        bgr = self._bgr[: 3 * n].reshape(h, w, 3)
        inv = self._inv[:n].reshape(h, w)
        inv3 = self._inv3[: 3 * n].reshape(h, w, 3)
        cv2.cvtColor(src, cv2.COLOR_BGRA2BGR, dst=bgr)
        cv2.extractChannel(src, 3, dst=inv)
        cv2.bitwise_not(inv, dst=inv)
        cv2.cvtColor(inv, cv2.COLOR_GRAY2BGR, dst=inv3)
        cv2.multiply(dst, inv3, dst=dst, scale=1.0 / 255.0)
        cv2.add(dst, bgr, dst=dst)


def composite_over(frame: np.ndarray, overlay_bgra: np.ndarray) -> np.ndarray:
    """Reference premultiplied "over" in numpy (slow; for tests): returns a new (H, W, 3) uint8."""
    a = overlay_bgra[..., 3:4].astype(np.float64) / 255.0
    out = overlay_bgra[..., :3].astype(np.float64) + frame.astype(np.float64) * (1.0 - a)
    return np.clip(np.round(out), 0, 255).astype(np.uint8)


# BT.601 limited range (FFmpeg's default for untagged video, and OpenCV's I420
# conversions): Y, U, V from B, G, R, with the offsets scaled by alpha, so that
# premultiplied colour maps to premultiplied YUV (all of it within 0..255).
_BGRA_TO_YUV = np.array([[24.966, 128.553, 65.481, 16.0], [112.0, -74.203, -37.797, 128.0], [-18.214, -93.786, 112.0, 128.0]]) / 255.0


def composite_i420(yuv: np.ndarray, width: int, height: int, bgra: np.ndarray, rects) -> None:
    """Premultiplied "over" of a BGRA overlay onto an I420 frame, in place.

    Only the rectangles are touched (aligned outward to even pixels). Inside
    them the overlay is converted to premultiplied YUV (BT.601 limited range);
    chroma uses the 2 x 2 mean of premultiplied colour and of alpha, which is
    what "over" followed by 4:2:0 subsampling gives. One compiled pass
    (:func:`render.kernels.composite_i420`), one rounding per sample.

    Parameters
    ----------
    yuv : (H * 3 / 2, W) uint8 I420 buffer, contiguous, modified in place
    width, height : int, even frame size
    bgra : (H, W, 4) uint8, premultiplied B, G, R, A (zero outside ``rects``)
    rects : iterable of (x0, y0, x1, y1), half-open pixel rectangles
    """
    from render.kernels import composite_i420 as blend  # (numba: loaded on first use, or by render.kernels.warm_up)

    r = rect_array(rects, width, height, even=True)
    if len(r):
        blend(yuv.reshape(-1), int(width), int(height), np.ascontiguousarray(bgra), r, *_BGRA_TO_YUV)


def rect_array(rects, width: int, height: int, *, even: bool = False) -> np.ndarray:
    """Rectangles (x0, y0, x1, y1) as an (R, 4) int64 array for the compiled I420
    passes: clipped to the frame (``even``: first grown outward to even pixels,
    as 4:2:0 chroma needs), the empty ones dropped."""
    out = []
    for rc in rects:  # (a handful of rectangles: plain ints beat numpy's per-call cost)
        x0, y0, x1, y1 = (int(v) for v in rc)
        if even:
            x0, y0, x1, y1 = x0 & ~1, y0 & ~1, (x1 + 1) & ~1, (y1 + 1) & ~1
        x0, x1 = min(max(x0, 0), width), min(max(x1, 0), width)
        y0, y1 = min(max(y0, 0), height), min(max(y1, 0), height)
        if x1 > x0 and y1 > y0:
            out.append((x0, y0, x1, y1))
    return np.array(out, np.int64).reshape(-1, 4)
