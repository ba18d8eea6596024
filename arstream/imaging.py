"""Small image operations shared by the pipeline and the detector."""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["THUMBNAIL_SIZE", "BAR_LEVEL", "MIN_BAR", "active_area", "grey_thumbnail", "pooled", "sample_bilinear", "scale_to", "shrink"]

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


def pooled(mask: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """A binary mask made smaller by max-pooling: an output pixel is set where
    any input pixel under it is (a painted line one pixel wide stays whole,
    where averaging the picture would fade it into the grass).

    Parameters
    ----------
    mask : (H, W) bool or uint8 (non-zero: set)
    size : (w, h), each at most the mask's

    Returns
    -------
    (h, w) of the mask's dtype: uint8 0 / 255, or bool. Output pixel ``u``
    covers input pixels ``s u`` to ``s (u + 1)``, ``s`` the scale (centres
    aligned as in :func:`shrink`).
    """
    w, h = int(size[0]), int(size[1])
    H, W = mask.shape[:2]
    if w > W or h > H or w < 1 or h < 1:
        raise ValueError(f"pooled: target {w}x{h} must be between 1x1 and the mask's {W}x{H}")
    m = mask.view(np.uint8) * np.uint8(255) if mask.dtype == bool else mask  # (1 / 4 of a 1 would round to 0)
    out = cv2.compare(cv2.resize(m, (w, h), interpolation=cv2.INTER_AREA), 0, cv2.CMP_GT)
    return out > 0 if mask.dtype == bool else out


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



#: brightest level (0..255, any channel) of a black bar's pixels, compression noise included
BAR_LEVEL = 32
#: least width of a bar, as a share of the frame's side: thinner black edges
#: are a border, which the detectors already leave out
MIN_BAR = 0.02
#: rows (columns) past a bar still taken for it when no brighter than twice
#: :data:`BAR_LEVEL`: the bar's edge rung by compression (a letterbox in a
#: synthetic clip at crf 16: 7, 7, then 45, then 231 levels)
EDGE_ROWS = 2


def active_area(image: np.ndarray, *, level: int = BAR_LEVEL, min_bar: float = MIN_BAR) -> tuple[int, int, int, int]:
    """The picture inside black bars (letterbox, pillarbox, a black box around
    an inset picture): ``(x0, y0, x1, y1)``, the end exclusive; the whole
    frame without bars.

    A bar is a run of whole rows (or columns) from the frame's edge whose 99th
    percentile in every channel is at most ``level``, at least ``min_bar``
    of the frame's height (width) thick. A bar's edge is a bright step
    across the frame, which the paint and line detectors take for a marking
    (registered as a still inside a pillarbox, 1 of 19 of the shared
    reference frames got a camera; the picture alone, 10).

    Parameters
    ----------
    image : (H, W, 3) uint8 BGR frame (or (H, W) grey)

    Returns
    -------
    tuple of 4 ints, frame pixels
    """
    img = np.asarray(image)
    if img.dtype != np.uint8 or img.ndim not in (2, 3) or img.size == 0:
        raise ValueError(f"image must be a non-empty uint8 array (H, W) or (H, W, 3), got {img.dtype} {img.shape}")
    top = img.max(axis=2) if img.ndim == 3 else img
    H, W = top.shape

    def run(profile: np.ndarray, n: int) -> int:
        dark = profile <= level
        k = int(np.argmin(dark)) if not dark.all() else len(dark)
        if k < max(1, int(round(min_bar * n))):
            return 0
        # (the bar's edge: compression rings a row or two past it, darker than the
        # picture but above the level; they belong to the bar)
        for _ in range(EDGE_ROWS):
            if k >= len(profile) or profile[k] > 2 * level:
                break
            k += 1
        return k

    rows = np.percentile(top, 99, axis=1)
    cols = np.percentile(top, 99, axis=0)
    y0, y1 = run(rows, H), H - run(rows[::-1], H)
    x0, x1 = run(cols, W), W - run(cols[::-1], W)
    if y1 - y0 < H // 4 or x1 - x0 < W // 4:
        return 0, 0, W, H  # (a dark frame, not bars)
    return x0, y0, x1, y1
