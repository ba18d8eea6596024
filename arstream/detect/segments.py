"""Straight lines from oriented ridge points: an orientation-aware Hough vote.

Every ridge centre carries its own line normal (from the Hessian), so it
votes once, in its own (theta, rho) cell, instead of along a whole
sinusoid: the accumulator is a 2-D histogram built with one ``bincount``.
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

import cv2
import numpy as np

from arstream.kernels import hough_lines

__all__ = ["LineGroup", "group_lines"]

_TH_BINS = 120  # 1.5 degree bins over [0, pi)
_PAD = 3  # wrapped rows on both ends
_HALF = 3  # theta bins either side gathered per peak
_K3 = np.ones((3, 3), np.uint8)


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
    th = np.arctan2(nrm[:, 1], nrm[:, 0])
    neg = th < 0
    th[neg] += np.pi
    sgn = np.where(neg, -1.0, 1.0)
    rho = ((pts[:, 0] - cx) * nrm[:, 0] + (pts[:, 1] - cy) * nrm[:, 1]) * sgn
    tb = np.minimum((th * (_TH_BINS / np.pi)).astype(np.intp), _TH_BINS - 1)
    rb = np.clip(((rho + rmax) * (1.0 / rho_bin)).astype(np.intp), 0, n_rho - 1)
    rows = _TH_BINS + 2 * _PAD
    acc = np.bincount((tb + _PAD) * n_rho + rb, minlength=rows * n_rho)
    # wrapped copies: theta near pi is theta near 0 with rho negated
    edge = (tb < _PAD) | (tb >= _TH_BINS - _PAD)
    if edge.any():
        te = tb[edge]
        te = np.where(te < _PAD, te + _TH_BINS, te - _TH_BINS)
        re = np.clip(((-rho[edge] + rmax) * (1.0 / rho_bin)).astype(np.intp), 0, n_rho - 1)
        acc += np.bincount((te + _PAD) * n_rho + re, minlength=rows * n_rho)
    A = acc.reshape(rows, n_rho).astype(np.float32)
    T = cv2.boxFilter(A, -1, (3, 3), normalize=False, borderType=cv2.BORDER_CONSTANT)
    core = T[_PAD : _PAD + _TH_BINS]
    thr = max(min_points, 0.5 * min_length)
    peak = (core >= thr) & (core >= cv2.dilate(core, _K3))
    cand = np.flatnonzero(peak.ravel())
    if len(cand) == 0:
        return [], np.zeros(n, bool)
    cand = cand[np.argsort(-core.ravel()[cand], kind="stable")[: 4 * max_lines]]
    order_t = np.argsort(tb, kind="stable")
    starts = np.searchsorted(tb[order_t], np.arange(_TH_BINS + 1))
    has_labels = labels is not None and len(labels) > 0
    lab = labels.astype(np.int64) if has_labels else np.zeros(n, np.int64)
    members, offsets, geo, used = hough_lines(
        np.ascontiguousarray(pts, np.float64), np.ascontiguousarray(nrm, np.float64), lab, has_labels, int(lab.max()) + 1,
        order_t.astype(np.int64), starts.astype(np.int64), cand.astype(np.int64), _TH_BINS, n_rho, rho_bin, rmax, cx, cy, _HALF,
        int(min_points), float(min_length), float(max_gap), float(tol), int(max_lines), float(max_sagitta), float(max_rms),
    )  # fmt: skip
    groups = [
        LineGroup(members[offsets[k] : offsets[k + 1]], g[:3].copy(), g[3:5].copy(), float(g[5]), float(g[6]), float(g[7]))
        for k, g in enumerate(geo)
    ]
    groups.sort(key=lambda g: -(g.t1 - g.t0))
    return groups, used
