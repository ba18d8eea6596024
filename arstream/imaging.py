"""Small image operations shared by the pipeline and the detector."""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["THUMBNAIL_SIZE", "grey_thumbnail", "sample_bilinear", "scale_to", "shrink"]

#: (w, h) of :func:`grey_thumbnail` (at most: smaller images keep their size)
THUMBNAIL_SIZE = (64, 36)


def shrink(src: np.ndarray, size: tuple[int, int], dst: np.ndarray | None = None) -> np.ndarray:
    """Scale an image down to ``size`` (w, h), anti-aliased, fast.

    OpenCV's area resampling is fast for exact halving and slow for other
    factors (1.2 ms for 1920x1080 -> 640x360 luma, against 0.3 ms for
    1920x1080 -> 960x540). Above a factor of 2 the image is therefore first
    halved by area averaging (exact 2x2 means), as often as that keeps it at
    least twice the target, then brought to ``size`` by bilinear resampling
    (a factor of at most 2 after the box pre-filter): 0.5 ms for that luma
    plane. Both steps keep pixel centres aligned (output pixel ``u`` sits at
    input ``s (u + 0.5) - 0.5``, ``s`` the overall scale), so coordinates map
    back exactly as for a single resampling; the kernel is a little wider
    than the plain 3x3 box at a factor of 3.

    Parameters
    ----------
    src : (H, W) or (H, W, C) uint8 or float32 image
    size : (w, h) target size, each at most the source's
    dst : optional output array of shape (h, w[, C]) and the source's dtype

    Returns
    -------
    The scaled image (``dst`` when given).
    """
    w, h = int(size[0]), int(size[1])
    H, W = src.shape[:2]
    if w > W or h > H:
        raise ValueError(f"shrink: target {w}x{h} is larger than the image {W}x{H}")
    img = src
    # halve while the result stays at least twice the target (even sizes only,
    # where the halving is the exact 2x2 mean)
    while img.shape[1] >= 4 * w and img.shape[0] >= 4 * h and img.shape[1] % 2 == 0 and img.shape[0] % 2 == 0:
        img = cv2.resize(img, (img.shape[1] // 2, img.shape[0] // 2), interpolation=cv2.INTER_AREA)
    if img.shape[1] == 2 * w and img.shape[0] == 2 * h:
        return cv2.resize(img, (w, h), dst=dst, interpolation=cv2.INTER_AREA)
    if img.shape[1] >= 2 * w and img.shape[0] >= 2 * h and img.shape[1] % 2 == 0 and img.shape[0] % 2 == 0:
        img = cv2.resize(img, (img.shape[1] // 2, img.shape[0] // 2), interpolation=cv2.INTER_AREA)
        return cv2.resize(img, (w, h), dst=dst, interpolation=cv2.INTER_LINEAR)
    return cv2.resize(img, (w, h), dst=dst, interpolation=cv2.INTER_AREA)


def scale_to(src: np.ndarray, size: tuple[int, int], dst: np.ndarray | None = None) -> np.ndarray:
    """:func:`shrink` (same arguments) when neither axis of ``size`` grows, else
    OpenCV's bilinear resampling: a frame of wide pixels stretched to square
    ones grows along its width (512 x 512 shown 16:9 becomes 640 x 360)."""
    w, h = int(size[0]), int(size[1])
    H, W = src.shape[:2]
    if w <= W and h <= H:
        return shrink(src, (w, h), dst=dst)
    return cv2.resize(src, (w, h), dst=dst, interpolation=cv2.INTER_LINEAR)


def grey_thumbnail(image: np.ndarray, *, video_range: bool = False) -> np.ndarray:
    """A small grey copy of a frame, for comparing whole frames (a shot cut).

    Parameters
    ----------
    image : (H, W, 3) uint8 BGR, or (H, W) uint8 grey
    video_range : ``image`` is grey in video (limited) range, the luma plane of
        a decoded frame (Y, 16-235, BT.601): mapped to full-range grey levels,
        those of ``cv2.COLOR_BGR2GRAY`` of the frame in BGR (the same within
        rounding, away from colours that clip in BGR)

    Returns
    -------
    (h, w) float32 grey levels (0-255), :data:`THUMBNAIL_SIZE` or the image's
    size where that is smaller; area-averaged (:func:`shrink`).
    """
    size = (min(THUMBNAIL_SIZE[0], image.shape[1]), min(THUMBNAIL_SIZE[1], image.shape[0]))
    thumb = shrink(image, size)
    if thumb.ndim == 3:
        thumb = cv2.cvtColor(thumb, cv2.COLOR_BGR2GRAY)
    thumb = thumb.astype(np.float32)
    if video_range:
        thumb -= 16.0
        thumb *= 255.0 / 219.0
    return thumb


def sample_bilinear(img: np.ndarray, q: np.ndarray, *, border: int = cv2.BORDER_CONSTANT) -> np.ndarray:
    """Bilinear samples of a single-channel image at pixels ``q`` (..., 2) (x, y).

    Parameters
    ----------
    img : (H, W) uint8 or float32 image
    q : (..., 2) pixel coordinates
    border : OpenCV border mode for samples outside the image (constant: 0)

    Returns
    -------
    (...) float32 (uint8 for a uint8 image) samples, the shape of ``q`` without its last axis.

    One cv2.remap; its maps may not be 32767 wide or high, so the points go in
    rows of 4096.
    """
    q = np.asarray(q)
    shape = q.shape[:-1]
    q = q.reshape(-1, 2)
    m = len(q)
    if m == 0:
        return np.zeros(shape, img.dtype)
    cols = 4096
    rows = -(-m // cols)
    mx = np.zeros(rows * cols, np.float32)
    my = np.zeros(rows * cols, np.float32)
    mx[:m], my[:m] = q[:, 0], q[:, 1]
    return cv2.remap(img, mx.reshape(rows, cols), my.reshape(rows, cols), cv2.INTER_LINEAR, borderMode=border).ravel()[:m].reshape(shape)

