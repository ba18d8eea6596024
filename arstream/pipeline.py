"""The streaming pipeline: decode -> detect -> track -> render -> encode.

Stages
------
A stage is a small object with one contract (:class:`Stage`)::

    process(item: Item) -> list[Item]   # the items that are now ready, in order
    flush() -> list[Item]               # at the end of the input: whatever it still holds
    close() -> None                     # release resources / finalise outputs

Most stages return ``[item]``. The tracker stage of the offline pipeline
holds up to ``lag`` items (a fixed-lag smoother emits each camera ``lag``
frames late) and returns them when their estimates are final; nothing else
buffers, so memory is flat in clip length.

Threads
-------
``decode thread -> bounded queue -> main thread (the stages) -> bounded queue -> encode thread``.
PyAV releases the GIL while FFmpeg decodes and x264 encodes, so decode and
encode overlap with the Python/OpenCV/GL work of the main thread and both
cores are used. Audio packets of the input are demuxed by the decode thread
and handed, in order, to the encode thread, which muxes them unchanged.
These threads are the pipeline's parallelism: while it runs, OpenCV and the
BLAS behind numpy and scipy work on one thread each (``Pipeline(pool_threads=1)``)
and Mesa's llvmpipe draws on the main thread (:mod:`render.context`), rather
than handing small jobs to pools of their own that would compete for the
same two cores.

Fast path (DESIGN.md section 4): frames of even size stay planar YUV 4:2:0
from decoder to encoder. BGR is made once, lazily, for the stages that ask
for ``frame.image`` (detection); the overlay is composited straight into the
Y, U and V planes, only inside the renderer's rectangles
(:func:`composite_i420`); the encoder gets the I420 buffer as is.

Interruption
------------
While :meth:`Pipeline.run` runs (in the main thread), SIGINT and SIGTERM stop
it gracefully between frames: the frames the tracker holds are flushed,
the encoder is drained, the container trailer written and ``cameras.jsonl``
closed, then :class:`Interrupted` (a ``KeyboardInterrupt``) is raised with the
signal number and the :class:`Summary`. A second signal skips the flush
(outputs are still closed; signals during the closing itself are ignored).

Live mode (``realtime=True``): the decode thread paces the source to its
clock (a file, or a network stream delivered faster than real time; a stall
re-anchors the clock); the queue to the main thread holds at most one
frame and a frame older than two frame intervals when its turn comes is
dropped (counted in ``Summary.dropped``), so the pipeline adds at most about
two frames of latency and never falls behind.
"""

from __future__ import annotations

import collections
import contextlib
import importlib
import importlib.util
import os
import signal
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import Callable, Iterable

import cv2
import numpy as np

from arstream.errors import ArstreamError, InputError
from arstream.estimate import CameraEstimate
from arstream.imaging import grey_thumbnail, shrink
from arstream.sink import JsonlWriter, VideoSink
from arstream.source import Frame, VideoSource, i420_planes

__all__ = [
    "Item",
    "Stage",
    "Analysis",
    "DetectStage",
    "MatteStage",
    "ThreadedStage",
    "own_detections",
    "TrackStage",
    "CamerasInStage",
    "RenderStage",
    "EncodeStage",
    "CamerasOutStage",
    "Pipeline",
    "Summary",
    "Interrupted",
    "composite_i420",
    "GrassKeyI420",
    "load_scene_arg",
    "process",
    "render_clip",
    "stream",
]

#: Default lag (frames) of the offline smoother.
DEFAULT_LAG = 10

#: Default width (pixels) of the frames detection and tracking work on (see :class:`Analysis`).
DEFAULT_ANALYSIS_WIDTH = 640


# --------------------------------------------------------------------------- items and stages
@dataclass
class Item:
    """One frame travelling through the stages.

    Attributes
    ----------
    frame : Frame (``frame.yuv`` is composited in place by the render stage)
    detections : the detector's result, or None (missing detector, or
        released while the frame waited for its smoothed camera)
    matte : uint8 grass matte (255 = pitch) for keying, at the analysis size or
        smaller (the render stage scales it to the frame)
    lines : uint8 mask of the detected line pixels (small), kept for keying once
        ``detections`` is let go
        (the render stage scales it to the frame), or None
    estimate : CameraEstimate once the tracker has given it
    drawn : True when graphics were composited onto the frame
    timings : stage name -> milliseconds spent on this frame
    cpu : stage name -> CPU milliseconds of the stage's own thread on this frame
    owned : True when ``detections`` and ``matte`` are private copies (not views
        into buffers the detector reuses)
    analysis : the frame at the analysis size (BGR), made once for detection and tracking
    thumbnail : the frame's :func:`arstream.imaging.grey_thumbnail` (the tracker's
        shot-cut test), made with ``analysis`` from the decoder's luma, or None
    """

    frame: Frame
    detections: object | None = None
    matte: np.ndarray | None = None
    lines: np.ndarray | None = None
    estimate: CameraEstimate | None = None
    drawn: bool = False
    timings: dict = field(default_factory=dict)
    cpu: dict = field(default_factory=dict)
    owned: bool = False
    analysis: np.ndarray | None = None
    thumbnail: np.ndarray | None = None

    @property
    def index(self) -> int:
        return self.frame.index

    @property
    def pts(self) -> float:
        return self.frame.pts

    def output_bgr(self) -> np.ndarray:
        """The frame as it is now (composited once the render stage ran), BGR."""
        return self.frame.image


class Stage:
    """Base class of the pipeline's stages (see the module docstring)."""

    name = "stage"

    def process(self, item: Item) -> list[Item]:
        return [item]

    def flush(self) -> list[Item]:
        return []

    def close(self) -> None:
        pass


def _optional(module: str, attr: str):
    """``module.attr`` if the module exists, else None (errors inside it propagate)."""
    if importlib.util.find_spec(module) is None:
        return None
    return getattr(importlib.import_module(module), attr, None)


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
        to even; the height keeps the aspect ratio (even too).
    """

    def __init__(self, width: int, height: int, analysis_width: int | None = None):
        self.W, self.H = int(width), int(height)
        if analysis_width is None or analysis_width <= 0 or analysis_width >= width:
            w, h = self.W, self.H
        else:
            w = max(16, int(round(analysis_width / 2.0)) * 2)
            h = max(16, int(round(self.H * w / self.W / 2.0)) * 2)
        self.w, self.h = w, h
        self.full = (w, h) == (self.W, self.H)
        self.sx, self.sy = self.W / w, self.H / h
        #: (3, 3) analysis pixels -> frame pixels
        self.S = np.array([[self.sx, 0.0, (self.sx - 1) / 2], [0.0, self.sy, (self.sy - 1) / 2], [0.0, 0.0, 1.0]])

    def prepare(self, frame: Frame) -> dict:
        """The :class:`Item` fields made from ``frame`` for detection and tracking:
        ``analysis`` (BGR (h, w, 3) at the analysis size) and, from an I420
        frame, ``thumbnail`` (the tracker's, from the scaled luma). Empty at full
        resolution (the frame itself is the analysis image)."""
        if self.full:
            return {}
        if frame.yuv is not None and not frame.has_image:
            buf = np.empty((self.h * 3 // 2, self.w), np.uint8)
            src, dst = i420_planes(frame.yuv, frame.width, frame.height), i420_planes(buf, self.w, self.h)
            shrink(src[0], (self.w, self.h), dst=dst[0])
            for k in (1, 2):
                shrink(src[k], (self.w // 2, self.h // 2), dst=dst[k])
            return {"analysis": cv2.cvtColor(buf, cv2.COLOR_YUV2BGR_I420), "thumbnail": grey_thumbnail(dst[0], video_range=True)}
        return {"analysis": shrink(frame.image, (self.w, self.h))}

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
        return pts * (self.sx, self.sy) + ((self.sx - 1) / 2, (self.sy - 1) / 2)

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
            detector = cls(self.analysis.w, self.analysis.h) if cls is not None else None
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
        return [item]


def _boxed(box: list, stage):
    """Put ``stage`` in ``box`` (for stages built before it to reach) and return it."""
    box.append(stage)
    return stage


def _hints_of(box: list):
    """The detector's hints from the tracker of the TrackStage in ``box`` (filled
    once it is built): a callable for :class:`DetectStage`, frame -> ``{motion,
    line_width}`` as of that frame (each None where the tracker does not know)."""

    def hints(frame: int) -> dict:
        tracker = box[0].tracker if box else None
        if tracker is None or not hasattr(tracker, "image_motion"):
            return {}
        return {"motion": tracker.image_motion(frame), "line_width": tracker.line_width(frame)}

    return hints


def _matte_of(det) -> np.ndarray | None:
    """The detector's grass mask as a keying matte: the small one when it has one
    (the render stage scales it to the frame once, smoothly), else the full one."""
    small = getattr(det, "grass_small", None)
    return small if small is not None else getattr(det, "grass_mask", None)


def _renice(nice: int) -> None:
    """Add ``nice`` to the calling thread's scheduling niceness (at most 19), on
    Linux, where niceness is per thread (and inherited by the threads it starts,
    such as FFmpeg's decoder threads); elsewhere nothing. Best effort: a hint."""
    if nice and sys.platform.startswith("linux"):
        with contextlib.suppress(OSError):
            tid = threading.get_native_id()
            os.setpriority(os.PRIO_PROCESS, tid, min(19, os.getpriority(os.PRIO_PROCESS, tid) + int(nice)))


def own_detections(item: Item) -> None:
    """Replace the item's detections (and matte) by private deep copies, so the
    detector may reuse its buffers for the next frame while this one is used."""
    import copy

    if item.detections is not None and not item.owned:
        det = item.detections
        item.detections = det.detach() if hasattr(det, "detach") else copy.deepcopy(det)
        item.matte = _matte_of(item.detections)
    elif item.matte is not None and not item.owned:
        item.matte = item.matte.copy()
    item.owned = True


class ThreadedStage(Stage):
    """Run a one-in, one-out stage on a worker thread, one frame ahead.

    ``process(item i)`` hands frame i to the worker and returns frame i-1's
    result, so the main thread works on frame i-1 (tracking, rendering)
    while the worker works on frame i (detection): the two cores both work
    even when the main thread is the slowest part. Adds one frame of latency.
    ``detach`` runs in the worker after the stage (default
    :func:`own_detections`: copy the buffers the detector reuses).
    ``nice`` is added to the worker's scheduling niceness (Linux, where it is
    per thread; 0 elsewhere): a worker that only runs ahead of the main thread
    can leave the cores to the encoder's threads, the offline pipeline's
    bottleneck, whenever both are ready to run (see :data:`WORKER_NICE`).
    """

    self_timed = True

    def __init__(self, stage: Stage, detach: Callable[[Item], None] | None = own_detections, *, nice: int = 0):
        import queue

        self.stage = stage
        self.nice = int(nice)
        self.name = stage.name
        self.available = getattr(stage, "available", True)
        self.detach = detach
        self.inq: queue.Queue = queue.Queue(maxsize=1)
        self.outq: queue.Queue = queue.Queue()
        self.pending = 0
        self.thread = threading.Thread(target=self._run, name=f"arstream-{stage.name}", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        _renice(self.nice)
        while True:
            item = self.inq.get()
            if item is None:
                return
            try:
                t0, c0 = time.perf_counter(), time.thread_time()
                res = self.stage.process(item)
                if len(res) != 1 or res[0] is not item:
                    raise ArstreamError(f"stage {self.name} must return exactly its input item to run on a thread")
                if self.detach is not None:
                    self.detach(item)
                item.timings[self.name] = item.timings.get(self.name, 0.0) + (time.perf_counter() - t0) * 1e3
                item.cpu[self.name] = item.cpu.get(self.name, 0.0) + (time.thread_time() - c0) * 1e3
                self.outq.put((item, None))
            except BaseException as exc:
                self.outq.put((None, exc))

    def _result(self) -> Item:
        item, exc = self.outq.get()
        self.pending -= 1
        if exc is not None:
            raise exc
        return item

    def process(self, item: Item) -> list[Item]:
        if not self.thread.is_alive():
            raise ArstreamError(f"the {self.name} worker thread has stopped")
        self.inq.put(item)
        self.pending += 1
        return [self._result()] if self.pending > 1 else []

    def flush(self) -> list[Item]:
        out = []
        while self.pending > 0:
            out.append(self._result())
        return out + self.stage.flush()

    def close(self) -> None:
        if self.thread.is_alive():
            while True:  # unblock a worker waiting to hand over, then stop it
                try:
                    self.inq.put(None, timeout=0.1)
                    break
                except Exception:
                    if not self.thread.is_alive():
                        break
            self.thread.join(timeout=10.0)
        self.stage.close()


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


class TrackStage(Stage):
    """Camera of every frame: :class:`arstream.track.Tracker`.

    ``lag=0`` (live, causal): one estimate per call, for this frame.
    ``lag>0`` (offline): a fixed-lag smoother; the stage holds the items
    whose estimates are not final yet (at most ``lag`` plus a small margin),
    keeping only what rendering needs (the frame and a copy of the grass
    matte). Without a tracker module every frame is "lost".
    """

    name = "track"

    def __init__(self, width: int, height: int, *, fps: float = 25.0, lag: int = 0, tracker=None, enabled: bool = True, analysis: Analysis | None = None):
        self.analysis = analysis or Analysis(width, height)
        if tracker is None and enabled:
            cls = _optional("arstream.track", "Tracker")
            tracker = cls(self.analysis.w, self.analysis.h, fps=fps, lag=lag) if cls is not None else None
        self.tracker = tracker
        self.available = tracker is not None
        self.lag = int(lag)
        self.max_held = self.lag + 8
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
            if det is not None and getattr(det, "line_small", None) is not None:
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
            it.estimate = est
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


class CamerasInStage(Stage):
    """Estimates read from a ``cameras.jsonl`` (instead of detect + track).

    The file is read line by line alongside the video; frames without a record
    are "lost". Used by :func:`render_clip` (``arstream render``).
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


# BT.601 limited range (FFmpeg's default for untagged video, and OpenCV's I420
# conversions): Y, U, V from B, G, R, with the offsets scaled by alpha, so that
# premultiplied colour maps to premultiplied YUV (all of it within 0..255).
_BGRA_TO_YUV = np.array([[24.966, 128.553, 65.481, 16.0], [112.0, -74.203, -37.797, 128.0], [-18.214, -93.786, 112.0, 128.0]]) / 255.0


def composite_i420(yuv: np.ndarray, width: int, height: int, bgra: np.ndarray, rects) -> None:
    """Premultiplied "over" of a BGRA overlay onto an I420 frame, in place.

    Only the rectangles are touched (aligned outward to even pixels). Inside
    them the overlay is converted to premultiplied YUV (BT.601 limited range);
    chroma uses the 2 x 2 mean of premultiplied colour and of alpha, which is
    what "over" followed by 4:2:0 subsampling gives. One compiled pass
    (:func:`arstream.kernels.composite_i420`), one rounding per sample.

    Parameters
    ----------
    yuv : (H * 3 / 2, W) uint8 I420 buffer, contiguous, modified in place
    width, height : int, even frame size
    bgra : (H, W, 4) uint8, premultiplied B, G, R, A (zero outside ``rects``)
    rects : iterable of (x0, y0, x1, y1), half-open pixel rectangles
    """
    from arstream.kernels import composite_i420 as blend  # (numba: loaded when a RenderStage is made)

    r = _rect_array(rects, width, height, even=True)
    if len(r):
        blend(yuv.reshape(-1), int(width), int(height), np.ascontiguousarray(bgra), r, *_BGRA_TO_YUV)


def _rect_array(rects, width: int, height: int, *, even: bool = False) -> np.ndarray:
    """Rectangles (x0, y0, x1, y1) as an (R, 4) int64 array for the compiled I420
    passes: clipped to the frame (``even``: first grown outward to even pixels,
    as 4:2:0 chroma needs), the empty ones dropped."""
    out = []
    for rc in rects:  # (a handful of rectangles: plain ints beat numpy's per-call cost)
        x0, y0, x1, y1 = (int(v) for v in rc)
        if even:
            x0, y0, x1, y1 = x0 & ~1, y0 & ~1, (x1 + 1) & ~1, (y1 + 1) & ~1
        x0, x1 = min(max(x0, 0), width), min(max(x1, 0), width)
        y0, y1 = min(max(y0, 0), height), min(max(y1, 0), height)
        if x1 > x0 and y1 > y0:
            out.append((x0, y0, x1, y1))
    return np.array(out, np.int64).reshape(-1, 4)


class GrassKeyI420:
    """:func:`render.keying.refine_matte` (with :func:`render.keying.green_matte`'s
    default grass colour) of I420 frames, without converting them to BGR: the
    same matte, pixel for pixel, in one compiled pass
    (:func:`arstream.kernels.key_i420`). One object per clip: it keeps the
    table of which colours are grass (2 MiB, filled as colours occur)."""

    def __init__(self):
        from render.keying import GRASS_HUE, MIN_SATURATION, MIN_VALUE

        i = np.arange(1, 256, dtype=np.float64)  # OpenCV's 8-bit HSV divisions (round half to even, as cvRound)
        sdiv, hdiv = np.zeros(256, np.int64), np.zeros(256, np.int64)
        sdiv[1:] = np.rint(255 * 4096 / i)
        hdiv[1:] = np.rint(180 * 4096 / (6 * i))
        self._params = (int(GRASS_HUE[0]), int(GRASS_HUE[1]), int(MIN_SATURATION), int(MIN_VALUE), sdiv, hdiv)
        self._lut = np.zeros((65536, 4), np.uint64)
        self._built = np.zeros(65536, np.bool_)
        self._se: dict = {}

    def __call__(self, out: np.ndarray, yuv: np.ndarray, width: int, height: int, rects, pitch: np.ndarray, *, keep: np.ndarray | None = None, keep_grow: int = 0) -> np.ndarray:
        """Key the frame inside ``rects``.

        Parameters
        ----------
        out : (H, W) uint8, written inside ``rects`` (255 = grass)
        yuv : (H * 3 / 2, W) uint8 I420 buffer, contiguous
        width, height : int, even frame size
        rects : iterable of (x0, y0, x1, y1) half-open pixel rectangles (clipped to the frame)
        pitch : (h', w') uint8 whole-frame mask at any resolution, non-zero = pitch
        keep : (h'', w'') uint8 whole-frame mask at any resolution, optional
        keep_grow : pixels by which ``keep`` is grown (an elliptical structuring element)

        Returns
        -------
        ``out``
        """
        from arstream.kernels import key_i420  # (numba: loaded when a RenderStage is made)

        r = _rect_array(rects, width, height)
        half = self._se.get(keep_grow)
        if half is None:
            if keep_grow > 0:
                se = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * keep_grow + 1, 2 * keep_grow + 1))
                half = np.array([(np.count_nonzero(row) - 1) // 2 if row.any() else -1 for row in se], np.int64)
            else:
                half = np.zeros(1, np.int64)
            self._se[keep_grow] = half
        c = np.ascontiguousarray
        kp = np.zeros((0, 0), np.uint8) if keep is None else c(keep, np.uint8)
        key_i420(yuv.reshape(-1), int(width), int(height), r, c(pitch, np.uint8), kp, half, self._lut, self._built, *self._params, out)
        return out


def load_scene_arg(scene):
    """A :class:`render.Scene` from None (the demo scene), a path, or a Scene."""
    import render

    if scene is None:
        return render.default_scene()
    if isinstance(scene, render.Scene):
        return scene
    return render.load_scene(scene)


class RenderStage(Stage):
    """Draw the scene with the frame's camera and composite it, keyed by the grass matte.

    Frames without a camera pass untouched. Raises :class:`ArstreamError`
    naming the fix when no OpenGL context can be made.
    """

    name = "render"

    def __init__(self, width: int, height: int, scene=None, *, renderer=None, fine_key: bool = True):
        from arstream.kernels import warm_up_compositor
        from render import GLContextError, Renderer

        warm_up_compositor()  # (numba's set-up, about 0.3 s, before the run rather than in its first frame)
        self.width, self.height = width, height
        self.fine_key = fine_key
        self._fine = None
        self._key_i420: GrassKeyI420 | None = None
        if renderer is None:
            try:
                renderer = Renderer(width, height, load_scene_arg(scene))
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


class EncodeStage(Stage):
    """H.264 encode (libx264) on a thread, with the input's audio copied through.

    Frames keep the input's timestamps and time base, and (``keep_b_frames``,
    see :class:`arstream.sink.VideoSink`) the input's B-frames. ``process`` queues the
    frame (bounded queue; it blocks when the encoder is behind) and returns
    the item at once; ``close`` drains the queue, writes the trailer and moves
    the file into place.
    """

    name = "encode"

    def __init__(self, path, source: VideoSource, *, crf: int = 20, preset: str = "veryfast", audio: bool = True, queue_size: int = 4, rebase: bool = False, keep_b_frames: bool = True):
        audio_in = source.audio_stream if audio else None
        self.sink = VideoSink(path, source.width, source.height, source.rate, crf=crf, preset=preset, time_base=source.time_base, audio_from=audio_in, keep_b_frames=keep_b_frames)
        self.path = self.sink.path
        self.rebase = rebase  # live sources: start the output at 0
        self._ts0 = None
        self.q: collections.deque = collections.deque()
        self.cv = threading.Condition()
        self.queue_size = queue_size
        self.error: BaseException | None = None
        self.encode_ms = 0.0
        self.thread = threading.Thread(target=self._run, name="arstream-encode", daemon=True)
        self.thread.start()

    def _put(self, msg) -> None:
        with self.cv:
            while len(self.q) >= self.queue_size and self.error is None and self.thread.is_alive():
                self.cv.wait(0.1)
            if self.error is not None:
                raise ArstreamError(f"encoding {self.path} failed: {self.error}")
            self.q.append(msg)
            self.cv.notify_all()

    def process(self, item: Item) -> list[Item]:
        f = item.frame
        ts = f.ts
        if ts is not None and self.rebase:
            if self._ts0 is None:
                self._ts0 = ts
            ts -= self._ts0
        self._put(("yuv" if f.yuv is not None else "bgr", f.yuv if f.yuv is not None else f.image, f.pts, ts, f.picture_type))
        return [item]

    def audio(self, packet) -> None:
        """Queue one input audio packet to be muxed unchanged."""
        if self.sink.audio_out is not None and not self.rebase:
            self._put(("audio", packet, None, None, None))

    def _run(self) -> None:
        sink = self.sink
        while True:
            with self.cv:
                while not self.q:
                    self.cv.wait()
                msg = self.q.popleft()
                self.cv.notify_all()
            if msg is None:
                return
            kind, data, pts, ts, picture_type = msg
            try:
                t0 = time.perf_counter()
                if kind == "yuv":
                    sink.write_yuv(data, pts, ts=ts, picture_type=picture_type)
                elif kind == "bgr":
                    sink.write(data, pts, ts=ts, picture_type=picture_type)
                else:
                    sink.mux_audio(data)
                    continue
                self.encode_ms += (time.perf_counter() - t0) * 1e3
            except BaseException as exc:  # reported to the main thread by the next _put / close
                with self.cv:
                    self.error = exc
                    self.q.clear()
                    self.cv.notify_all()
                return

    @property
    def frames_written(self) -> int:
        return self.sink.frames_written

    def close(self) -> None:
        if self.thread.is_alive():
            with self.cv:
                self.q.append(None)
                self.cv.notify_all()
            self.thread.join()
        try:
            self.sink.close()
        finally:
            if self.error is not None:
                raise ArstreamError(f"encoding {self.path} failed: {self.error}")


class CamerasOutStage(Stage):
    """Write each frame's estimate to ``cameras.jsonl`` (complete lines, flushed per frame)."""

    name = "cameras"

    def __init__(self, path):
        self.writer = JsonlWriter(path)
        self.path = self.writer.path

    def process(self, item: Item) -> list[Item]:
        self.writer.write(item.estimate.to_record())
        return [item]

    def close(self) -> None:
        self.writer.close()


# --------------------------------------------------------------------------- summary
@dataclass
class Summary:
    """What a run did.

    Attributes
    ----------
    input : str
    output, cameras : str or None, files written
    frames : int, frames that went through every stage (= frames written)
    tracked : int, frames with a camera (status "ok" or "tracked")
    confidence : float, mean confidence over all frames (0 for lost frames)
    seconds : float, wall time of the run (decode to trailer)
    cpu_seconds : float, CPU time of the process over the run (all threads)
    dropped : int, frames dropped to keep up in real time
    errors : list of str, input damage (skipped packets, truncation)
    interrupted : int or None, the signal that stopped the run
    stage_ms : dict, mean milliseconds per frame of each stage
    stage_cpu_ms : dict, mean CPU milliseconds per frame of each stage's own thread
        (the encoder's and decoder's codec threads are not included)
    missing : list of str, pipeline stages whose module does not exist yet
    """

    input: str = ""
    output: str | None = None
    cameras: str | None = None
    frames: int = 0
    tracked: int = 0
    confidence: float = 0.0
    seconds: float = 0.0
    cpu_seconds: float = 0.0
    dropped: int = 0
    errors: list = field(default_factory=list)
    interrupted: int | None = None
    stage_ms: dict = field(default_factory=dict)
    stage_cpu_ms: dict = field(default_factory=dict)
    missing: list = field(default_factory=list)
    width: int = 0
    height: int = 0

    @property
    def fps(self) -> float:
        return self.frames / self.seconds if self.seconds > 0 else 0.0

    @property
    def share_tracked(self) -> float:
        return self.tracked / self.frames if self.frames else 0.0

    def line(self) -> str:
        """One line for the terminal."""
        s = (
            f"{self.frames} frames in {self.seconds:.1f} s ({self.fps:.1f} fps), "
            f"tracked {self.share_tracked:.1%}, mean confidence {self.confidence:.2f}"
        )
        if self.dropped:
            s += f", dropped {self.dropped}"
        outs = [p for p in (self.output, self.cameras) if p]
        if outs:
            s += " -> " + ", ".join(outs)
        return s

    def to_dict(self) -> dict:
        return {
            "input": self.input,
            "output": self.output,
            "cameras": self.cameras,
            "frames": self.frames,
            "tracked": self.tracked,
            "share_tracked": round(self.share_tracked, 4),
            "mean_confidence": round(self.confidence, 4),
            "seconds": round(self.seconds, 3),
            "cpu_seconds": round(self.cpu_seconds, 3),
            "fps": round(self.fps, 2),
            "dropped": self.dropped,
            "errors": list(self.errors),
            "interrupted": self.interrupted,
            "stage_ms": {k: round(v, 3) for k, v in self.stage_ms.items()},
            "stage_cpu_ms": {k: round(v, 3) for k, v in self.stage_cpu_ms.items()},
            "missing": list(self.missing),
            "size": [self.width, self.height],
        }


class Interrupted(KeyboardInterrupt):
    """The run was stopped by SIGINT/SIGTERM after its outputs were finalised."""

    def __init__(self, signum: int, summary: Summary):
        super().__init__(f"interrupted by {signal.Signals(signum).name}")
        self.signum = signum
        self.summary = summary

    @property
    def exit_code(self) -> int:
        return 128 + int(self.signum)


# --------------------------------------------------------------------------- the runner
class _Mailbox:
    """Decode -> main hand-over: a bounded queue of ("frame", Frame, t, fields) / ("audio", pkt) / ("end",).

    ``latest_only``: a new frame replaces a waiting one (counted in ``dropped``).
    """

    def __init__(self, size: int, latest_only: bool):
        self.q: collections.deque = collections.deque()
        self.cv = threading.Condition()
        self.size = size
        self.latest_only = latest_only
        self.frames = 0
        self.dropped = 0
        self.closed = False

    def put(self, msg) -> bool:
        """Returns False when the receiver has gone away."""
        with self.cv:
            if msg[0] == "frame":
                if self.latest_only:
                    while self.frames >= 1:
                        for i, m in enumerate(self.q):
                            if m[0] == "frame":
                                del self.q[i]
                                break
                        self.frames -= 1
                        self.dropped += 1
                else:
                    while self.frames >= self.size and not self.closed:
                        self.cv.wait(0.1)
                self.frames += 1
            elif not self.latest_only:
                while len(self.q) >= 4 * self.size and not self.closed:
                    self.cv.wait(0.1)
            if self.closed:
                return False
            self.q.append(msg)
            self.cv.notify_all()
            return True

    def get(self, timeout: float):
        with self.cv:
            if not self.q:
                self.cv.wait(timeout)
                if not self.q:
                    return None
            msg = self.q.popleft()
            if msg[0] == "frame":
                self.frames -= 1
            self.cv.notify_all()
            return msg

    def close(self) -> None:
        with self.cv:
            self.closed = True
            self.q.clear()
            self.frames = 0
            self.cv.notify_all()


class Pipeline:
    """Run a :class:`VideoSource` through stages on three threads.

    Parameters
    ----------
    source : VideoSource (opened; the pipeline does not close it)
    stages : list of Stage, in order
    realtime : bool, pace to the source clock and drop frames to keep up
    queue_size : int, frames between decode and the stages (offline)
    progress : callable(done, total), optional, called after each frame
    max_frames : int, optional, stop after this many decoded frames
    pool_threads : int or None, threads of the libraries' own worker pools
        (OpenCV's, and the BLAS behind numpy and scipy, via threadpoolctl)
        while :meth:`run` runs; their settings are restored after. Default 1:
        the pipeline's own threads already keep the cores busy, and those
        pools would only add hand-overs and spinning workers beside them
        (about 4 ms of CPU a 720p frame together, see bench/README.md).
        None leaves them as they are.
    decode_nice : int, added to the decode thread's niceness (and its
        decoder's threads'), see :data:`WORKER_NICE`; 0 for live sources,
        whose reader must keep up with the network
    prepare : callable(Frame) -> dict, optional, run on the decode thread with
        each frame as it is decoded (while its planes are still in that core's
        cache); the dict holds :class:`Item` fields for the frame's item (such
        as :meth:`Analysis.prepare`'s). Its time counts as the frame's decode time.
    """

    def __init__(
        self,
        source: VideoSource,
        stages: list[Stage],
        *,
        realtime: bool = False,
        queue_size: int = 4,
        progress: Callable | None = None,
        max_frames: int | None = None,
        pool_threads: int | None = 1,
        decode_nice: int = 0,
        prepare: Callable[[Frame], dict] | None = None,
    ):
        self.source = source
        self.prepare = prepare
        self.pool_threads = pool_threads
        self.decode_nice = int(decode_nice)
        self.stages = list(stages)
        self.realtime = realtime
        self.progress = progress
        self.max_frames = max_frames
        self.box = _Mailbox(queue_size, latest_only=realtime)
        self._stop = threading.Event()
        self._signal: int | None = None
        self._closing = False  # while outputs are finalised, signals are not raised
        self._decode_error: BaseException | None = None
        self.summary = Summary(input=source.path, width=source.width, height=source.height)
        self._stage_ms = collections.Counter()
        self._stage_cpu = collections.Counter()
        self._late = 0
        self._conf = 0.0
        self._audio_stages = [s for s in self.stages if hasattr(s, "audio")]

    # ---- decode thread
    def _decode(self) -> None:
        _renice(self.decode_nice)
        box = self.box
        interval = 1.0 / self.source.fps if self.source.fps > 0 else 0.04
        anchor = None  # (wall time, pts) of the pacing clock
        on_audio = (lambda p: box.put(("audio", p))) if self._audio_stages else None
        frames = self.source.frames(on_audio=on_audio, stop=self._stop.is_set)
        try:
            n = 0
            for frame in frames:
                if self.realtime:
                    now = time.perf_counter()
                    if anchor is None:
                        anchor = (now, frame.pts)
                    wait = anchor[0] + (frame.pts - anchor[1]) - now
                    if wait > 1.0 or wait < -2 * interval:  # a jump in the clock, or the source stalled: re-anchor
                        anchor = (now, frame.pts)
                    elif wait > 0:  # ahead of the clock (a file, or a burst from the network): wait
                        if self._stop.wait(wait):
                            break
                fields = None
                if self.prepare is not None:
                    t0 = time.perf_counter()
                    fields = self.prepare(frame)
                    frame.decode_ms += (time.perf_counter() - t0) * 1e3
                if not box.put(("frame", frame, time.perf_counter(), fields)):
                    break
                n += 1
                if self.max_frames is not None and n >= self.max_frames:
                    break
        except BaseException as exc:
            self._decode_error = exc
        finally:
            frames.close()
            box.put(("end",))

    # ---- signals
    @contextlib.contextmanager
    def _signals(self, enabled: bool):
        if not enabled or threading.current_thread() is not threading.main_thread():
            yield
            return

        def handler(signum, _frame):
            if self._signal is None:
                self._signal = signum  # graceful: stop between frames
            elif not self._closing:
                raise KeyboardInterrupt  # a second signal: stop now (outputs are still closed)

        old = {}
        try:
            for s in (signal.SIGINT, signal.SIGTERM):
                old[s] = signal.signal(s, handler)
            yield
        finally:
            for s, h in old.items():
                signal.signal(s, h)

    @contextlib.contextmanager
    def _pools(self):
        """OpenCV's and BLAS's worker pools at ``pool_threads`` for the run."""
        if self.pool_threads is None:
            yield
            return
        from threadpoolctl import threadpool_limits

        old = cv2.getNumThreads()
        cv2.setNumThreads(self.pool_threads)
        try:
            with threadpool_limits(self.pool_threads, user_api="blas"):
                yield
        finally:
            cv2.setNumThreads(old)

    # ---- stage plumbing
    def _push(self, items: list[Item], start: int = 0) -> None:
        for stage in self.stages[start:]:
            nxt = []
            name = stage.name
            self_timed = getattr(stage, "self_timed", False)
            for it in items:
                t0, c0 = time.perf_counter(), time.thread_time()
                res = stage.process(it)
                if not self_timed:
                    it.timings[name] = it.timings.get(name, 0.0) + (time.perf_counter() - t0) * 1e3
                    it.cpu[name] = it.cpu.get(name, 0.0) + (time.thread_time() - c0) * 1e3
                nxt.extend(res)
            items = nxt
            if not items:
                return
        for it in items:
            self._done(it)

    def _done(self, item: Item) -> None:
        s = self.summary
        s.frames += 1
        for k, v in item.timings.items():
            self._stage_ms[k] += v
        for k, v in item.cpu.items():
            self._stage_cpu[k] += v
        est = item.estimate
        if est is not None and est.status != "lost":
            s.tracked += 1
        if est is not None:
            self._conf += float(est.confidence)
        if self.progress is not None:
            total = self.source.frame_count
            if self.max_frames is not None:
                total = min(total, self.max_frames) if total else self.max_frames
            self.progress(s.frames, total)

    def _flush(self) -> None:
        for i, stage in enumerate(self.stages):
            items = stage.flush()
            if items:
                self._push(items, i + 1)

    # ---- run
    def run(self, *, handle_signals: bool = True) -> Summary:
        """Process the whole source (or until stopped); returns the :class:`Summary`.

        Raises
        ------
        Interrupted
            After a graceful stop by SIGINT/SIGTERM (outputs finalised).
        """
        s = self.summary
        t_start = time.perf_counter()
        cpu_start = time.process_time()
        interval = 1.0 / self.source.fps if self.source.fps > 0 else 0.04
        decoder = threading.Thread(target=self._decode, name="arstream-decode", daemon=True)
        failed = False
        with self._signals(handle_signals), self._pools():
            try:
                decoder.start()
                while self._signal is None:
                    msg = self.box.get(0.1)
                    if msg is None:
                        continue
                    kind = msg[0]
                    if kind == "end":
                        break
                    if kind == "audio":
                        for st in self._audio_stages:
                            st.audio(msg[1])
                        continue
                    frame, t_put, fields = msg[1], msg[2], msg[3]
                    if self.realtime and time.perf_counter() - t_put > 2 * interval:
                        self._late += 1  # too old to show: drop it rather than fall behind
                        continue
                    item = Item(frame, **(fields or {}))
                    item.timings["decode"] = frame.decode_ms
                    self._push([item])
                if self._decode_error is not None:
                    raise self._decode_error
                self._flush()
            except BaseException:
                failed = True
                raise
            finally:
                self._closing = True
                self._stop.set()
                self.box.close()
                decoder.join(timeout=5.0)
                self._close_stages(quiet=failed)
                s.seconds = time.perf_counter() - t_start
                s.cpu_seconds = time.process_time() - cpu_start
                s.dropped = self.box.dropped + self._late
                s.errors = list(self.source.errors)
                if s.frames:
                    s.confidence = self._conf / s.frames
                    s.stage_ms = {k: v / s.frames for k, v in self._stage_ms.items()}
                    s.stage_cpu_ms = {k: v / s.frames for k, v in self._stage_cpu.items()}
                    enc = next((st for st in self.stages if isinstance(st, EncodeStage)), None)
                    if enc is not None:
                        s.stage_ms["encode"] = enc.encode_ms / max(enc.frames_written, 1)
        if self._signal is not None:
            s.interrupted = self._signal
            raise Interrupted(self._signal, s)
        return s

    def _close_stages(self, quiet: bool) -> None:
        first = None
        for stage in self.stages:
            try:
                stage.close()
            except BaseException as exc:  # close every stage; report the first failure
                if first is None:
                    first = exc
        if first is not None and not quiet:
            raise first


# --------------------------------------------------------------------------- library API
#: Niceness added to the threads that work ahead of the main thread in
#: :func:`process` and :func:`render_clip`: the overlapped stage's worker
#: (detection, keying) and the decode thread with FFmpeg's decoder threads.
#: x264 is their bottleneck and its frame threads stall on one another; the
#: threads ahead, with frames queued, do their work in those gaps rather than
#: beside x264. At 720p, five alternating pairs each: the worker alone about
#: 54.6 fps against 51.8, with the decoder too about 56.8 against 53.7.
WORKER_NICE = 10


def _overlapped(stage: Stage, overlap: bool) -> Stage:
    """``stage`` on a worker thread one frame ahead (when it does work), else as is."""
    if overlap and getattr(stage, "available", True):
        return ThreadedStage(stage, nice=WORKER_NICE)
    return stage


def _has(module: str) -> bool:
    return importlib.util.find_spec(module) is not None


def _missing(*stages) -> list[str]:
    """Stages whose module is not in this build (they pass frames through)."""
    return [name for name, mod in (("detect", "arstream.detect"), ("track", "arstream.track")) if any(st.name == name for st in stages) and not _has(mod)]


def _open(input, *, format=None, options=None, threads: bool = True) -> VideoSource:
    return VideoSource(input, format=format, options=options, threads=threads)


def _check_output(output, input) -> None:
    if output is not None and os.path.abspath(os.fspath(output)) == os.path.abspath(os.fspath(input)):
        raise InputError(f"output {output} would overwrite the input")


def _build(stages_fn, source: VideoSource) -> list[Stage]:
    """Create the stages; close the ones already made if a later one fails."""
    made: list[Stage] = []
    try:
        for make in stages_fn:
            st = make()
            if st is not None:
                made.append(st)
    except BaseException:
        for st in made:
            with contextlib.suppress(Exception):
                if isinstance(st, EncodeStage):
                    st.close()
                    with contextlib.suppress(OSError):
                        os.remove(st.path)  # nothing was written: leave no empty file
                else:
                    st.close()
        raise
    return made


def _load_kernels() -> None:
    """Start loading the compiled kernels on a background thread (once per
    process; see :func:`arstream.kernels.warm_up_async`), so that numba's
    set-up overlaps opening the input and building the stages rather than
    following them (the detector would start it only once it is made)."""
    from arstream.kernels import warm_up_async

    warm_up_async()


def process(
    input,
    output=None,
    *,
    scene=None,
    cameras_out=None,
    lag: int = DEFAULT_LAG,
    crf: int = 20,
    preset: str = "veryfast",
    audio: bool = True,
    progress: Callable | None = None,
    max_frames: int | None = None,
    handle_signals: bool = True,
    overlap: bool = True,
    analysis_width: int | None = DEFAULT_ANALYSIS_WIDTH,
    threads: int = 0,
    keep_b_frames: bool = True,
) -> Summary:
    """Augment a clip: detect, solve, track (fixed-lag smoothing), render, composite, encode.

    Mirrors ``arstream process IN -o OUT.mp4 [--scene S] [--cameras-out C]``.

    Parameters
    ----------
    input : path of a video file
    output : path of the augmented video (H.264; the input's frame rate, time
        base and audio kept), or None to write only ``cameras_out``
    scene : path of a scene file (.toml/.json), a ``render.Scene``, or None
        for the demo scene (a logo on the grass and an offside line)
    cameras_out : path for ``cameras.jsonl`` (one record per frame), optional
    lag : frames of look-ahead of the smoother (0: causal, as live)
    crf, preset : x264 quality and speed
    audio : copy the input's first audio stream through
    keep_b_frames : code the input's B-frames as B-frames (the input's frame
        pattern kept: a smaller output, closer to the input; see
        :class:`arstream.sink.VideoSink`); False: x264 chooses every frame's type
    progress : callable(done, total), optional
    max_frames : stop after this many frames
    handle_signals : stop gracefully on SIGINT/SIGTERM (main thread only)
    overlap : detect frame i+1 on a worker thread while frame i is tracked and rendered
    analysis_width : width (pixels) of the frames detection and tracking work on;
        None or 0: full resolution (see :class:`Analysis`)
    threads : 0 (default): use the machine (detection overlapped on a thread,
        decoder threads as FFmpeg chooses); 1: about one core's worth of work
        per clip (no overlap, single-threaded decode), for running as many
        clips at once as there are cores (``arstream batch``). x264 keeps its
        own threading either way: its output depends on its thread count, and
        a clip's video must not depend on how many ran beside it.

    Returns
    -------
    Summary. ``summary.errors`` lists damage found in the input (the frames
    that decoded were processed).

    Raises
    ------
    InputError : missing file, not a video, bad output path
    ArstreamError : no OpenGL context (names the fix), stage failures
    Interrupted : stopped by a signal, after the outputs were finalised
    """
    if output is None and cameras_out is None:
        raise InputError("nothing to write: give an output video, cameras_out, or both")
    _check_output(output, input)
    _check_output(cameras_out, input)
    if threads < 0:
        raise ValueError(f"threads must be 0 (auto) or positive, got {threads}")
    single = threads == 1
    _load_kernels()
    with _open(input, threads=not single) as src:
        W, H = src.width, src.height
        an = Analysis(W, H, analysis_width)
        track_box: list = []
        stages = _build(
            [
                lambda: _overlapped(DetectStage(W, H, analysis=an, hints=_hints_of(track_box)), overlap and not single),
                lambda: _boxed(track_box, TrackStage(W, H, fps=src.fps, lag=lag, enabled=_has("arstream.detect"), analysis=an)),
                (lambda: RenderStage(W, H, scene)) if output is not None else (lambda: None),
                (lambda: EncodeStage(output, src, crf=crf, preset=preset, audio=audio, keep_b_frames=keep_b_frames)) if output is not None else (lambda: None),
                (lambda: CamerasOutStage(cameras_out)) if cameras_out is not None else (lambda: None),
            ],
            src,
        )
        # (the analysis frame on the decode thread, from the planes it just copied)
        prepare = an.prepare if _has("arstream.detect") else None
        pipe = Pipeline(src, stages, progress=progress, max_frames=max_frames, decode_nice=WORKER_NICE, prepare=prepare)
        pipe.summary.output = os.fspath(output) if output is not None else None
        pipe.summary.cameras = os.fspath(cameras_out) if cameras_out is not None else None
        pipe.summary.missing = _missing(*stages)
        return pipe.run(handle_signals=handle_signals)


def render_clip(
    input,
    cameras,
    output,
    *,
    scene=None,
    key: bool | str | Callable = True,
    crf: int = 20,
    preset: str = "veryfast",
    audio: bool = True,
    progress: Callable | None = None,
    handle_signals: bool = True,
    overlap: bool = True,
    keep_b_frames: bool = True,
) -> Summary:
    """Draw a scene on a clip with cameras read from a ``cameras.jsonl`` (no solving).

    The decode -> composite -> encode loop of :func:`process`, for
    ``arstream render``. ``key`` chooses the grass matte that keys on-grass
    graphics (players pass in front of them): True or "detector" runs the
    detector (no keying when this build has none); "green" a chroma key on the
    grass hue; a callable(image_bgr) -> (H, W) uint8 matte your own; False or
    None no keying. ``overlap`` computes the matte of frame i+1 on a worker
    thread while frame i is rendered. ``keep_b_frames`` as for :func:`process`.
    """
    _check_output(output, input)
    if key is True:
        key = "detector"
    if not (key in (None, False, "detector", "green") or callable(key)):
        raise InputError(f"key must be 'detector', 'green', a function or None, got {key!r}")
    with _open(input) as src:
        W, H = src.width, src.height
        if key == "detector":
            make_key = lambda: _overlapped(DetectStage(W, H, analysis=Analysis(W, H, DEFAULT_ANALYSIS_WIDTH)), overlap)  # noqa: E731
        elif key == "green":
            make_key = lambda: _overlapped(MatteStage.green(W, H), overlap)  # noqa: E731
        elif callable(key):
            make_key = lambda: _overlapped(MatteStage(key), overlap)  # noqa: E731
        else:
            make_key = lambda: None  # noqa: E731
        stages = _build(
            [
                make_key,
                lambda: CamerasInStage(cameras),
                lambda: RenderStage(W, H, scene),
                lambda: EncodeStage(output, src, crf=crf, preset=preset, audio=audio, keep_b_frames=keep_b_frames),
            ],
            src,
        )
        pipe = Pipeline(src, stages, progress=progress, decode_nice=WORKER_NICE)
        pipe.summary.output = os.fspath(output)
        pipe.summary.missing = _missing(*stages)
        return pipe.run(handle_signals=handle_signals)


def stream(
    source,
    *,
    rerun: tuple | list | str | None = None,
    realtime: bool | None = None,
    scene=None,
    output=None,
    cameras_out=None,
    format: str | None = None,
    options: dict | None = None,
    bind: str = "127.0.0.1",
    port: int = 9876,
    jpeg_quality: int = 75,
    max_frames: int | None = None,
    progress: Callable | None = None,
    handle_signals: bool = True,
    warn: Callable[[str], None] | None = None,
    analysis_width: int | None = DEFAULT_ANALYSIS_WIDTH,
) -> Summary:
    """Live mode: causal tracking (no look-ahead) of a file, URL or capture device,
    logged to rerun. Mirrors ``arstream stream --source SRC [--rerun ...] [--realtime]``.

    Parameters
    ----------
    source : file path, URL (rtsp://, http://, udp://, ...) or device (with ``format``,
        e.g. ``format="v4l2"``, ``source="/dev/video0"``)
    rerun : None (no logging), "spawn", ("save", path), ("connect", url or None), "serve"
    realtime : pace to the source clock and drop frames rather than fall behind;
        None: on for URLs and devices, off for files
    scene, output, cameras_out : as :func:`process` (output and cameras optional)
    bind, port : address of the rerun gRPC server for ``serve``
    jpeg_quality : quality of the JPEG frames sent to rerun
    warn : callable(str) for non-fatal problems (unreachable viewer); default stderr
    analysis_width : as :func:`process`
    """
    from arstream.live import RerunLogger, parse_rerun

    warn = warn or (lambda msg: print(f"arstream: warning: {msg}", file=sys.stderr))
    mode = parse_rerun(rerun)
    if output is not None:
        _check_output(output, source)
    _load_kernels()
    with _open(source, format=format, options=options) as src:
        W, H = src.width, src.height
        rt = src.is_live if realtime is None else bool(realtime)
        an = Analysis(W, H, analysis_width)
        logger_box: list = []
        track_box: list = []

        def make_logger():
            if mode is None:
                return None
            lg = RerunLogger(mode, W, H, bind=bind, port=port, jpeg_quality=jpeg_quality, warn=warn, name=os.path.basename(src.path), analysis=an)
            logger_box.append(lg)
            return lg.input_stage

        stages = _build(
            [
                lambda: DetectStage(W, H, analysis=an, hints=_hints_of(track_box)),
                lambda: _boxed(track_box, TrackStage(W, H, fps=src.fps, lag=0, enabled=_has("arstream.detect"), analysis=an)),
                make_logger,
                lambda: RenderStage(W, H, scene),
                (lambda: logger_box[0].output_stage) if mode is not None else (lambda: None),
                (lambda: EncodeStage(output, src, audio=not src.is_live, rebase=src.is_live)) if output is not None else (lambda: None),
                (lambda: CamerasOutStage(cameras_out)) if cameras_out is not None else (lambda: None),
            ],
            src,
        )
        pipe = Pipeline(src, stages, realtime=rt, queue_size=1 if rt else 2, progress=progress, max_frames=max_frames)
        pipe.summary.output = os.fspath(output) if output is not None else None
        pipe.summary.cameras = os.fspath(cameras_out) if cameras_out is not None else None
        pipe.summary.missing = _missing(*stages)
        return pipe.run(handle_signals=handle_signals)
