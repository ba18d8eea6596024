"""Frame sources: PyAV decode of files, URLs and capture devices.

A source is an iterator of :class:`Frame` (BGR uint8 H x W x 3, OpenCV
order, with its index and presentation time in seconds). Opening a missing
or unreadable input raises :class:`~arstream.errors.InputError` with one
clear line; decode errors part-way through a file are recorded in
``VideoSource.errors`` (process what decodes, say what was skipped): a
packet that does not decode is skipped, a container that cannot be read any
further ends the iteration, and a file that ends before the frame count its
header promises is reported as truncated.

Fast path: frames of even size are kept as planar YUV 4:2:0 (I420, what
H.264 decodes to) and converted to BGR only when ``Frame.image`` is first
read (OpenCV's SIMD conversion, about 2.5x faster than FFmpeg's swscale to
bgr24). The pipeline composites and encodes in YUV and so never converts a
whole frame back. Colour conversions use BT.601 limited range both ways,
like FFmpeg's default for untagged video.

Live network sources: :class:`ReconnectingSource` reads a URL with a read
timeout (a stalled source does not block for ever), opens it again with a
backoff when it stalls or drops, for a set time, and reports each event; its
frames go on with consecutive indices and increasing timestamps across
reconnections, and it raises :class:`~arstream.errors.SourceLost` when it
gives up.

Audio: :meth:`VideoSource.frames` can hand the first audio stream's packets,
demuxed from the same container, to a callback so that a sink copies them
through unchanged (see :class:`arstream.sink.VideoSink`).
"""

from __future__ import annotations

import math
import os
import re
import sys
import threading
import time
from fractions import Fraction
from typing import Callable, Iterator

import av
import cv2
import numpy as np

from av.video.reformatter import VideoReformatter

from arstream.errors import InputError, SourceLost

__all__ = ["Frame", "VideoSource", "ReconnectingSource", "SourceLost", "open_live", "probe", "i420_planes", "reconnect_wait", "DEFAULT_TIMEOUT", "DEFAULT_RECONNECT"]

#: Consecutive undecodable packets after which the rest of the file is given up.
MAX_BAD_PACKETS = 50


def i420_planes(yuv: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Views of the Y (H, W), U (H/2, W/2) and V (H/2, W/2) planes of an I420 buffer.

    Parameters
    ----------
    yuv : (H * 3 / 2, W) uint8, contiguous (the layout of PyAV's ``to_ndarray()``
        for yuv420p and of OpenCV's ``COLOR_*2YUV_I420``)
    width, height : int, even frame size
    """
    flat = yuv.reshape(-1)
    n = width * height
    q = n // 4
    return (
        flat[:n].reshape(height, width),
        flat[n : n + q].reshape(height // 2, width // 2),
        flat[n + q : n + 2 * q].reshape(height // 2, width // 2),
    )


# FFmpeg's picture types (AVPictureType) that a Frame reports
_PICTURE_TYPES = {int(av.video.frame.PictureType.I): "I", int(av.video.frame.PictureType.P): "P", int(av.video.frame.PictureType.B): "B"}


class Frame:
    """One decoded frame.

    Attributes
    ----------
    index : int, 0-based position in decode order
    pts : float, presentation time in seconds (index / fps when the stream has none)
    image : (H, W, 3) uint8, BGR. Computed from ``yuv`` on first access
        (and cached) when the frame was decoded on the YUV fast path.
    yuv : (H * 3 / 2, W) uint8 I420 buffer, or None (odd frame sizes, or a
        frame made from a BGR image)
    ts : int or None, presentation time in the stream's ``time_base`` units
        (the exact value to write back when re-encoding)
    decode_ms : float, time spent decoding and converting this frame
    picture_type : "I", "P" or "B": how the input coded this frame (as its
        decoder reports it), or None (unknown, or another type)
    """

    __slots__ = ("index", "pts", "_image", "yuv", "ts", "decode_ms", "width", "height", "picture_type")

    def __init__(self, index: int, pts: float, image: np.ndarray | None = None, *, yuv: np.ndarray | None = None, ts: int | None = None, width: int | None = None, height: int | None = None, decode_ms: float = 0.0, picture_type: str | None = None):
        if image is None and yuv is None:
            raise ValueError("a Frame needs an image or a yuv buffer")
        self.index = index
        self.pts = pts
        self._image = image
        self.yuv = yuv
        self.ts = ts
        self.decode_ms = decode_ms
        self.picture_type = picture_type
        if image is not None:
            self.height, self.width = image.shape[:2]
        else:
            if width is None or height is None:
                raise ValueError("a Frame made from a yuv buffer needs width and height")
            self.width, self.height = int(width), int(height)

    @property
    def image(self) -> np.ndarray:
        if self._image is None:
            self._image = cv2.cvtColor(self.yuv, cv2.COLOR_YUV2BGR_I420)
        return self._image

    @image.setter
    def image(self, value: np.ndarray) -> None:
        self._image = value
        self.yuv = None

    @property
    def has_image(self) -> bool:
        """True when the BGR image exists already (reading ``image`` costs nothing)."""
        return self._image is not None

    @property
    def gray(self) -> np.ndarray:
        """(H, W) uint8 luma: a view of the Y plane on the fast path, else converted from BGR."""
        if self.yuv is not None:
            return i420_planes(self.yuv, self.width, self.height)[0]
        return cv2.cvtColor(self._image, cv2.COLOR_BGR2GRAY)

    def __repr__(self) -> str:
        kind = "yuv" if self.yuv is not None else "bgr"
        return f"Frame(index={self.index}, pts={self.pts:.4f}, {self.width}x{self.height} {kind})"

    def __eq__(self, other) -> bool:
        if not isinstance(other, Frame):
            return NotImplemented
        return self.index == other.index and self.pts == other.pts and np.array_equal(self.image, other.image)


def _is_url(path: str) -> bool:
    return "://" in path


#: file name endings of the frames a folder may hold (:class:`VideoSource`)
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")


def _image_sequence(folder: str) -> tuple[int, str]:
    """(number of frames, their suffix) of a folder of numbered images, which
    must sort by name in frame order (zero-padded numbers). InputError
    otherwise."""
    names = sorted(n for n in os.listdir(folder) if n.lower().endswith(IMAGE_SUFFIXES) and not n.startswith("."))
    if not names:
        raise InputError(f"{folder} is a folder without images ({', '.join(IMAGE_SUFFIXES)}): give a video file or a folder of numbered frames")
    suffixes = {os.path.splitext(n)[1] for n in names}
    if len(suffixes) > 1:
        raise InputError(f"{folder} holds images of several kinds ({', '.join(sorted(suffixes))}): one kind of numbered frames a folder")

    def natural(n):
        return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", n)]

    if sorted(names, key=natural) != names:
        raise InputError(f"{folder}: the frames' names do not sort in frame order (number them with zero padding: frame_0001{suffixes.pop()}, ...)")
    return len(names), suffixes.pop()


class VideoSource:
    """Decode a video file, URL (rtsp/http/udp...), device, or a folder of
    numbered frames (in name order, zero-padded numbers, 25 fps unless the
    ``framerate`` option says otherwise) with PyAV.

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
    open_timeout : float, optional
        Seconds to wait for a network source to open (URLs only).
    read_timeout : float, optional
        Seconds without data after which reading a network source stops
        (URLs only; default None: wait for ever). The stop is recorded in
        ``errors`` and ``read_error`` and the frames still in the decoder are
        delivered; :class:`ReconnectingSource` uses it to notice a stalled source.

    Attributes
    ----------
    read_error : str or None
        Why reading stopped before the end of the stream, in a few words (a
        read timeout: "no data for 10 s (timed out)", a dropped connection,
        a damaged container), or None after a clean end. ``errors`` says it too.

    Raises
    ------
    InputError
        Missing file, not a video, or no video stream.
    """

    def __init__(self, path, *, threads: bool = True, options: dict | None = None, format: str | None = None, open_timeout: float | None = 10.0, read_timeout: float | None = None):
        self.path = os.fspath(path)
        self._reformatter = VideoReformatter()  # frames of other pixel formats -> I420 (to_i420)
        is_url = _is_url(self.path)
        if not is_url and format is None and not os.path.exists(self.path):
            raise InputError(f"input not found: {self.path}")
        sequence = None
        if not is_url and format is None and os.path.isdir(self.path):
            # a folder of numbered frames: FFmpeg's image sequence demuxer, in name order
            sequence = _image_sequence(self.path)
            format = "image2"
            options = {"pattern_type": "glob", "framerate": "25", **(options or {})}
            self.path = os.path.join(self.path, "*" + sequence[1])
        kwargs = {}
        self.read_timeout = read_timeout if is_url and read_timeout else None
        if is_url and (open_timeout or self.read_timeout):
            kwargs["timeout"] = (open_timeout or None, self.read_timeout)
        try:
            self.container = av.open(self.path, mode="r", options=options or {}, format=format, **kwargs)
        except (av.error.FFmpegError, OSError, ValueError) as exc:
            raise InputError(f"cannot open {self.path} as a video: {_reason(exc, open_timeout)}") from None
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
        sar = self.stream.sample_aspect_ratio or cc.sample_aspect_ratio
        #: a pixel's width over its height (the stream's sample aspect ratio; 1 when unset)
        self.pixel_aspect = float(sar) if sar and float(sar) > 0 else 1.0
        self.time_base = self.stream.time_base
        self.frame_count = int(self.stream.frames or 0) or (sequence[0] if sequence else 0)  # 0 when the container does not say
        self.is_live = is_url or (format is not None and sequence is None)
        self.errors: list[str] = []
        self.read_error: str | None = None
        self._read_error_entry: str | None = None
        self.frames_decoded = 0
        self.packets_skipped = 0
        self._reading = False
        self._reader = None

    def __enter__(self) -> "VideoSource":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Close the container (not while another thread is still inside :meth:`frames`:
        a reader stuck on a stalled network source is left to the process exit)."""
        if self._reading and self._reader is not threading.current_thread():
            return
        try:
            self.container.close()
        except Exception:  # closing a broken container must not mask the real error
            pass

    @property
    def audio_stream(self):
        """The first audio stream, or None."""
        return self.container.streams.audio[0] if self.container.streams.audio else None

    @property
    def yuv_fast_path(self) -> bool:
        """Frames come as I420 (even frame sizes)."""
        return self.width % 2 == 0 and self.height % 2 == 0

    def __iter__(self) -> Iterator[Frame]:
        return self.frames()

    def frames(self, on_audio: Callable | None = None, stop: Callable[[], bool] | None = None) -> Iterator[Frame]:
        """Decode the video stream.

        Parameters
        ----------
        on_audio : callable(av.Packet), optional
            Receives every packet of the first audio stream, in demux order,
            interleaved with the frames (for a sink to copy through).
        stop : callable() -> bool, optional
            Polled between packets; iteration ends when it returns True.

        Yields
        ------
        Frame, in presentation order, ``index`` counting from 0.
        """
        self._reading, self._reader = True, threading.current_thread()
        try:
            yield from self._frames(on_audio, stop)
        finally:
            self._reading = False

    def _frames(self, on_audio, stop) -> Iterator[Frame]:
        audio = self.audio_stream if on_audio is not None else None
        streams = [self.stream] + ([audio] if audio is not None else [])
        index = 0
        bad_run = 0
        demux = self.container.demux(*streams)
        while True:
            if stop is not None and stop():
                return
            t0 = time.perf_counter()
            try:
                packet = next(demux)
            except StopIteration:
                break
            except (av.error.FFmpegError, OSError, ValueError, EOFError) as exc:
                self.read_error = _reason(exc, self.read_timeout)
                self._read_error_entry = f"reading stopped after frame {index}: {self.read_error}"
                self.errors.append(self._read_error_entry)
                packet = None
            if packet is None:  # the container cannot be read further: drain the decoder
                try:
                    decoded = self.stream.codec_context.decode(None)
                except (av.error.FFmpegError, ValueError):
                    decoded = []
                for vf in decoded:
                    yield self._frame(vf, index, t0)
                    index += 1
                    self.frames_decoded = index
                break
            if packet.stream is not self.stream:
                if packet.dts is not None:
                    on_audio(packet)
                continue
            try:
                decoded = packet.decode()  # the final empty packet flushes the decoder
                bad_run = 0
            except (av.error.FFmpegError, ValueError) as exc:
                self.packets_skipped += 1
                bad_run += 1
                if self.packets_skipped <= 3:
                    t = float(packet.pts * packet.time_base) if packet.pts is not None and packet.time_base else None
                    where = f"at {t:.3f} s" if t is not None else f"after frame {index}"
                    self.errors.append(f"skipped an undecodable packet {where}: {_reason(exc)}")
                if bad_run >= MAX_BAD_PACKETS:
                    self.errors.append(f"gave up after {bad_run} undecodable packets in a row (frame {index})")
                    break
                continue
            for vf in decoded:
                yield self._frame(vf, index, t0)
                t0 = time.perf_counter()
                index += 1
                self.frames_decoded = index
        if self.packets_skipped > 3:
            self.errors.append(f"{self.packets_skipped} undecodable packets skipped in all")
        if not self.is_live and self.frame_count and index < self.frame_count:
            self.errors.append(f"decoded {index} of the {self.frame_count} frames the container lists; {self.frame_count - index} missing (truncated or corrupt file?)")

    def _frame(self, vf: av.VideoFrame, index: int, t0: float) -> Frame:
        tb = vf.time_base if vf.time_base is not None else self.time_base  # frames drained from the decoder have none
        if vf.pts is not None and tb is not None:
            t = float(vf.pts * tb)
            ts = int(vf.pts)
        else:
            t = index / self.fps
            ts = None
        w, h = vf.width, vf.height
        kind = _PICTURE_TYPES.get(int(vf.pict_type))
        if (w, h) != (self.width, self.height):  # mid-stream size change: keep the first size
            vf = vf.reformat(width=self.width, height=self.height)
            w, h = self.width, self.height
        if w % 2 == 0 and h % 2 == 0:
            if vf.format.name != "yuv420p":
                vf = to_i420(vf, self._reformatter)
            return Frame(index, t, yuv=vf.to_ndarray(), ts=ts, width=w, height=h, decode_ms=(time.perf_counter() - t0) * 1e3, picture_type=kind)
        return Frame(index, t, vf.to_ndarray(format="bgr24"), ts=ts, decode_ms=(time.perf_counter() - t0) * 1e3, picture_type=kind)


def to_i420(vf: av.VideoFrame, reformatter: VideoReformatter) -> av.VideoFrame:
    """A decoded frame of another pixel format (JPEG's full-range yuvj420p, PNG's
    rgb24, ...) as limited-range yuv420p, the planes the pipeline reads as
    BT.601 video levels (16-235, :data:`cv2.COLOR_YUV2BGR_I420`).

    The range is set explicitly: PyAV's reformatter leaves it unspecified by
    default, and swscale then copies full-range levels into the limited-range
    planes, which the pipeline stretches by 255/219 (the Premier League JPEG
    frames came out 1.15 x - 17 levels in grey, faint lines brighter against
    their box mean by that factor). ``reformatter``: the source's own (it keeps
    its scaler between frames; not shared across threads)."""
    return reformatter.reformat(vf, format="yuv420p", dst_color_range="MPEG")


#: Seconds without data after which a network source counts as stalled, and the
#: longest a (re)connection may take (``arstream stream --timeout``).
DEFAULT_TIMEOUT = 10.0

#: Seconds a lost network source is tried again before giving up (``arstream stream --reconnect``).
DEFAULT_RECONNECT = 30.0

#: First and longest wait (seconds) between reconnection attempts; each wait doubles the one before.
RECONNECT_BACKOFF = (0.5, 8.0)


def reconnect_wait(attempt: int, backoff: tuple[float, float] = RECONNECT_BACKOFF) -> float:
    """Seconds to wait before reconnection attempt ``attempt`` (1-based): ``first * 2**(attempt - 1)``, at most ``longest``.

    >>> [reconnect_wait(n) for n in range(1, 7)]
    [0.5, 1.0, 2.0, 4.0, 8.0, 8.0]
    """
    first, longest = backoff
    return min(first * 2.0 ** (attempt - 1), longest)


class ReconnectingSource:
    """A network source (URL) that survives stalls and drops.

    Reads like a :class:`VideoSource` (same attributes; iterate or call
    :meth:`frames`). Reading stops when no data comes for ``timeout`` seconds
    or the connection fails (the frames still in the decoder are delivered
    first); the URL is then opened again, after waits of 0.5, 1, 2, 4, 8, 8, ...
    seconds (:func:`reconnect_wait`), until a connection delivers a frame or
    ``reconnect`` seconds have passed since the loss (the last attempt is made
    at the end of that window; each attempt may take up to ``timeout``, so the
    source gives up at most ``reconnect + timeout`` seconds after the loss). Frames go on as if
    nothing happened: ``index`` counts on from the last frame, and ``pts`` /
    ``ts`` go on one frame interval after the last frame (the outage leaves no
    gap in the timeline, and a source whose clock restarted still moves
    forward). A clean end of the stream (an HTTP body read to its end, an RTSP
    stream the server ended) ends the iteration as a file's end does.

    Each loss, failed attempt and reconnection is one line to ``report``:
    what happened, the attempt number and the next wait. Giving up raises
    :class:`~arstream.errors.SourceLost` after the last frame, so the outputs
    of a pipeline hold every frame that was read.

    Parameters
    ----------
    url : str, anything FFmpeg opens over a network (http://, rtsp://, udp://, srt://, ...)
    reconnect : float, seconds to go on trying after a loss; 0: no
        reconnection (a loss raises SourceLost at once)
    timeout : float, seconds without data that count as a stall; also the
        longest each (re)connection may take
    options, format, threads : as :class:`VideoSource`
    report : callable(str), optional, receives the event lines (default: stderr)

    Raises
    ------
    InputError
        The first connection fails (nothing is retried before the stream ran).
    ValueError
        ``reconnect`` not a finite number >= 0, or ``timeout`` not > 0.

    The audio of a reconnecting source is not passed on (``audio_stream`` is
    None): its timestamps would not follow the video's across a reconnection.
    """

    def __init__(self, url, *, reconnect: float = DEFAULT_RECONNECT, timeout: float = DEFAULT_TIMEOUT, options: dict | None = None, format: str | None = None, threads: bool = True, report: Callable[[str], None] | None = None):
        if not (isinstance(reconnect, (int, float)) and math.isfinite(reconnect) and reconnect >= 0):
            raise ValueError(f"reconnect must be 0 (off) or a number of seconds, got {reconnect!r}")
        if not (isinstance(timeout, (int, float)) and math.isfinite(timeout) and timeout > 0):
            raise ValueError(f"timeout must be a number of seconds > 0, got {timeout!r}")
        self.path = os.fspath(url)
        if not _is_url(self.path):
            raise ValueError(f"a reconnecting source needs a URL (such as http://, rtsp://, udp://), got {self.path!r}")
        self.reconnect = float(reconnect)
        self.timeout = float(timeout)
        self._open_args = dict(options=options, format=format, threads=threads)
        self.report = report or (lambda msg: print(f"arstream: warning: {msg}", file=sys.stderr))
        self._src = self._connect()
        first = self._src
        self.width, self.height = first.width, first.height
        self.rate, self.fps, self.time_base = first.rate, first.fps, first.time_base
        self.frame_count = 0
        self.is_live = True
        self.errors: list[str] = []
        self.frames_decoded = 0
        #: successful reconnections so far
        self.reconnections = 0
        self._reading = False
        self._reader = None

    audio_stream = None

    def _connect(self) -> VideoSource:
        return VideoSource(self.path, open_timeout=self.timeout, read_timeout=self.timeout, **self._open_args)

    def __enter__(self) -> "ReconnectingSource":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Close the connection (not while another thread is still reading; see :meth:`VideoSource.close`)."""
        if self._reading and self._reader is not threading.current_thread():
            return
        self._src.close()

    @property
    def yuv_fast_path(self) -> bool:
        """Frames come as I420 (even frame sizes)."""
        return self.width % 2 == 0 and self.height % 2 == 0

    def __iter__(self) -> Iterator[Frame]:
        return self.frames()

    def frames(self, on_audio: Callable | None = None, stop: Callable[[], bool] | None = None) -> Iterator[Frame]:
        """Decode the stream across reconnections.

        Parameters
        ----------
        on_audio : ignored (no audio from a reconnecting source)
        stop : callable() -> bool, optional
            Polled between packets and during the waits between attempts;
            iteration ends when it returns True.

        Yields
        ------
        Frame, ``index`` counting from 0 without a gap or a repeat across
        reconnections, ``pts`` (and ``ts``, in units of ``time_base``) strictly increasing.

        Raises
        ------
        SourceLost
            After the last frame, when the source was lost and did not come back.
        """
        self._reading, self._reader = True, threading.current_thread()
        try:
            yield from self._frames(stop)
        finally:
            self._reading = False

    def _frames(self, stop) -> Iterator[Frame]:
        stopped = stop or (lambda: False)
        tb0 = Fraction(self.time_base) if self.time_base else None
        index = 0
        last_t: Fraction | None = None  # output time (seconds) of the last frame delivered
        outage = None  # (monotonic time of the loss, attempts made) while the source is lost
        src = self._src
        while True:
            tb = Fraction(src.time_base) if src.time_base else None
            shift = None
            for f in src.frames(stop=stop):
                t = Fraction(f.ts) * tb if f.ts is not None and tb is not None else Fraction(f.pts)
                if shift is None:  # the first frame of this connection follows the last one delivered
                    shift = Fraction(0) if last_t is None else last_t + 1 / self.rate - t
                    outage = None
                t += shift
                f.index, f.pts = index, float(t)
                f.ts = round(t / tb0) if f.ts is not None and tb0 is not None else None
                last_t = t
                index += 1
                self.frames_decoded = index
                yield f
            self.errors.extend(e for e in src.errors if e is not src._read_error_entry)
            if stopped() or src.read_error is None:  # stopped, or the stream ended cleanly
                return
            src.close()
            src, outage = self._reconnect(src.read_error, index, outage, stopped)
            if src is None:
                return
            self._src = src

    def _reconnect(self, why: str, index: int, outage, stopped) -> tuple[VideoSource | None, tuple]:
        """Open the URL again: (source, outage), (None, outage) when stopped while
        waiting; SourceLost when the window is over."""
        where = f"after frame {index - 1}" if index else "before any frame"
        if outage is None:
            if self.reconnect <= 0:
                raise SourceLost(f"lost the source {self.path}: {why} {where}; reconnection is off")
            outage = (time.monotonic(), 0)
            wait = min(reconnect_wait(1), self.reconnect)
            self.report(f"lost the source {self.path}: {why} {where}; reconnecting for up to {self.reconnect:g} s, attempt 1 in {wait:.1f} s")
        else:  # a connection that came back dropped again before a frame
            t0, attempts = outage
            left = self.reconnect - (time.monotonic() - t0)
            if left <= 0:
                raise SourceLost(f"lost the source {self.path}: {why} {where}; gave up after {attempts} reconnection attempts in {time.monotonic() - t0:.1f} s")
            wait = min(reconnect_wait(attempts + 1), left)
            self.report(f"the source {self.path} dropped again before a frame ({why}); attempt {attempts + 1} in {wait:.1f} s ({left:.1f} s left)")
        t0, attempts = outage
        while True:
            if _sleep(wait, stopped):
                return None, outage
            attempts += 1
            outage = (t0, attempts)
            try:
                src = self._connect()
            except InputError as exc:
                reason = str(exc)
            else:
                self.reconnections += 1
                if (src.width, src.height) != (self.width, self.height):
                    self.report(f"the source {self.path} came back at {src.width}x{src.height}; its frames are scaled to {self.width}x{self.height}")
                    src.width, src.height = self.width, self.height  # VideoSource._frame scales to its width and height
                self.report(f"reconnected to {self.path} on attempt {attempts}, {time.monotonic() - t0:.1f} s after the loss; frames go on from {index}")
                return src, outage
            elapsed = time.monotonic() - t0
            left = self.reconnect - elapsed
            if left <= 0:
                raise SourceLost(f"lost the source {self.path}: {why} {where}; gave up after {attempts} reconnection attempts in {elapsed:.1f} s (last: {reason})")
            wait = min(reconnect_wait(attempts + 1), left)
            self.report(f"reconnection attempt {attempts} to {self.path} failed ({reason}); attempt {attempts + 1} in {wait:.1f} s ({left:.1f} s left)")


def open_live(path, *, format: str | None = None, options: dict | None = None, reconnect: float = DEFAULT_RECONNECT, timeout: float = DEFAULT_TIMEOUT, report: Callable[[str], None] | None = None) -> "VideoSource | ReconnectingSource":
    """The source of live mode: a :class:`ReconnectingSource` for a URL, else
    (a file, or a device with ``format``) a :class:`VideoSource`.

    ``reconnect``, ``timeout`` and ``report`` apply to URLs only (see :class:`ReconnectingSource`).
    """
    if _is_url(os.fspath(path)):
        return ReconnectingSource(path, reconnect=reconnect, timeout=timeout, options=options, format=format, report=report)
    return VideoSource(path, options=options, format=format)


def _sleep(seconds: float, stopped: Callable[[], bool]) -> bool:
    """Wait ``seconds``, polling ``stopped`` every 50 ms; True when it said stop."""
    end = time.monotonic() + seconds
    while (left := end - time.monotonic()) > 0:
        if stopped():
            return True
        time.sleep(min(left, 0.05))
    return stopped()


def _reason(exc: BaseException, timeout: float | None = None) -> str:
    """One line saying why an FFmpeg call failed; ``timeout``: the seconds after
    which PyAV interrupted it (FFmpeg's "Immediate exit requested")."""
    if isinstance(exc, av.error.ExitError) and timeout:
        return f"no data for {timeout:g} s (timed out)"
    msg = getattr(exc, "strerror", None) or str(exc).strip() or type(exc).__name__
    return str(msg).splitlines()[0]


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


def image_frames(spec, *, fps: float = 25.0) -> tuple[list[str], Iterator[Frame]] | None:
    """Frames of still images: one image, a folder of images, or a glob.

    ``spec`` names a single image file (PNG, JPEG, ...: one frame, index 0), a
    folder (every image file in it) or a glob pattern (``frames/frame_*.jpg``).
    The files are taken in natural order (``frame_2`` before ``frame_10``);
    a frame's index is its position and its time ``index / fps``.

    Returns
    -------
    ``(paths, frames)``: the image files in order and an iterator of
    :class:`Frame` (BGR images, read one at a time); None when ``spec`` is
    none of these (a video file, a URL, a device), for :class:`VideoSource`.

    Raises
    ------
    InputError
        A missing image, a glob or folder without images; while iterating, a
        file that does not read as an image or whose size differs from the first.
    """
    import glob
    import re

    from arstream.framein import IMAGE_EXT

    spec = os.fspath(spec)
    is_image = os.path.splitext(spec)[1].lower() in IMAGE_EXT
    if _is_url(spec):
        return None
    if any(c in spec for c in "*?["):
        paths = [p for p in glob.glob(spec) if os.path.isfile(p)]
        if not paths:
            raise InputError(f"no files match {spec}")
    elif os.path.isdir(spec):
        paths = [e.path for e in os.scandir(spec) if e.is_file() and os.path.splitext(e.name)[1].lower() in IMAGE_EXT]
        if not paths:
            raise InputError(f"no images ({', '.join(sorted(IMAGE_EXT))}) in the folder {spec}")
    elif is_image:
        if not os.path.exists(spec):
            raise InputError(f"input not found: {spec}")
        paths = [spec]
    else:
        return None
    paths.sort(key=lambda p: [int(s) if s.isdigit() else s for s in re.split(r"(\d+)", p)])

    def frames() -> Iterator[Frame]:
        size = None
        for i, p in enumerate(paths):
            img = cv2.imread(p, cv2.IMREAD_COLOR)
            if img is None:
                raise InputError(f"cannot read {p} as an image")
            if size is None:
                size = img.shape[:2]
            elif img.shape[:2] != size:
                raise InputError(f"{p} is {img.shape[1]}x{img.shape[0]}, the first image {paths[0]} is {size[1]}x{size[0]}")
            yield Frame(i, i / fps, img)

    return paths, frames()
