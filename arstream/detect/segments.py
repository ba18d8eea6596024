"""Straight lines from oriented ridge points: an orientation-aware Hough vote.

Every ridge centre carries its own line normal (from the Hessian), so it
votes once, in its own (theta, rho) cell, instead of along a whole
sinusoid: the accumulator is a 2-D histogram (one compiled pass,
:func:`arstream.detect.kernels.segments.hough_votes`, which also finds its peaks).
Local maxima are taken strongest first; each gathers the still unassigned
points of the nearby orientations that lie close to it and point the same
way, is refitted by total least squares, cut at gaps longer than
``max_gap`` (collinear pieces separated by players merge across shorter
ones), and checked for straightness: a quadratic through the residuals must
have a sagitta within ``max_sagitta``, which keeps the flat stretches of the
circles' ellipses out. A connected chain of points that has twice failed
that test is not tried again (the many flat-looking stretches of one big
ellipse cost one look each, not one per Hough peak).

Coordinates are working-resolution pixels; the caller maps them to the
frame and runs :func:`geometry.lines.fit_line` on the final support.
"""

from __future__ import annotations

import math

import numpy as np

from arstream.detect.kernels.segments import hough_lines, hough_votes

__all__ = ["LineGroup", "group_lines"]

_TH_BINS = 120  # 1.5 degree bins over [0, pi)
_PAD = 3  # wrapped rows on both ends
_HALF = 3  # theta bins either side gathered per peak


class LineGroup:
    __slots__ = ("idx", "line", "direction", "rms", "t0", "t1")

    def __init__(self, idx, line, direction, rms, t0, t1):
        self.idx, self.line, self.direction, self.rms, self.t0, self.t1 = idx, line, direction, rms, t0, t1


def group_lines(
    pts: np.ndarray,
    nrm: np.ndarray,
    size: tuple[int, int],
    *,
    labels: np.ndarray | None = None,
    min_length: float,
    min_points: int = 12,
    max_gap: float,
    tol: float = 1.0,
    max_lines: int = 24,
    max_sagitta: float = 0.5,
    max_rms: float = 0.3,
    source: tuple[float, float] = (1.0, 1.0),
) -> tuple[list[LineGroup], np.ndarray]:
    """Group ridge points into long straight lines.

    Parameters
    ----------
    pts : (N, 2) float64 ridge centres (working pixels)
    nrm : (N, 2) unit normals
    size : (w, h) of the working image
    labels : (N,) int, optional, connected chain of each point (0: none)
    min_length : shortest line (px)
    max_gap : longest gap (px) bridged between collinear pieces
    tol : inlier distance (px) from the fitted line
    max_sagitta : largest peak-to-peak deviation (px) of a quadratic through
        the residuals over the line's length (more means a curve)
    max_rms : largest RMS distance (px) of the support from the line (a chord
        of a gentle curve has a larger spread than a painted line)
    source : (sx, sy) source pixels per pixel of ``pts`` along x and y, where
        the image was enlarged from its source (a still of anamorphic pixels
        stretched to square ones: 720 / 1024 along x). ``max_rms`` and
        ``max_sagitta`` are then source pixels: the enlargement widens a
        line's wobble (compression's, the ridge centres') as it widens the
        line, along the line's normal (a, b) by ``1 / hypot(a sx, b sy)``.
        Values above 1 (a shrunk image) count as 1: the limits are never
        tighter than the image's own pixels.

    Returns
    -------
    (groups, used) : line groups sorted by length, and a (N,) bool mask of
    the points they took.
    """
    n = len(pts)
    if n < min_points:
        return [], np.zeros(n, bool)
    w, h = size
    cx, cy = 0.5 * (w - 1), 0.5 * (h - 1)
    rmax = 0.5 * math.hypot(w, h) + 2
    rho_bin = 2.0
    n_rho = int(math.ceil(2 * rmax / rho_bin)) + 1
    pts = np.ascontiguousarray(pts, np.float64)
    nrm = np.ascontiguousarray(nrm, np.float64)
    src_x, src_y = (min(1.0, float(v)) for v in source)
    if not (src_x > 0 and src_y > 0):
        raise ValueError(f"source pixels per pixel must be positive, got {tuple(source)}")
    thr = max(min_points, 0.5 * min_length)
    cand, order_t, starts = hough_votes(pts, nrm, cx, cy, rmax, rho_bin, _TH_BINS, n_rho, _PAD, float(thr), 4 * max_lines)
    if len(cand) == 0:
        return [], np.zeros(n, bool)
    has_labels = labels is not None and len(labels) > 0
    lab = labels.astype(np.int64) if has_labels else np.zeros(n, np.int64)
    members, offsets, geo, used = hough_lines(
        pts, nrm, lab, has_labels, int(lab.max()) + 1,
        order_t, starts, cand, _TH_BINS, n_rho, rho_bin, rmax, cx, cy, _HALF,
        int(min_points), float(min_length), float(max_gap), float(tol), int(max_lines), float(max_sagitta), float(max_rms), src_x, src_y,
    )  # fmt: skip
    groups = [
        LineGroup(members[offsets[k] : offsets[k + 1]], g[:3].copy(), g[3:5].copy(), float(g[5]), float(g[6]), float(g[7]))
        for k, g in enumerate(geo)
    ]
    groups.sort(key=lambda g: -(g.t1 - g.t0))
    return groups, used
