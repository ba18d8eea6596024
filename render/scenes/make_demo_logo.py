"""Regenerate ``demo_logo.png`` (the demo scene's logo), procedurally with OpenCV.

Run from the repository root: ``python render/scenes/make_demo_logo.py``.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np


def demo_logo(width: int = 512, height: int = 160) -> np.ndarray:
    """(height, width, 4) uint8 BGRA: a rounded badge with a wordmark, transparent outside."""
    scale = 4  # draw large, then downsample: smooth edges and alpha
    W, H = width * scale, height * scale
    alpha = np.zeros((H, W), np.uint8)
    r = H // 3
    cv2.rectangle(alpha, (r, 0), (W - r, H - 1), 255, -1)
    cv2.rectangle(alpha, (0, r), (W - 1, H - r), 255, -1)
    for cx, cy in ((r, r), (W - r, r), (r, H - r), (W - r, H - r)):
        cv2.circle(alpha, (cx, cy), r, 255, -1)
    bgr = np.zeros((H, W, 3), np.uint8)
    top, bottom = np.array([150, 60, 10], np.float32), np.array([90, 25, 5], np.float32)  # deep blue gradient (BGR)
    s = np.linspace(0.0, 1.0, H, dtype=np.float32)[:, None, None]
    bgr[:] = ((1 - s) * top + s * bottom).astype(np.uint8)
    band = int(0.16 * H)
    cv2.rectangle(bgr, (0, H - band), (W, H), (40, 200, 255), -1)  # amber stripe
    face = cv2.FONT_HERSHEY_DUPLEX
    text = "ARSTREAM"
    (tw, th), _ = cv2.getTextSize(text, face, 1.0, 1)
    fs = 0.72 * W / tw
    thick = max(1, int(fs * 2.2))
    (tw, th), _ = cv2.getTextSize(text, face, fs, thick)
    org = ((W - tw) // 2, (H - band + th) // 2)
    cv2.putText(bgr, text, org, face, fs, (255, 255, 255), thick, cv2.LINE_AA)
    bgra = np.dstack([bgr, alpha])
    bgra = cv2.resize(bgra, (width, height), interpolation=cv2.INTER_AREA)
    bgra[..., 3] = (bgra[..., 3].astype(np.float32) * 0.92).astype(np.uint8)  # slightly see-through
    return bgra


if __name__ == "__main__":
    out = Path(__file__).resolve().parent / "demo_logo.png"
    cv2.imwrite(str(out), demo_logo(), [cv2.IMWRITE_PNG_COMPRESSION, 9])
    print(f"wrote {out}")
