"""The pipeline's encoder stage: H.264 on a thread of its own, fed the frames
(I420 as decoded and composited, or BGR) and the input's audio packets, in
order. The writers themselves are :mod:`arstream.sink`'s.
"""

from __future__ import annotations

import collections
import threading
import time

from arstream.errors import ArstreamError
from arstream.pipeline.stage import Item, Stage
from arstream.sink import VideoSink
from arstream.source import VideoSource

__all__ = ["EncodeStage"]

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
