"""Result types of the detector (DESIGN.md conventions: pixels, homogeneous
lines with a^2 + b^2 = 1, conics normalised to unit Frobenius norm)."""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from geometry.conics import Ellipse

__all__ = ["DetectedLine", "DetectedEllipse", "PaintArc", "Detections"]


@dataclass
class DetectedLine:
    """A long straight line in the image.

    Attributes
    ----------
    line : (3,) float64 homogeneous image line, a^2 + b^2 = 1, pixels
    endpoints : (2, 2) float64 extreme support points, pixels
    points : (N, 2) float64 sub-pixel support points, pixels
    length : float, pixels between the endpoints
    normal_sigma : float, offset uncertainty (px), from :func:`geometry.lines.fit_line`
    angle_sigma : float, direction uncertainty (rad)
    rms : float, RMS distance of the support points from the line (px)
    """

    line: np.ndarray
    endpoints: np.ndarray
    points: np.ndarray = field(repr=False)
    length: float = 0.0
    normal_sigma: float = 0.0
    angle_sigma: float = 0.0
    rms: float = 0.0

    def to_json(self) -> dict:
        return {
            "line": [round(float(v), 8) for v in self.line],
            "endpoints": np.round(self.endpoints, 2).tolist(),
            "length": round(float(self.length), 2),
            "support": int(len(self.points)),
            "normal_sigma": round(float(self.normal_sigma), 4),
            "angle_sigma": round(float(self.angle_sigma), 6),
            "rms": round(float(self.rms), 3),
        }


@dataclass
class DetectedEllipse:
    """The image of a circle marking: the centre circle or a penalty arc.

    Attributes
    ----------
    ellipse : geometry.conics.Ellipse, pixels
    conic : (3, 3) float64 normalised conic (unit Frobenius norm, negative inside)
    points : (N, 2) float64 inlier support points, pixels
    rms : float, residual of the support (px; first-order orthogonal distance)
    coverage : float, share (0-1) of the perimeter with support (arc-length weighted angular bins)
    score : float, confidence (0-1) that this is a real circle marking
    kind : "circle" (a closed circle: the centre circle when in view) or
        "arc" (a short arc cut off by a straight line: a penalty arc)
    """

    ellipse: Ellipse
    conic: np.ndarray
    points: np.ndarray = field(repr=False)
    rms: float = 0.0
    coverage: float = 0.0
    score: float = 0.0
    kind: str = "circle"

    def to_json(self) -> dict:
        e = self.ellipse
        return {
            "kind": self.kind,
            "conic": np.round(self.conic, 12).tolist(),
            "center": [round(e.center[0], 3), round(e.center[1], 3)],
            "axes": [round(e.axes[0], 3), round(e.axes[1], 3)],
            "angle": round(e.angle, 6),
            "rms": round(float(self.rms), 4),
            "coverage": round(float(self.coverage), 3),
            "score": round(float(self.score), 3),
            "support": int(len(self.points)),
        }


@dataclass
class PaintArc:
    """A penalty arc found in the paint (:func:`arstream.detect.paint.paint_arcs`).

    Attributes
    ----------
    arc : DetectedEllipse, ``kind="arc"``: the arc's ellipse and its pixels (frame pixels)
    front : DetectedLine, the straight line the arc leaves and comes back to
        (the penalty area's front line)
    """

    arc: DetectedEllipse
    front: DetectedLine


class _LazyMask:
    """A full-resolution mask made on first use from a small one (nearest-neighbour
    upsampling into a reused buffer)."""

    __slots__ = ("small", "buf", "done")

    def __init__(self, small: np.ndarray, buf: np.ndarray):
        self.small, self.buf, self.done = small, buf, False

    def get(self) -> np.ndarray:
        if not self.done:
            H, W = self.buf.shape
            if self.small is None:
                self.buf[:] = 0
            else:
                cv2.resize(self.small, (W, H), dst=self.buf, interpolation=cv2.INTER_NEAREST)
            self.done = True
        return self.buf


class Detections:
    """What the detector found in one frame.

    Attributes
    ----------
    width, height : int, frame size (pixels)
    pitch_visible : bool, enough grass to be a pitch view (False on crowd close-ups)
    grass_mask : (H, W) uint8, 255 = pitch (grass, players standing on it included)
    line_mask : (H, W) uint8, 255 = painted-line pixel (the ridge region of the lines)
    line_points : (M, 2) float64, sub-pixel centres of all line pixels, straight and curved (pixels)
    line_normals : (M, 2) float64, unit normals of the lines at ``line_points``
    lines : list of DetectedLine, longest first
    ellipses : list of DetectedEllipse, best first (closed circles before arcs): the
        centre circle, when in view, is ``ellipses[0]``

    graphics_small : (h, w) uint8 or None, the screen graphics (a score box, a
        caption) cut out of the pitch, on the grass mask's small grid (255 =
        graphic; :func:`arstream.detect.grass.grass_masks`), None where none

    ``lines`` and ``ellipses`` may be deferred (``Detector.process(...,
    lazy=True)``): they are computed on first access (:meth:`resolve`).
    timings : dict, ms per sub-stage (``lines`` and ``ellipses`` once computed)
    scale : float, frame pixels per working pixel (the ridge search resolution)

    ``grass_mask`` and ``line_mask`` are upsampled on first access, into the
    detector's reused buffers; like every array here, they are valid until
    the next :meth:`Detector.process` call (copy them, or :meth:`detach` the
    result, to keep them).
    """

    def __init__(
        self, width, height, pitch_visible, grass_small, grass_buf, line_small, line_buf, line_points, line_normals, lines=None, ellipses=None, timings=None, scale=1.0, *, structure=None, graphics_small=None
    ):
        self.width = int(width)
        self.height = int(height)
        self.pitch_visible = bool(pitch_visible)
        self._grass = _LazyMask(grass_small, grass_buf)
        self._line = _LazyMask(line_small, line_buf)
        self.line_points = line_points
        self.line_normals = line_normals
        if structure is None and (lines is None or ellipses is None):
            raise ValueError("Detections needs lines and ellipses, or a structure callable that makes them")
        self._lines, self._ellipses = lines, ellipses
        self._structure = structure if lines is None else None
        self.timings = {} if timings is None else timings
        self.scale = float(scale)
        self.graphics_small = graphics_small

    def resolve(self) -> "Detections":
        """Compute the deferred straight lines and ellipses now (a lazy detection,
        :meth:`Detector.process` with ``lazy=True``); a no-op otherwise."""
        if self._structure is not None:
            self._lines, self._ellipses = self._structure()
            self._structure = None
        return self

    @property
    def lines(self) -> list:
        return self.resolve()._lines

    @property
    def ellipses(self) -> list:
        return self.resolve()._ellipses

    @property
    def resolved(self) -> bool:
        """Whether the lines and ellipses have been computed."""
        return self._structure is None

    @property
    def grass_mask(self) -> np.ndarray:
        return self._grass.get()

    @property
    def grass_small(self) -> np.ndarray | None:
        """The grass mask as detected, on a small copy of the frame (about 160 px
        wide; same aspect), or None without a pitch: a matte to scale up once."""
        return self._grass.small

    @property
    def line_small(self) -> np.ndarray | None:
        """The line-pixel mask as detected, at the working resolution (255 = a line
        pixel's centre)."""
        return self._line.small

    def detach(self) -> "Detections":
        """Make this result independent of the detector's reused buffers (cheaply:
        the small masks are copied, the full-size ones made anew on access), so
        it stays valid after the next :meth:`Detector.process` call. Returns self."""
        for lm in (self._grass, self._line):
            if lm.small is not None:
                lm.small = lm.small.copy()
            lm.buf = np.empty_like(lm.buf)
            lm.done = False
        if self.graphics_small is not None:
            self.graphics_small = self.graphics_small.copy()
        return self

    @property
    def line_mask(self) -> np.ndarray:
        return self._line.get()

    @property
    def grass_fraction(self) -> float:
        s = self._grass.small
        return 0.0 if s is None else float(cv2.countNonZero(s)) / s.size

    def __repr__(self) -> str:
        return (
            f"Detections({self.width}x{self.height}, pitch_visible={self.pitch_visible}, "
            f"{len(self.line_points)} line points, "
            + (f"{len(self._lines)} lines, {len(self._ellipses)} ellipses)" if self.resolved else "lines and ellipses deferred)")
        )

    def to_json(self) -> dict:
        """Lines and conics (no pixel arrays)."""
        return {
            "width": self.width,
            "height": self.height,
            "pitch_visible": self.pitch_visible,
            "grass_fraction": round(self.grass_fraction, 4),
            "line_pixels": int(len(self.line_points)),
            "lines": [l.to_json() for l in self.lines],
            "ellipses": [e.to_json() for e in self.ellipses],
            "timings_ms": {k: round(float(v), 3) for k, v in self.timings.items()},
        }
