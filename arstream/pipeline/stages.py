"""The pipeline's stages: detection (with the analysis frame it works on),
tracking, the grass matte, cameras read from and written to ``cameras.jsonl``,
and rendering (draw, key, composite; the keys and the compositing themselves
are :mod:`render`'s). The encoder's stage is :mod:`arstream.pipeline.encode`.
"""

from __future__ import annotations

import collections
import importlib
import importlib.util
import math
import os
from typing import Callable, Iterable

import cv2
import numpy as np

from arstream.errors import ArstreamError, InputError
from arstream.estimate import CameraEstimate
from arstream.imaging import grey_thumbnail, scale_to
from arstream.pipeline.stage import Item, Stage, _matte_of
from arstream.sink import JsonlWriter
from arstream.source import Frame, i420_planes
from arstream.support import frame_mask, line_support, marking_points
from render.compositor import composite_i420
from render.keying import GrassKeyI420

__all__ = [
    "Analysis",
    "DetectStage",
    "MatteStage",
    "TrackStage",
    "SizeWatchStage",
    "CamerasInStage",
    "RenderStage",
    "CamerasOutStage",
    "load_scene_arg",
    "DEFAULT_ANALYSIS_WIDTH",
]

#: Default width (pixels) of the frames detection and tracking work on (see :class:`Analysis`).
DEFAULT_ANALYSIS_WIDTH = 640

def _optional(module: str, attr: str):
    """``module.attr`` if the module exists, else None (errors inside it propagate)."""
    if importlib.util.find_spec(module) is None:
        return None
    return getattr(importlib.import_module(module), attr, None)


#: the least reduction worth making: a frame of square pixels less than this
#: many times the analysis width (e.g. 854 x 480 for 640) is analysed at its
#: own size (frames of other pixels are resampled to square ones anyway). Scaling
#: it by 0.75 saves little and smears its one- or two-pixel painted lines
#: (israel_league_wide at 854 x 480: 34 % of frames with a camera scaled, 97 %
#: at its own size), and the line-support test's 2 frame pixels would be 1.5
#: analysis pixels, which the tracker can only round (2.7 or 1.3 frame pixels)
MIN_REDUCTION = 1.5
#: the most reduction made: a frame more than this many times the analysis
#: width is analysed at 1 / MAX_REDUCTION of its size (1920 x 1080 at 960 x
#: 540 for 640). The line-support test's 2 frame pixels are then at least
#: one analysis pixel, and the camera is solved to a frame pixel or two:
#: israel_league_wide scaled to 1920 x 1080 analysed at 640 x 360 had 14
#: frames drawn that the frame's own test puts below 0.5 (3 frame pixels a
#: pixel of the tracker's test), at 960 x 540 one at 0.50, and fewer lost
MAX_REDUCTION = 2.0


class Analysis:
    """The frame size detection and tracking work at, and the map back to frame pixels.

    Broadcast frames carry far more pixels than the camera needs: detecting
    and solving on a frame scaled to ``analysis_width`` pixels wide costs a
    fraction of full resolution, and the solved camera is mapped back exactly
    (``K_frame = S K_analysis``; R, t and the distortion, which lives in
    normalised coordinates, are unchanged). Pixel centres are at integer
    coordinates in both (DESIGN.md section 2), so analysis pixel ``u`` is
    frame pixel ``sx u + (sx - 1) / 2``.

    The scaled frame comes straight from the decoder's I420 planes (luma and
    chroma resized on their own, one colour conversion at the small size):
    the full-size BGR frame is never made on this path. :meth:`prepare` makes
    it, on whichever thread calls it: :func:`process` calls it on the decode
    thread, just after the frame was copied out of the decoder (its planes
    are still in that core's cache).

    Parameters
    ----------
    width, height : frame size
    analysis_width : int or None; None or >= width: full resolution. Rounded
        to even; the height keeps the aspect ratio (even too). A frame of
        square pixels less than :data:`MIN_REDUCTION` times as wide is
        analysed at its own size, and one more than :data:`MAX_REDUCTION`
        times as wide at 1 / MAX_REDUCTION of it.
    pixel_aspect : float, a frame pixel's width over its height (1: square;
        an anamorphic SD stream's sample aspect ratio, or frames resized from
        another shape). The analysis frame has square pixels: its width is
        the frame's displayed width ``width * pixel_aspect`` (at most
        ``analysis_width``), so the solver's square-pixel camera maps back to
        a frame camera whose ``K[1, 1] / K[0, 0]`` is the pixel aspect.
    area : ``(x0, y0, x1, y1)`` frame pixels (end exclusive) or None: the
        picture inside black bars (:func:`arstream.imaging.active_area`). The
        analysis frame is then that picture only (a bar's edge is a bright
        step the line finders take for a marking), at the same scale; the solver's
        principal point is the frame's centre (:attr:`principal_point`), and
        masks for keying are put back in the whole frame (:meth:`embed`).
    """

    def __init__(self, width: int, height: int, analysis_width: int | None = None, *, pixel_aspect: float = 1.0, area=None):
        self.W, self.H = int(width), int(height)
        if not (np.isfinite(pixel_aspect) and 0.1 <= pixel_aspect <= 10.0):
            raise ValueError(f"pixel aspect must be between 0.1 and 10, got {pixel_aspect}")
        self.pixel_aspect = float(pixel_aspect)
        shown = self.W * self.pixel_aspect  # the displayed width, in pixels of the frame's height
        if self.pixel_aspect == 1.0 and analysis_width is not None and 0 < analysis_width and width < MIN_REDUCTION * analysis_width:
            analysis_width = None  # (a low-resolution frame: its own size, see MIN_REDUCTION)
        elif analysis_width is not None and 0 < analysis_width < shown / MAX_REDUCTION:
            analysis_width = int(math.ceil(shown / MAX_REDUCTION))  # (see MAX_REDUCTION)
        if self.pixel_aspect == 1.0 and (analysis_width is None or analysis_width <= 0 or analysis_width >= width):
            w, h = self.W, self.H
        else:
            target = shown if analysis_width is None or analysis_width <= 0 else min(float(analysis_width), shown)
            w = max(16, int(round(target / 2.0)) * 2)
            h = max(16, int(round(self.H * w / shown / 2.0)) * 2)
        #: the whole frame's size at the analysis scale
        self.scaled = (w, h)
        self.scaling = (w, h) != (self.W, self.H)
        self.sx, self.sy = self.W / w, self.H / h
        #: the picture's box in the scaled frame (analysis pixels, end exclusive)
        self.crop = self._crop(area, w, h)
        self.w, self.h = self.crop[2] - self.crop[0], self.crop[3] - self.crop[1]
        self.cropped = (self.w, self.h) != (w, h)
        self.full = not self.scaling and not self.cropped
        #: (3, 3) analysis pixels -> frame pixels
        self.S = np.array([[self.sx, 0.0, (self.sx - 1) / 2 + self.sx * self.crop[0]], [0.0, self.sy, (self.sy - 1) / 2 + self.sy * self.crop[1]], [0.0, 0.0, 1.0]])

    def _crop(self, area, w: int, h: int) -> tuple[int, int, int, int]:
        """The box of the analysis frame in the scaled frame: the whole, or the
        picture of ``area`` (frame pixels), its corners inward on even pixels
        (whole pixels of the half-size chroma planes)."""
        if area is None:
            return 0, 0, w, h
        x0, y0, x1, y1 = (float(v) for v in area)
        if not (0 <= x0 < x1 <= self.W and 0 <= y0 < y1 <= self.H):
            raise ValueError(f"picture area must lie in the {self.W} x {self.H} frame, got {tuple(area)}")
        if (x0, y0, x1, y1) == (0, 0, self.W, self.H):
            return 0, 0, w, h
        # (no margin: the detectors leave out the frame's border themselves, and
        # 2 frame pixels more cost the long-lens views of bench/real_bars.py
        # accuracy: 51 -> 37 of 84 reference frames within 5 px)
        ax0 = 2 * math.ceil(x0 / self.sx / 2)
        ay0 = 2 * math.ceil(y0 / self.sy / 2)
        ax1 = w if x1 == self.W else 2 * math.floor(x1 / self.sx / 2)
        ay1 = h if y1 == self.H else 2 * math.floor(y1 / self.sy / 2)
        if ax1 - ax0 < w // 4 or ay1 - ay0 < h // 4:
            return 0, 0, w, h  # (a sliver: not a picture worth analysing alone)
        return ax0, ay0, ax1, ay1

    @property
    def picture(self) -> list | None:
        """``[x0, y0, x1, y1]`` frame pixels (end exclusive) the analysis frame
        covers when it is a picture inside black bars, else None."""
        if not self.cropped:
            return None
        x0, y0, x1, y1 = self.crop
        return [round(x0 * self.sx), round(y0 * self.sy), round(x1 * self.sx), round(y1 * self.sy)]

    @property
    def enlarged(self) -> tuple[float, float]:
        """(ex, ey) analysis pixels per frame pixel along x and y where the
        analysis frame is the frame enlarged (above 1; 1 where shrunk or kept):
        the detector's ``enlarged`` (an anamorphic SD still, 720 x 576 at pixel
        aspect 64:45, is analysed at 1024 x 576: (1.42, 1)).

        >>> Analysis(720, 576, None, pixel_aspect=64 / 45).enlarged
        (1.4222222222222223, 1.0)
        >>> Analysis(1280, 720, 640).enlarged
        (1.0, 1.0)
        """
        return (max(1.0, 1.0 / self.sx), max(1.0, 1.0 / self.sy))

    @property
    def principal_point(self) -> np.ndarray:
        """(2,) the frame's centre in analysis pixels: the solver's principal point."""
        return np.linalg.solve(self.S, [(self.W - 1) / 2, (self.H - 1) / 2, 1.0])[:2]

    def embed(self, mask):
        """A mask of the analysis frame (at its size or a whole fraction of it)
        put back in the whole frame at that scale, zero over the bars; as it
        is without a crop."""
        if mask is None or not self.cropped:
            return mask
        k = self.w / mask.shape[1]
        out = np.zeros((int(round(self.scaled[1] / k)), int(round(self.scaled[0] / k))) + mask.shape[2:], mask.dtype)
        x, y = int(round(self.crop[0] / k)), int(round(self.crop[1] / k))
        h, w = min(mask.shape[0], out.shape[0] - y), min(mask.shape[1], out.shape[1] - x)
        out[y : y + h, x : x + w] = mask[:h, :w]
        return out

    @property
    def support_reach(self) -> int:
        """The line-support test's 2 px of the frame (docs/evaluate.md) in analysis
        pixels: the nearest whole number, a tie to the narrower (1.5 analysis
        px: 2 would judge by 2.7 px of the frame, and drew frames the frame's
        own test puts below 0.5)."""
        return max(1, math.ceil(2.0 / min(self.sx, self.sy) - 0.5))

    def prepare(self, frame: Frame) -> dict:
        """The :class:`Item` fields made from ``frame`` for detection and tracking:
        ``analysis`` (BGR (h, w, 3) at the analysis size) and, from an I420
        frame, ``thumbnail`` (the tracker's, from the scaled luma). Empty at full
        resolution (the frame itself is the analysis image)."""
        if self.full:
            return {}
        (w, h), (x0, y0, x1, y1) = self.scaled, self.crop
        if not self.scaling:
            return {"analysis": np.ascontiguousarray(frame.image[y0:y1, x0:x1])}
        if frame.yuv is not None and not frame.has_image:
            buf = np.empty((h * 3 // 2, w), np.uint8)
            src, dst = i420_planes(frame.yuv, frame.width, frame.height), i420_planes(buf, w, h)
            scale_to(src[0], (w, h), dst=dst[0])
            for k in (1, 2):
                scale_to(src[k], (w // 2, h // 2), dst=dst[k])
            if self.cropped:
                buf = np.concatenate([dst[0][y0:y1, x0:x1].ravel()] + [p[y0 // 2 : y1 // 2, x0 // 2 : x1 // 2].ravel() for p in dst[1:]]).reshape(-1, x1 - x0)
                dst = i420_planes(buf, x1 - x0, y1 - y0)
            return {"analysis": cv2.cvtColor(buf, cv2.COLOR_YUV2BGR_I420), "thumbnail": grey_thumbnail(dst[0], video_range=True)}
        img = scale_to(frame.image, (w, h))
        return {"analysis": np.ascontiguousarray(img[y0:y1, x0:x1]) if self.cropped else img}

    def image(self, item: Item) -> np.ndarray:
        """BGR (h, w, 3) of the item's frame at the analysis size (cached on the
        item, with its thumbnail: :meth:`prepare`, unless that ran already)."""
        if self.full:
            return item.frame.image
        if item.analysis is None:
            for k, v in self.prepare(item.frame).items():
                setattr(item, k, v)
        return item.analysis

    def camera(self, cam):
        """The camera of the full frame from the camera of the analysis image."""
        if self.full or cam is None:
            return cam
        from geometry.camera import Camera

        return Camera(K=self.S @ cam.K, R=cam.R, t=cam.t, dist=cam.dist)

    def points(self, pts) -> np.ndarray:
        """(N, 2) analysis pixels -> frame pixels."""
        pts = np.asarray(pts, dtype=np.float64)
        if self.full:
            return pts
        return pts * (self.sx, self.sy) + self.S[:2, 2]

    def ellipse(self, ell):
        """A geometry.conics.Ellipse in analysis pixels -> frame pixels (exact for sx == sy)."""
        if self.full or ell is None:
            return ell
        from geometry.conics import ellipse_from_conic

        Sinv = np.linalg.inv(self.S)
        return ellipse_from_conic(Sinv.T @ ell.conic @ Sinv)


class DetectStage(Stage):
    """Pitch markings and the grass matte: :class:`arstream.detect.Detector`,
    on the frame at the analysis size (see :class:`Analysis`).

    Without a detector module every item passes with ``detections=None``
    (``available`` is False). ``item.matte`` is the detector's grass mask, at
    the analysis size (the render stage scales it up). A ``detector`` given
    instead has the same ``process(image, lazy=True)`` contract. ``hints``: a
    callable giving the tracker's hints as of a frame (keyword arguments of
    :meth:`arstream.detect.Detector.process`: ``motion``, the sideways image
    motion, and ``line_width``, the widest painted line, analysis pixels),
    passed on to the detector as of two frames back (it skips the search for
    lines smeared by a fast pan when the image moves slowly, and the coarse
    pass for wide lines when the lines are thin too).
    """

    name = "detect"

    def __init__(self, width: int, height: int, detector=None, *, analysis: Analysis | None = None, hints=None):
        self.analysis = analysis or Analysis(width, height)
        self.hints = hints  # (frame) -> dict of the detector's hints as of then
        if detector is None:
            cls = _optional("arstream.detect", "Detector")
            detector = cls(self.analysis.w, self.analysis.h, enlarged=self.analysis.enlarged) if cls is not None else None
        self.detector = detector
        self.available = detector is not None

    def process(self, item: Item) -> list[Item]:
        if self.detector is not None:
            # lines and ellipses on demand: a tracker following a locked camera
            # needs only the line points (re-initialisation asks for the rest)
            # as of two frames back: what a tracker one frame behind (the detector on
            # its own thread) has surely solved, so threaded or not, the same hint
            hint = {} if self.hints is None else self.hints(item.index - 2)
            det = self.detector.process(self.analysis.image(item), lazy=True, **hint)
            item.detections = det
            item.matte = _matte_of(det)
            if self.analysis.cropped:  # (the render stage keys the whole frame: new arrays, the item's own)
                item.matte = self.analysis.embed(item.matte)
                item.lines = self.analysis.embed(getattr(det, "line_small", None))
        return [item]

class MatteStage(Stage):
    """A grass matte from a function of the BGR frame (e.g. ``render.keying.green_matte``),
    for keying without the detector.

    Parameters
    ----------
    fn : callable(image_bgr) -> (H, W) uint8 matte, 255 = grass
    """

    name = "key"

    def __init__(self, fn: Callable[[np.ndarray], np.ndarray]):
        self.fn = fn

    def process(self, item: Item) -> list[Item]:
        item.matte = self.fn(item.frame.image)
        return [item]

    @classmethod
    def green(cls, width: int, height: int) -> "MatteStage":
        """Chroma key on the grass hue (``render.keying.green_matte``), into a reused buffer."""
        from render.keying import green_matte

        buf = np.empty((height, width), np.uint8)
        return cls(lambda image: green_matte(image, out=buf))


#: every how many frames :class:`TrackStage` measures a frame's line support
#: for :attr:`TrackStage.supports` (about 4 ms at 720p: 0.8 ms a frame)
JUDGE_EVERY = 5

#: a camera the tracker judged (at the analysis size, on white paint) at a
#: line support below this is judged again by :class:`TrackStage` on the
#: whole frame, as ``arstream eval`` does (docs/evaluate.md) ...
RECHECK_BELOW = 0.75
#: ... and not drawn (reported "lost") below this line support there: issue
#: 29's "no frame drawn with line support < 0.5". The analysis size's coarser
#: mask backs a camera a few pixels off more than the frame's own (a
#: re-encoded copy's frame 101: 0.62 there, 0.33 on the frame)
MIN_DRAWN_SUPPORT = 0.5


class TrackStage(Stage):
    """Camera of every frame: :class:`arstream.track.Tracker`.

    ``lag=0`` (live, causal): one estimate per call, for this frame.
    ``lag>0`` (offline): a fixed-lag smoother; the stage holds the items
    whose estimates are not final yet (at most ``lag`` plus a small margin),
    keeping only what rendering needs (the frame and a copy of the grass
    matte). Without a tracker module every frame is "lost". ``pitch``,
    ``estimate_pitch``, ``watch_pitch``: the tracker's (``pitch="auto"``:
    105 x 68 m with the size estimated).
    """

    name = "track"

    def __init__(self, width: int, height: int, *, fps: float = 25.0, lag: int = 0, tracker=None, enabled: bool = True, analysis: Analysis | None = None, pitch=None, estimate_pitch: bool = False, watch_pitch: bool = False):
        self.analysis = analysis or Analysis(width, height)
        if tracker is None and enabled:
            cls = _optional("arstream.track", "Tracker")
            auto = isinstance(pitch, str) and pitch == "auto"
            tracker = cls(self.analysis.w, self.analysis.h, fps=fps, lag=lag, principal_point=self.analysis.principal_point, support_reach=self.analysis.support_reach, pitch=None if auto else pitch, estimate_pitch=auto or estimate_pitch, watch_pitch=watch_pitch) if cls is not None else None
        self.tracker = tracker
        #: the line support (docs/evaluate.md, on the frame at its own size) of
        #: every :data:`JUDGE_EVERY`-th frame released, None where it had no
        #: camera: what :func:`arstream.pipeline.process` decides by whether the
        #: pitch's size fits the clip (the tracker's own test works at the
        #: analysis size and on white paint, and tells sizes apart less well)
        self.supports: list = []
        self.available = tracker is not None
        self.lag = int(lag)
        self.max_held = getattr(tracker, "holds", self.lag) + 8
        self.held: collections.OrderedDict[int, Item] = collections.OrderedDict()

    def process(self, item: Item) -> list[Item]:
        if self.tracker is None:
            item.estimate = CameraEstimate.lost(item.index, item.pts, reason="no tracker")
            return [item]
        image = self.analysis.image(item)  # (first: it may make the thumbnail)
        estimates = self.tracker.process(item.index, item.pts, image, item.detections, thumbnail=item.thumbnail)
        self.held[item.index] = item
        out = self._release(estimates)
        if item.index in self.held:  # waits for a later estimate: keep only what rendering needs
            if item.matte is not None and not item.owned:
                item.matte = item.matte.copy()  # the detector reuses its buffers
            det = item.detections
            if det is not None and item.lines is None and getattr(det, "line_small", None) is not None:
                item.lines = det.line_small if item.owned else det.line_small.copy()
            item.detections = None
            item.analysis = item.thumbnail = None
            if item.frame.yuv is not None:
                item.frame._image = None  # the BGR copy is rebuilt if anyone asks
            if len(self.held) > self.max_held:
                raise ArstreamError(f"the tracker has held {len(self.held)} frames without an estimate (lag {self.lag}); this is a bug in arstream.track")
        return out

    def _release(self, estimates: Iterable[CameraEstimate]) -> list[Item]:
        out = []
        for est in estimates:
            it = self.held.pop(est.frame, None)
            if it is None:
                raise ArstreamError(f"the tracker returned an estimate for frame {est.frame}, which is not waiting; this is a bug in arstream.track")
            if est.camera is not None and not self.analysis.full:
                est = CameraEstimate(est.frame, est.pts, est.status, self.analysis.camera(est.camera), est.confidence, est.info)
            mask = None
            judged = est.info.get("support") if est.camera is not None else None
            if est.camera is not None and (judged is None or judged < RECHECK_BELOW):
                mask = frame_mask(it.frame)
                share = line_support(est.camera, mask, marking_points(self.tracker.pitch)).share
                if share is not None and share < MIN_DRAWN_SUPPORT:
                    est = CameraEstimate.lost(est.frame, est.pts, reason=f"unsupported camera (line support {share:.2f} on the whole frame)")
            it.estimate = est
            it.pitch = self.tracker.pitch
            if est.frame % JUDGE_EVERY == 0:
                self.supports.append(None if est.camera is None else line_support(est.camera, frame_mask(it.frame) if mask is None else mask, marking_points(self.tracker.pitch)).share)
            out.append(it)
        return out

    def flush(self) -> list[Item]:
        if self.tracker is None:
            return []
        out = self._release(self.tracker.flush())
        for it in self.held.values():  # no estimate came: an honest "lost"
            it.estimate = CameraEstimate.lost(it.index, it.pts, reason="no estimate at flush")
            out.append(it)
        self.held.clear()
        out.sort(key=lambda it: it.index)
        return out


class SizeWatchStage(Stage):
    """Live: whether the frames' paint backs the pitch size tracked with, said once.

    :func:`arstream.pipeline.process` runs a clip whose markings fit the
    default 105 x 68 m poorly again at other sizes
    (:mod:`arstream.pipeline.pitch_scan`); a live source cannot be run
    twice, and on a pitch of another size its cameras lay the markings
    metres off (``artificial_turf_multisport``, about 100 x 67 m, streamed
    at 105 x 68: its reference frames 8-70 px off, each drawn). This stage
    applies the rule by which ``process`` asks for a scan
    (:func:`arstream.pitch_size.needs_scan` on :attr:`TrackStage.supports`:
    their median below :data:`arstream.pitch_size.SCAN_BELOW`, with at
    least :data:`arstream.pitch_size.SCAN_MIN_FRAMES` judged frames with a
    camera) once, over the scan's window of the stream's first frames (or
    the whole stream, if shorter: ``process`` judges its whole first run,
    and a long lens's opening may score lower than the rest), and where it
    holds calls ``report`` with :meth:`message`. Frames pass unchanged.

    Parameters
    ----------
    track : the run's TrackStage (its ``supports`` are read)
    report : callable(str), e.g. a warning on stderr
    window : judged frames watched (the scan's frames over :data:`JUDGE_EVERY`)
    """

    name = "size-watch"

    def __init__(self, track: "TrackStage", report: Callable[[str], None], *, window: int):
        self.track = track
        self.report = report
        self.window = int(window)
        #: the median line support when the fit was found poor, else None
        self.median: float | None = None
        #: judged frames with a camera behind :attr:`median`
        self.judged = 0
        self.done = False

    def process(self, item: Item) -> list[Item]:
        if not self.done and len(self.track.supports) >= self.window:
            self._judge()
        return [item]

    def flush(self) -> list[Item]:
        if not self.done:
            self._judge()
        return []

    def _judge(self) -> None:
        from arstream.pitch_size import _median, needs_scan

        self.done = True
        supports = self.track.supports[: self.window]
        if needs_scan(supports):
            self.median, self.judged = _median(supports, 1), sum(v is not None for v in supports)
            self.report(self.message())

    def message(self) -> str:
        """What the operator is told (after the fit was found poor)."""
        from arstream.pitch_size import SCAN_BELOW

        pitch = self.track.tracker.pitch if self.track.tracker is not None else None
        size = f"{pitch.length:g} x {pitch.width:g} m" if pitch is not None else "the default size"
        return (
            f"the pitch's markings fit {size} poorly (median line support {self.median:.2f} over {self.judged} judged frames, below {SCAN_BELOW:g}): "
            "graphics may be drawn metres off. A live run does not estimate the size; give it with --pitch LxW "
            "(arstream process on a recording from this venue estimates it)"
        )


class CamerasInStage(Stage):
    """Estimates read from a ``cameras.jsonl`` (instead of detect + track).

    The file is read line by line alongside the video; frames without a record
    are "lost". Used by :func:`render_clip` (``arstream render``).
    :attr:`pitch`: the size its first record with a ``pitch`` entry says its
    camera was made at (docs/formats.md; ``arstream process`` writes it), the
    size a scene without a ``[pitch]`` table is drawn on; None without one.
    """

    name = "cameras"

    def __init__(self, path):
        import json

        from geometry.camera import Camera

        self._json, self._Camera = json, Camera
        self.path = os.fspath(path)
        if not os.path.exists(self.path):
            raise InputError(f"cameras file not found: {self.path}")
        self.f = open(self.path, encoding="utf-8")
        self.line = 0
        self.pitch = None
        while True:  # (a first pass to the first record that says its size)
            rec = self._read()
            if rec is None or isinstance(rec, dict) and rec.get("pitch") is not None:
                break
        if rec is not None:
            from arstream.evaluate import record_pitches

            self.pitch = next(iter(record_pitches([rec], self.path).values()), None)
        self.f.seek(0)
        self.line = 0
        self.next_rec = self._read()

    def _read(self):
        for line in self.f:
            self.line += 1
            if line.strip():
                try:
                    return self._json.loads(line)
                except ValueError as exc:
                    raise InputError(f"{self.path}:{self.line}: not valid JSON ({exc})") from None
        return None

    def process(self, item: Item) -> list[Item]:
        while self.next_rec is not None and int(self.next_rec.get("frame", -1)) < item.index:
            self.next_rec = self._read()
        rec = self.next_rec
        if rec is not None and int(rec.get("frame", -1)) == item.index and rec.get("K") is not None:
            try:
                cam = self._Camera.from_dict(rec)
            except (KeyError, TypeError, ValueError) as exc:
                raise InputError(f"{self.path}:{self.line}: bad camera record ({exc})") from None
            status = rec.get("status", "ok")
            item.estimate = CameraEstimate(item.index, item.pts, status if status != "lost" else "tracked", cam, float(rec.get("confidence", 1.0)))
        else:
            item.estimate = CameraEstimate.lost(item.index, item.pts)
        return [item]

    def close(self) -> None:
        self.f.close()

def load_scene_arg(scene, pitch=None):
    """A :class:`render.Scene` from None (the demo scene), a path, or a Scene;
    ``pitch``: the PitchModel the run solves at (None: 105 x 68 m), which a
    scene without a ``[pitch]`` table, the demo's among them, stands on."""
    import render

    size = None if pitch is None else (pitch.length, pitch.width)
    if scene is None:
        return render.default_scene(size)
    if isinstance(scene, render.Scene):
        return scene
    return render.load_scene(scene, pitch=size)


class RenderStage(Stage):
    """Draw the scene with the frame's camera and composite it, keyed by the grass matte.

    Frames without a camera pass untouched. Raises :class:`ArstreamError`
    naming the fix when no OpenGL context can be made.
    """

    name = "render"

    def __init__(self, width: int, height: int, scene=None, *, renderer=None, fine_key: bool = True, pitch=None):
        from render import GLContextError, Renderer
        from render.kernels import warm_up

        warm_up()  # (numba's set-up, about 0.3 s, before the run rather than in its first frame)
        self.width, self.height = width, height
        self.fine_key = fine_key
        self._fine = None
        self._key_i420: GrassKeyI420 | None = None
        if renderer is None:
            try:
                renderer = Renderer(width, height, load_scene_arg(scene, pitch))
            except GLContextError as exc:
                raise ArstreamError(f"{exc} (or leave out -o to write only cameras.jsonl)") from None
        self.renderer = renderer
        self._matte = None

    def _full_matte(self, matte):
        """The grass matte for the renderer: as it is when it has the frame's size or
        is smaller with its aspect ratio (the renderer stretches it on the GPU),
        else scaled to the frame."""
        if matte is None or matte.shape[:2] == (self.height, self.width) or self.renderer.stretches_matte(matte.shape):
            return matte
        if self._matte is None:
            self._matte = np.empty((self.height, self.width), np.uint8)
        return cv2.resize(matte, (self.width, self.height), dst=self._matte, interpolation=cv2.INTER_LINEAR)

    def _key(self, item: Item):
        """The renderer's grass matte for this frame. With ``fine_key`` and a
        detector's pitch mask: a callable that keys the frame at full resolution
        inside the overlay's rectangles only (render.keying.refine_matte: grass
        colour or a detected line pixel, on the pitch; :class:`GrassKeyI420` on an
        I420 frame), so that players and the ball pass in front of on-grass
        graphics at pixel precision; else the matte as it is (the renderer
        stretches a small one)."""
        matte = item.matte
        if matte is None or not self.fine_key or matte.shape[0] >= self.height:
            return self._full_matte(matte)  # (a full-size matte is already fine)
        f = item.frame
        if self._fine is None:
            self._fine = np.zeros((self.height, self.width), np.uint8)
        lines = item.lines if item.lines is not None else getattr(item.detections, "line_small", None)
        grow = max(1, int(round(3 * self.width / 1280)))  # about half a painted line's width
        if f.yuv is not None:  # the same key, on the I420 planes (compiled)
            if self._key_i420 is None:
                self._key_i420 = GrassKeyI420()
            return lambda rects: self._key_i420(self._fine, f.yuv, f.width, f.height, rects, matte, keep=lines, keep_grow=grow)
        from render.keying import refine_matte

        img = f.image
        return lambda rects: refine_matte(self._fine, rects, lambda r: img[r[1] : r[3], r[0] : r[2]], matte, keep=lines, keep_grow=grow)

    def process(self, item: Item) -> list[Item]:
        cam = item.estimate.camera if item.estimate is not None else None
        if cam is None:
            return [item]
        ov = self.renderer.render(cam, grass_matte=self._key(item))
        if ov.empty:
            return [item]
        f = item.frame
        if f.yuv is not None:
            composite_i420(f.yuv, f.width, f.height, ov.bgra, ov.rects)
            f._image = None  # the BGR copy (if any) shows the input, not the output
        else:
            self.renderer.compositor.composite(f.image, ov)
        item.drawn = True
        return [item]

    def close(self) -> None:
        self.renderer.release()

class CamerasOutStage(Stage):
    """Write each frame's estimate to ``cameras.jsonl`` (complete lines, flushed
    per frame). A record with a camera carries the pitch's size it was solved
    at (``"pitch": {"length", "width"}`` in metres, :attr:`Item.pitch`; given,
    105 x 68, or the size the run found), so that ``arstream eval --video``
    judges it on its own pitch's markings without being told the size."""

    name = "cameras"

    def __init__(self, path):
        self.writer = JsonlWriter(path)
        self.path = self.writer.path

    def process(self, item: Item) -> list[Item]:
        rec = item.estimate.to_record()
        if rec["K"] is not None and item.pitch is not None:
            rec["pitch"] = {"length": round(float(item.pitch.length), 3), "width": round(float(item.pitch.width), 3)}
        self.writer.write(rec)
        return [item]

    def close(self) -> None:
        self.writer.close()
