"""The pipeline's stage protocol and its threaded stage.

A stage is a small object with one contract (:class:`Stage`)::

    process(item: Item) -> list[Item]   # the items that are now ready, in order
    flush() -> list[Item]               # at the end of the input: whatever it still holds
    close() -> None                     # release resources / finalise outputs

Most stages return ``[item]``. The tracker stage of the offline pipeline
holds up to ``lag`` items (a fixed-lag smoother emits each camera ``lag``
frames late) and returns them when their estimates are final; nothing else
buffers, so memory is flat in clip length. An :class:`Item` is one frame on
its way through them. :class:`ThreadedStage` runs a one-in, one-out stage on a
worker thread one frame ahead (detection, keying), with the detector's
buffers copied out for the frame (:func:`own_detections`).
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from arstream.errors import ArstreamError
from arstream.estimate import CameraEstimate
from arstream.source import Frame

__all__ = ["Item", "Stage", "ThreadedStage", "own_detections"]

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
    pitch : the ``geometry.pitch.PitchModel`` the frame's camera was solved at
        (set with ``estimate`` by the tracker's stage), or None
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
    pitch: object | None = None

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
        # (the detector's own buffer follows the copy; a matte put back in a
        # whole frame inside black bars is the item's already)
        detectors = item.matte is _matte_of(det)
        item.detections = det.detach() if hasattr(det, "detach") else copy.deepcopy(det)
        if detectors:
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
