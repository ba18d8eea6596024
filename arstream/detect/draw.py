"""The debug view: detections drawn over the frame."""

from __future__ import annotations

import cv2
import numpy as np

from .results import Detections

__all__ = ["draw_detections"]


def draw_detections(image: np.ndarray, det: Detections) -> np.ndarray:
    """A copy of ``image`` (BGR uint8, H x W x 3) with the detections drawn.

    Outside the pitch is dimmed; line points are red, straight lines blue
    (with their numbers), the centre-circle candidate yellow, arcs orange
    and other ellipses cyan.
    """
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
        raise ValueError("image must be a BGR uint8 array (H, W, 3)")
    if image.shape[:2] != (det.height, det.width):
        raise ValueError(f"image is {image.shape[1]}x{image.shape[0]}, detections are for {det.width}x{det.height}")
    out = image.copy()
    off = det.grass_mask == 0
    out[off] = (out[off] * 0.45).astype(np.uint8)
    if len(det.line_points):
        ix = np.clip(np.rint(det.line_points).astype(np.intp), 0, [det.width - 1, det.height - 1])
        out[ix[:, 1], ix[:, 0]] = (0, 0, 255)
    for k, l in enumerate(det.lines):
        a, b = np.rint(l.endpoints * 16).astype(np.int32)
        cv2.line(out, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), (255, 120, 0), 2, cv2.LINE_AA, shift=4)
        m = 0.5 * (l.endpoints[0] + l.endpoints[1])
        cv2.putText(out, str(k), (int(m[0]) + 4, int(m[1]) - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 120, 0), 1, cv2.LINE_AA)
    for k, e in enumerate(det.ellipses):
        color = (0, 160, 255) if e.kind == "arc" else ((0, 255, 255) if k == 0 else (255, 255, 0))
        pts = np.rint(e.ellipse.points(360) * 16).astype(np.int32)
        cv2.polylines(out, [pts], True, color, 2, cv2.LINE_AA, shift=4)
        c = e.ellipse.center
        if 0 <= c[0] < det.width and 0 <= c[1] < det.height:
            cv2.drawMarker(out, (int(c[0]), int(c[1])), color, cv2.MARKER_CROSS, 10, 1)
    return out
