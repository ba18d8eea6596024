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

__all__ = ["LineGroup", "group_lines"]

_TH_BINS = 120  # 1.5 degree bins over [0, pi)
_PAD = 3  # wrapped rows on both ends
_HALF = 3  # theta bins either side gathered per peak
_K3 = np.ones((3, 3), np.uint8)


class LineGroup:
    __slots__ = ("idx", "line", "direction", "rms", "t0", "t1")

    def __init__(self, idx, line, direction, rms, t0, t1):
        self.idx, self.line, self.direction, self.rms, self.t0, self.t1 = idx, line, direction, rms, t0, t1


def _tls(P: np.ndarray):
    """Total-least-squares line of points (N, 2): (line (3,), direction (2,), rms).
    (:func:`geometry.lines.fit_line`'s fit without its checks and uncertainties:
    it runs some 15 times a frame in the Hough loop, and the final support is
    fitted with ``fit_line`` in frame pixels. Second moments from one product:
    coordinates are working pixels, so the centring in floating point loses
    nothing that matters.)"""
    n = len(P)
    s = P.sum(axis=0)
    S = P.T @ P
    cx, cy = float(s[0]) / n, float(s[1]) / n
    sxx = float(S[0, 0]) - n * cx * cx
    sxy = float(S[0, 1]) - n * cx * cy
    syy = float(S[1, 1]) - n * cy * cy
    phi = 0.5 * math.atan2(2 * sxy, sxx - syy)
    ux, uy = math.cos(phi), math.sin(phi)
    half = 0.5 * (sxx + syy)
    lmin = half - math.sqrt(max(half * half - (sxx * syy - sxy * sxy), 0.0))
    rms = math.sqrt(max(lmin, 0.0) / n)
    return np.array([-uy, ux, uy * cx - ux * cy]), np.array([ux, uy]), rms


def _count_curve(curved_hits: np.ndarray, labels: np.ndarray | None, members: np.ndarray) -> bool:
    """Count a failed straight-line candidate against the chain most of its
    points belong to (a chain that fails twice is not tried again); whether
    anything was counted."""
    if labels is None:
        return False
    curved_hits[np.bincount(labels[members]).argmax()] += 1
    return True


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
    used = np.zeros(n, bool)
    if n < min_points:
        return [], used
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
        return [], used
    cand = cand[np.argsort(-core.ravel()[cand], kind="stable")[: 4 * max_lines]]
    order_t = np.argsort(tb, kind="stable")
    starts = np.searchsorted(tb[order_t], np.arange(_TH_BINS + 1))
    groups: list[LineGroup] = []
    claimed = np.zeros((_TH_BINS, n_rho), bool)
    curved_hits = np.zeros(int(labels.max()) + 1 if labels is not None and len(labels) else 1, np.int32)
    any_curved = False
    for c in cand:
        ti, ri = divmod(int(c), n_rho)
        if claimed[ti, ri]:
            continue
        a, b = ti - _HALF, ti + _HALF + 1
        if a < 0:
            idx = np.concatenate([order_t[starts[a + _TH_BINS] :], order_t[: starts[b]]])
        elif b > _TH_BINS:
            idx = np.concatenate([order_t[starts[a] :], order_t[: starts[b - _TH_BINS]]])
        else:
            idx = order_t[starts[a] : starts[b]]
        idx = idx[~used[idx]]
        if len(idx) < min_points:
            continue
        th0 = (ti + 0.5) * (math.pi / _TH_BINS)
        r0 = (ri + 0.5) * rho_bin - rmax
        n0x, n0y = math.cos(th0), math.sin(th0)
        P = pts[idx]
        sel = np.abs(P @ np.array([n0x, n0y]) - (r0 + cx * n0x + cy * n0y)) <= 2.5
        if np.count_nonzero(sel) < min_points:
            continue
        if any_curved:
            lab = labels[idx[sel]]
            top = np.bincount(lab).argmax()
            if top and curved_hits[top] >= 2 and np.count_nonzero(lab == top) > 0.7 * len(lab):
                continue
        line, u, rms = _tls(P[sel])
        sel = (np.abs(P @ line[:2] + line[2]) <= tol) & (np.abs(nrm[idx] @ line[:2]) > 0.985)
        if np.count_nonzero(sel) >= min_points:
            line, u, rms = _tls(P[sel])
            members = idx[sel]
            t = pts[members] @ u
            o = np.argsort(t)
            ts = t[o]
            gaps = np.flatnonzero(np.diff(ts) > max_gap)
            if len(gaps):
                bounds = np.r_[0, gaps + 1, len(ts)]
                ext = ts[bounds[1:] - 1] - ts[bounds[:-1]] + 0.5 * np.diff(bounds)
                j = int(np.argmax(ext))
                members = members[o[bounds[j] : bounds[j + 1]]]
                if len(members) < min_points:
                    continue
                line, u, rms = _tls(pts[members])
                t = pts[members] @ u
            t0, t1 = float(t.min()), float(t.max())
            length = t1 - t0
            if length < min_length or len(members) < 0.4 * length:
                continue
            if rms > max_rms:  # the chord of a gentle curve (or a smeared band)
                any_curved |= _count_curve(curved_hits, labels, members)
                continue
            # straightness: a quadratic through the residuals, peak-to-peak over the length
            res = pts[members] @ line[:2] + line[2]
            uu = (t - 0.5 * (t0 + t1)) * (2.0 / length)
            q2 = uu * uu - (1.0 / 3.0)
            k2 = float(q2 @ res) / max(float(q2 @ q2), 1e-12)  # u^2 is orthogonal to u and 1 on a symmetric spread
            if abs(k2) > max_sagitta:
                any_curved |= _count_curve(curved_hits, labels, members)
                continue
            used[members] = True
            groups.append(LineGroup(members, line, u, rms, t0, t1))
            claimed[max(ti - 1, 0) : ti + 2, max(ri - 2, 0) : ri + 3] = True
            if len(groups) >= max_lines:
                break
    groups.sort(key=lambda g: -(g.t1 - g.t0))
    return groups, used
