"""Cameras from straight lines: the initialisers for views without the
centre circle (penalty areas, goal areas, touchlines).

The pitch's straight markings run in two directions. Their images meet in
two vanishing points, which split the detected lines into two families;
seen from the main side (Y < 0), each family keeps its order in the image
(lines along the touchlines bottom to top, lines across them left to right).
Ordered assignments of image lines to model lines give homographies
(normalised DLT from lines, :func:`geometry.homography.homographies_from_lines`)
and, with the principal point, cameras.

* :func:`cameras_from_line_hypotheses` — for the detector's lines on clean
  pictures: ordered runs of lines, the caller refines and scores.
* :func:`cameras_from_line_pairs` — for real frames: every ordered pair of
  lines of each direction against every ordered pair of model lines, each
  homography scored against the frame's paint (its markings on paint, and
  the lines on markings), the best extended by guided matching and turned
  into the nearest camera (:func:`geometry.camera.camera_near_homography`).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np
import scipy.spatial

from geometry.camera import Camera, camera_near_homography, decompose_homographies, homographies_from_parallel_lines_batch, intrinsic_matrix
from geometry.homography import homographies_from_four_points, homographies_from_lines, normalize_homographies
from geometry.lines import normalize_line
from geometry.pitch import PitchModel

__all__ = ["cameras_from_line_hypotheses", "cameras_from_line_pairs", "LineHypotheses", "plausible", "same_camera"]


def _vp_candidates(L: list[np.ndarray], mids: np.ndarray, tol_deg: float = 1.5, ends: np.ndarray | None = None) -> list[tuple[np.ndarray, list[int]]]:
    """Candidate vanishing points (pairwise intersections of the lines) with the
    lines that point at each: [(point (3,), inlier indices)].

    With the segments' endpoints ``ends`` (N, 2, 2), a line counts only when the
    point lies beyond its segment: parallel pitch lines meet on the horizon,
    above every pitch pixel, never between a segment's ends (where lines of
    both directions meet at a corner of the markings, which is no vanishing
    point)."""
    out = []
    n = len(L)
    tol = np.sin(np.radians(tol_deg))
    for a in range(n):
        for b in range(a + 1, n):
            v = np.cross(L[a], L[b])
            if np.linalg.norm(v) < 1e-12:
                continue
            v = v / np.linalg.norm(v)
            inl = []
            for k in range(n):
                # direction from the line's midpoint to v versus the line's direction
                d_line = np.array([L[k][1], -L[k][0]])
                to_v = v[:2] - v[2] * mids[k]
                nv = np.linalg.norm(to_v)
                if not (nv < 1e-12 or abs(d_line[0] * to_v[1] - d_line[1] * to_v[0]) / nv <= tol):
                    continue
                if ends is not None and abs(v[2]) > 1e-12:
                    # the point's place along the line against the segment's ends
                    t = (v[:2] / v[2] - mids[k]) @ d_line
                    t0, t1 = sorted(((ends[k] - mids[k]) @ d_line).tolist())
                    half = 0.5 * (t1 - t0)
                    if t0 - 0.25 * half < t < t1 + 0.25 * half:
                        continue
                inl.append(k)
            out.append((v, inl))
    return out


def _vp_family(L: list[np.ndarray], mids: np.ndarray, tol_deg: float = 1.5, ends: np.ndarray | None = None) -> tuple[np.ndarray | None, list[int]]:
    """The vanishing point shared by the most lines (:func:`_vp_candidates`);
    returns (point (3,), inlier indices). With ``ends``, "most" is the largest
    total length of the segments (two long markings outweigh three players' legs)."""
    seg_len = None if ends is None else np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1)

    def weight(idx):
        return len(idx) if seg_len is None else float(seg_len[idx].sum())

    best_v, best_in = None, []
    for v, inl in _vp_candidates(L, mids, tol_deg, ends):
        if weight(inl) > weight(best_in):
            best_v, best_in = v, inl
    return best_v, best_in


def cameras_from_line_hypotheses(
    lines: list[np.ndarray],
    size: tuple[int, int],
    principal_point,
    pitch: PitchModel | None = None,
    *,
    midpoints: np.ndarray | None = None,
    endpoints: np.ndarray | None = None,
    max_family: tuple[int, int] = (3, 4),
    tol_deg: float = 1.5,
) -> list[Camera]:
    """Candidate cameras from detected straight lines alone.

    The lines are grouped by their two dominant vanishing points (the pitch's
    two line directions). Lines parallel to the touchlines look nearly
    horizontal from the main camera and are ordered near to far (bottom to
    top); lines parallel to the goal lines are ordered left to right. Ordered
    assignments of two or more lines of each family to the model's lines of
    either half give homographies (normalised DLT from lines) and, with the
    known principal point, cameras. The caller scores them (e.g. by refinement).

    Parameters
    ----------
    lines : list of (3,) image lines (pixels), longest first
    size : (width, height)
    principal_point : (2,) pixels
    pitch : PitchModel
    midpoints : (N, 2) midpoints of the detected segments (pixels); default: the
        foot of the perpendicular from the image centre (or the middle of
        ``endpoints``)
    endpoints : (N, 2, 2) the segments' ends (pixels), optional: a family's
        vanishing point must lie beyond each of its segments
    max_family : most lines of each family used
    tol_deg : angle (degrees) within which a line points at a family's
        vanishing point

    Returns
    -------
    list of Camera (possibly empty): valid ones only (above the pitch, behind the
    near touchline, plausible focal length).
    """
    pitch = pitch or PitchModel()
    W, H = size
    L = [normalize_line(np.asarray(l, float)) for l in lines]
    if len(L) < 4:
        return []
    c = np.array([W / 2, H / 2])
    ends = None if endpoints is None else np.asarray(endpoints, float).reshape(len(L), 2, 2)
    if midpoints is None:
        midpoints = ends.mean(axis=1) if ends is not None else np.array([c - (l[:2] @ c + l[2]) * l[:2] for l in L])
    mids = np.asarray(midpoints, float)
    v1, in1 = _vp_family(L, mids, tol_deg, ends)
    rest = [k for k in range(len(L)) if k not in in1]
    if v1 is None or len(in1) < 2 or len(rest) < 2:
        return []
    v2, in2r = _vp_family([L[k] for k in rest], mids[rest], tol_deg, None if ends is None else ends[rest])
    in2 = [rest[k] for k in in2r]
    if len(in2) < 2:
        return []
    fams = []
    for idx in (in1, in2):
        ang = np.degrees(np.arctan2(-np.array([L[k][0] for k in idx]), np.array([L[k][1] for k in idx])))  # line angle
        ang = (ang + 90) % 180 - 90
        fams.append((idx, float(np.median(np.abs(ang)))))
    # "along" (parallel to X) = the flatter family in the image
    (along_idx, _), (across_idx, _) = sorted(fams, key=lambda f: f[1])
    along_idx = along_idx[: max_family[1]]
    across_idx = across_idx[: max_family[0]]
    # order: along lines bottom -> top (near -> far), across lines left -> right
    along_idx = sorted(along_idx, key=lambda k: -(-(L[k][0] * c[0] + L[k][2]) / L[k][1]) if abs(L[k][1]) > 1e-9 else 0.0)
    across_idx = sorted(across_idx, key=lambda k: -(L[k][1] * c[1] + L[k][2]) / L[k][0] if abs(L[k][0]) > 1e-9 else 0.0)
    half_len = pitch.length / 2
    # every ordered assignment, of both halves, grouped by its number of lines:
    # one batched solve per group (the many small batches' overheads cost as
    # much as the solves); the cameras come back in the assignments' order
    groups: dict[int, tuple[list, list, list]] = {}
    count = 0
    for side in ("left", "right"):
        across = [pitch[n].line for n in ("halfway_line", f"penalty_area_{side}_front", f"goal_area_{side}_front", f"goal_line_{side}")]
        if side == "left":
            across = across[::-1]
        along = [pitch[n].line for n in ("touchline_near", f"penalty_area_{side}_near", f"goal_area_{side}_near", f"goal_area_{side}_far", f"penalty_area_{side}_far", "touchline_far")]
        for na in range(min(len(across_idx), 4), 1, -1):
            for nb in range(min(len(along_idx), 6), 1, -1):
                if na + nb < 4:
                    continue
                dst = np.array([L[k] for k in across_idx[:na]] + [L[k] for k in along_idx[:nb]])
                src = np.array([[across[m] for m in ma] + [along[m] for m in mb] for ma in combinations(range(len(across)), na) for mb in combinations(range(len(along)), nb)])
                srcs, dsts, order = groups.setdefault(na + nb, ([], [], []))
                srcs.append(src)
                dsts.append(np.broadcast_to(dst, src.shape))
                order.append(count + np.arange(len(src)))
                count += len(src)
    found: list[tuple[int, Camera]] = []
    for srcs, dsts, order in groups.values():
        Hs, ok = homographies_from_lines(np.concatenate(srcs), np.concatenate(dsts))
        # only those with a plausible focal length decomposed
        poses = decompose_homographies(Hs[ok], principal_point)
        C, f = poses.centre, poses.focal
        # valid, above the pitch behind the near touchline, a plausible focal length
        good = poses.ok & (C[:, 1] < -pitch.width / 2 - 3) & (C[:, 2] > 3) & (C[:, 2] < 80) & (np.abs(C[:, 0]) < half_len) & (f > 0.3 * W) & (f < 12 * W)
        rank = np.concatenate(order)[ok]
        found += [(int(rank[k]), Camera(K=intrinsic_matrix(float(f[k]), *principal_point), R=poses.R[k], t=poses.t[k])) for k in np.flatnonzero(good)]
    found.sort(key=lambda rc: rc[0])
    return [cam for _, cam in found]


# ---------------------------------------------------------------------------
# initialiser from pairs of lines of each direction, scored on the paint
@dataclass(frozen=True)
class LineHypotheses:
    """Cameras from ordered pairs of lines of each pitch direction, best first
    (:func:`cameras_from_line_pairs`).

    Attributes
    ----------
    cameras : list of Camera, at most ``keep`` of them
    scores : (M,) float64, their scores (hits / (in view + 30) over the model
        samples, see :func:`cameras_from_line_pairs`)
    n_tried : int, homographies solved
    n_plausible : int, of which gave a plausible camera
    """

    cameras: list
    scores: np.ndarray
    n_tried: int
    n_plausible: int


def _line_families(L: np.ndarray, ends: np.ndarray, tol_deg: float, principal_point=None, width: float | None = None, splits: int = 1) -> list[tuple[list[int], list[int]]]:
    """Split lines (N, 3) with segment ends (N, 2, 2) into the pitch's two
    directions: (along the touchlines, across them), by two vanishing points
    (:func:`_vp_candidates`); the flatter family is "along".

    Without a ``principal_point`` (or without such a pair): the point with the
    most line length, then the one with the most of the rest. With it (2,) and the frame's
    ``width``: the two points with the most line length together that make a
    camera: vanishing points ``v1``, ``v2`` of perpendicular directions give
    ``f^2 = -(v1 - p) . (v2 - p)``, which must lie between (0.3 width)^2 and
    (12 width)^2 (a touchline, an arc's piece and a line across can share a
    point that the longest family's lines do not make a camera with).

    Returns up to ``splits`` different splits [(along, across)], the most line
    length first (one where a line is missing can pair a piece of an arc
    with the wrong family: the next split still has the right one); empty
    when the lines make none."""
    mids = ends.mean(axis=1)
    in1, in2 = [], []
    if principal_point is not None and width is not None:
        seg_len = np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1)
        p = np.asarray(principal_point, float)
        cands = [(v, inl) for v, inl in _vp_candidates(list(L), mids, tol_deg, ends) if inl]
        found: dict = {}  # (family, family) -> line length
        lo, hi = (0.3 * width) ** 2, (12.0 * width) ** 2
        for i, (va, ia) in enumerate(cands):
            if len(ia) < 2:
                continue
            for j, (vb, ib) in enumerate(cands):
                if j == i:
                    continue
                ib2 = [k for k in ib if k not in ia]
                if not ib2:
                    continue
                if abs(va[2]) > 1e-9 and abs(vb[2]) > 1e-9:
                    f2 = -float((va[:2] / va[2] - p) @ (vb[:2] / vb[2] - p))
                    if not lo <= f2 <= hi:
                        continue
                key = (tuple(sorted(ia)), tuple(sorted(ib2)))
                found[key] = max(found.get(key, 0.0), float(seg_len[ia].sum() + seg_len[ib2].sum()))
        ranked = sorted(found.items(), key=lambda e: -e[1])
        if ranked:
            out = []
            for (fa, fb), _ in ranked:
                split = _oriented(L, list(fa), list(fb))
                if split not in out:
                    out.append(split)
                if len(out) >= splits:
                    break
            return out
    if len(in1) < 2 or not in2:
        # (no such pair, or no principal point: the point with the most line
        # length, then the one with the most of the rest; a single line left is
        # a family of its own, with no point to check)
        _, in1 = _vp_family(list(L), mids, tol_deg, ends)
        rest = [k for k in range(len(L)) if k not in in1]
        if len(in1) < 2 or not rest:
            return []
        _, in2r = _vp_family([L[k] for k in rest], mids[rest], tol_deg, ends[rest])
        in2 = [rest[k] for k in in2r] if len(rest) >= 2 else rest
    if not in2:
        return []
    return [_oriented(L, in1, in2)]


def _oriented(L: np.ndarray, in1: list[int], in2: list[int]) -> tuple[list[int], list[int]]:
    """(along, across) of two families of lines (N, 3): the flatter is "along"."""

    def flatness(idx):
        return float(np.median([abs(L[k][1]) for k in idx]))  # |b| ~ 1 for a horizontal line

    return (in1, in2) if flatness(in1) >= flatness(in2) else (in2, in1)


def same_camera(a: Camera, b: Camera) -> bool:
    """Two hypotheses are one camera: centres within 1 m, focal lengths within 2 %."""
    return bool(np.linalg.norm(a.center - b.center) < 1.0 and abs(np.log(a.focal / b.focal)) < 0.02)


def plausible(centre: np.ndarray, focal: np.ndarray, width: float, pitch: PitchModel) -> np.ndarray:
    """Which cameras could be a main broadcast camera: above the pitch (3-80 m),
    outside the near touchline by 3 to 100 m, within 20 m of the goal lines' extent,
    with a focal length from 0.3 to 12 frame widths.

    Parameters
    ----------
    centre : (K, 3) camera centres, pitch frame, metres
    focal : (K,) focal lengths, pixels
    width : frame width, pixels
    pitch : PitchModel

    Returns
    -------
    (K,) bool
    """
    C = np.asarray(centre, float).reshape(-1, 3)
    f = np.asarray(focal, float).reshape(-1)
    hl, hw = pitch.length / 2, pitch.width / 2
    with np.errstate(invalid="ignore"):
        return (C[:, 1] < -hw - 3) & (C[:, 1] > -hw - 100) & (C[:, 2] > 3) & (C[:, 2] < 80) & (np.abs(C[:, 0]) < hl + 20) & (f > 0.3 * width) & (f < 12 * width)


def _corner_homographies(L: np.ndarray, across, along, xs, ys, centre, scale: float, metres: float) -> tuple[np.ndarray, np.ndarray]:
    """The homographies (pitch -> image) of every pairing of two image lines
    of each direction with two model lines of each: lines ``across`` (pairs
    of indices into L, (N, 3) pixels) on X = x0, x1 for each (x0, x1) of
    ``xs``, lines ``along`` on Y = y0, y1 for each of ``ys``. The two lines
    of each direction meet at four corners, the model's at the rectangle's
    (x_i, y_j), so each is the closed-form homography of four points
    (:func:`geometry.homography.homographies_from_four_points`), made in
    frames of order one (the image about ``centre`` over ``scale`` pixels,
    the pitch over ``metres``).

    Returns
    -------
    (H (A * B * X * Y, 3, 3), ok): ordered by across pair, along pair, xs
    pair, ys pair (the first slowest)
    """
    cx, cy = centre
    Ln = L * np.array([scale, scale, 1.0])
    Ln[:, 2] = L[:, 0] * cx + L[:, 1] * cy + L[:, 2]
    ia, ib = np.array(across, dtype=np.int64).reshape(-1, 2), np.array(along, dtype=np.int64).reshape(-1, 2)
    # image corners: (across a, along b) for (a, b) = (0, 0), (1, 0), (0, 1), (1, 1)
    order = ((0, 0), (1, 0), (0, 1), (1, 1))
    P = np.stack([np.cross(Ln[ia[:, a]][:, None, :], Ln[ib[:, b]][None, :, :]) for a, b in order], axis=2).reshape(-1, 4, 3)
    X, Y = np.asarray(xs, float).reshape(-1, 2) / metres, np.asarray(ys, float).reshape(-1, 2) / metres
    Q = np.stack([np.stack(np.broadcast_arrays(X[:, a][:, None], Y[:, b][None, :], 1.0), axis=-1) for a, b in order], axis=2).reshape(-1, 4, 3)
    # corner bases once per pair of pairs, then every image one with every model one
    n_img, n_mod = len(P), len(Q)
    basis = np.tile(np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0], [1.0, 1, 1]]), (max(n_img, n_mod), 1, 1))
    Hi, oki = homographies_from_four_points(basis[:n_img], P)  # basis -> image corners
    Hm, okm = homographies_from_four_points(Q, basis[:n_mod])  # model corners -> basis
    H = np.einsum("aij,bjk->abik", Hi, Hm).reshape(-1, 3, 3)
    ok = (oki[:, None] & okm[None, :]).reshape(-1)
    # back to pixels and metres
    Ti = np.array([[scale, 0.0, cx], [0.0, scale, cy], [0.0, 0.0, 1.0]])
    Tm = np.diag([1.0 / metres, 1.0 / metres, 1.0])
    H = Ti @ H @ Tm
    sv = np.linalg.svd(H, compute_uv=False)
    ok &= sv[:, 2] >= 1e-12 * sv[:, 0]
    H[~ok] = np.eye(3)
    return normalize_homographies(H), ok


def _guided(Hs: np.ndarray, L: np.ndarray, E: np.ndarray, across, along, m_across: np.ndarray, m_along: np.ndarray, reach: float) -> tuple[np.ndarray, list[int]]:
    """Guided matching of hypotheses (pitch -> image homographies ``Hs``, (T, 3, 3),
    none singular): each takes, for every image line of each direction
    (indices ``across``, ``along`` into L, (N, 3), with segment ends E,
    (N, 2, 2)), the model line of that direction (``m_across``, ``m_along``,
    (M, 3) pitch lines) whose image under it passes within ``reach`` pixels
    of both the segment's ends (the nearest), and is solved again from all
    its correspondences (:func:`geometry.homography.homographies_from_lines`)
    where there are more than four.

    Returns
    -------
    (the new homographies (K, 3, 3), the index into Hs of each)
    """
    Hit = np.transpose(np.linalg.inv(Hs), (0, 2, 1))  # model line -> image line
    src, fam = [], []
    for ks, models in ((across, m_across), (along, m_along)):
        if not len(ks) or not len(models):
            continue
        li = np.einsum("tij,mj->tmi", Hit, models)  # (T, M, 3) image lines
        nrm = np.hypot(li[..., 0], li[..., 1])
        for k in ks:
            with np.errstate(divide="ignore", invalid="ignore"):
                dd = np.max(np.abs(np.einsum("tmi,ei->tme", li[..., :2], E[k]) + li[..., 2:3]), axis=2) / nrm
            dd = np.where(nrm >= 1e-12, dd, np.inf)
            best = np.argmin(dd, axis=1)
            hit = dd[np.arange(len(Hs)), best] < reach
            src.append(np.where(hit[:, None], models[best], np.nan))
            fam.append(k)
    if not src:
        return np.zeros((0, 3, 3)), []
    S = np.stack(src, axis=1)  # (T, F, 3), NaN where the line took no model line
    matched = ~np.isnan(S[..., 0])
    count = matched.sum(axis=1)
    out, idx = [], []
    for n in sorted(set(count[count > 4].tolist())):
        rows = np.flatnonzero(count == n)
        src_l = S[rows][matched[rows]].reshape(len(rows), n, 3)
        dst_l = np.broadcast_to(L[np.array(fam)], (len(rows), len(fam), 3))[matched[rows]].reshape(len(rows), n, 3)
        H2, ok2 = homographies_from_lines(src_l, dst_l)
        out.append(H2[ok2])
        idx += rows[ok2].tolist()
    return (np.concatenate(out) if out else np.zeros((0, 3, 3))), idx


def cameras_from_line_pairs(
    lines,
    endpoints,
    size: tuple[int, int],
    principal_point,
    near: np.ndarray,
    pitch: PitchModel | None = None,
    *,
    max_family: int = 4,
    tol_deg: float = 2.0,
    keep: int = 8,
    spacing: float = 1.0,
    guided: int = 150,
    prescreen: int = 600,
    splits: int = 2,
    first_split: int = 0,
) -> LineHypotheses:
    """Candidate cameras from straight lines, scored against the frame's paint.

    The lines are split into the pitch's two directions by their vanishing
    points (each must lie beyond every segment of its family). Seen from the
    main side (Y < 0), lines along the touchlines (Y = const) keep their
    order bottom to top and lines across them (X = const) left to right; so
    every ordered pair of image lines of each direction, with every ordered
    pair of model lines of that direction (touchlines, penalty- and goal-area
    sides; goal lines, goal-area and penalty-area fronts, the halfway line),
    fixes a homography (four line correspondences, :func:`homographies_from_lines`).
    Each split is tried both ways round: the flatter family is along the
    touchlines only while the camera looks within about 45 degrees of
    straight across the pitch.
    With the principal point it gives a camera (:func:`decompose_homographies`),
    kept when plausible (:func:`plausible`: above the pitch, outside the near
    touchline, a focal length from 0.3 to 12 widths). Each is scored by the model's markings
    sampled every ``spacing`` m: ``hits / (in view + 30)``, hits being
    samples that land on a non-zero pixel of ``near`` (paint, grown by the
    tolerance); the 30 keeps a view of one short stretch from winning.

    Parameters
    ----------
    lines : (N, 3) image lines, pixels, a^2 + b^2 = 1
    endpoints : (N, 2, 2) their segments' ends, pixels
    size : (width, height) of the frame
    principal_point : (2,) pixels
    near : (h, w) uint8 or bool, non-zero within the tolerance of paint; any
        size (scaled to the frame)
    pitch : PitchModel (default 105 x 68)
    max_family : most lines of each direction used (the first ones given)
    tol_deg : angle within which a line points at its family's vanishing point
    keep : most cameras returned
    splits : most splits of the lines into the two directions tried
        (:func:`_line_families`, the most line length first)
    first_split : the splits before this one are left out (already tried:
        a caller that found no camera from the first splits asks for the
        next ones)

    Returns
    -------
    LineHypotheses
    """
    pitch = pitch or PitchModel()
    W, H = size
    L = np.array([normalize_line(np.asarray(l, float)) for l in lines]).reshape(-1, 3)
    E = np.asarray(endpoints, float).reshape(-1, 2, 2)
    empty = LineHypotheses([], np.zeros(0), 0, 0)
    if len(L) < 4:
        return empty
    def one(along, across) -> LineHypotheses:
        """The hypotheses of one split of the lines into the two directions."""
        three_one = (len(along) >= 3 and len(across) == 1) or (len(across) >= 3 and len(along) == 1)
        if (len(along) < 2 or len(across) < 2) and not three_one:
            return empty
        along, across = along[:max_family], across[:max_family]
        c = np.array([W / 2, H / 2])

        def y_at_centre(k):
            return -(L[k][0] * c[0] + L[k][2]) / L[k][1] if abs(L[k][1]) > 1e-9 else np.inf

        def x_at_centre(k):
            return -(L[k][1] * c[1] + L[k][2]) / L[k][0] if abs(L[k][0]) > 1e-9 else np.inf

        along = sorted(along, key=lambda k: -y_at_centre(k))  # bottom (near) to top (far)
        across = sorted(across, key=x_at_centre)  # left to right
        hl, hw = pitch.length / 2, pitch.width / 2
        # the model's straight markings of each direction, by their centrelines
        xs = sorted({round(sg.start[0], 6) for sg in pitch.segments if abs(sg.start[0] - sg.end[0]) < 1e-9})
        ys = sorted({round(sg.start[1], 6) for sg in pitch.segments if abs(sg.start[1] - sg.end[1]) < 1e-9})
        m_across = [np.array([1.0, 0.0, -x]) for x in xs]  # X = x
        m_along = [np.array([0.0, 1.0, -y]) for y in ys]  # Y = y
        hs = []
        if three_one:
            # one line of a direction only (a goal line behind the net, the far side
            # of the penalty area out of view): three lines of the other direction,
            # ordered, against three model lines, and the one against every model
            # line of its direction; the camera's principal point and square pixels
            # take up the degree of freedom four such lines leave
            # (:func:`homographies_from_parallel_lines`). (Tried also beside the pairs
            # when both directions have two or more lines, they registered 3 more
            # of the 51 Premier League frames, one of them wrong: not done.)
            for par, rest, axis in ((along, across, 1), (across, along, 0)):
                if len(par) < 3:
                    continue
                vals, others = (ys, xs) if axis == 1 else (xs, ys)
                LT, VT = np.repeat(L[rest], len(others), axis=0), np.tile(others, len(rest))
                for ti in combinations(par, 3):
                    for tm in combinations(range(len(vals)), 3):
                        Hb, okb = homographies_from_parallel_lines_batch(L[list(ti)], [vals[m] for m in tm], LT, VT, principal_point, axis=axis)
                        hs.extend(Hb[okb])
        Hs = np.array(hs).reshape(-1, 3, 3)
        ok = np.ones(len(Hs), bool)
        n = len(Hs)
        if len(along) >= 2 and len(across) >= 2:
            ia = list(combinations(across, 2))
            ib = list(combinations(along, 2))
            ma = list(combinations(range(len(xs)), 2))
            mb = list(combinations(range(len(ys)), 2))
            # every (image pair, model pair) of each direction, in that order
            # (image pairs slowest): two lines of each direction meet at four
            # corners, the model's at a rectangle's (homographies_from_four_points)
            H4, ok4 = _corner_homographies(L, ia, ib, [(xs[i], xs[j]) for i, j in ma], [(ys[i], ys[j]) for i, j in mb], c, W, hl)
            n += len(H4)
            Hs, ok = np.concatenate([H4, Hs]), np.concatenate([ok4, ok])
        if not len(Hs):
            return LineHypotheses([], np.zeros(0), n, 0)
        poses = decompose_homographies(Hs[ok], principal_point)
        C, f = poses.centre, poses.focal
        good = poses.ok & plausible(C, f, W, pitch)
        idx = np.flatnonzero(good)
        if not len(idx):
            return LineHypotheses([], np.zeros(0), n, 0)
        Hg = Hs[ok][idx]
        # precision: the model's markings sampled, the share that lands on paint
        P = np.concatenate([m.sample(spacing) for m in pitch.markings.values()])
        Ph = np.column_stack([P, np.ones(len(P))])
        nz = np.asarray(near) > 0
        sy, sx = nz.shape[0] / H, nz.shape[1] / W
        # recall: points along the detected segments (the family lines used), the
        # share that lies within ``tol`` pixels of a marking (distance on the pitch
        # over the pitch metres one pixel across the line covers there)
        used = sorted(set(along) | set(across))
        t = np.linspace(0.0, 1.0, 16)
        Q = np.concatenate([(1 - t)[:, None] * E[k, 0] + t[:, None] * E[k, 1] for k in used])
        Qn = np.concatenate([np.tile(L[k][:2], (len(t), 1)) for k in used])
        Qh = np.column_stack([Q, np.ones(len(Q))])
        Qh1 = np.column_stack([Q + Qn, np.ones(len(Q))])
        tree = scipy.spatial.cKDTree(pitch.sample_points(0.25))
        tol = max(2.0, 2.5 * W / 1280)

        def score(Hb: np.ndarray) -> np.ndarray:
            """precision x recall of homographies (K, 3, 3)"""
            out = np.empty(len(Hb))
            for s in range(0, len(Hb), 1024):
                Hk = Hb[s : s + 1024]
                X = np.einsum("kij,nj->kni", Hk, Ph)
                with np.errstate(divide="ignore", invalid="ignore"):
                    u, v = X[..., 0] / X[..., 2], X[..., 1] / X[..., 2]
                inside = (X[..., 2] > 0) & (u >= 0) & (u <= W - 1) & (v >= 0) & (v <= H - 1)
                ui = np.clip(np.where(inside, u * sx, 0), 0, nz.shape[1] - 1).astype(np.int64)
                vi = np.clip(np.where(inside, v * sy, 0), 0, nz.shape[0] - 1).astype(np.int64)
                hits = (nz[vi, ui] & inside).sum(axis=1)
                precision = hits / (inside.sum(axis=1) + 30.0)
                with np.errstate(divide="ignore", invalid="ignore"):
                    Hi = np.linalg.inv(Hk)
                    G = np.einsum("kij,nj->kni", Hi, Qh)
                    G1 = np.einsum("kij,nj->kni", Hi, Qh1)
                    g, g1 = G[..., :2] / G[..., 2:], G1[..., :2] / G1[..., 2:]
                    scale = np.linalg.norm(g1 - g, axis=2)
                fin = np.all(np.isfinite(g), axis=2) & np.isfinite(scale)
                d = np.full(g.shape[:2], np.inf)
                d[fin], _ = tree.query(g[fin], distance_upper_bound=5.0)
                with np.errstate(invalid="ignore"):
                    recall = np.mean(d / np.where(scale > 0, scale, np.inf) <= tol, axis=1)
                out[s : s + 1024] = precision * recall
            return out

        # precision alone first (cheap), on a sparser sampling; the full score for the best
        scores = np.full(len(Hg), -1.0)
        pre = np.empty(len(Hg))
        P2h = Ph[::2]
        for s in range(0, len(Hg), 2048):
            X = np.einsum("kij,nj->kni", Hg[s : s + 2048], P2h)
            with np.errstate(divide="ignore", invalid="ignore"):
                u, v = X[..., 0] / X[..., 2], X[..., 1] / X[..., 2]
            inside = (X[..., 2] > 0) & (u >= 0) & (u <= W - 1) & (v >= 0) & (v <= H - 1)
            ui = np.clip(np.where(inside, u * sx, 0), 0, nz.shape[1] - 1).astype(np.int64)
            vi = np.clip(np.where(inside, v * sy, 0), 0, nz.shape[0] - 1).astype(np.int64)
            pre[s : s + 2048] = (nz[vi, ui] & inside).sum(axis=1) / (inside.sum(axis=1) + 15.0)
        first = np.argsort(-pre)[:prescreen]
        scores[first] = score(Hg[first])
        # guided matching: the best hypotheses take every family line that lies
        # on a model line of its direction under them, and are solved again from
        # all those correspondences (more lines, a better homography)
        top = np.argsort(-scores)[:guided]
        top = top[np.abs(np.linalg.det(Hg[top])) > 0]
        Hx, cand = _guided(Hg[top], L, E, across, along, np.array(m_across), np.array(m_along), 0.012 * W)
        cand = [int(top[i]) for i in cand]
        if len(Hx):
            p2 = decompose_homographies(Hx, principal_point)
            C2, f2 = p2.centre, p2.focal
            ok = p2.ok & plausible(C2, f2, W, pitch)
            s2 = score(Hx)
            for i in np.flatnonzero(ok & (s2 > scores[np.array(cand)])):
                scores[cand[i]] = s2[i]
                Hg[cand[i]] = Hx[i]
        # the camera nearest to each of the best homographies on the pitch it shows
        gx, gy = np.meshgrid(np.arange(-hl - 4, hl + 4.1, 2.0), np.arange(-hw - 4, hw + 4.1, 2.0))
        grid = np.column_stack([gx.ravel(), gy.ravel()])
        gh = np.column_stack([grid, np.ones(len(grid))])
        cams, sc = [], []
        for j in np.argsort(-scores):
            X = gh @ Hg[j].T
            with np.errstate(divide="ignore", invalid="ignore"):
                u, v = X[:, 0] / X[:, 2], X[:, 1] / X[:, 2]
            seen = (X[:, 2] > 0) & (u >= 0) & (u <= W - 1) & (v >= 0) & (v <= H - 1)
            try:
                cam = camera_near_homography(Hg[j], principal_point, grid[seen])
            except ValueError:
                continue
            # the same camera from another assignment (a line pair read twice): skip
            if any(same_camera(cam, o) for o in cams):
                continue
            cams.append(cam)
            sc.append(scores[j])
            if len(cams) >= keep:
                break
        return LineHypotheses(cams, np.array(sc), n, int(len(idx)))

    # each split both ways round: the flatter family is along the touchlines
    # while the camera looks within 45 degrees of straight across the pitch; a
    # penalty area seen from near the halfway line can be farther round
    out = [one(*ab) for a, b in _line_families(L, E, tol_deg, principal_point, W, splits=splits)[first_split:] for ab in ((a, b), (b, a))]
    if not out:
        return empty
    # the first split's ``keep`` best (each way round) and each further split's
    # ``keep // 2``, best first (the refinement against the paint decides between them)
    cams, sc = [], []
    for i, h in enumerate(out):
        for cam, v in list(zip(h.cameras, h.scores))[: keep if i < 2 else max(1, keep // 2)]:
            if not any(same_camera(cam, o) for o in cams):
                cams.append(cam)
                sc.append(v)
    order = np.argsort(-np.array(sc), kind="stable")
    return LineHypotheses([cams[k] for k in order], np.array(sc)[order], sum(h.n_tried for h in out), sum(h.n_plausible for h in out))
