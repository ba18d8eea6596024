"""What a pipeline run reports: its :class:`Summary`, and :class:`Interrupted`,
raised with it when SIGINT or SIGTERM stopped the run (after the outputs were
finalised; the handler is :class:`arstream.pipeline.runner.Pipeline`'s).
"""

from __future__ import annotations

import signal
from dataclasses import dataclass, field

__all__ = ["Summary", "Interrupted"]

@dataclass
class Summary:
    """What a run did.

    Attributes
    ----------
    input : str
    output, cameras : str or None, files written
    cameras_in : str or None, the cameras file a run drew with
        (:func:`~arstream.pipeline.render_clip`): nothing was tracked, and
        ``tracked`` counts the frames that had a camera in that file
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
    pitch : dict or None, the pitch's size the cameras were solved with
        (:meth:`arstream.pitch_size.PitchSize.to_dict`: length, width, their
        standard deviations where estimated, source "given", "default" or
        "estimated", views)
    pitch_text : str or None, the same in words (printed after :meth:`line`)
    picture : list or None, ``[x0, y0, x1, y1]`` (frame pixels, end exclusive):
        the picture inside black bars that detection and tracking analysed
        (:func:`arstream.imaging.active_area` of the clip's first frames);
        None: the whole frame
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
    cameras_in: str | None = None
    pitch: dict | None = None
    pitch_text: str | None = None
    picture: list | None = None

    @property
    def fps(self) -> float:
        return self.frames / self.seconds if self.seconds > 0 else 0.0

    @property
    def share_tracked(self) -> float:
        return self.tracked / self.frames if self.frames else 0.0

    def line(self) -> str:
        """One line for the terminal."""
        s = f"{self.frames} frames in {self.seconds:.1f} s ({self.fps:.1f} fps), "
        if self.cameras_in is None:
            s += f"tracked {self.share_tracked:.1%}, mean confidence {self.confidence:.2f}"
        else:  # drawn with cameras from a file: nothing was tracked
            s += f"a camera from {self.cameras_in} on {self.share_tracked:.1%} of them"
        if self.picture is not None:
            x0, y0, x1, y1 = self.picture
            s += f", the {x1 - x0} x {y1 - y0} picture inside black bars"
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
            "cameras_in": self.cameras_in,
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
            "pitch": self.pitch,
            "picture": self.picture,
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
