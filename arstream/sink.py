"""Sinks: H.264 encode with PyAV, and JSON-lines writers (``cameras.jsonl``,
``truth.jsonl``).

Sinks are context managers: on leaving the ``with`` block — normally, on an
exception or on Ctrl-C — the encoder is flushed and the container trailer
written, so the file is always playable up to the last frame written, and
JSON-lines files are complete up to the last record. Outputs are written to
a temporary name beside the target and renamed into place on close, so a
file with the final name is never half-written.
"""

from __future__ import annotations

import contextlib
import functools
import json
import math
import os
import subprocess
import sys
from fractions import Fraction

import av
import numpy as np

from arstream.errors import InputError

__all__ = ["VideoSink", "JsonlWriter", "read_jsonl", "atomic_path", "x264_capabilities", "x264_reproducible_params"]

#: Opens a tiny libx264 encoder with FFmpeg's log captured and prints the CPU
#: capabilities x264 reports (``using cpu capabilities: MMX2 SSE2Fast ...``).
_X264_PROBE = """
import os, tempfile, av, av.logging
av.logging.set_level(av.logging.INFO)
with tempfile.TemporaryDirectory() as d, av.logging.Capture(True) as logs:
    with av.open(os.path.join(d, "probe.mp4"), "w") as out:
        s = out.add_stream("libx264", rate=25)
        s.width = s.height = 64
        s.pix_fmt = "yuv420p"
        s.codec_context.open()
for _, name, msg in logs:
    if name == "libx264" and msg.startswith("using cpu capabilities:"):
        print(msg.split(":", 1)[1].strip())
"""


@functools.lru_cache(maxsize=1)
def x264_capabilities() -> tuple[str, ...]:
    """libx264's CPU capabilities on this processor, as x264 names them when an
    encoder opens (e.g. ``("MMX2", "SSE2Fast", ..., "AVX2", "AVX512")``); ``()``
    where they cannot be learnt.

    x264 says them only in FFmpeg's log. The probe runs once per process, in
    a child process: capturing FFmpeg's log in this one routes every
    decoder's log through Python while it lasts, and freeing a
    frame-threaded decoder whose thread then waits for the GIL hangs the
    process (PyAV issues #909 and #367)."""
    try:
        r = subprocess.run([sys.executable, "-c", _X264_PROBE], capture_output=True, text=True, timeout=120)
    except (OSError, subprocess.SubprocessError):
        return ()
    return tuple(r.stdout.split()) if r.returncode == 0 else ()


def x264_reproducible_params() -> str | None:
    """libx264's ``x264-params`` for an encode that gives the same bytes on every
    run: its CPU capabilities less AVX-512 (``"asm=MMX2,SSE2Fast,...,AVX2"``),
    or None where x264 uses no AVX-512 here (its choice is then reproducible).

    x264's AVX-512 code reads memory it never wrote at some frame sizes
    (320 x 180, 720 x 576, 1366 x 768; not 1280 x 720 or 1920 x 1080), so two
    encodes of the same pictures may differ in a few pixels; without it they
    do not, for about 6 % more x264 CPU at 720p (bench/README.md,
    "Reproducible encodes"). The list is the processor's own: ``asm=``
    replaces x264's detection, and a capability the processor lacks would
    crash the encoder."""
    caps = x264_capabilities()
    if not any(c.upper().startswith("AVX512") for c in caps):
        return None
    return "asm=" + ",".join(c for c in caps if not c.upper().startswith("AVX512"))


def atomic_path(path: str) -> str:
    """Temporary name beside ``path`` used until the output is complete
    (keeps the extension, so muxers still recognise the format)."""
    d, name = os.path.split(os.path.abspath(path))
    stem, ext = os.path.splitext(name)
    return os.path.join(d, f".{stem}.partial{ext}")


def _prepare_dir(path: str) -> None:
    d = os.path.dirname(os.path.abspath(path))
    try:
        os.makedirs(d, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create output folder {d}: {exc.strerror}") from None


def _open_tmp(path: str, tmp: str, mode: str):
    """Open ``tmp`` (the temporary name of the output ``path``) for writing; an
    ``InputError`` naming ``path`` when the file system refuses (e.g. under
    /proc, a read-only folder), instead of an errno naming nothing or the
    temporary name."""
    try:
        return open(tmp, mode, **({} if "b" in mode else {"encoding": "utf-8"}))
    except OSError as exc:
        raise InputError(f"cannot write {path}: {exc.strerror or exc}") from None


def _reason(exc: BaseException) -> str:
    msg = getattr(exc, "strerror", None) or str(exc).strip() or type(exc).__name__
    return msg.splitlines()[0]


def _format_for(path: str) -> str | None:
    """The muxer for ``path``'s extension; a clear error for one FFmpeg does not know."""
    ext = os.path.splitext(path)[1].lower()
    if not ext:
        raise InputError(f"cannot write {path}: give the file an extension (.mp4, .mkv, .mov)")
    return None


class VideoSink:
    """Encode BGR frames to H.264 (libx264, yuv420p) with PyAV.

    Parameters
    ----------
    path : str, output file (.mp4, .mkv, ...)
    width, height : int, frame size (even numbers are padded by the encoder's
        requirements: odd sizes are rejected with a clear error)
    rate : Fraction or float, frame rate
    crf : int, x264 constant rate factor (lower is better quality)
    preset : str, x264 preset
    time_base : Fraction, optional, stream time base (defaults to 1/rate)
    audio_from : av.audio.stream.AudioStream, optional
        An input audio stream to copy through unchanged (use :meth:`mux_audio`).
    threads : int, encoder threads (0 = auto)
    keep_b_frames : bool
        Code a frame that the input coded as a B-frame (``picture_type="B"``
        to :meth:`write` / :meth:`write_yuv`) as a B-frame too, instead of
        leaving every frame's type to x264. A re-encode that keeps the
        input's frame pattern predicts from the frames the input's encoder
        predicted from: fewer bits and less generation loss at the same
        ``crf``, and less work for x264 (on the wide preset with the demo
        scene: 34 % smaller, 2 dB closer to the frames given, about 18 % less
        x264 CPU). Only B-frames are followed: an input without them (all
        intra, or I and P only) is left to x264, and a B that x264's settings
        cannot take (the first frame, a run longer than the preset's B-frame
        limit, or a preset without B-frames) is made a P by x264 itself.
    sample_aspect : Fraction, optional, the pixels' aspect ratio written into
        the stream (width over height of one pixel; None: leave it unset, 1:1)
    reproducible : bool
        Encode the same frames to the same bytes on every run
        (:func:`x264_reproducible_params`: x264 without its AVX-512 code, about
        6 % more x264 CPU at 720p). The synthetic clips are made so, since
        benchmarks and tests compare runs on them; ``arstream process`` is
        not (its frames and cameras are reproducible, x264's bytes at some
        sizes not).
    """

    def __init__(
        self,
        path,
        width: int,
        height: int,
        rate,
        *,
        crf: int = 20,
        preset: str = "veryfast",
        time_base: Fraction | None = None,
        audio_from=None,
        threads: int = 0,
        keep_b_frames: bool = True,
        sample_aspect: Fraction | None = None,
        reproducible: bool = False,
    ):
        self.path = os.fspath(path)
        if width <= 0 or height <= 0:
            raise InputError(f"invalid frame size {width}x{height}")
        _prepare_dir(self.path)
        self.tmp = atomic_path(self.path)
        self.rate = Fraction(rate).limit_denominator(100000)
        fmt = _format_for(self.path)
        _open_tmp(self.path, self.tmp, "wb").close()  # FFmpeg opens the file only at the first packet
        try:
            self.container = av.open(self.tmp, mode="w", format=fmt)
        except (av.error.FFmpegError, OSError, ValueError) as exc:
            with contextlib.suppress(OSError):
                os.remove(self.tmp)
            raise InputError(f"cannot write {self.path}: {_reason(exc)}") from None
        self.stream = self.container.add_stream("libx264", rate=self.rate)
        self.stream.width = width + (width % 2)
        self.stream.height = height + (height % 2)
        self.stream.pix_fmt = "yuv420p"
        # Frame timestamps are in ``self.time_base`` (the input's, to keep its timing
        # exactly); PyAV rebases them to the encoder's and then the muxer's time base.
        self.time_base = Fraction(time_base) if time_base else Fraction(1, 1) / self.rate
        self.stream.time_base = self.time_base
        self.stream.codec_context.time_base = self.time_base
        params = x264_reproducible_params() if reproducible else None
        self.stream.options = {"crf": str(crf), "preset": preset, **({"x264-params": params} if params else {})}
        if sample_aspect is not None:
            self.stream.codec_context.sample_aspect_ratio = Fraction(sample_aspect)  # e.g. 64:45, anamorphic 16:9 PAL
        self.stream.codec_context.thread_count = threads
        self.width, self.height = width, height
        self.keep_b_frames = bool(keep_b_frames)
        self.audio_out = None
        if audio_from is not None:
            self.audio_out = self.container.add_stream_from_template(audio_from)
        self.frames_written = 0
        self.audio_packets = 0
        self._last_pts = None
        self._closed = False

    def __enter__(self) -> "VideoSink":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def write(self, image: np.ndarray, pts: float | None = None, *, ts: int | None = None, picture_type: str | None = None) -> None:
        """Encode one BGR uint8 (H, W, 3) frame.

        ``pts`` in seconds (default: index / rate), or ``ts`` in units of the
        sink's ``time_base`` (exact; wins over ``pts``). ``picture_type``: how
        the input coded this frame ("I", "P", "B" or None; see ``keep_b_frames``).
        """
        if image.shape[:2] != (self.height, self.width):
            raise ValueError(f"frame is {image.shape[1]}x{image.shape[0]}, sink expects {self.width}x{self.height}")
        if (self.stream.width, self.stream.height) != (self.width, self.height):
            image = np.pad(image, ((0, self.stream.height - self.height), (0, self.stream.width - self.width), (0, 0)), mode="edge")
        vf = av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format="bgr24")
        self._encode(vf, pts, ts, picture_type)

    def write_yuv(self, yuv: np.ndarray, pts: float | None = None, *, ts: int | None = None, picture_type: str | None = None) -> None:
        """Encode one I420 frame ((H * 3 / 2, W) uint8, see :func:`arstream.source.i420_planes`).

        The fast path: no colour conversion (even frame sizes only). Timing and
        ``picture_type`` as :meth:`write`.
        """
        if yuv.shape != (self.height * 3 // 2, self.width) or self.width % 2 or self.height % 2:
            raise ValueError(f"I420 buffer is {yuv.shape}, sink expects {(self.height * 3 // 2, self.width)} (even sizes only)")
        self._encode(av.VideoFrame.from_numpy_buffer(np.ascontiguousarray(yuv), format="yuv420p"), pts, ts, picture_type)

    def _encode(self, vf, pts, ts, picture_type) -> None:
        if picture_type == "B" and self.keep_b_frames:
            vf.pict_type = av.video.frame.PictureType.B  # libx264 takes it as the frame's type (X264_TYPE_B)
        tb = self.time_base
        if ts is not None:
            vf.pts = int(ts)
        elif pts is None:
            vf.pts = int(round(self.frames_written / self.rate / tb))
        else:
            vf.pts = int(round(pts / tb))
        if self._last_pts is not None and vf.pts <= self._last_pts:
            vf.pts = self._last_pts + 1  # the encoder needs strictly increasing timestamps
        self._last_pts = vf.pts
        vf.time_base = tb
        for packet in self.stream.encode(vf):
            self.container.mux(packet)
        self.frames_written += 1

    def mux_audio(self, packet) -> None:
        """Copy one demuxed audio packet through unchanged."""
        if self.audio_out is None or packet.dts is None:
            return
        packet.stream = self.audio_out
        self.container.mux(packet)
        self.audio_packets += 1

    def close(self, *, keep: bool = True) -> None:
        """Flush the encoder, write the trailer and move the file into place.

        ``keep=False`` discards the output (nothing is left under the final name).
        """
        if self._closed:
            return
        self._closed = True
        try:
            for packet in self.stream.encode(None):
                self.container.mux(packet)
        finally:
            self.container.close()
        if keep and self.frames_written > 0:
            os.replace(self.tmp, self.path)
        else:
            try:
                os.remove(self.tmp)
            except FileNotFoundError:
                pass


def _json_default(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating,)):
        return float(o)
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, np.bool_):
        return bool(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def _check_finite(obj, where: str) -> None:
    if isinstance(obj, float) and not math.isfinite(obj):
        raise ValueError(f"refusing to write a non-finite number in {where}")
    if isinstance(obj, dict):
        for k, v in obj.items():
            _check_finite(v, f"{where}.{k}")
    elif isinstance(obj, (list, tuple)):
        for v in obj:
            _check_finite(v, where)


class JsonlWriter:
    """Write one JSON object per line; flushed per record, renamed into place on close.

    NaN or infinite numbers raise ``ValueError`` (DESIGN: never NaNs in output).
    """

    def __init__(self, path):
        self.path = os.fspath(path)
        _prepare_dir(self.path)
        self.tmp = atomic_path(self.path)
        self.f = _open_tmp(self.path, self.tmp, "w")
        self.count = 0

    def __enter__(self) -> "JsonlWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def write(self, record: dict) -> None:
        try:
            line = json.dumps(record, default=_json_default, allow_nan=False, separators=(",", ":"))
        except ValueError:
            _check_finite(json.loads(json.dumps(record, default=_json_default)), "record")  # names the key
            raise
        self.f.write(line + "\n")
        self.f.flush()
        self.count += 1

    def close(self) -> None:
        if self.f.closed:
            return
        self.f.close()
        os.replace(self.tmp, self.path)


def read_jsonl(path) -> list[dict]:
    """Read a JSON-lines file; a clear ``InputError`` for a missing file or a bad line."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise InputError(f"file not found: {path}")
    out = []
    with open(path, encoding="utf-8") as f:
        for i, line in enumerate(f, 1):
            line = line.strip()
            if not line:
                continue
            try:
                out.append(json.loads(line))
            except json.JSONDecodeError as exc:
                raise InputError(f"{path}:{i}: not valid JSON ({exc.msg})") from None
    return out
