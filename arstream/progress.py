"""A small terminal progress bar (frames, fps, ETA) that stays quiet off a terminal."""

from __future__ import annotations

import sys
import time


class Progress:
    """Progress over ``total`` items (0 or None: unknown), redrawn at most 4 times a second
    when ``stream`` is a terminal; silent otherwise."""

    def __init__(self, total: int | None, *, label: str = "", stream=None):
        self.total = total or 0
        self.label = label
        self.stream = stream or sys.stderr
        self.enabled = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.start = time.perf_counter()
        self.last = 0.0
        self.done = 0

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc) -> None:
        if self.enabled:
            self._draw(final=True)
            self.stream.write("\n")
            self.stream.flush()

    @property
    def fps(self) -> float:
        dt = time.perf_counter() - self.start
        return self.done / dt if dt > 0 else 0.0

    def update(self, done: int, total: int | None = None) -> None:
        self.done = done
        if total:
            self.total = total
        now = time.perf_counter()
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
