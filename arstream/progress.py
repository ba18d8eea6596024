"""A small terminal progress bar (frames, fps, ETA) that stays quiet off a terminal."""

from __future__ import annotations

import sys
import time


class Progress:
    """Progress over ``total`` items (0 or None: unknown), redrawn at most 4 times a second
    when ``stream`` is a terminal; silent otherwise.

    The rate is counted from the first :meth:`update` (the first item done), not
    from the bar's creation, so that set-up before the work (opening the input,
    the GL context, loading the compiled kernels) does not lower it. A caller
    that measured the run itself gives its own count and seconds to
    :meth:`finish`, and the final bar shows exactly that rate (``arstream
    process``: the summary line's fps)."""

    def __init__(self, total: int | None, *, label: str = "", stream=None):
        self.total = total or 0
        self.label = label
        self.stream = stream or sys.stderr
        self.enabled = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.start = time.perf_counter()
        self.first: tuple[float, int] | None = None  # (time, done) of the first update
        self.last = 0.0
        self.done = 0
        self.final_fps: float | None = None

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc) -> None:
        if self.enabled:
            self._draw(final=True)
            self.stream.write("\n")
            self.stream.flush()

    @property
    def fps(self) -> float:
        """Items a second since the first update (the final rate after :meth:`finish`)."""
        if self.final_fps is not None:
            return self.final_fps
        if self.first is None:
            return 0.0
        t0, d0 = self.first
        dt = time.perf_counter() - t0
        return (self.done - d0) / dt if dt > 0 else 0.0

    def finish(self, done: int, seconds: float) -> None:
        """The run's own count and wall time: the final bar shows ``done`` and
        ``done / seconds`` (the rate the run's summary reports)."""
        self.done = done
        self.final_fps = done / seconds if seconds > 0 else 0.0

    def update(self, done: int, total: int | None = None) -> None:
        now = time.perf_counter()
        if self.first is None:
            self.first = (now, done)
        self.done = done
        if total:
            self.total = total
        if self.enabled and now - self.last >= 0.25:
            self.last = now
            self._draw()

    def _draw(self, final: bool = False) -> None:
        fps = self.fps
        if self.total:
            frac = min(self.done / self.total, 1.0)
            bar = "#" * int(frac * 30)
            eta = (self.total - self.done) / fps if fps > 0 else 0.0
            text = f"\r{self.label} [{bar:<30s}] {self.done}/{self.total} {fps:6.1f} fps ETA {eta:5.1f}s"
        else:
            text = f"\r{self.label} {self.done} frames {fps:6.1f} fps"
        self.stream.write(text)
        self.stream.flush()
