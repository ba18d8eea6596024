"""The detection stage: :class:`Detector` (one per clip) and :func:`detect`."""

from __future__ import annotations

import time

import cv2
import numpy as np

from arstream.imaging import shrink
from arstream.detect.kernels.points import chains, cut_by_line, fit_lines, grid_clear, mask_at, settle_points

from .ellipses import find_ellipses
from .grass import GrassModel, grass_masks
from .results import DetectedEllipse, DetectedLine, Detections
from .ridges import RidgePoints, band_centres, grass_luma, ridge_points
from .segments import group_lines

__all__ = ["Detector", "detect"]

_K3 = cv2.getStructuringElement(cv2.MORPH_RECT, (3, 3))
# working pixels of sideways motion per frame below which the squashed pass is
# skipped (when the caller knows the motion): bands narrower than the coarse
# pass's scale (a pan blurs a line by at most its motion over the exposure)
SQUASH_MOTION = 3.0
# working pixels: the widest line the fine pass centres well (its Hessian scale
# 1.2 px sees a bar up to 2 sqrt(3) 1.2 = 4.2 px wide); when the caller knows
# that no line is wider and the image moves slowly, the coarse pass is skipped
FINE_WIDTH = 4.0


class Detector:
    """Pitch detection for the frames of one clip.

    One object per clip: it keeps its buffers between frames (no per-frame
    allocation of image-sized arrays) and adapts its grass colour model and
    its line-width scale over the frames.

    Parameters
    ----------
    width, height : int
        Frame size in pixels (at least 16 x 16).
    work_width : int
        Ridges are searched on the frame shrunk by the integer factor
        ``max(1, width // work_width)`` (2 at 720p, 3 at 1080p).
    ridge_threshold : float, optional
        Least contrast (grey levels) of a line over the grass on both sides;
        by default 12 % of the grass's mean luma, at least 6.
    min_line_length : float
        Shortest straight line reported (frame pixels).
    tau : float, optional
        Half-width bound (frame pixels) of the widest line the fine ridge pass
        takes (its top-hat kernel); by default that kernel is 11 working pixels
        (wider lines are the coarse pass's).
    min_grass : float
        Least share of the frame that must be grass for a pitch view.
    max_ellipses : int
        Most ellipses reported.
    thin_lines : bool
        Judge a line narrower than the fine scale by its own contrast where it
        stands above the grass around it (:func:`arstream.detect.ridges.ridge_points`'
        ``grass_luma``): the far lines of a real frame, one or two pixels wide,
        which smoothing takes most of the height of. Off by default: it about
        doubles the markings' pixels found on the shared real frames
        (``bench/real_detection.py --thin-lines``), but the tracker's
        tripod-centre and pan-sweep decisions are not yet tuned to the denser
        pixels (docs/real-footage.md).
    shade : bool
        Ask a line where the grass is darker than the frame's (a stand's
        shadow across the pitch) 12 % of *that* grass's luma, not of the whole
        frame's (which left every line in the shade out). On in
        :func:`detect` (a still: ``arstream register``); off by default for a
        clip's detector: on a clip it moved the tracker (the synthetic
        ``hard`` preset, with its stadium shadow, 0.37 -> 0.57 px median,
        99.6 -> 94.4 % within 5 px; ``israel_league_wide``'s size choice
        tipped to 104 x 72.6 m), which is not yet tuned to it
        (bench/README.md "Stop 85", "Stop 86").
    enlarged : (ex, ey), frame pixels per pixel of the frame's source along
        x and y, where the frame was enlarged from it (a still of anamorphic
        SD pixels stretched to square ones, 720 x 576 shown 1024 x 576:
        (1.42, 1); :attr:`arstream.pipeline.stages.Analysis.enlarged`). A
        straight line's thickness and straightness tests
        (:func:`arstream.detect.segments.group_lines`) are then judged in
        the source's pixels: the stretch widens a compressed line's wobble
        along with the line (a halfway line of a ``real-sd`` still, 0.23
        frame pixels RMS about its fit at 720 x 576, 0.32 when stretched,
        over the 0.3 allowed, was no line). Below 1 counts as 1.
    """

    def __init__(
        self,
        width: int,
        height: int,
        *,
        work_width: int = 640,
        ridge_threshold: float | None = None,
        min_line_length: float = 50.0,
        tau: float | None = None,
        min_grass: float = 0.1,
        max_ellipses: int = 3,
        thin_lines: bool = False,
        shade: bool = False,
        enlarged: tuple[float, float] = (1.0, 1.0),
    ):
        try:
            width, height = int(width), int(height)
        except (TypeError, ValueError):
            raise ValueError(f"frame size must be integers, got {width!r} x {height!r}") from None
        if width < 16 or height < 16:
            raise ValueError(f"frame size must be at least 16x16, got {width}x{height}")
        if work_width < 16:
            raise ValueError(f"work_width must be at least 16, got {work_width}")
        if ridge_threshold is not None and not ridge_threshold > 0:
            raise ValueError(f"ridge_threshold must be positive, got {ridge_threshold}")
        if tau is not None and not tau > 0:
            raise ValueError(f"tau must be positive, got {tau}")
        if not 0.0 < min_grass < 1.0:
            raise ValueError(f"min_grass must be in (0, 1), got {min_grass}")
        try:
            ex, ey = (float(v) for v in enlarged)
        except (TypeError, ValueError):
            raise ValueError(f"enlarged must be two numbers (x, y), got {enlarged!r}") from None
        if not (np.isfinite(ex) and np.isfinite(ey) and ex > 0 and ey > 0):
            raise ValueError(f"enlarged must be two positive numbers, got {enlarged!r}")
        self.enlarged = (max(1.0, ex), max(1.0, ey))
        self.width, self.height = width, height
        self.thin_lines = bool(thin_lines)
        self.shade = bool(shade)
        self.factor = max(1, width // int(work_width))
        w, h = max(width // self.factor, 16), max(height // self.factor, 16)
        self.work_size = (w, h)
        tw, th = max(w // 4, 8), max(h // 4, 8)
        self.tiny_size = (tw, th)
        sx, sy = width / w, height / h
        # working pixel centre (i) -> frame pixel: s (i + 0.5) - 0.5 (area resampling)
        self.A_wf = np.array([[sx, 0.0, 0.5 * sx - 0.5], [0.0, sy, 0.5 * sy - 0.5], [0.0, 0.0, 1.0]])
        self.ridge_threshold = ridge_threshold
        self.min_line_length = float(min_line_length)
        self.tau = tau
        self.min_grass = float(min_grass)
        self.max_ellipses = int(max_ellipses)
        self.grass_model = GrassModel()
        self._small = np.empty((h, w, 3), np.uint8) if self.factor > 1 else None  # (the image itself at factor 1)
        self._gray = np.empty((h, w), np.uint8)
        self._tiny = np.empty((th, tw, 3), np.uint8)
        self._tiny_gray = np.empty((th, tw), np.uint8)
        self._region = np.empty((h, w), np.uint8)
        self._region_tiny = np.empty((th, tw), np.uint8)
        self._linemask_small = np.empty((h, w), np.uint8)
        self._scratch = np.full((h, w), -1, np.int32)  # the ellipse search's grid (-1 between calls)
        wc, hc = max(w // 2, 8), max(h // 2, 8)
        self._coarse_size = (wc, hc)
        self._gray_c = np.empty((hc, wc), np.uint8)
        self._region_c = np.empty((hc, wc), np.uint8)
        self._rbufs_c: dict = {}
        self._squash_w = max(w // 4, 16)
        self._gray_s = np.empty((h, self._squash_w), np.uint8)
        self._region_s = np.empty((h, self._squash_w), np.uint8)
        self._rbufs_s: dict = {}
        # the kernels' scratch grids: zero (uint8) or -1 (int32) between calls
        self._block = np.zeros((h, w), np.uint8)
        self._occ_c = np.zeros((hc, wc), np.uint8)
        self._chain_grid = np.full((hc, wc), -1, np.int32)
        self._runs_grid = np.full((h, self._squash_w), -1, np.int32)
        self._grass_full = np.empty((height, width), np.uint8)
        self._line_full = np.empty((height, width), np.uint8)
        self._gbufs: dict = {}
        self._rbufs: dict = {}
        self.frames = 0
        self._prev_conics: list = []  # the previous frame's ellipses (frame pixels)
        from arstream.kernels import warm_up_async  # (here: arstream.kernels imports this package's kernels)

        warm_up_async()  # load the compiled kernels while the caller starts up

    # -----------------------------------------------------------------------------
    def _merge(self, pts, nrm, extra, scale, min_abs_nx=0.0, block=None):
        """Add the ridge points ``extra`` found on the working image resized by
        1 / ``scale`` (sx, sy), where the points so far (working pixels, (N, 2),
        normals (N, 2)) found nothing nearby (within 2 cells of the coarse grid).
        ``min_abs_nx``: keep only those whose normal (in working pixels) is at
        least this horizontal; ``block``: working-pixel points (M, 2) whose
        neighbourhood (2 px along rows) blocks additions, instead of the
        neighbourhood of ``pts``. The added points come last (new arrays when
        any are added)."""
        if not len(extra.pts):
            return pts, nrm
        sx, sy = scale
        ep = (extra.pts + 0.5) * np.array([sx, sy]) - 0.5
        en = extra.nrm / np.array([sx, sy])  # gradients scale inversely with the axes
        en /= np.linalg.norm(en, axis=1, keepdims=True)
        w, h = self.work_size
        if block is not None:
            keep = grid_clear(block, ep, 1.0, 1.0, True, 2, 0, self._block)
        else:
            wc, hc = self._coarse_size
            keep = grid_clear(pts, ep, wc / w, hc / h, False, 2, 2, self._occ_c)
        if min_abs_nx > 0:
            keep &= np.abs(en[:, 0]) >= min_abs_nx
        if not keep.any():
            return pts, nrm
        return np.concatenate([pts, ep[keep]]), np.concatenate([nrm, en[keep]])

    def _long_runs(self, rp, size, min_rows):
        """The ridge points ``rp`` (RidgePoints, on an image of ``size`` (w, h)) in
        connected chains spanning at least ``min_rows`` rows: a smeared line is
        long, a player's legs (a thin bright ridge once squashed) are not."""
        if not len(rp.pts):
            return rp
        w, h = size
        xi = np.clip(np.rint(rp.pts[:, 0]).astype(np.int64), 0, w - 1)
        yi = np.clip(np.rint(rp.pts[:, 1]).astype(np.int64), 0, h - 1)
        _, _, ext_y = chains(xi, yi, 3, self._runs_grid)  # linked when within 3 px: a 3x3 dilation's 8-connectivity
        keep = ext_y + 3 >= min_rows  # the dilated chain: a row more at each end
        return RidgePoints(rp.pts[keep], rp.nrm[keep], rp.contrast[keep], rp.n_candidates)

    def _check(self, image) -> None:
        if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
            raise ValueError(
                f"image must be a BGR uint8 array (H, W, 3), got {getattr(image, 'dtype', type(image).__name__)} {getattr(image, 'shape', '')}"
            )
        if image.shape[:2] != (self.height, self.width):
            raise ValueError(f"image is {image.shape[1]}x{image.shape[0]}, detector expects {self.width}x{self.height}")

    def _empty(self, timings, grass_small=None) -> Detections:
        self._prev_conics = []
        self._linemask_small[:] = 0
        z = np.zeros((0, 2))
        return Detections(
            self.width, self.height, False, grass_small, self._grass_full, self._linemask_small, self._line_full, z, z.copy(), [], [], timings, self.factor
        )

    def process(self, image: np.ndarray, *, lazy: bool = False, motion: float | None = None, line_width: float | None = None) -> Detections:
        """Detect grass, line pixels, straight lines and circle ellipses in one frame.

        Parameters
        ----------
        image : (H, W, 3) uint8, BGR, the size given to the constructor
        lazy : bool
            Leave the straight lines and the ellipses to the first access of
            ``lines`` or ``ellipses`` (a tracker that follows a locked camera
            needs only the line points; grass and line points are always
            computed). The deferred work uses private copies of the detector's
            buffers, so it may run after the next call, on another thread.
        motion : float, optional
            Expected sideways image motion (frame pixels per frame, e.g. from a
            tracker's pan rate). Below ``SQUASH_MOTION`` working pixels per frame
            no line is smeared wider than the fine and coarse passes see, and the
            pass over the squashed frame is skipped. None (unknown): it runs.
        line_width : float, optional
            Width (frame pixels) of the widest painted line expected in the
            frame (e.g. from a tracker's camera: :func:`arstream.track.widest_line`).
            When it is at most ``FINE_WIDTH`` working pixels and ``motion`` says
            the image moves slowly, the fine pass sees every line and the coarse
            pass is skipped. None (unknown): it runs.

        Returns
        -------
        Detections (arrays valid until the next call)
        """
        self._check(image)
        self.frames += 1
        t0 = time.perf_counter()
        w, h = self.work_size
        small = image if self.factor == 1 else shrink(image, (w, h), dst=self._small)  # (read only below)
        tiny = cv2.resize(small, self.tiny_size, dst=self._tiny, interpolation=cv2.INTER_LINEAR)
        g = grass_masks(tiny, self.grass_model, min_fraction=self.min_grass, bufs=self._gbufs)
        t1 = time.perf_counter()
        timings = {"grass": 1e3 * (t1 - t0)}
        if g.fraction < self.min_grass:
            timings.update(line_pixels=0.0, lines=0.0, ellipses=0.0)
            return self._empty(timings, g.filled)
        # where lines may be: the grass, lines closed in, grown by a cell (steps at the
        # pitch's outline, such as the boards' lower edge, fail the two-sided ridge test)
        rt = cv2.bitwise_and(g.filled, g.closed, dst=self._region_tiny)
        cv2.dilate(rt, _K3, dst=rt)  # a line on the pitch's outline (the far touchline) is in
        if g.graphics is not None:  # ... but not the edge of a screen graphic
            cv2.subtract(rt, cv2.dilate(g.graphics, _K3), dst=rt)
        region = cv2.resize(rt, (w, h), dst=self._region, interpolation=cv2.INTER_NEAREST)
        gray = cv2.cvtColor(small, cv2.COLOR_BGR2GRAY, dst=self._gray)
        tg = cv2.cvtColor(tiny, cv2.COLOR_BGR2GRAY, dst=self._tiny_gray)
        luma = cv2.mean(tg, mask=g.raw)[0]
        min_contrast = self.ridge_threshold if self.ridge_threshold is not None else max(6.0, 0.12 * luma)
        # the grass's own luma around each line, on the small grid
        local = grass_luma(tg, g.raw, luma) if self.thin_lines or self.shade else None
        # shade: the contrast asked of a line where the grass is darker than the
        # frame's (a stand's shadow across the pitch halves the paint's contrast
        # there) is that grass's own share: lower, never higher
        grid = None if self.ridge_threshold is not None or not self.shade else np.minimum(np.float32(min_contrast), np.maximum(np.float32(6.0), np.float32(0.12) * local))
        # fine scale: thin and sharp lines; coarse scale (half the working size):
        # wide lines (zoomed in, or smeared by a fast pan). Coarse points count
        # only where the fine scale found nothing.
        kf = 11 if self.tau is None else 2 * max(2, int(np.ceil(self.tau / self.factor))) + 1
        # the grass's own luma around each line (a strip of grass between a player's
        # legs is a thin bright ridge, no brighter than the grass)
        gl = local if self.thin_lines else None
        fine = ridge_points(gray, region, sigma=1.2, kernel=kf, min_contrast=min_contrast, grass_luma=gl, contrast_grid=grid, bufs=self._rbufs)
        wc, hc = self._coarse_size
        slow = motion is not None and motion / self.factor < SQUASH_MOTION
        if slow and line_width is not None and line_width / self.factor <= FINE_WIDTH:
            pts, nrm = fine.pts, fine.nrm  # thin, sharp lines only: the fine pass's
        else:
            gc = cv2.resize(gray, (wc, hc), dst=self._gray_c, interpolation=cv2.INTER_AREA)
            rc = cv2.resize(rt, (wc, hc), dst=self._region_c, interpolation=cv2.INTER_NEAREST)
            coarse = ridge_points(gc, rc, sigma=1.3, kernel=11, min_contrast=min_contrast, grass_luma=gl, contrast_grid=grid, bufs=self._rbufs_c)
            pts, nrm = self._merge(fine.pts, fine.nrm, coarse, (w / wc, h / hc))
        # a fast horizontal pan smears the near-vertical lines (the halfway line)
        # sideways into wide, faint bands: look for them on the frame squashed
        # 4x horizontally, where they are thin again (near-vertical ones only;
        # on every frame unless the caller knows the image moves slowly: how
        # blurred a frame is does not show reliably in cheap image statistics,
        # and this pass costs about 1.5 ms)
        smeared = not slow
        if smeared:
            ws = self._squash_w
            gs = cv2.resize(gray, (ws, h), dst=self._gray_s, interpolation=cv2.INTER_AREA)
            rs = cv2.resize(region, (ws, h), dst=self._region_s, interpolation=cv2.INTER_NEAREST)
            squashed = ridge_points(gs, rs, sigma=1.2, kernel=11, min_contrast=0.7 * min_contrast, band_width=np.inf, grass_luma=gl, contrast_grid=None if grid is None else 0.7 * grid, bufs=self._rbufs_s)
            squashed = self._long_runs(squashed, (ws, h), min_rows=max(20, h // 9))
        if smeared and len(squashed.pts):
            # blocked only where the fine scale found the same line sharp (within 2 px
            # across it): its scattered hits on a smeared band do not count
            n0 = len(pts)
            pts, nrm = self._merge(pts, nrm, squashed, (w / ws, 1.0), min_abs_nx=0.95, block=fine.pts)
            # squashed, a band is too few pixels wide for its edges: centred between
            # them on the working image (its bright end is a stripe's side when the
            # line runs along a stripe's edge)
            if len(pts) > n0:  # on the fine pass's smoothed luma
                shift, _ = band_centres(self._rbufs["blur"], pts[n0:], nrm[n0:], reach=int(w / ws * 11) // 2 + 5)
                pts[n0:] += shift[:, None] * nrm[n0:]
        # a painted line has grass beside it, on one side at least (the other may
        # be the boards: the far touchline); a white kit has a shirt above and legs
        # below (sampled on the tiny grass mask, beyond the line's width). Then
        # connected chains of line points (coarse raster: gaps of a few pixels
        # bridge); blobs (kits, the ball, a crowd seen through) are dropped. One
        # compiled pass, which also draws the line mask and maps the points to the frame
        raw = g.raw
        lm = self._linemask_small
        A = self.A_wf
        sel, labels, line_points = settle_points(
            pts, np.ascontiguousarray(nrm, np.float64), 0.5 * kf + 4.0, raw, raw.shape[1] / w, raw.shape[0] / h,
            wc / w, hc / h, self._chain_grid, float(max(5, 0.008 * wc)), lm, A[0, 0], A[0, 2], A[1, 1], A[1, 2],
        )  # fmt: skip
        if len(sel) < len(pts):
            pts, nrm = pts[sel], nrm[sel]
        t2 = time.perf_counter()
        timings["line_pixels"] = 1e3 * (t2 - t1)
        # lazy: a private copy of the pitch mask (it may run after the next frame's
        # process(), on another thread) and a scratch buffer of its own, made only if it runs
        filled = g.filled.copy() if lazy else g.filled

        def structure():
            scratch = np.full_like(self._scratch, -1) if lazy else self._scratch
            return self._structure(pts, nrm, labels, line_points, filled, scratch, timings)

        det = Detections(
            self.width,
            self.height,
            len(pts) >= 30 or g.fraction >= 2 * self.min_grass,
            g.filled,
            self._grass_full,
            lm,
            self._line_full,
            line_points,
            nrm,
            timings=timings,
            scale=self.factor,
            structure=structure,
            graphics_small=None if g.graphics is None else (g.graphics.copy() if lazy else g.graphics),
        )
        if not lazy:
            det.resolve()
        return det

    def _structure(self, pts, nrm, labels, line_points, gf, scratch, timings) -> tuple[list, list]:
        """Straight lines and ellipses from the line points (working pixels ``pts``,
        normals ``nrm``, chain ``labels``; frame pixels ``line_points``), given the
        tiny pitch mask ``gf`` and a working-size int32 scratch grid (-1)."""
        w, h = self.work_size
        t2 = time.perf_counter()
        groups, used = group_lines(
            pts, nrm, (w, h), labels=labels, min_length=self.min_line_length / self.factor, max_gap=max(16.0, 0.2 * w), min_points=12,
            source=(self.factor / self.enlarged[0], self.factor / self.enlarged[1]),
        )
        # each group's total-least-squares line in frame pixels (geometry.lines.fit_line
        # of each, in one compiled pass)
        lines = []
        if groups:
            offsets = np.zeros(len(groups) + 1, np.int64)
            np.cumsum([len(g.idx) for g in groups], out=offsets[1:])
            L, rms, sig_n, sig_a, ends, length = fit_lines(line_points, np.concatenate([g.idx for g in groups]), offsets)
            fitted = np.isfinite(L[:, 0])  # (a group's points never coincide: it spans min_line_length)
            if not fitted.all():
                groups = [g for g, ok in zip(groups, fitted) if ok]
                L, rms, sig_n, sig_a, ends, length = L[fitted], rms[fitted], sig_n[fitted], sig_a[fitted], ends[fitted], length[fitted]
            for k, grp in enumerate(groups):
                P = line_points[grp.idx]
                lines.append(
                    DetectedLine(
                        line=L[k], endpoints=P[ends[k]], points=P, length=float(length[k]), normal_sigma=float(sig_n[k]), angle_sigma=float(sig_a[k]), rms=float(rms[k])
                    )
                )
        t3 = time.perf_counter()
        # short lines may be flat stretches of a big ellipse: their points stay
        # available to the ellipse search, which has the last word on them
        pool = ~used
        group = np.full(len(pts), -1, np.int32)
        long_len = 0.3 * w
        for k, grp in enumerate(groups):
            if grp.t1 - grp.t0 < long_len:
                pool[grp.idx] = True
                group[grp.idx] = k
        free = np.flatnonzero(pool)
        seed = ~used[free]
        th_, tw_ = gf.shape
        fx, fy = tw_ / self.width, th_ / self.height
        W, H = self.width, self.height

        def visible(p):
            """Frame pixels (N, 2) where a marking could be seen: in the frame, on the pitch."""
            return mask_at(np.ascontiguousarray(p, np.float64), gf, fx, fy, float(W - 1), float(H - 1))

        L = np.array([dl.line for dl in lines[:12]]).reshape(-1, 3)

        def is_arc(e, P):
            return _cut_by_line(e, P, L)

        cands = find_ellipses(
            pts[free],
            nrm[free],
            (w, h),
            self.A_wf,
            full_size=(W, H),
            visible=visible,
            is_arc=is_arc,
            grid_buf=scratch,
            pts_full=line_points[free],
            seed=seed,
            group=group[free],
            max_ellipses=self.max_ellipses,
            prior=self._prev_conics,
        )
        self._prev_conics = [c.conic for c in cands]
        ellipses = [
            DetectedEllipse(ellipse=c.ellipse, conic=c.conic, points=line_points[free[c.idx]], rms=c.rms, coverage=c.coverage, score=c.score, kind=c.kind)
            for c in cands
        ]
        ellipses.sort(key=lambda e: (e.kind != "circle", -e.score))
        if ellipses:
            taken = np.zeros(len(pts), bool)
            for c in cands:
                taken[free[c.idx]] = True
            keep = []
            for grp, dl in zip(groups, lines):
                if grp.t1 - grp.t0 < long_len and np.count_nonzero(taken[grp.idx]) > 0.3 * len(grp.idx):
                    continue  # a piece of an ellipse
                keep.append(dl)
            lines = keep
        t4 = time.perf_counter()
        timings.update(lines=1e3 * (t3 - t2), ellipses=1e3 * (t4 - t3))
        return lines, ellipses

def _cut_by_line(e, P: np.ndarray, L: np.ndarray) -> bool:
    """Whether a straight line (a row of ``L`` (K, 3), unit normals) cuts the
    ellipse with all the support ``P`` (N, 2) on its side away from the
    ellipse's centre: a penalty arc beyond the penalty area's front line (the
    halfway line, through the centre circle's middle, is no such line).
    One compiled loop (:func:`arstream.detect.kernels.points.cut_by_line`)."""
    if not len(L):
        return False
    (cx, cy), (a, b) = e.center, e.axes
    return bool(cut_by_line(np.ascontiguousarray(P, np.float64), L, cx, cy, a, b, e.angle, 0.95))


def detect(image: np.ndarray, **options) -> Detections:
    """One-shot detection of one BGR uint8 (H, W, 3) frame (a fresh :class:`Detector`:
    no adaptation across frames). ``options`` as for :class:`Detector`;
    ``shade`` is on unless given (a still's lines in a stand's shadow are
    asked their own grass's contrast)."""
    options.setdefault("shade", True)
    if not isinstance(image, np.ndarray) or image.ndim != 3 or image.shape[-1] != 3 or image.dtype != np.uint8:
        raise ValueError(
            f"image must be a BGR uint8 array (H, W, 3), got {getattr(image, 'dtype', type(image).__name__)} {getattr(image, 'shape', '')}"
        )
    return Detector(image.shape[1], image.shape[0], **options).process(image)
