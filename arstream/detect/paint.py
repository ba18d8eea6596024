"""White paint on real frames: a paint mask and the straight lines in it.

The ridge detector (:mod:`.ridges`) centres lines to a tenth of a pixel on
clean pictures; on broadcast television the far lines are one or two pixels
wide and faint after compression, and lines of other sports cross the pitch.
This module is the initialiser's second look at such frames:

* :func:`paint_mask` — pixels brighter than their 15 x 15 neighbourhood in
  *every* colour channel (white paint raises blue, green and red alike; a
  yellow or orange line of another sport leaves blue, a blue one leaves red,
  at the grass's level), inside the pitch, less thick blobs (players, the
  ball, a crowd seen through) and the frame's border.
* :func:`paint_lines` — straight lines in that mask: probabilistic Hough
  segments (OpenCV) merged when collinear, each refitted (Huber) to the mask
  pixels near it and kept as its longest run with gaps under 4 % of the
  frame's width (a player on the line leaves a gap; a chain of players in a
  row is no line: most of a line's length must be covered).

Coordinates are frame pixels (x right, y down, pixel centres at integers).
"""

from __future__ import annotations

import cv2
import numpy as np

from .results import DetectedLine

__all__ = ["paint_mask", "paint_lines", "PAINT_CONTRAST", "PAINT_BOX"]

# the line-support test's neighbourhood and contrast (DESIGN.md section 5b):
# brighter than the 15 x 15 box mean by more than 12 levels
PAINT_BOX = 15
PAINT_CONTRAST = 12


def paint_mask(image: np.ndarray, region: np.ndarray | None = None, *, contrast: float = PAINT_CONTRAST, box: int = PAINT_BOX, border: int = 6) -> np.ndarray:
    """Pixels of white paint.

    Parameters
    ----------
    image : (H, W, 3) uint8 BGR frame
    region : (H, W) uint8, optional, non-zero where paint may be (the pitch);
        any other size is resized (nearest)
    contrast : levels by which every channel must exceed its ``box`` x ``box`` mean
    box : odd box size (pixels)
    border : pixels at the frame's edges left out (a black border's edge is a step)

    Returns
    -------
    (H, W) uint8, 255 on paint, 0 elsewhere. Blobs thicker than about
    ``W / 180`` pixels (a painted line never is, at the frame's scale) are removed.
    """
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"image must be a BGR uint8 array (H, W, 3), got {getattr(image, 'dtype', type(image).__name__)} {getattr(image, 'shape', '')}")
    H, W = image.shape[:2]
    low = None
    for c in range(3):
        ch = image[:, :, c]
        d = cv2.subtract(ch, cv2.blur(ch, (box, box), borderType=cv2.BORDER_REPLICATE))
        low = d if low is None else cv2.min(low, d, dst=low)
    mask = cv2.compare(low, float(contrast), cv2.CMP_GT)
    if region is not None:
        if region.shape[:2] != (H, W):
            region = cv2.resize(region, (W, H), interpolation=cv2.INTER_NEAREST)
        cv2.bitwise_and(mask, cv2.compare(region, 0, cv2.CMP_GT), dst=mask)
    k = max(5, int(round(W / 180)) | 1)
    thick = cv2.morphologyEx(mask, cv2.MORPH_OPEN, cv2.getStructuringElement(cv2.MORPH_RECT, (k, k)))
    cv2.subtract(mask, cv2.dilate(thick, np.ones((3, 3), np.uint8)), dst=mask)
    b = int(border)
    if b > 0:
        mask[:b] = 0
        mask[-b:] = 0
        mask[:, :b] = 0
        mask[:, -b:] = 0
    return mask


def _longest_run(t: np.ndarray, max_gap: float) -> tuple[float, float]:
    """The ends of the longest stretch of the sorted positions ``t`` without a gap over ``max_gap``."""
    ts = np.sort(t)
    cut = np.flatnonzero(np.diff(ts) > max_gap)
    a, b = np.r_[0, cut + 1], np.r_[cut, len(ts) - 1]
    k = int(np.argmax(ts[b] - ts[a]))
    return float(ts[a[k]]), float(ts[b[k]])


def _merge_segments(segs: np.ndarray, ang_tol: float, dist_tol: float) -> list[tuple[np.ndarray, float]]:
    """Lines ``(n (2,), c)`` (``n . x + c = 0``) of collinear Hough segments (K, 4), longest first."""
    length = np.hypot(segs[:, 2] - segs[:, 0], segs[:, 3] - segs[:, 1])
    out: list[tuple[np.ndarray, float]] = []
    s_tol = np.sin(ang_tol)
    for i in np.argsort(-length):
        x0, y0, x1, y1 = segs[i]
        d = np.array([x1 - x0, y1 - y0]) / max(length[i], 1e-9)
        for n, c in out:
            if abs(n @ d) < s_tol and abs(n @ (x0, y0) + c) < dist_tol and abs(n @ (x1, y1) + c) < dist_tol:
                break
        else:
            n = np.array([-d[1], d[0]])
            out.append((n, -float(n @ (x0, y0))))
    return out


def _green(image: np.ndarray) -> np.ndarray:
    """(H, W) bool: green dominates red and blue (grass, sunlit or shaded, natural or artificial)."""
    b, g, r = (cv2.blur(image[:, :, c], (3, 3)).astype(np.int16) for c in range(3))
    return (g > r + 4) & (g > b + 4)


def grass_beside(lines: list[DetectedLine], image: np.ndarray, *, samples: int = 64) -> np.ndarray:
    """(N,) float: for each line, the share of its length with grass on both
    sides (about 0.5 % of the width away from it). A painted line runs through
    grass; the lower edge of the boards, a goal's frame or a graphic's edge has
    grass on one side only."""
    H, W = image.shape[:2]
    green = _green(image)
    off = max(4.0, 0.005 * W)
    t = np.linspace(0.0, 1.0, samples)[:, None]
    out = np.zeros(len(lines))
    for i, dl in enumerate(lines):
        Q = (1 - t) * dl.endpoints[0] + t * dl.endpoints[1]
        both = np.ones(samples, bool)
        for side in (-1.0, 1.0):
            q = np.rint(Q + side * off * dl.line[:2]).astype(np.int64)
            ok = (q[:, 0] >= 0) & (q[:, 0] < W) & (q[:, 1] >= 0) & (q[:, 1] < H)
            gr = np.zeros(samples, bool)
            gr[ok] = green[q[ok, 1], q[ok, 0]]
            both &= gr
        out[i] = both.mean()
    return out


def paint_lines(mask: np.ndarray, image: np.ndarray | None = None, *, min_length: float | None = None, max_lines: int = 16, work_width: int = 1000) -> list[DetectedLine]:
    """Straight painted lines in a paint mask (:func:`paint_mask`).

    Parameters
    ----------
    mask : (H, W) uint8 paint mask
    image : (H, W, 3) uint8 BGR frame, optional: lines with grass on both
        sides along at least half their length (:func:`grass_beside`) come
        first, edges with grass on one side only (the boards' lower edge, or a
        far touchline right below them) after them
    min_length : shortest line (frame pixels); default 4 % of the width
    max_lines : most lines returned (the best covered first)
    work_width : the mask is max-pooled to at most about this width first
        (a one-pixel line stays whole), for speed

    Returns
    -------
    list of DetectedLine (frame pixels), most support first; ``normal_sigma``
    and ``angle_sigma`` from the support's spread. Lines closer than about
    0.6 % of the width and 2 degrees to a better one are dropped (the two
    edges of one wide line).
    """
    if not isinstance(mask, np.ndarray) or mask.ndim != 2:
        raise ValueError(f"mask must be a 2-D array, got {getattr(mask, 'shape', type(mask).__name__)}")
    H, W = mask.shape
    f = max(1, int(np.ceil(W / work_width)))
    m = mask if f == 1 else cv2.compare(cv2.resize(mask, (W // f, H // f), interpolation=cv2.INTER_AREA), 0, cv2.CMP_GT)
    w = m.shape[1]
    min_len = float(min_length) / f if min_length is not None else 0.04 * w
    segs = cv2.HoughLinesP(m, 1, np.pi / 720, threshold=max(8, int(0.5 * min_len)), minLineLength=min_len, maxLineGap=max(5.0, 0.25 * min_len))
    if segs is None:
        return []
    segs = segs.reshape(-1, 4).astype(np.float64)
    ys, xs = np.nonzero(m)
    P = np.column_stack([xs, ys]).astype(np.float64)
    max_gap = 0.04 * w
    near = max(2.0, 0.002 * w)
    found = []
    for n, c in _merge_segments(segs, np.radians(1.5), max(3.0, 0.004 * w)):
        sel = P[np.abs(P @ n + c) < max(2.5, 0.003 * w)]
        if len(sel) < 0.5 * min_len:
            continue
        d = np.array([n[1], -n[0]])
        t0, t1 = _longest_run(sel @ d, max_gap)
        t = sel @ d
        sel = sel[(t >= t0) & (t <= t1)]
        if len(sel) < 2:
            continue
        vx, vy, x0, y0 = cv2.fitLine(sel.astype(np.float32), cv2.DIST_HUBER, 0, 0.01, 0.01).ravel()
        nn = np.array([-vy, vx], np.float64)
        nn /= np.hypot(nn[0], nn[1])  # (fitLine's direction is single precision)
        cc = -float(nn @ (x0, y0))
        sel = P[np.abs(P @ nn + cc) < near]
        if len(sel) < 2:
            continue
        t = sel @ np.array([nn[1], -nn[0]])
        t0, t1 = _longest_run(t, max_gap)
        keep = (t >= t0) & (t <= t1)
        sel, t = sel[keep], t[keep]
        length = t1 - t0
        covered = len(np.unique(np.round(t).astype(np.int64)))
        if length < min_len or covered < 0.6 * length:
            continue
        r = sel @ nn + cc
        rms = float(np.sqrt(np.mean(r * r)))
        found.append((covered, nn, cc, sel, t, length, rms))
    found.sort(key=lambda x: -x[0])
    lines: list[DetectedLine] = []
    kept: list[tuple[np.ndarray, np.ndarray]] = []
    s2 = np.sin(np.radians(2.0))
    for covered, nn, cc, sel, t, length, rms in found:
        mid = sel[[np.argmin(t), np.argmax(t)]].mean(axis=0)
        if any(abs(nn[0] * m2[1] - nn[1] * m2[0]) < s2 and abs(m2 @ mid + c2) < max(4.0, 0.006 * w) for m2, c2 in kept):
            continue
        kept.append((nn, cc))
        # to frame pixels: a pooled pixel i covers frame pixels f i .. f i + f - 1
        pts = sel * f + 0.5 * (f - 1)
        line = np.array([nn[0], nn[1], cc * f - 0.5 * (f - 1) * (nn[0] + nn[1])])
        ends = pts[[np.argmin(t), np.argmax(t)]]
        sig = rms * f / np.sqrt(len(sel))
        lines.append(
            DetectedLine(line=line, endpoints=ends, points=pts, length=float(length * f), normal_sigma=float(sig), angle_sigma=float(sig / max(length * f, 1.0) * np.sqrt(12.0)), rms=float(rms * f))
        )
    if image is not None and lines:
        both = grass_beside(lines, image)
        lines = [lines[k] for k in np.argsort(both < 0.5, kind="stable")]
    return lines[:max_lines]
