"""Circle markings: ellipses found among the curved ridge points.

1. Arcs: the ridge centres that no straight line took are linked into arcs
   (points within 3 px along both axes: gaps of up to 2 px bridged).
2. Hypotheses (RANSAC over the direct fit, sampling arcs rather than single
   points): the direct least-squares ellipse (Fitzgibbon / Halir-Flusser) of
   every large arc, pair and triple of arcs. Each arc's scatter matrix of
   conic monomials is computed once; the scatter of a union is the sum, so
   each hypothesis is one small 3x3 eigenproblem (compiled:
   :func:`arstream.detect.kernels.ellipses.direct_fits`).
3. Scoring: the points within a Sampson distance of each hypothesis *and*
   whose ridge normal agrees with the conic's gradient there.
4. Refinement: iteratively reweighted direct fits on the inliers (Sampson
   gradient weights, which turn the algebraic fit into an approximately
   geometric one; compiled: :func:`arstream.detect.kernels.ellipses.refine_conic`).
5. Validation: size, shape (a ground circle seen from above: minor axis
   roughly vertical, b/a well under 1 but above 0.1, i.e. seen from at least
   about 6 degrees above the pitch: the tip of a flatter one fits two lines
   meeting at a corner), support around the perimeter
   (coverage in arc-length-weighted angular bins, each needing a real share
   of its expected points), residual, and the ellipse lying on the pitch.

Every ellipse found removes its inliers; the search repeats for the next one.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from arstream.detect.kernels.ellipses import conic_band, conic_counts, direct_fits, ellipse_params, frame_ellipse, hartley_monomials, label_scatters, perimeter_bins, refine_conic
from arstream.detect.kernels.points import chains
from geometry.conics import Ellipse

__all__ = ["EllipseCandidate", "find_ellipses"]



class EllipseCandidate:
    __slots__ = ("ellipse", "conic", "idx", "rms", "coverage", "score", "kind")

    def __init__(self, ellipse, conic, idx, rms, coverage, score, kind="circle"):
        self.ellipse, self.conic, self.idx, self.rms = ellipse, conic, idx, rms
        self.coverage, self.score, self.kind = coverage, score, kind


class _PerimeterBins:
    """Share of an ellipse's perimeter with support, in two steps.

    The perimeter is cut into ``bins`` equal steps of the parametric angle; a
    bin counts when it holds at least ``density`` of the points expected along
    its arc length at one point per ``spacing`` px
    (:func:`arstream.detect.kernels.ellipses.perimeter_bins`). ``cov``: covered arc length over
    the whole perimeter, at once; :meth:`visible_coverage`: over the part of
    it that ``visible`` (a callable, points (N, 2) -> (N,) bool; everything
    when None) says could be seen, asked only when wanted.
    """

    __slots__ = ("cov", "covered", "seg", "mid")

    def __init__(self, pts, e: Ellipse, *, bins=64, density=0.3, spacing=1.0):
        a, b = e.axes
        P = np.ascontiguousarray(pts, np.float64)
        self.cov, self.covered, self.seg, self.mid = perimeter_bins(P, float(e.center[0]), float(e.center[1]), float(e.angle), float(a), float(b), int(bins), float(density), float(spacing))

    def visible_coverage(self, visible) -> float:
        if visible is None:
            return self.cov
        vis = visible(self.mid) | self.covered
        vis_len = float(self.seg[vis].sum())
        return float(self.seg[self.covered].sum()) / vis_len if vis_len > 0 else 0.0


def largest_gap(pts: np.ndarray, e: Ellipse, *, bins: int = 36) -> float:
    """Largest run of parametric angle (share of the full turn) without support:
    small when the support surrounds the centre (opposite arcs), large for one arc."""
    ca, sa = np.cos(e.angle), np.sin(e.angle)
    d = pts - np.asarray(e.center)
    th = np.arctan2((-d[:, 0] * sa + d[:, 1] * ca) / e.axes[1], (d[:, 0] * ca + d[:, 1] * sa) / e.axes[0])
    occ = np.bincount(((th + np.pi) * (bins / (2 * np.pi))).astype(np.intp) % bins, minlength=bins) >= 2
    if not occ.any():
        return 1.0
    # longest circular run of empty bins
    k = int(np.argmax(occ))
    r = np.roll(occ, -k)
    idx = np.flatnonzero(r)
    gaps = np.diff(np.r_[idx, bins]) - 1
    return float(gaps.max()) / bins


def find_ellipses(
    pts: np.ndarray,
    nrm: np.ndarray,
    work_size: tuple[int, int],
    A_wf: np.ndarray,
    *,
    full_size: tuple[int, int],
    visible,
    is_arc=None,
    grid_buf: np.ndarray,
    pts_full: np.ndarray | None = None,
    labels: np.ndarray | None = None,
    seed: np.ndarray | None = None,
    group: np.ndarray | None = None,
    max_ellipses: int = 3,
    prior=None,
    prior_band: float = 4.0,
    min_points: int = 30,
    min_coverage: float = 0.15,
    min_visible: float = 0.55,
    max_rms: float = 0.8,
    tol: float = 1.5,
) -> list[EllipseCandidate]:
    """Ellipses among curved ridge points.

    Parameters
    ----------
    pts, nrm : (N, 2) working-pixel ridge centres and unit normals (curved points only)
    work_size : (w, h) of the working image
    A_wf : (3, 3) map from working pixels to frame pixels (homogeneous): a scale
        and a shift per axis
    full_size : (W, H) frame size
    visible : callable, frame pixels (N, 2) -> (N,) bool: where a marking could be
        seen (in the frame, on the pitch)
    is_arc : callable (Ellipse, support (N, 2)) -> bool, optional: whether the
        support is an arc cut off by a straight line (a penalty arc)
    grid_buf : (h, w) int32 scratch, -1 on entry and on return
    pts_full : (N, 2) the points in frame pixels (``A_wf`` applied), optional
        (the caller's copy; made here by default)
    labels : (N,) int, optional, connected chain of each point (0: none); by default
        the points' chains, linked within 3 px (:func:`arstream.detect.kernels.points.chains`)
    seed : (N,) bool, optional: points that may seed hypotheses (arcs); the
        others (stretches that also passed for short straight lines) only
        support them, or seed as arcs of their own: ``group`` (N,) int, the
        stretch of each point (-1: none)
    prior : sequence of (3, 3) conics (frame pixels), optional: the ellipses of
        the previous frame, tried first (inliers within ``prior_band`` working
        pixels, then the usual refinement and validation); the RANSAC search
        runs only when none of them holds
    min_points : least inliers (working pixels of support)
    min_coverage : least share of the perimeter with support
    min_visible : least share of the visible perimeter with support for a closed
        circle (an arc with less must be cut off by a straight line: ``is_arc``)
    max_rms : largest residual (working pixels)
    tol : inlier distance (working pixels)

    Returns
    -------
    list of EllipseCandidate (ellipse and conic in frame pixels; ``idx`` into ``pts``)
    """
    (ax, r01, bx), (r10, ay, by) = np.asarray(A_wf, np.float64)[:2].tolist()
    if r01 or r10:
        raise ValueError("A_wf must scale and shift each axis (no rotation or shear)")
    n = len(pts)
    if n < min_points:
        return []
    nrm = np.ascontiguousarray(nrm, np.float64)
    if pts_full is None:
        pts_full = pts * (ax, ay) + (bx, by)
    w, h = work_size
    W, H = full_size
    sw = ax  # frame pixels per working pixel
    # 1. arcs: the caller's chain labels, or the points' own chains
    n_cc = None
    if labels is None:
        sp = pts if seed is None else pts[seed]
        xi = np.clip(np.rint(sp[:, 0]).astype(np.int64), 0, w - 1)
        yi = np.clip(np.rint(sp[:, 1]).astype(np.int64), 0, h - 1)
        # linked within 3 px: the 8-connected components of the raster dilated by 3x3
        lab, _, _ = chains(xi, yi, 3, grid_buf)
        if seed is None:
            labels = lab
        else:
            labels = np.zeros(n, np.int32)
            labels[seed] = lab
            n_cc = int(lab.max(initial=0)) + 1
            if group is not None:
                # each short straight stretch is an arc of its own (not merged
                # with the curve it touches)
                g = (group >= 0) & ~seed
                labels[g] = n_cc + group[g]
    nlab = int(labels.max()) + 1
    n_cc = nlab if n_cc is None else n_cc
    # normalised coordinates (Hartley) and their monomials
    q, Dall, mx, my, s = hartley_monomials(np.ascontiguousarray(pts, np.float64))
    m = (mx, my)
    # frame pixels -> normalised coordinates and back (A_wf: a scale and shift per axis)
    Tfq = np.array([[s / ax, 0.0, -s * (bx / ax + mx)], [0.0, s / ay, -s * (by / ay + my)], [0.0, 0.0, 1.0]])
    Tqf = np.array([[ax / s, 0.0, ax * mx + bx], [0.0, ay / s, ay * my + by], [0.0, 0.0, 1.0]])
    free = np.ones(n, bool)
    out: list[EllipseCandidate] = []
    rms_scale = math.sqrt(abs(ax * ay))  # working -> frame pixels, for distances
    ctx = (q, nrm, pts_full, s, m, tol, w, min_points, min_coverage, min_visible, max_rms, (W, H), visible, is_arc, sw, Tfq, rms_scale)
    priors = [np.asarray(C, float) for C in (prior or ())]
    for _round in range(max_ellipses):
        accepted = None
        # the ellipses of the previous frame first: a wide band around each
        # (the camera moved), refined and validated like any hypothesis
        while priors and accepted is None:
            c0 = _conic_to_coef(Tqf.T @ priors.pop(0) @ Tqf)
            accepted = _accept(c0 / np.linalg.norm(c0), np.flatnonzero(free), ctx, first_band=prior_band)
        if accepted is None:
            accepted = _search(free, labels, nlab, n_cc, Dall, ctx, first=not out)
        if accepted is None:
            break
        out.append(accepted)
        # release everything near this ellipse
        fidx = np.flatnonzero(free)
        near, _, _ = conic_band(_conic_to_coef(Tqf.T @ accepted.conic @ Tqf), q, nrm, fidx, 2.5 * tol * s, 0.0, False)
        free[fidx[near]] = False
        free[accepted.idx] = False
    return out


def _search(free, labels, nlab, n_cc, Dall, ctx, *, first):
    """One round of the RANSAC search over arcs: the first hypothesis that
    validates, or None. ``first``: the first round (pairs and triples of arcs
    for a circle broken into pieces; later rounds try single arcs)."""
    arc_n = np.bincount(labels[free], minlength=nlab)
    arc_n[0] = 0
    order = np.argsort(-arc_n)
    order = order[arc_n[order] >= 10]
    # curved arcs first; stretches that passed for short straight lines only
    # as partners of a curved arc
    curved = [int(k) for k in order if k < n_cc][:6]
    straight = [int(k) for k in order if k >= n_cc][:4]
    if not curved or arc_n[curved[0]] < (20 if first else 40):
        return None
    slot_of = np.full(nlab, -1, np.int64)
    slot_of[curved + straight] = np.arange(len(curved) + len(straight))
    Sarc = label_scatters(Dall, labels, free, slot_of)
    fidx = np.flatnonzero(free)
    # 2. hypotheses, cheapest first: single arcs and pairs, then triples
    # (the scatter of a union of arcs is the sum of their scatters)
    accepted = None
    for sel_m in _combinations(len(curved), len(straight), first):
        accepted = _try(np.einsum("hk,kij->hij", sel_m, Sarc), fidx, ctx)
        if accepted is not None:
            break
    return accepted


@functools.lru_cache(maxsize=None)
def _combinations(nc: int, ns: int, first: bool) -> tuple[np.ndarray, ...]:
    """The search's stages of hypotheses over ``nc`` curved arcs then ``ns``
    straight stretches: per stage, a (hypotheses, nc + ns) 0/1 matrix of the
    arcs each combines. First round: single curved arcs, pairs, a curved arc
    with a straight stretch; then triples of the 5 largest curved arcs (a
    circle broken into many arcs by players and the halfway line). Later
    rounds look for penalty arcs: the 4 largest curved arcs alone."""
    if first:
        top = min(nc, 5)
        st1 = [(i,) for i in range(nc)] + [(i, j) for i in range(nc) for j in range(i + 1, nc)]
        st1 += [(i, nc + j) for i in range(min(nc, 3)) for j in range(ns)]
        st2 = [(i, j, k) for i in range(top) for j in range(i + 1, top) for k in range(j + 1, top)]
        stages = [st1, st2]
    else:
        stages = [[(i,) for i in range(min(nc, 4))]]
    out = []
    for combos in stages:
        if combos:
            sel_m = np.zeros((len(combos), nc + ns))
            for r, cmb in enumerate(combos):
                sel_m[r, list(cmb)] = 1.0
            sel_m.flags.writeable = False
            out.append(sel_m)
    return tuple(out)


def _try(S, fidx, ctx):
    """Fit, screen, score and refine a stack of hypotheses (scatter matrices
    (K, 6, 6)); the first that validates, or None."""
    q, nrm, _, s, m, tol, w, min_points, min_coverage, min_visible, max_rms, size, visible, is_arc, sw, Tfq, _ = ctx
    coef, valid = direct_fits(np.ascontiguousarray(S, np.float64))
    # plausibility in working pixels before any scoring
    a, b, ang, ok = ellipse_params(coef, s, *m)
    valid &= ok & (a > 0.05 * w) & (a < 1.5 * w) & (b > 0.012 * w) & (b < 0.85 * a) & (b > 0.05 * a) & (np.abs(ang) < np.radians(30))
    if not valid.any():
        return None
    coef = coef[valid]
    # score on the free points: Sampson distance and gradient direction
    step = max(1, len(fidx) // 1000)
    n_in = conic_counts(coef, q, nrm, np.ascontiguousarray(fidx[::step]), tol * s, 0.95) * float(step)
    # inliers, discounted when they cover little of the hypothesis' perimeter
    # (a gentle curve fits huge flat ellipses with many inliers)
    av, bv = a[valid], b[valid]
    perim = np.pi * (3 * (av + bv) - np.sqrt((3 * av + bv) * (av + 3 * bv)))
    score = n_in * np.minimum(1.0, n_in / (0.5 * perim))
    for bi in np.argsort(-score)[:3]:
        if n_in[bi] < min_points:
            break
        accepted = _accept(coef[bi], fidx, ctx)
        if accepted is not None:
            return accepted
    return None


def _accept(coef0, fidx, ctx, *, first_band=None):
    """Refine a hypothesis (normalised coefficients (6,)) on the free points
    ``fidx`` and validate it in frame pixels: an EllipseCandidate, or None."""
    q, nrm, pts_full, s, m, tol, w, min_points, min_coverage, min_visible, max_rms, size, visible, is_arc, sw, Tfq, rms_scale = ctx
    cand = _refine(coef0, q, nrm, fidx, s, tol, first_band)
    if cand is None:
        return None
    coef_n, idx, rms_w = cand
    if rms_w > max_rms or len(idx) < min_points:
        return None
    # the answer in frame pixels: the conic pulled back through frame -> normalised coordinates
    status, cx, cy, a, b, angle = frame_ellipse(coef_n, Tfq)
    if status:
        return None
    ell = Ellipse(center=(cx, cy), axes=(a, b), angle=angle)
    P_full = pts_full[idx]
    rms = rms_w * rms_scale
    ok, cov, sc, kind = _validate(
        ell, P_full, rms, size, visible, is_arc, s_full=sw, min_points=min_points, min_coverage=min_coverage, min_visible=min_visible, max_rms=max_rms
    )
    return EllipseCandidate(ell, ell.conic, idx, rms, cov, sc, kind) if ok else None


def _conic_to_coef(C: np.ndarray) -> np.ndarray:
    return np.array([C[0, 0], 2 * C[0, 1], C[1, 1], 2 * C[0, 2], 2 * C[1, 2], C[2, 2]])


def _refine(coef0, q, nrm, fidx, s, tol, first_band=None):
    """Inliers of a hypothesis and iteratively reweighted direct fits (Sampson
    gradient weights, which make the algebraic fit nearly geometric) with a
    shrinking inlier band, in normalised coordinates: (coef, inlier indices,
    rms Sampson distance in working px), or None. ``first_band`` (working px,
    default 1.5 ``tol``): the first inlier band (wider for a prediction from
    the previous frame). The later bands lie inside the first: only the points
    near the hypothesis take part (the fits move the conic by a fraction of a
    pixel). One compiled loop (:func:`arstream.detect.kernels.ellipses.refine_conic`)."""
    if first_band is None:
        first_band = 1.5 * tol
    coef, idx, rms, ok = refine_conic(np.ascontiguousarray(coef0, np.float64), q, nrm, fidx.astype(np.int64, copy=False), float(s), float(tol), float(first_band))
    return (coef, idx, float(rms)) if ok else None


def _validate(e: Ellipse, P_full, rms, size, visible, is_arc, *, s_full, min_points, min_coverage, min_visible, max_rms):
    """Final checks in frame pixels: (ok, coverage, score, kind)."""
    W, H = size
    a, b = e.axes
    if len(P_full) < min_points:
        return False, 0.0, 0.0, ""
    if not (0.06 * W < a < 1.5 * W and b > 0.016 * W and 0.1 < b / a < 0.85 and abs(e.angle) < np.radians(30)):
        return False, 0.0, 0.0, ""
    if rms > max_rms * s_full:
        return False, 0.0, 0.0, ""
    pb = _PerimeterBins(P_full, e, spacing=s_full)
    cov = pb.cov
    if cov < min_coverage:
        return False, cov, 0.0, ""
    vcov = None
    if is_arc is not None and is_arc(e, P_full):
        kind = "arc"
    elif (vcov := pb.visible_coverage(visible)) >= min_visible or (
        vcov >= 0.6 * min_visible and rms <= 0.25 * max_rms * s_full and largest_gap(P_full, e) <= 0.4
    ):
        # a closed circle: most of its visible perimeter supported, or at least
        # opposite arcs of it (a fast pan smears the sides away)
        kind = "circle"
    else:
        return False, cov, 0.0, ""
    if vcov is None:
        vcov = pb.visible_coverage(visible)
    score = float(min(1.0, vcov / 0.8) * np.exp(-((rms / s_full) / 0.6) ** 2))
    return True, cov, score, kind
