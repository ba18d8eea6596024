"""The pipeline's runner: a :class:`arstream.source.VideoSource` through the
stages on three threads.

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

Interruption
------------
While :meth:`Pipeline.run` runs (in the main thread), SIGINT and SIGTERM stop
it gracefully between frames: the frames the tracker holds are flushed,
the encoder is drained, the container trailer written and ``cameras.jsonl``
closed, then :class:`arstream.pipeline.summary.Interrupted` (a
``KeyboardInterrupt``) is raised with the signal number and the
:class:`arstream.pipeline.summary.Summary`. A second signal skips the flush
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
import signal
import threading
import time
from typing import Callable

import cv2

from arstream.pipeline.encode import EncodeStage
from arstream.pipeline.stage import Item, Stage, _renice
from arstream.pipeline.summary import Interrupted, Summary
from arstream.source import Frame, VideoSource

__all__ = ["Pipeline"]

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
