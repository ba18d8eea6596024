"""Pitch detection: grass, white line pixels, long straight lines and circle ellipses.

Per frame (BGR uint8):

1. **Grass.** A colour model of the grass (hue centre and spread, least
   saturation and value) is estimated from the frame's dominant green hue
   peak and adapted slowly over the clip (exponential average), on a 1/4-size
   HSV image. The mask is closed morphologically and its holes are filled, so
   that players standing on the pitch are inside it; stands, boards and screen
   graphics (not grass-coloured, or not connected to the pitch) are outside.
2. **Line pixels.** A pixel is on a painted line when it is brighter than the
   pixels ``tau`` to both sides of it, horizontally or vertically (a
   two-sided ridge test on luma, robust to the soft edges of mowing stripes
   and shadows, which are one-sided). The ridge pixels are thinned by
   non-maximum suppression across the line and given a sub-pixel centre by a
   parabola through the luma profile.
3. **Straight lines.** Probabilistic Hough segments on the thinned line pixels
   are grouped into long lines (collinear pieces split by players merge),
   each refitted by weighted total least squares to its support points, with
   the fit's uncertainty.
4. **Ellipses.** Line pixels not explained by the straight lines are grouped
   into connected arcs (on a half-resolution mask); an ellipse grown from
   each large arc (direct fit, then gathering every curved point near it by
   Sampson distance, then a refit on the orthogonal-distance inliers) is kept
   when it is well supported around its perimeter and plausible in size and
   shape — the centre circle, and penalty arcs.

Arrays in :class:`Detections` are views into the detector's reused buffers:
valid until the next :meth:`Detector.process` call.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import cv2
import numpy as np

from geometry.conics import Ellipse, ellipse_distance, fit_ellipse_direct, sampson_distance
from geometry.lines import fit_line

__all__ = ["Detector", "Detections", "DetectedLine", "DetectedEllipse", "detect"]


@dataclass
class DetectedLine:
    """A long straight line in the image.

    Attributes
    ----------
    line : (3,) homogeneous image line, a^2 + b^2 = 1, pixels
    endpoints : (2, 2) extreme support points, pixels
    points : (N, 2) sub-pixel support points, pixels
    length : float, pixels between the endpoints
    normal_sigma : float, offset uncertainty (px)
    angle_sigma : float, direction uncertainty (rad)
    """

    line: np.ndarray
    endpoints: np.ndarray
    points: np.ndarray = field(repr=False)
    length: float = 0.0
    normal_sigma: float = 0.0
    angle_sigma: float = 0.0

    def to_json(self) -> dict:
        return {
            "line": [round(float(v), 8) for v in self.line],
            "endpoints": np.round(self.endpoints, 2).tolist(),
            "length": round(self.length, 2),
            "support": int(len(self.points)),
            "normal_sigma": round(self.normal_sigma, 4),
            "angle_sigma": round(self.angle_sigma, 6),
        }


@dataclass
class DetectedEllipse:
    """A circle marking's image (centre circle or penalty arc).

    Attributes
    ----------
    ellipse : Ellipse, pixels
    conic : (3, 3) normalised conic (DESIGN convention)
    points : (N, 2) inlier support points
    rms : float, orthogonal residual (px)
    coverage : float, share of the perimeter with support (36 angular bins)
    score : float in [0, 1]
    """

    ellipse: Ellipse
    conic: np.ndarray
    points: np.ndarray = field(repr=False)
    rms: float = 0.0
    coverage: float = 0.0
    score: float = 0.0

    def to_json(self) -> dict:
        e = self.ellipse
        return {
            "conic": np.round(self.conic, 12).tolist(),
            "center": [round(e.center[0], 3), round(e.center[1], 3)],
            "axes": [round(e.axes[0], 3), round(e.axes[1], 3)],
            "angle": round(e.angle, 6),
            "rms": round(self.rms, 4),
            "coverage": round(self.coverage, 3),
            "score": round(self.score, 3),
            "support": int(len(self.points)),
        }


@dataclass
class Detections:
    """What the detector found in one frame (see the module docstring)."""

    width: int
    height: int
    pitch_visible: bool
    grass_mask: np.ndarray = field(repr=False)
    line_mask: np.ndarray = field(repr=False)
    line_points: np.ndarray = field(repr=False)
    lines: list = field(default_factory=list)
    ellipses: list = field(default_factory=list)
    timings: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        """Lines and conics (no pixel arrays)."""
        return {
            "width": self.width,
            "height": self.height,
            "pitch_visible": self.pitch_visible,
            "grass_fraction": round(float(np.count_nonzero(self.grass_mask)) / max(self.grass_mask.size, 1), 4),
            "line_pixels": int(len(self.line_points)),
            "lines": [l.to_json() for l in self.lines],
            "ellipses": [e.to_json() for e in self.ellipses],
            "timings_ms": {k: round(v, 3) for k, v in self.timings.items()},
        }


class Detector:
    """The detection stage: one object per clip (reuses buffers, adapts its grass model).

    Parameters
    ----------
    width, height : frame size (pixels)
    tau : ridge half-width test distances (px); lines up to about 2 tau wide are found
    ridge_threshold : least luma contrast (grey levels) of a line pixel over both sides
    min_line_length : shortest straight line reported (px)
    """

    def __init__(self, width: int, height: int, *, tau: int | None = None, ridge_threshold: int = 12, min_line_length: float = 50.0):
        if width < 16 or height < 16:
            raise ValueError(f"frame size must be at least 16x16, got {width}x{height}")
        self.width, self.height = int(width), int(height)
        self.tau = int(tau if tau is not None else max(3, round(4 * width / 1280)))
        self.ridge_threshold = int(ridge_threshold)
        self.min_line_length = float(min_line_length)
        self.scale = 4
        self._hue: float | None = None  # adapted grass model
        self._hue_sd: float = 10.0
        self._sat_min: float = 40.0
        self._val_min: float = 30.0
        sw, sh = (width + self.scale - 1) // self.scale, (height + self.scale - 1) // self.scale
        self._small = np.empty((sh, sw, 3), np.uint8)
        self._grass_full = np.zeros((height, width), np.uint8)
        self._line_mask = np.zeros((height, width), np.uint8)
        self._half = np.zeros(((height + 1) // 2, (width + 1) // 2), np.uint8)
        self._close_k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (9, 9))
        self._lsd = None

    # --- grass -----------------------------------------------------------------
    def _grass(self, image: np.ndarray) -> float:
        H, W = self.height, self.width
        small = cv2.resize(image, (self._small.shape[1], self._small.shape[0]), dst=self._small, interpolation=cv2.INTER_AREA)
        hsv = cv2.cvtColor(small, cv2.COLOR_BGR2HSV)
        h, s, v = hsv[..., 0], hsv[..., 1], hsv[..., 2]
        cand = (s > 35) & (v > 25) & (h >= 25) & (h <= 95)  # greenish at all (OpenCV hue 0-180)
        if cand.sum() < 0.05 * h.size:
            cv2.resize(np.zeros(h.shape, np.uint8), (W, H), dst=self._grass_full, interpolation=cv2.INTER_NEAREST)
            return 0.0
        hist = np.bincount(h[cand].ravel(), minlength=181).astype(np.float64)
        hist = np.convolve(hist, np.ones(5) / 5, mode="same")
        peak = float(np.argmax(hist))
        sel = cand & (np.abs(h.astype(np.int16) - peak) <= 12)
        hv = h[sel].astype(np.float64)
        mu, sd = float(hv.mean()), float(max(hv.std(), 3.0))
        smin = float(np.percentile(s[sel], 3)) * 0.7
        vmin = float(np.percentile(v[sel], 2)) * 0.6
        if self._hue is None:
            self._hue, self._hue_sd, self._sat_min, self._val_min = mu, sd, smin, vmin
        else:  # adapt slowly over the clip
            a = 0.1
            self._hue += a * (mu - self._hue)
            self._hue_sd += a * (sd - self._hue_sd)
            self._sat_min += a * (smin - self._sat_min)
            self._val_min += a * (vmin - self._val_min)
        lo = max(self._hue - 3.0 * self._hue_sd - 2, 0)
        hi = min(self._hue + 3.0 * self._hue_sd + 2, 180)
        mask = cv2.inRange(hsv, (lo, max(self._sat_min, 20), max(self._val_min, 15)), (hi, 255, 255))
        # grass is smooth; a crowd in green shirts is not: drop highly textured areas
        vf = v.astype(np.float32)
        mean = cv2.blur(vf, (5, 5))
        var = cv2.blur(vf * vf, (5, 5)) - mean * mean
        mask[var > 20.0**2] = 0
        mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, self._close_k)
        # keep the large connected grass regions, then fill holes (players on the pitch)
        n, lab, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=4)
        if n > 1:
            big = np.flatnonzero(stats[1:, cv2.CC_STAT_AREA] >= 0.02 * mask.size) + 1
            keep = np.isin(lab, big)
            mask = np.where(keep, 255, 0).astype(np.uint8)
        inv = cv2.bitwise_not(mask)
        n, lab, stats, _ = cv2.connectedComponentsWithStats(inv, connectivity=4)
        for k in range(1, n):
            x, y, w, hh, area = stats[k]
            touches = x == 0 or y == 0 or x + w >= mask.shape[1] or y + hh >= mask.shape[0]
            if not touches or area < 0.003 * mask.size and y > 0:
                mask[lab == k] = 255  # a hole inside the pitch (a player, the ball, a line)
        cv2.resize(mask, (W, H), dst=self._grass_full, interpolation=cv2.INTER_NEAREST)
        return float(np.count_nonzero(mask)) / mask.size

    # --- line pixels ---------------------------------------------------------------
    def _line_pixels(self, gray: np.ndarray) -> np.ndarray:
        t = self.tau
        H, W = gray.shape
        g = cv2.GaussianBlur(gray, (3, 3), 0)
        thr = self.ridge_threshold
        # two-sided ridge test, horizontally and vertically (saturating differences)
        left = np.zeros_like(g)
        right = np.zeros_like(g)
        left[:, t:] = cv2.subtract(g[:, t:], g[:, :-t])
        right[:, :-t] = cv2.subtract(g[:, :-t], g[:, t:])
        rh = cv2.min(left, right)
        up = np.zeros_like(g)
        down = np.zeros_like(g)
        up[t:, :] = cv2.subtract(g[t:, :], g[:-t, :])
        down[:-t, :] = cv2.subtract(g[:-t, :], g[t:, :])
        rv = cv2.min(up, down)
        grass = self._grass_full
        mh = (rh > thr) & (grass > 0)
        mv = (rv > thr) & (grass > 0)
        gi = g.astype(np.int16)
        # centres across the line: local maxima (plateaus of wide lines included), then the
        # centroid of the brightness above the local background within +-tau along the test
        # axis (a parabola or a one-sided NMS would bias wide, flat-topped lines)
        pts = []
        gf = g.astype(np.float32)
        for m, axis in ((mh, 1), (mv, 0)):
            prev = np.roll(gi, 1, axis=axis)
            nxt = np.roll(gi, -1, axis=axis)
            nms = m & (gi >= prev) & (gi >= nxt)
            ys, xs = np.nonzero(nms)
            if len(ys) == 0:
                continue
            offs = np.arange(-t, t + 1)
            if axis == 1:
                cols = np.clip(xs[:, None] + offs[None, :], 0, W - 1)
                prof = gf[ys[:, None], cols]
            else:
                rows = np.clip(ys[:, None] + offs[None, :], 0, H - 1)
                prof = gf[rows, xs[:, None]]
            base = np.minimum(prof[:, 0], prof[:, -1])[:, None]
            w = np.clip(prof - base, 0, None)
            off = (w * offs[None, :]).sum(1) / np.maximum(w.sum(1), 1e-6)
            if axis == 1:
                pts.append(np.column_stack([xs + off, ys.astype(np.float64), np.ones(len(xs))]))
            else:
                pts.append(np.column_stack([xs.astype(np.float64), ys + off, np.ones(len(xs))]))
        # a coarse horizontal pass (3 tau) for near-vertical lines smeared by fast pans:
        # used for straight lines only (it also answers to the edges of players, which
        # would pull the ellipse fits)
        t2 = 3 * t
        a = np.zeros_like(g)
        b = np.zeros_like(g)
        a[:, t2:] = cv2.subtract(g[:, t2:], g[:, :-t2])
        b[:, :-t2] = cv2.subtract(g[:, :-t2], g[:, t2:])
        m2 = (cv2.min(a, b) > thr) & (grass > 0)
        near_fine = cv2.dilate(mh.astype(np.uint8), np.ones((1, 2 * t2 + 1), np.uint8)) > 0
        # not on near-horizontal lines (found by the fine vertical test), where a wide
        # horizontal window runs along the line instead of across it
        near_fine |= cv2.dilate(mv.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
        prev = np.roll(gi, 1, axis=1)
        nxt = np.roll(gi, -1, axis=1)
        ys, xs = np.nonzero(m2 & ~near_fine & (gi >= prev) & (gi >= nxt))
        if len(ys):
            offs = np.arange(-t2, t2 + 1)
            prof = gf[ys[:, None], np.clip(xs[:, None] + offs[None, :], 0, W - 1)]
            base = np.minimum(prof[:, 0], prof[:, -1])[:, None]
            w = np.clip(prof - base, 0, None)
            off = (w * offs[None, :]).sum(1) / np.maximum(w.sum(1), 1e-6)
            pts.append(np.column_stack([xs + off, ys.astype(np.float64), np.zeros(len(xs))]))
        lm = self._line_mask
        lm[:] = 0
        if not pts:
            self._fine = np.zeros(0, bool)
            return np.zeros((0, 2))
        P3 = np.concatenate(pts)
        P, fine = P3[:, :2], P3[:, 2] > 0
        # plateau pixels of one cross-section give the same centre, and a pixel may pass both
        # tests: keep one point per half-pixel cell
        key = np.round(P * 2).astype(np.int64)
        key = key[:, 1] * (2 * W + 2) + key[:, 0]
        _, first = np.unique(key, return_index=True)
        first = np.sort(first)
        P, fine = P[first], fine[first]
        ix = np.clip(np.round(P).astype(np.int64), 0, [W - 1, H - 1])
        lm[ix[:, 1], ix[:, 0]] = 255
        # drop blobs: white kits, the ball, graphics give short clusters, lines long ones
        # (connected components on a half-resolution mask: cheap, and gaps of a pixel close)
        half = self._half
        half[:] = 0
        half[ix[:, 1] // 2, ix[:, 0] // 2] = 255
        n, lab, stats, _ = cv2.connectedComponentsWithStats(half, connectivity=8)
        if n > 1:
            ext = 2 * np.maximum(stats[:, cv2.CC_STAT_WIDTH], stats[:, cv2.CC_STAT_HEIGHT])
            good = ext >= max(12, 0.012 * W)
            good[0] = False
            keep_px = good[lab[ix[:, 1] // 2, ix[:, 0] // 2]]
            P, fine = P[keep_px], fine[keep_px]
            lm[:] = 0
            ix = ix[keep_px]
            lm[ix[:, 1], ix[:, 0]] = 255
        self._fine = fine
        return P

    # --- straight lines --------------------------------------------------------------
    def _lines(self, P: np.ndarray) -> list[DetectedLine]:
        if len(P) < 20:
            return []
        # Hough on the half-resolution mask (4x fewer pixels); the lines are refitted to
        # the full-resolution sub-pixel points below, so its coarseness does not matter
        half = self._half
        half[:] = 0
        ix = np.clip((P * 0.5).astype(np.int64), 0, [half.shape[1] - 1, half.shape[0] - 1])
        half[ix[:, 1], ix[:, 0]] = 255
        segs = cv2.HoughLinesP(half, 1, np.pi / 360, threshold=15, minLineLength=max(10, self.min_line_length * 0.2), maxLineGap=4)
        if segs is None:
            return []
        segs = 2.0 * np.asarray(segs).reshape(-1, 4).astype(np.float64) + 0.5
        seg_len = np.hypot(segs[:, 2] - segs[:, 0], segs[:, 3] - segs[:, 1])
        order = np.argsort(-seg_len)
        used = np.zeros(len(P), bool)
        out: list[DetectedLine] = []
        for k in order:
            x0, y0, x1, y1 = segs[k]
            l = np.cross([x0, y0, 1.0], [x1, y1, 1.0])
            n = np.hypot(l[0], l[1])
            if n < 1e-9:
                continue
            l = l / n
            mid = np.array([(x0 + x1) / 2, (y0 + y1) / 2, 1.0])
            if any(abs(d.line @ mid) < 3.0 and abs(d.line[:2] @ l[:2]) > 0.998 and _within(d, mid[:2]) for d in out):
                continue  # a piece of a line already found
            d = np.abs(P @ l[:2] + l[2])
            sel = (d < 2.0) & ~used
            if sel.sum() < 20:
                continue
            for _ in range(2):
                fit = fit_line(P[sel])
                d = np.abs(P @ fit.line[:2] + fit.line[2])
                sel = (d < 1.5) & ~used
                if sel.sum() < 20:
                    break
            if sel.sum() < 20:
                continue
            pts = P[sel]
            t = pts @ fit.direction
            # split at gaps wider than 5 % of the frame: keep the longest run (players split lines
            # by a few dozen pixels; unrelated collinear pieces, such as two arcs of an ellipse
            # that a chord touches, are farther apart)
            o = np.argsort(t)
            ts = t[o]
            gaps = np.flatnonzero(np.diff(ts) > max(25.0, 0.05 * self.width))
            bounds = np.r_[0, gaps + 1, len(ts)]
            run = max(range(len(bounds) - 1), key=lambda j: ts[bounds[j + 1] - 1] - ts[bounds[j]])
            keep_idx = o[bounds[run] : bounds[run + 1]]
            pts = pts[keep_idx]
            if len(pts) < 20:
                continue
            fit = fit_line(pts)
            tt = pts @ fit.direction
            length = float(tt.max() - tt.min())
            # a line is a long, thin, densely supported structure, and straight: the
            # sagitta of a quadratic through the residuals rejects arcs of the circles
            if length < self.min_line_length or len(pts) < 0.5 * length or fit.rms > 1.0:
                continue
            idx_all = np.flatnonzero(sel)[keep_idx]
            if np.mean(self._fine[idx_all]) < 0.5 and length < 4 * self.min_line_length:
                continue  # found mostly by the coarse pass: only long lines (players' edges are short)
            tn = (tt - 0.5 * (tt.max() + tt.min())) / (0.5 * length)
            res = pts @ fit.line[:2] + fit.line[2]
            quad = np.polyfit(tn, res, 2)[0]
            if abs(quad) > 0.6:
                continue
            e = np.array([pts[np.argmin(tt)], pts[np.argmax(tt)]])
            used[idx_all] = True
            out.append(DetectedLine(line=fit.line, endpoints=e, points=pts, length=length, normal_sigma=fit.normal_sigma, angle_sigma=fit.angle_sigma))
            if len(out) >= 16:
                break
        out.sort(key=lambda d: -d.length)
        return out

    # --- ellipses --------------------------------------------------------------------
    def _ellipses(self, P: np.ndarray, lines: list[DetectedLine]) -> list[DetectedEllipse]:
        if len(P) < 40:
            return []
        curved = np.ones(len(P), bool)
        for d in lines:
            curved &= np.abs(P @ d.line[:2] + d.line[2]) > 2.5
        C = P[curved]
        if len(C) < 40:
            return []
        H, W = self.height, self.width
        m = self._half
        m[:] = 0
        ix = np.clip((C * 0.5).astype(np.int64), 0, [m.shape[1] - 1, m.shape[0] - 1])
        m[ix[:, 1], ix[:, 0]] = 255
        m = cv2.dilate(m, None)
        n, lab, stats, _ = cv2.connectedComponentsWithStats(m, connectivity=8)
        stats = stats.copy()
        stats[:, cv2.CC_STAT_WIDTH] *= 2
        stats[:, cv2.CC_STAT_HEIGHT] *= 2
        comp = lab[ix[:, 1], ix[:, 0]]
        order = np.argsort(-stats[:, cv2.CC_STAT_AREA])
        found: list[DetectedEllipse] = []
        taken = np.zeros(len(C), bool)
        tried = 0
        for k in order:
            if k == 0:
                continue
            sel = (comp == k) & ~taken
            if sel.sum() < 30:
                continue
            ext = max(stats[k, cv2.CC_STAT_WIDTH], stats[k, cv2.CC_STAT_HEIGHT])
            if ext < 0.04 * W:
                continue
            tried += 1
            if tried > 6:
                break
            try:
                e = fit_ellipse_direct(C[sel])
            except ValueError:
                continue
            if not self._plausible(e):
                continue
            for _ in range(2):  # gather the other arcs of the same ellipse, refit
                near = (np.abs(sampson_distance(C, e.conic)) < 3.0) & ~taken
                if near.sum() < 30:
                    break
                try:
                    e = fit_ellipse_direct(C[near])
                except ValueError:
                    break
                if not self._plausible(e):
                    break
            near = (np.abs(sampson_distance(C, e.conic)) < 2.0) & ~taken
            if near.sum() < 40 or not self._plausible(e):
                continue
            pts = C[near]
            # trim to the orthogonal-distance inliers and refit (the direct fit on clean,
            # well-spread points is within a few hundredths of a pixel of the geometric fit)
            d = ellipse_distance(pts, e)
            if (d < 1.5).sum() >= 40:
                try:
                    e = fit_ellipse_direct(pts[d < 1.5])
                except ValueError:
                    continue
                if not self._plausible(e):
                    continue
            d = ellipse_distance(pts, e)
            inl = d < 1.5
            if inl.sum() < 40:
                continue
            pts = pts[inl]
            cov = _coverage(pts, e)
            rms = float(np.sqrt(np.mean(d[inl] ** 2)))
            if cov < 0.3 or rms > 0.75 or not self._plausible(e):
                continue
            # support density: a painted ellipse is dense along its supported arcs
            a, b = e.axes
            perim = np.pi * (3 * (a + b) - np.sqrt((3 * a + b) * (a + 3 * b)))
            if len(pts) < 0.25 * cov * perim:
                continue
            taken |= np.abs(sampson_distance(C, e.conic)) < 2.5
            score = float(min(1.0, cov * 1.2) * np.exp(-rms))
            found.append(DetectedEllipse(ellipse=e, conic=e.conic, points=pts, rms=rms, coverage=cov, score=score))
            if len(found) >= 3:
                break
        found.sort(key=lambda d: -d.score)
        return found

    def _plausible(self, e: Ellipse) -> bool:
        a, b = e.axes
        W, H = self.width, self.height
        cx, cy = e.center
        return 0.04 * W < a < 3.0 * W and b > 12 * W / 1280 and b / a > 0.06 and -W < cx < 2 * W and -H < cy < 2 * H

    # --- public ----------------------------------------------------------------------
    def process(self, image: np.ndarray) -> Detections:
        """Detect the pitch markings of one BGR uint8 (H, W, 3) frame."""
        if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
            raise ValueError(f"image must be a BGR uint8 array (H, W, 3), got {getattr(image, 'dtype', type(image))} {getattr(image, 'shape', '')}")
        if image.shape[:2] != (self.height, self.width):
            raise ValueError(f"image is {image.shape[1]}x{image.shape[0]}, detector expects {self.width}x{self.height}")
        t0 = time.perf_counter()
        frac = self._grass(image)
        t1 = time.perf_counter()
        visible = frac > 0.2
        if visible:
            gray = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
            P = self._line_pixels(gray)
        else:
            self._line_mask[:] = 0
            self._fine = np.zeros(0, bool)
            P = np.zeros((0, 2))
        t2 = time.perf_counter()
        lines = self._lines(P) if visible else []
        t3 = time.perf_counter()
        ells = self._ellipses(P[self._fine], lines) if visible and len(P) else []
        if ells:
            # a flat stretch of an ellipse can pass for a short line: drop lines lying on one
            lines = [l for l in lines if not any(np.median(np.abs(sampson_distance(l.points, e.conic))) < 1.5 for e in ells)]
        t4 = time.perf_counter()
        return Detections(
            width=self.width,
            height=self.height,
            pitch_visible=bool(visible and len(P) >= 30),
            grass_mask=self._grass_full,
            line_mask=self._line_mask,
            line_points=P,
            lines=lines,
            ellipses=ells,
            timings={"grass": 1000 * (t1 - t0), "line_pixels": 1000 * (t2 - t1), "lines": 1000 * (t3 - t2), "ellipses": 1000 * (t4 - t3)},
        )


def _within(d: DetectedLine, p: np.ndarray, margin: float = 20.0) -> bool:
    """Whether point ``p`` (2,) lies between the ends of line ``d`` (along it, +- margin px)."""
    u = d.endpoints[1] - d.endpoints[0]
    n = np.linalg.norm(u)
    if n < 1e-9:
        return False
    t = (p - d.endpoints[0]) @ u / n
    return -margin <= t <= n + margin


def _coverage(pts: np.ndarray, e: Ellipse, bins: int = 36) -> float:
    """Share of the ellipse's perimeter (in parametric angle bins) with support points."""
    ca, sa = np.cos(e.angle), np.sin(e.angle)
    d = pts - np.asarray(e.center)
    u = (d[:, 0] * ca + d[:, 1] * sa) / e.axes[0]
    v = (-d[:, 0] * sa + d[:, 1] * ca) / e.axes[1]
    th = np.arctan2(v, u)
    idx = ((th + np.pi) / (2 * np.pi) * bins).astype(int) % bins
    return float(len(np.unique(idx))) / bins


def detect(image: np.ndarray, **options) -> Detections:
    """One-shot detection (a fresh :class:`Detector`; no adaptation across frames)."""
    if not isinstance(image, np.ndarray) or image.ndim != 3:
        raise ValueError(f"image must be a BGR uint8 array (H, W, 3), got {getattr(image, 'shape', type(image))}")
    return Detector(image.shape[1], image.shape[0], **options).process(image)
