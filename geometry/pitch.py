"""The IFAB pitch model (Law 1): named straight segments and circular arcs.

Frame: metres; origin at the centre spot; X along the touchlines (pitch
length), Y along the halfway line pointing away from the main camera, Z up;
the pitch is the plane Z = 0. "Left" is -X, "near" is -Y (the main camera's
side).

Markings are stored as the *centrelines* of lines ``line_width`` wide (0.12 m
by default). As Law 1 says, lines belong to the areas they bound and
distances are measured to their outer edges: the touchline's outer edge is at
``Y = -width/2``, so its centreline is at ``-width/2 + line_width/2``; the
centre circle's outer edge has radius 9.15 m, so its centreline radius is
9.09 m. Conics and samples use the centrelines, which is where a detector
finds the middle of a painted line.

>>> pitch = PitchModel()
>>> round(pitch["centre_circle"].radius, 2)
9.09
>>> pts = pitch.sample_points(1.0)
>>> bool(np.allclose(np.sort(pts[:, 0]), np.sort((pts @ np.diag([-1.0, 1.0]))[:, 0])))
True
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from geometry.conics import conic_from_circle
from geometry.lines import line_through

__all__ = ["Segment", "Arc", "PitchModel", "CENTRE_CIRCLE_RADIUS", "LINE_WIDTH"]

LINE_WIDTH = 0.12
CENTRE_CIRCLE_RADIUS = 9.15
PENALTY_AREA_DEPTH = 16.5
PENALTY_AREA_WIDTH = 40.32
GOAL_AREA_DEPTH = 5.5
GOAL_AREA_WIDTH = 18.32
PENALTY_MARK_DISTANCE = 11.0
CORNER_ARC_RADIUS = 1.0
GOAL_WIDTH = 7.32
GOAL_HEIGHT = 2.44


@dataclass(frozen=True)
class Segment:
    """A straight marking's centreline from ``start`` to ``end`` ((2,) metres each)."""

    name: str
    start: tuple[float, float]
    end: tuple[float, float]

    @property
    def length(self) -> float:
        return float(np.hypot(self.end[0] - self.start[0], self.end[1] - self.start[1]))

    @property
    def line(self) -> np.ndarray:
        """(3,) homogeneous line through the segment, pitch frame, a^2 + b^2 = 1."""
        return line_through((*self.start, 1.0), (*self.end, 1.0))

    def sample(self, spacing: float) -> np.ndarray:
        """Points every ``spacing`` metres (at most), both ends included: (N, 2) float64."""
        n = max(int(np.ceil(self.length / spacing)), 1) + 1
        s = np.linspace(0.0, 1.0, n)[:, None]
        return (1 - s) * np.asarray(self.start) + s * np.asarray(self.end)


@dataclass(frozen=True)
class Arc:
    """A circular marking's centreline: centre (2,) metres, radius, and the arc from
    ``start_angle`` to ``end_angle`` (radians, counter-clockwise seen from above,
    ``end_angle > start_angle``; a full circle spans 2 pi)."""

    name: str
    center: tuple[float, float]
    radius: float
    start_angle: float
    end_angle: float

    @property
    def is_full_circle(self) -> bool:
        return self.end_angle - self.start_angle >= 2 * np.pi - 1e-12

    @property
    def length(self) -> float:
        return float(self.radius * (self.end_angle - self.start_angle))

    @property
    def conic(self) -> np.ndarray:
        """(3, 3) conic of the whole circle in the pitch frame (normalised)."""
        return conic_from_circle(self.center, self.radius)

    def sample(self, spacing: float) -> np.ndarray:
        """Points every ``spacing`` metres (at most) along the arc: (N, 2) float64."""
        n = max(int(np.ceil(self.length / spacing)), 2)
        th = np.linspace(self.start_angle, self.end_angle, n + (0 if self.is_full_circle else 1), endpoint=not self.is_full_circle)
        return np.column_stack([self.center[0] + self.radius * np.cos(th), self.center[1] + self.radius * np.sin(th)])


class PitchModel:
    """The markings of a pitch of the given size (Law 1 dimensions inside it).

    Parameters
    ----------
    length : float, metres along X (touchline length), 90-120 (Law 1)
    width : float, metres along Y (goal line length), 45-90, less than ``length``
    line_width : float, metres (at most 0.12 by Law 1)

    Raises
    ------
    ValueError
        For a size outside Law 1's limits.
    """

    def __init__(self, length: float = 105.0, width: float = 68.0, line_width: float = LINE_WIDTH):
        if not (90.0 <= length <= 120.0):
            raise ValueError(f"pitch length must be 90-120 m (Law 1), got {length}")
        if not (45.0 <= width <= 90.0):
            raise ValueError(f"pitch width must be 45-90 m (Law 1), got {width}")
        if width >= length:
            raise ValueError(f"pitch width ({width}) must be less than its length ({length})")
        if not (0.0 < line_width <= 0.12 + 1e-9):
            raise ValueError(f"line width must be in (0, 0.12] m, got {line_width}")
        self.length = float(length)
        self.width = float(width)
        self.line_width = float(line_width)

    def __repr__(self) -> str:
        return f"PitchModel(length={self.length}, width={self.width}, line_width={self.line_width})"

    # --- markings -----------------------------------------------------------
    @cached_property
    def segments(self) -> tuple[Segment, ...]:
        """All straight markings (centrelines)."""
        h = self.line_width / 2
        X = self.length / 2 - h  # goal line centreline
        Y = self.width / 2 - h  # touchline centreline
        segs = [
            Segment("touchline_near", (-X, -Y), (X, -Y)),
            Segment("touchline_far", (-X, Y), (X, Y)),
            Segment("goal_line_left", (-X, -Y), (-X, Y)),
            Segment("goal_line_right", (X, -Y), (X, Y)),
            Segment("halfway_line", (0.0, -Y), (0.0, Y)),
        ]
        for side, sgn in (("left", -1.0), ("right", 1.0)):
            for box, depth, half_w in (
                ("penalty_area", PENALTY_AREA_DEPTH, PENALTY_AREA_WIDTH / 2),
                ("goal_area", GOAL_AREA_DEPTH, GOAL_AREA_WIDTH / 2),
            ):
                xf = sgn * (self.length / 2 - depth + h)  # front line centre
                yb = half_w - h
                segs += [
                    Segment(f"{box}_{side}_front", (xf, -yb), (xf, yb)),
                    Segment(f"{box}_{side}_near", (sgn * X, -yb), (xf, -yb)),
                    Segment(f"{box}_{side}_far", (sgn * X, yb), (xf, yb)),
                ]
        return tuple(segs)

    @cached_property
    def arcs(self) -> tuple[Arc, ...]:
        """All circular markings (centrelines)."""
        h = self.line_width / 2
        r = CENTRE_CIRCLE_RADIUS - h
        arcs = [Arc("centre_circle", (0.0, 0.0), r, 0.0, 2 * np.pi)]
        # penalty arcs: the part outside the penalty area (beyond its front line's outer edge)
        dx = PENALTY_AREA_DEPTH - PENALTY_MARK_DISTANCE
        half = float(np.arccos(dx / r))
        xm = self.length / 2 - PENALTY_MARK_DISTANCE
        arcs.append(Arc("penalty_arc_left", (-xm, 0.0), r, -half, half))
        arcs.append(Arc("penalty_arc_right", (xm, 0.0), r, np.pi - half, np.pi + half))
        rc = CORNER_ARC_RADIUS - h
        L, W = self.length / 2, self.width / 2
        for name, (cx, cy), a0 in (
            ("corner_arc_near_left", (-L, -W), 0.0),
            ("corner_arc_near_right", (L, -W), np.pi / 2),
            ("corner_arc_far_right", (L, W), np.pi),
            ("corner_arc_far_left", (-L, W), 3 * np.pi / 2),
        ):
            arcs.append(Arc(name, (cx, cy), rc, a0, a0 + np.pi / 2))
        return tuple(arcs)

    @cached_property
    def spots(self) -> dict[str, tuple[float, float]]:
        """Centre mark and penalty marks, (2,) metres each."""
        xm = self.length / 2 - PENALTY_MARK_DISTANCE
        return {"centre_mark": (0.0, 0.0), "penalty_mark_left": (-xm, 0.0), "penalty_mark_right": (xm, 0.0)}

    @cached_property
    def markings(self) -> dict[str, Segment | Arc]:
        """All segments and arcs by name."""
        return {m.name: m for m in (*self.segments, *self.arcs)}

    def __getitem__(self, name: str) -> Segment | Arc:
        try:
            return self.markings[name]
        except KeyError:
            raise KeyError(f"no marking named {name!r}; known: {sorted(self.markings)}") from None

    @property
    def circles(self) -> dict[str, np.ndarray]:
        """Conics (3, 3) of the radius-9.09 m circles in the pitch frame: the centre
        circle and both penalty arcs' full circles."""
        return {n: self[n].conic for n in ("centre_circle", "penalty_arc_left", "penalty_arc_right")}

    # --- sampling -------------------------------------------------------------
    def sample(self, spacing: float = 0.25) -> dict[str, np.ndarray]:
        """Every marking sampled at ``spacing`` metres: name -> (N, 2) float64."""
        if not spacing > 0:
            raise ValueError(f"spacing must be positive, got {spacing}")
        return {name: m.sample(spacing) for name, m in self.markings.items()}

    def sample_points(self, spacing: float = 0.25) -> np.ndarray:
        """All markings sampled at ``spacing`` metres, concatenated: (N, 2) float64."""
        return np.concatenate(list(self.sample(spacing).values()), axis=0)

    # --- symmetries -------------------------------------------------------------
    @property
    def symmetries(self) -> np.ndarray:
        """(4, 3, 3) homogeneous maps of the pitch plane that leave the markings
        unchanged: identity, X mirror, Y mirror, and the half turn."""
        return np.array([np.diag([sx, sy, 1.0]) for sx, sy in ((1, 1), (-1, 1), (1, -1), (-1, -1))])

    def polylines(self, spacing: float = 0.25) -> list[np.ndarray]:
        """Each marking as an (N, 2) polyline in drawing order (full circles closed)."""
        out = []
        for m in self.markings.values():
            p = m.sample(spacing)
            if isinstance(m, Arc) and m.is_full_circle:
                p = np.vstack([p, p[:1]])
            out.append(p)
        return out
