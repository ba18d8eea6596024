"""The per-frame camera estimate that the solver/tracker hands to the rest of
the pipeline, and its ``cameras.jsonl`` record (docs/formats.md)."""

from __future__ import annotations

from dataclasses import dataclass, field

from geometry.camera import Camera

__all__ = ["CameraEstimate", "STATUSES"]

STATUSES = ("ok", "tracked", "lost")


@dataclass
class CameraEstimate:
    """The camera of one frame.

    Attributes
    ----------
    frame : int, frame index
    pts : float, presentation time (seconds)
    status : "ok" (measured this frame), "tracked" (carried by the temporal
        filter through a frame without a usable measurement) or "lost"
    camera : Camera or None (None exactly when ``status == "lost"``)
    confidence : float in [0, 1]
    info : dict, diagnostics (timings, residuals, which initialiser), not written
        to cameras.jsonl
    """

    frame: int
    pts: float
    status: str
    camera: Camera | None
    confidence: float = 0.0
    info: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.status not in STATUSES:
            raise ValueError(f"status must be one of {STATUSES}, got {self.status!r}")
        if (self.camera is None) != (self.status == "lost"):
            raise ValueError("camera must be None exactly when status is 'lost'")

    @classmethod
    def lost(cls, frame: int, pts: float, **info) -> "CameraEstimate":
        return cls(frame, pts, "lost", None, 0.0, dict(info))

    def to_record(self) -> dict:
        """The ``cameras.jsonl`` record of this frame."""
        rec = {"frame": int(self.frame), "pts": round(float(self.pts), 6), "status": self.status}
        if self.camera is None:
            rec.update(K=None, R=None, t=None, dist=None, H=None)
        else:
            rec.update(self.camera.to_dict())
        rec["confidence"] = round(float(min(max(self.confidence, 0.0), 1.0)), 4)
        return rec
