"""Text as textures: glyphs drawn with ``cv2.putText`` (Hershey fonts, no extra dependency)."""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["FONTS", "text_mask", "premultiplied_rgba"]

#: Font names accepted in scene files.
FONTS = {
    "sans": cv2.FONT_HERSHEY_DUPLEX,
    "simplex": cv2.FONT_HERSHEY_SIMPLEX,
    "serif": cv2.FONT_HERSHEY_TRIPLEX,
    "bold": cv2.FONT_HERSHEY_TRIPLEX,
}


def text_mask(text: str, font: str = "sans", *, px_height: int = 96, bold: bool = False) -> np.ndarray:
    """Anti-aliased coverage mask of one line of text.

    Parameters
    ----------
    text : str, one line, printable ASCII (Hershey fonts have no other glyphs)
    font : str, a key of :data:`FONTS`
    px_height : int, approximate cap height in texture pixels
    bold : bool, thicker strokes

    Returns
    -------
    (h, w) uint8 mask, 255 = ink, tightly cropped around the glyphs with a
    margin of a few pixels (so mipmaps do not bleed). ``w / h`` is the text's
    aspect ratio.
    """
    if not isinstance(text, str) or not text.strip():
        raise ValueError("text must be a non-empty string")
    if "\n" in text or not text.isascii() or not text.isprintable():
        raise ValueError(f"text must be one line of printable ASCII, got {text!r}")
    if font not in FONTS:
        raise ValueError(f"unknown font {font!r} (known: {', '.join(sorted(FONTS))})")
    face = FONTS[font]
    (_, h1), _ = cv2.getTextSize("H", face, 1.0, 1)
    scale = px_height / max(h1, 1)
    thickness = max(1, int(round(scale * (2.6 if (bold or font == "bold") else 1.6))))
    (w, h), base = cv2.getTextSize(text, face, scale, thickness)
    pad = thickness + 4
    canvas = np.zeros((h + base + 2 * pad, w + 2 * pad), np.uint8)
    cv2.putText(canvas, text, (pad, pad + h), face, scale, 255, thickness, cv2.LINE_AA)
    ys, xs = np.nonzero(canvas)
    if len(ys) == 0:  # e.g. only spaces
        raise ValueError(f"text {text!r} draws no glyphs")
    m = 4
    y0, y1 = max(ys.min() - m, 0), min(ys.max() + m + 1, canvas.shape[0])
    x0, x1 = max(xs.min() - m, 0), min(xs.max() + m + 1, canvas.shape[1])
    return np.ascontiguousarray(canvas[y0:y1, x0:x1])


def premultiplied_rgba(mask: np.ndarray, rgb) -> np.ndarray:
    """(h, w, 4) uint8 premultiplied RGBA of a solid colour ``rgb`` (3 floats 0..1) seen through ``mask``."""
    a = mask.astype(np.float32) / 255.0
    out = np.empty(mask.shape + (4,), np.uint8)
    for c in range(3):
        out[..., c] = np.round(a * (255.0 * float(rgb[c])))
    out[..., 3] = mask
    return out
