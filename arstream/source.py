"""Frame sources: PyAV decode of files, URLs and capture devices.

A source is an iterator of :class:`Frame` (BGR uint8 H x W x 3, OpenCV
order, with its index and presentation time in seconds). Opening a missing
or unreadable input raises :class:`~arstream.errors.InputError` with one
clear line; decode errors part-way through a file end the iteration and are
recorded in ``VideoSource.errors`` (process what decodes, say what was
skipped).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from fractions import Fraction
from typing import Iterator

import av
import numpy as np

from arstream.errors import InputError

__all__ = ["Frame", "VideoSource", "probe"]


@dataclass
class Frame:
    """One decoded frame.

    Attributes
    ----------
    index : int, 0-based position in decode order
    pts : float, presentation time in seconds (index / fps when the stream has none)
    image : (H, W, 3) uint8, BGR
    """

    index: int
    pts: float
    image: np.ndarray


def _is_url(path: str) -> bool:
    return "://" in path


class VideoSource:
    """Decode a video file, URL (rtsp/http/udp...) or device with PyAV.

    Use as a context manager and iterate::

        with VideoSource("clip.mp4") as src:
            for frame in src:
                ...

    Parameters
    ----------
    path : str or os.PathLike
    threads : bool
        Let FFmpeg decode with frame+slice threads (releases the GIL).
    options : dict, optional
        FFmpeg demuxer options (e.g. ``{"rtsp_transport": "tcp"}``).
    format : str, optional
        Input format (e.g. ``"v4l2"`` for a capture device).

    Raises
    ------
    InputError
        Missing file, not a video, or no video stream.
    """

    def __init__(self, path, *, threads: bool = True, options: dict | None = None, format: str | None = None):
        self.path = os.fspath(path)
        if not _is_url(self.path) and format is None and not os.path.exists(self.path):
            raise InputError(f"input not found: {self.path}")
        try:
            self.container = av.open(self.path, mode="r", options=options or {}, format=format)
        except (av.error.FFmpegError, OSError, ValueError) as exc:
            raise InputError(f"cannot open {self.path} as a video: {_reason(exc)}") from None
        if not self.container.streams.video:
            self.container.close()
            raise InputError(f"{self.path} has no video stream")
        self.stream = self.container.streams.video[0]
        if threads:
            self.stream.thread_type = "AUTO"
        cc = self.stream.codec_context
        self.width = int(cc.width)
        self.height = int(cc.height)
        if self.width <= 0 or self.height <= 0:
            self.container.close()
            raise InputError(f"{self.path}: video stream has no frame size (corrupt or not a video)")
        rate = self.stream.average_rate or self.stream.guessed_rate or self.stream.base_rate
        self.rate: Fraction = Fraction(rate) if rate else Fraction(25, 1)
        self.fps = float(self.rate)
        self.time_base = self.stream.time_base
        self.frame_count = int(self.stream.frames or 0)  # 0 when the container does not say
        self.errors: list[str] = []
        self.frames_decoded = 0

    def __enter__(self) -> "VideoSource":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        try:
            self.container.close()
        except Exception:  # closing a broken container must not mask the real error
            pass

    @property
    def audio_stream(self):
        """The first audio stream, or None."""
        return self.container.streams.audio[0] if self.container.streams.audio else None

    def __iter__(self) -> Iterator[Frame]:
        index = 0
        try:
            for vf in self.container.decode(self.stream):
                if vf.pts is not None and vf.time_base is not None:
                    t = float(vf.pts * vf.time_base)
                else:
                    t = index / self.fps
                yield Frame(index=index, pts=t, image=vf.to_ndarray(format="bgr24"))
                index += 1
                self.frames_decoded = index
        except (av.error.FFmpegError, OSError, ValueError, EOFError) as exc:
            self.errors.append(f"decode stopped after frame {index}: {_reason(exc)}")


def _reason(exc: BaseException) -> str:
    msg = str(exc).strip() or type(exc).__name__
    return msg.splitlines()[0]


def probe(path) -> dict:
    """Basic facts of a video: ``{"width", "height", "fps", "frames", "duration", "audio"}``.

    ``frames`` is counted by decoding when the container does not store it.
    """
    with VideoSource(path) as src:
        n = src.frame_count
        if n == 0:
            n = sum(1 for _ in src)
        dur = src.container.duration
        return {
            "width": src.width,
            "height": src.height,
            "fps": src.fps,
            "frames": n,
            "duration": (dur / 1e6) if dur else n / src.fps,
            "audio": src.audio_stream is not None,
        }
