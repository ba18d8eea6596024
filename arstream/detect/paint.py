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
  row is no line: most of a line's length must be covered). Given the frame,
  a line on the grass must be brighter than the grass on both of its sides
  (:func:`bright_across`): the sunlit edge of a stand's shadow is a step.
* :func:`paint_arcs` — penalty arcs: a curve of paint that leaves a long
  straight line (the penalty area's front line) and comes back to it, fitted
  by an ellipse (the ridge detector's ellipse search asks for more of the
  perimeter than a real penalty arc shows).

Coordinates are frame pixels (x right, y down, pixel centres at integers).
"""

from __future__ import annotations

import cv2
import numpy as np

from arstream.imaging import pooled, sample_bilinear
from arstream.memo import ContentMemo, content_key
from geometry.conics import conic_from_ellipse, ellipse_from_conic, intersect_line_conic, normalize_conic, refine_ellipse, sampson_distance
from geometry.lines import hartley_normalization

from .results import DetectedEllipse, DetectedLine, PaintArc

__all__ = ["paint_mask", "paint_lines", "paint_arcs", "grass_beside", "bright_across", "PAINT_CONTRAST", "PAINT_BOX", "MIN_RIDGE_SHARE"]

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
    # (the three channels blurred at once: 40 % less time than one by one)
    b, g, r = cv2.split(cv2.subtract(image, cv2.blur(image, (box, box), borderType=cv2.BORDER_REPLICATE)))
    mask = cv2.compare(cv2.min(cv2.min(b, g, dst=b), r, dst=b), float(contrast), cv2.CMP_GT)
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


#: pixels (at 1280 wide, scaled with the width) on either side of a line at
#: which :func:`bright_across` compares its luma: a far line's one or two
#: pixels up to a near line's eight
ACROSS_OFFSETS = (2.0, 4.0, 7.0)
#: levels by which a line's luma must rise above both sides (:func:`bright_across`)
ACROSS_RISE = 3.0
#: least share of a line's length that is a bright ridge (:func:`bright_across`)
#: for a line with grass on both sides to be kept by :func:`paint_lines`
MIN_RIDGE_SHARE = 0.25


def bright_across(lines: list[DetectedLine], image: np.ndarray, *, samples: int = 64) -> np.ndarray:
    """(N,) float: for each line, the share of its length where it is a bright
    ridge: its luma (smoothed by a 1 px Gaussian; at its crest, the brightest
    pixel within 2 px across it, both at 1280 wide) above that on *both*
    sides at one of :data:`ACROSS_OFFSETS`, by more than :data:`ACROSS_RISE`
    levels. ``lines``: DetectedLine in the frame's pixels; ``image``: (H, W, 3)
    uint8 BGR; ``samples`` points along each line.

    A painted line is brighter than the grass on both of its sides. The
    sunlit side of a stand's shadow across the pitch is brighter than its
    box mean in every channel (:func:`paint_mask`'s test) and makes a long
    straight line of the paint mask, but it is not brighter than the sunlit
    grass beyond it: a step, not a ridge (bench/README.md "Stop 87")."""
    if not lines:
        return np.zeros(0)
    W = image.shape[1]
    luma = cv2.GaussianBlur(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY), (0, 0), 1.0).astype(np.float32)

    def at(q):
        """luma at the points q (..., 2), nearest pixel (0 outside the frame)"""
        return sample_bilinear(luma, np.rint(q))

    t = np.linspace(0.0, 1.0, samples)[None, :, None]
    ends = np.stack([dl.endpoints for dl in lines])  # (L, 2, 2)
    Q = (1 - t) * ends[:, :1] + t * ends[:, 1:]  # (L, S, 2)
    n = np.stack([dl.line[:2] / np.hypot(*dl.line[:2]) for dl in lines])[:, None]  # (L, 1, 2)
    # the line's brightest pixel across it, within 2 px (a fitted line is a
    # pixel or two off a blurred line's crest), and the sides from there
    reach = max(1, int(round(2 * W / 1280)))
    ks = np.arange(-reach, reach + 1)
    across = at(Q[None] + ks[:, None, None, None] * n[None])  # (K, L, S)
    best = across.argmax(axis=0)
    c = np.take_along_axis(across, best[None], axis=0)[0]
    crest = Q + ks[best][..., None] * n
    ridge = np.zeros(c.shape, bool)
    for d in (max(1.0, d * W / 1280) for d in ACROSS_OFFSETS):
        ridge |= c - np.maximum(at(crest + d * n), at(crest - d * n)) > ACROSS_RISE
    return ridge.mean(axis=1)


#: the last frames' lines and penalty arcs (:func:`paint_lines`, :func:`paint_arcs`)
#: by their masks' and frames' content: a scan asks for a frame's at each
#: pitch size it tries (:mod:`arstream.memo`)
_LINES = ContentMemo(16)
_ARCS = ContentMemo(16)


def paint_lines(mask: np.ndarray, image: np.ndarray | None = None, *, min_length: float | None = None, max_lines: int = 16, work_width: int = 1000) -> list[DetectedLine]:
    """Straight painted lines in a paint mask (:func:`paint_mask`).

    Parameters
    ----------
    mask : (H, W) uint8 paint mask
    image : (H, W, 3) uint8 BGR frame, optional: lines with grass on both
        sides along at least half their length (:func:`grass_beside`) come
        first, edges with grass on one side only (the boards' lower edge, or a
        far touchline right below them) after them; a line with grass on both
        sides that is a bright ridge along less than :data:`MIN_RIDGE_SHARE`
        of its length (:func:`bright_across`: a shadow's sunlit edge across
        the pitch, a step of brightness) is left out
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
    key = content_key(mask, np.zeros(0) if image is None else image, (-1.0 if min_length is None else float(min_length), max_lines, work_width))
    return _LINES.answer(key, lambda: _paint_lines(mask, image, min_length, max_lines, work_width))


def _paint_lines(mask: np.ndarray, image: np.ndarray | None, min_length: float | None, max_lines: int, work_width: int) -> list[DetectedLine]:
    """:func:`paint_lines`' work."""
    H, W = mask.shape
    f = max(1, int(np.ceil(W / work_width)))
    m = mask if f == 1 else pooled(mask, (W // f, H // f))
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
        # a line with grass on both sides that is nowhere brighter than both
        # (a shadow's sunlit edge across the pitch) is no paint
        step = (both >= 0.5) & (bright_across(lines, image) < MIN_RIDGE_SHARE)
        lines, both = [dl for dl, s in zip(lines, step) if not s], both[~step]
        lines = [lines[k] for k in np.argsort(both < 0.5, kind="stable")]
    return lines[:max_lines]


def paint_arcs(mask: np.ndarray, lines: list[DetectedLine], *, fronts: int = 6, max_arcs: int = 2, min_chord: float = 0.05, max_rise: float = 0.6) -> list[PaintArc]:
    """Penalty arcs in a paint mask: a curve that leaves one of the long
    straight ``lines`` and comes back to it.

    Beside each of the first ``fronts`` lines at least 10 % of the width long
    (candidate front lines), on either side, the paint pixels a little off
    the line (more than ``tol``, about 1.5 px at 1280 wide) and less than
    ``max_rise`` times its length away are taken; their connected pieces
    (a player on the arc cuts it), alone and in pairs, are fitted by an
    ellipse (RANSAC over 5-point conics, then refined to the paint pixels
    near it by :func:`geometry.conics.refine_ellipse`). An arc is kept when
    its ellipse crosses the line twice, at least ``min_chord`` times the
    width apart and within the line's extent (a tenth of it to spare: an
    arc the frame's edge cuts is left out, for half an arc and its front
    line leave the camera free to slide along the line: on
    ``israel_league_wide`` frame 175 such an arc, found right to 0.3 px,
    fits a camera 27 m from the right one at the right focal length); it
    rises off the line by more than 3 ``tol`` and by at most ``max_rise``
    times its chord; its pixels lie further from their best straight line
    than from the ellipse (3 times its RMS distance, at least ``tol``: a
    touchline meeting the front line at a corner fits a long flat ellipse
    as well as a line); and the paint pixels beyond the line within ``tol``
    of the ellipse (Sampson distance) cover at least half of the chord's
    length. The arc with the most covered length is kept for each line.

    Parameters
    ----------
    mask : (H, W) uint8 paint mask (:func:`paint_mask`)
    lines : list of DetectedLine (:func:`paint_lines`), frame pixels
    fronts, max_arcs, min_chord, max_rise : as above

    Returns
    -------
    list of PaintArc (at most ``max_arcs``, the best covered first): the arc
    (DetectedEllipse, ``kind="arc"``, its inlier pixels, frame pixels) and
    the line it leaves.
    """
    if not isinstance(mask, np.ndarray) or mask.ndim != 2:
        raise ValueError(f"mask must be a 2-D array, got {getattr(mask, 'shape', type(mask).__name__)}")
    key = content_key(mask, (fronts, max_arcs, min_chord, max_rise), *[x for dl in lines for x in (dl.line, dl.endpoints, dl.points, dl.length)])
    return _ARCS.answer(key, lambda: _paint_arcs(mask, lines, fronts, max_arcs, min_chord, max_rise))


def _paint_arcs(mask: np.ndarray, lines: list[DetectedLine], fronts: int, max_arcs: int, min_chord: float, max_rise: float) -> list[PaintArc]:
    """:func:`paint_arcs`' work."""
    H, W = mask.shape
    ys, xs = np.nonzero(mask)
    if len(xs) < 20:
        return []
    P = np.column_stack([xs, ys]).astype(np.float64)
    tol = max(1.0, 1.5 * W / 1280)
    raster = np.zeros((H, W), np.uint8)
    found: list[tuple[float, PaintArc]] = []
    for front in [dl for dl in lines if dl.length >= 0.1 * W][:fronts]:
        n, c = front.line[:2], float(front.line[2])
        d = np.array([n[1], -n[0]])
        t, s = P @ d, P @ n + c
        t0, t1 = np.sort(front.endpoints @ d)
        L = t1 - t0
        best = None
        for side in (1.0, -1.0):
            u = side * s
            sel = np.flatnonzero((u > tol) & (u < max_rise * L) & (t > t0 - 0.1 * L) & (t < t1 + 0.1 * L))
            if len(sel) < 20:
                continue
            Q = P[sel]
            raster[Q[:, 1].astype(np.int64), Q[:, 0].astype(np.int64)] = 255
            _, lab, stats, _ = cv2.connectedComponentsWithStats(cv2.dilate(raster, np.ones((3, 3), np.uint8)), connectivity=8)
            raster[Q[:, 1].astype(np.int64), Q[:, 0].astype(np.int64)] = 0
            pl = lab[Q[:, 1].astype(np.int64), Q[:, 0].astype(np.int64)]
            # pieces of some length (a player's blob is short), longest first
            ext = np.maximum(stats[:, cv2.CC_STAT_WIDTH], stats[:, cv2.CC_STAT_HEIGHT])
            pieces = [j for j in np.argsort(-ext) if j > 0 and ext[j] >= 0.015 * W][:7]
            groups = [(a,) for a in pieces] + [(a, b) for i, a in enumerate(pieces) for b in pieces[i + 1 :]]
            tp = t[sel]
            for g in groups:
                inside = np.isin(pl, g)
                if inside.sum() < 12 or np.ptp(tp[inside]) < 0.5 * min_chord * W:
                    continue  # (too short along the line to be most of an arc)
                pts = Q[inside]
                arc = _arc_along(pts, Q, front.line, d, (t0, t1), side, tol, W, min_chord, max_rise)
                if arc is not None and (best is None or arc[0] > best[0]):
                    best = arc
        if best is not None:
            found.append((best[0], PaintArc(arc=best[1], front=front)))
    found.sort(key=lambda x: -x[0])
    return [a for _, a in found[:max_arcs]]


def _arc_along(pts, Q, line, d, ends, side, tol, W, min_chord, max_rise):
    """:func:`paint_arcs`' test of one piece (or pair of pieces) ``pts``:
    (covered length px, DetectedEllipse) or None. The piece's ellipse is found
    by RANSAC (a player standing on the arc joins its piece), then refitted
    to the paint pixels ``Q`` near it."""
    C = _ransac_conic(pts, tol)
    if C is None or (tt := _crossings(C, line, d)) is None:
        return None
    ta, tb = tt
    t0, t1 = ends
    L = t1 - t0
    if tb - ta < min_chord * W or ta < t0 - 0.1 * L or tb > t1 + 0.1 * L:
        return None
    dist = np.abs(sampson_distance(Q, C))
    tq = Q @ d
    inl = Q[(dist < tol) & (tq > ta) & (tq < tb)]
    if len(inl) < 12 or _covered(inl @ d, W) < 0.5 * (tb - ta):
        return None
    try:
        e = ellipse_from_conic(C)
    except ValueError:
        return None
    for _ in range(2):  # refined to all the arc's pixels near it (Sampson distance), twice
        try:
            e = refine_ellipse(inl[:: max(1, len(inl) // 150)], e, residual="sampson", max_nfev=30).ellipse
        except ValueError:
            return None
        C = conic_from_ellipse(e)
        if (tt := _crossings(C, line, d)) is None:
            return None
        ta, tb = tt
        dist = np.abs(sampson_distance(Q, C))
        keep = (dist < tol) & (tq > ta) & (tq < tb)
        if keep.sum() < 12:
            return None
        inl, r = Q[keep], dist[keep]
    rise = float(np.max(side * (inl @ line[:2] + line[2])))
    if tb - ta < min_chord * W or rise < 3 * tol or rise > max_rise * (tb - ta):
        return None
    rms = float(np.sqrt(np.mean(r * r)))
    # curved: its pixels lie further from their best straight line than from
    # the ellipse (a line that meets the front line at a corner, a touchline
    # or the boards, fits a long flat ellipse as well as a line)
    vx, vy, x0, y0 = cv2.fitLine(inl.astype(np.float32), cv2.DIST_L2, 0, 0.01, 0.01).ravel()
    if np.sqrt(np.mean(((inl - (x0, y0)) @ (-vy, vx)) ** 2)) < max(tol, 3.0 * rms):
        return None
    covered = _covered(inl @ d, W)
    if covered < 0.5 * (tb - ta):
        return None
    return covered, DetectedEllipse(ellipse=e, conic=normalize_conic(C), points=inl, rms=rms, coverage=float(covered / (tb - ta)), score=float(min(1.0, covered / (tb - ta))), kind="arc")


def _crossings(C: np.ndarray, line: np.ndarray, d: np.ndarray) -> tuple[float, float] | None:
    """Where the conic ``C`` crosses ``line``: the two positions along the
    line's direction ``d`` (pixels), in order, or None when it misses it."""
    try:
        X = intersect_line_conic(C, line)
    except ValueError:
        return None
    ta, tb = np.sort((X[:, :2] / X[:, 2:]) @ d)
    return float(ta), float(tb)


def _covered(t: np.ndarray, W: int) -> float:
    """Length (px) of the positions ``t`` along a line that pixels cover (in
    steps of a pixel of a 1280-wide frame, at least one pixel)."""
    step = max(1.0, W / 1280)
    return len(np.unique(np.round(t / step).astype(np.int64))) * step


def _ransac_conic(pts: np.ndarray, tol: float, *, samples: int = 150, max_points: int = 300) -> np.ndarray | None:
    """The ellipse (3, 3 conic, pixels) through 5 of ``pts`` (N, 2) with the
    most of them within ``tol`` (Sampson distance), from ``samples`` random
    5-point sets (a fixed seed: the same frame gives the same arcs); None
    without one. Hartley-normalised (:func:`geometry.lines.hartley_normalization`);
    one batched SVD."""
    if len(pts) > max_points:
        pts = pts[np.linspace(0, len(pts) - 1, max_points).astype(np.int64)]
    T = hartley_normalization(pts)  # pixels -> normalised
    q = pts * T[0, 0] + T[:2, 2]
    x, y = q[:, 0], q[:, 1]
    D = np.column_stack([x * x, x * y, y * y, x, y, np.ones_like(x)])
    rng = np.random.default_rng(len(pts))
    idx = np.argpartition(rng.random((samples, len(D))), 5, axis=1)[:, :5]  # 5 distinct points a sample
    _, _, Vt = np.linalg.svd(D[idx])
    c = Vt[:, -1]  # (S, 6)
    ell = c[:, 1] ** 2 - 4 * c[:, 0] * c[:, 2] < 0
    if not ell.any():
        return None
    c = c[ell]
    F = c @ D.T  # (S, N)
    gx = 2 * c[:, :1] * x + c[:, 1:2] * y + c[:, 3:4]
    gy = c[:, 1:2] * x + 2 * c[:, 2:3] * y + c[:, 4:5]
    dist = np.abs(F) / np.maximum(np.hypot(gx, gy), 1e-12) / T[0, 0]
    a, b, cc, d, e, f = c[int(np.argmax((dist < tol).sum(axis=1)))]
    return T.T @ np.array([[a, b / 2, d / 2], [b / 2, cc, e / 2], [d / 2, e / 2, f]]) @ T
