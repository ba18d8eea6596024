"""Pitch (grass) mask with a colour model that adapts per clip.

The model is a hue-saturation histogram of the grass of the current clip,
learnt from the frames themselves: on the first frame (or after it was lost)
it is seeded from the dominant peak inside a broad "green-ish" gate, then
every frame with a pitch in view blends in the histogram of its own core
grass pixels (exponential forgetting). Brightness is left out on purpose so
that mowing stripes and hard shadows stay grass.

Everything here runs on a small copy of the frame (``tiny``, about 160 px
wide): a grass mask needs no more detail, and the line stage works on
sub-pixel ridges of the luma plane instead.
"""

from __future__ import annotations

import cv2
import numpy as np

from arstream.detect.kernels.grass import component_stats, full_rows

__all__ = ["GrassModel", "GrassResult", "grass_masks"]

H_BINS, S_BINS = 45, 32
_RANGES = [0, 180, 0, 256]
# broad prior gate used only to seed the model (OpenCV hue units 0-180)
_PRIOR_LO = np.array([22, 35, 20], np.uint8)
_PRIOR_HI = np.array([100, 255, 255], np.uint8)


class GrassModel:
    """Hue-saturation histogram of one clip's grass (float32 (45, 32), max 255).

    Parameters
    ----------
    adapt : float
        Weight of the newest frame when the model is updated (0-1).
    threshold : float
        Back-projection level (share of the model's peak) above which a pixel
        counts as grass.
    """

    def __init__(self, adapt: float = 0.15, threshold: float = 0.04):
        if not 0.0 < adapt <= 1.0:
            raise ValueError(f"adapt must be in (0, 1], got {adapt}")
        if not 0.0 < threshold < 1.0:
            raise ValueError(f"threshold must be in (0, 1), got {threshold}")
        self.adapt = float(adapt)
        self.threshold = float(threshold)
        self.hist: np.ndarray | None = None
        self.frames = 0  # frames that updated the model

    def reset(self) -> None:
        self.hist = None
        self.frames = 0

    @staticmethod
    def _hist(hsv: np.ndarray, mask: np.ndarray | None) -> np.ndarray:
        h = cv2.calcHist([hsv], [0, 1], mask, [H_BINS, S_BINS], _RANGES)
        h = cv2.GaussianBlur(h, (3, 3), 0)
        m = float(h.max())
        if m > 0:
            h *= 255.0 / m
        return h

    def seed(self, hsv: np.ndarray, prior: np.ndarray) -> np.ndarray:
        """A one-frame model: the histogram peak inside the prior gate, grown to
        the bins that hold a real share of it. Returns the model (not stored)."""
        h = self._hist(hsv, prior)
        if h.max() <= 0:
            return h
        # keep only the connected blob of bins around the peak (drops other
        # green-ish things: shirts in the crowd, ad boards)
        keep = (h > 255.0 * self.threshold).astype(np.uint8)
        _, lab = cv2.connectedComponents(keep, connectivity=8)
        pk = np.unravel_index(int(np.argmax(h)), h.shape)
        h[lab != lab[pk]] = 0
        return h

    def backproject(self, hsv: np.ndarray, hist: np.ndarray, out: np.ndarray) -> np.ndarray:
        cv2.calcBackProject([hsv], [0, 1], hist, _RANGES, 1.0, dst=out)
        return out

    def update(self, hsv: np.ndarray, core: np.ndarray, seed: np.ndarray | None = None) -> None:
        h = self._hist(hsv, core)
        if self.hist is None:
            self.hist = h if seed is None else 0.5 * (h + seed)
        else:
            self.hist *= 1.0 - self.adapt
            self.hist += self.adapt * h
        self.frames += 1


class GrassResult:
    """Masks at the tiny resolution (uint8, 255 = yes).

    raw : grass-coloured pixels of the pitch component(s)
    closed : ``raw`` with thin gaps (painted lines) closed: where lines are searched
    filled : the pitch region: ``closed`` with players and other holes filled,
             screen graphics removed
    fraction : share of the frame that is pitch (``filled``)
    graphics : the screen graphics cut out of the pitch (or None)
    """

    __slots__ = ("raw", "closed", "filled", "fraction", "graphics")

    def __init__(self, raw, closed, filled, fraction, graphics=None):
        self.raw, self.closed, self.filled, self.fraction, self.graphics = raw, closed, filled, fraction, graphics


_K3 = cv2.getStructuringElement(cv2.MORPH_RECT, (3, 3))
_K5 = cv2.getStructuringElement(cv2.MORPH_RECT, (5, 5))


def _components(mask: np.ndarray, connectivity: int) -> tuple[int, np.ndarray, np.ndarray]:
    """``cv2.connectedComponentsWithStats`` without the centroids: (n, labels,
    stats (n, 5) in OpenCV's layout), the statistics in one compiled pass
    (:func:`arstream.detect.kernels.grass.component_stats`)."""
    n, lab = cv2.connectedComponents(mask, connectivity=connectivity)
    return n, lab, component_stats(lab, n)


def _graphics(raw: np.ndarray, bufs: dict) -> np.ndarray | None:
    """Screen graphics (a score box): bands of at least two full rows of a
    non-grass component, wide but not frame-wide, inside a box that is mostly
    solid (a player touching the box does not hide it). None when there are none."""
    h, w = raw.shape
    inv = cv2.bitwise_not(raw, dst=bufs["prior"])
    ng, gl, gst = _components(inv, 4)
    out = None
    ks = np.flatnonzero((gst[1:, cv2.CC_STAT_WIDTH] >= 0.1 * w) & (gst[1:, cv2.CC_STAT_WIDTH] <= 0.6 * w) & (gst[1:, cv2.CC_STAT_AREA] >= 0.002 * h * w)) + 1
    if not len(ks):
        return None
    # per candidate: how many of its box's rows it fills (90 %), the first and the last
    for k, (n_full, first, last) in zip(ks.tolist(), full_rows(gl, gst, ks, 0.9).tolist()):
        if n_full < 2 or last - first + 1 > 0.25 * h or gst[k, cv2.CC_STAT_WIDTH] < 2 * n_full:
            continue
        if out is None:
            out = bufs["graphics"]
            out[:] = 0
        x, y, bw = int(gst[k, 0]), int(gst[k, 1]), int(gst[k, 2])
        out[y + first : y + last + 1, x : x + bw] = 255
    return out


def grass_masks(tiny_bgr: np.ndarray, model: GrassModel, *, min_fraction: float = 0.08, bufs: dict | None = None) -> GrassResult:
    """Grass masks of a tiny BGR frame, updating ``model`` when a pitch is in view.

    Parameters
    ----------
    tiny_bgr : (h, w, 3) uint8
    model : GrassModel (updated in place)
    min_fraction : smallest share of the frame that counts as a pitch view

    Returns
    -------
    GrassResult
    """
    h, w = tiny_bgr.shape[:2]
    if bufs is None:
        bufs = {}
    hsv = bufs.get("hsv")
    if hsv is None or hsv.shape != tiny_bgr.shape:
        hsv = bufs["hsv"] = np.empty_like(tiny_bgr)
        for k in ("bp", "raw", "closed", "filled", "prior", "tmp", "graphics"):
            bufs[k] = np.empty((h, w), np.uint8)
    cv2.cvtColor(tiny_bgr, cv2.COLOR_BGR2HSV, dst=hsv)
    prior = cv2.inRange(hsv, _PRIOR_LO, _PRIOR_HI, dst=bufs["prior"])
    seed = None
    if model.hist is None:
        seed = model.seed(hsv, prior)
        hist = seed
    else:
        hist = model.hist
    bp = model.backproject(hsv, hist, bufs["bp"])
    thr = 255.0 * model.threshold
    raw = bufs["raw"]
    cv2.threshold(bp, thr, 255, cv2.THRESH_BINARY, dst=raw)
    cv2.bitwise_and(raw, prior, dst=raw)
    cv2.morphologyEx(raw, cv2.MORPH_OPEN, _K3, dst=raw)
    closed = bufs["closed"]
    filled = bufs["filled"]
    # painted lines and the ball are thin gaps in the grass: close them first, so
    # that the grass inside the circles and on both sides of a line stays one
    # region. Gaps up to 2 px close whatever they are; wider ones (up to 4 px: a
    # zoomed-in line, or one smeared by a pan) only where they are at least as
    # bright as the grass (a dark screen graphic or a player stays a hole)
    cv2.morphologyEx(raw, cv2.MORPH_CLOSE, _K3, dst=closed)
    wide = cv2.morphologyEx(raw, cv2.MORPH_CLOSE, _K5, dst=bufs["tmp"])
    v_grass = cv2.mean(hsv, mask=raw)[2]
    bright = cv2.threshold(cv2.extractChannel(hsv, 2), 0.9 * v_grass, 255, cv2.THRESH_BINARY)[1]
    cv2.bitwise_and(wide, bright, dst=wide)
    cv2.bitwise_or(closed, wide, dst=closed)
    graphics = _graphics(raw, bufs)
    if graphics is not None:
        cv2.subtract(closed, graphics, dst=closed)
    # the pitch: the large connected grass components
    n, lab, stats = _components(closed, 8)
    if n <= 1:
        raw[:] = 0
        closed[:] = 0
        filled[:] = 0
        return GrassResult(raw, closed, filled, 0.0)
    areas = stats[1:, cv2.CC_STAT_AREA]
    big = np.flatnonzero(areas >= max(0.25 * areas.max(), 0.01 * h * w)) + 1
    if len(big) < n - 1:
        keep = np.zeros(n, np.uint8)
        keep[big] = 255
        closed[:] = keep[lab]
        cv2.bitwise_and(raw, closed, dst=raw)
    total = float(areas[big - 1].sum()) / (h * w)
    if total < min_fraction:
        raw[:] = 0
        closed[:] = 0
        filled[:] = 0
        return GrassResult(raw, closed, filled, total)
    # filled: holes of the pitch (players, lines, the ball) are pitch; holes
    # that touch the frame border are filled too when the pitch surrounds them
    # on three sides, which the convex hull captures (the pitch's image is
    # convex); screen graphics (solid rectangles) are cut out again.
    cnts, _ = cv2.findContours(closed, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    filled[:] = 0
    if cnts:
        pts = np.concatenate(cnts, axis=0)
        hull = cv2.convexHull(pts)
        cv2.fillConvexPoly(filled, hull, 255)
        holes = cv2.subtract(filled, closed, dst=bufs["tmp"])
        nh, hl, hst = _components(holes, 4)
        if nh > 1:
            ww, hh, aa = hst[1:, cv2.CC_STAT_WIDTH], hst[1:, cv2.CC_STAT_HEIGHT], hst[1:, cv2.CC_STAT_AREA]
            rect = aa / np.maximum(ww * hh, 1)
            # solid rectangles; big regions hugging the hull's edge that are not
            # pitch coloured at all (stands seen past a corner)
            drop = ((rect > 0.8) & (ww >= 2 * hh) & (aa >= 0.002 * h * w)) | (aa >= 0.12 * h * w)
            if drop.any():
                lut = np.zeros(nh, np.uint8)
                lut[np.flatnonzero(drop) + 1] = 255
                cv2.subtract(filled, lut[hl], dst=filled)
        if graphics is not None:
            cv2.subtract(filled, graphics, dst=filled)
    frac = float(cv2.countNonZero(filled)) / (h * w)
    core = cv2.erode(raw, _K3, dst=bufs["tmp"])
    if cv2.countNonZero(core) > 0.02 * h * w:
        model.update(hsv, core, seed)
    return GrassResult(raw, closed, filled, frac, graphics)
