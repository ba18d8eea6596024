"""The camera of a frame: closed form from the centre circle's pole-polar
relations, an initialiser from line correspondences, and refinement against
every visible marking.

Closed form (DESIGN.md section 3). The centre circle is ``C_w = diag(1, 1, -r^2)``
(r = 9.09 m, the painted line's centre) and its image is the ellipse ``E``.
Pole-polar relations survive projection, so the vanishing line of the pitch
is the polar of the imaged centre, the pole of the halfway line is the
touchlines' vanishing point, and the imaged circular points lie on ``E``, on
the vanishing line and on the image of the absolute conic ``omega``. With
square pixels, zero skew and a known principal point, ``omega`` depends on f
only. For each f, ``E`` and ``omega(f)`` meet in two complex-conjugate pairs;
each pair spans a real line, the candidate vanishing line ``l_v(f)``; the true
f makes the pole of ``l_v`` lie on the halfway line:
``g(f) = l_h^T E^-1 l_v(f) = 0``. Everything is computed in coordinates
centred on the principal point and scaled by the image width (without that,
``g`` is numerically flat). Then ``r1 ~ K^-1 v_x``, ``r2 ~ K^-1 v_y``, the
centre's image gives the direction of ``t`` and the radius its length; signs
follow from "camera above the pitch, on the near side (Y < 0)".

Refinement: the model's markings are sampled, projected, matched to the
nearest detected line pixels, and the point-to-line distances along the
projected markings' normals are minimised (robust soft-L1 loss) over the pose
and f — or, for a broadcast camera on a tripod whose centre is known, over
pan, tilt, roll and f only — optionally with one radial coefficient k1.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, field
from itertools import combinations

import cv2
import numpy as np
import scipy.optimize
import scipy.spatial

from arstream.solve_kernels import grid_nearest, point_grid, pose_from_params, project_points, refine_pose
from geometry.camera import Camera, camera_near_homography, decompose_homographies, intrinsic_matrix
from geometry.conics import ellipse_from_conic, intersect_line_conic, normalize_conic, split_degenerate_conics
from geometry.homography import homographies_from_lines
from geometry.lines import normalize_line
from geometry.pitch import Arc, PitchModel

__all__ = [
    "CircleSolution",
    "solve_from_circle",
    "ModelSamples",
    "LineIndex",
    "Refinement",
    "refine_camera",
    "cameras_from_line_hypotheses",
]


# ---------------------------------------------------------------------------
# closed form from the centre circle
@dataclass(frozen=True)
class CircleSolution:
    """A camera from the centre circle and the halfway line.

    Attributes
    ----------
    camera : Camera (pitch frame; square pixels, the given principal point)
    f : float, focal length (pixels)
    orthogonality : float, ``|r1 . r2|`` before orthonormalisation (0 for exact data)
    centre_image : (2,) pixels, the image of the centre spot (pole of the vanishing line)
    """

    camera: Camera
    f: float
    orthogonality: float
    centre_image: np.ndarray


def _normaliser(principal_point, scale: float) -> np.ndarray:
    cx, cy = principal_point
    return np.array([[1 / scale, 0, -cx / scale], [0, 1 / scale, -cy / scale], [0, 0, 1.0]])


def _candidate_vanishing_lines(En: np.ndarray, phi: float) -> list[np.ndarray]:
    """The two real lines through the conjugate pairs of ``E_n ∩ omega_n(phi)``.

    ``E_n`` meets the imaginary conic ``omega_n = diag(1, 1, phi^2)`` in two
    complex-conjugate pairs. Of the three degenerate members of the pencil
    ``E_n - lam omega_n`` (the three ways to pair the four points), the one
    joining each point to its conjugate is a pair of *real* lines, i.e. an
    indefinite rank-2 matrix; the other two are conjugate line pairs
    (semi-definite). The candidate vanishing lines are that pair's lines
    (normalised coordinates): a list of two (3,) unit lines, or empty.
    """
    lines, found = _candidate_vanishing_lines_at(En, np.array([phi], dtype=np.float64))
    return list(lines[0]) if found[0] else []


def _candidate_vanishing_lines_at(En: np.ndarray, phis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_candidate_vanishing_lines` at P focal lengths ``phis`` (P,) at once
    (the solver's grid): lines (P, 2, 3) and ``found`` (P,) bool (where False,
    no real line pair and the lines are meaningless)."""
    P = len(phis)
    omega = np.ones((P, 3))
    omega[:, 2] = phis * phis
    lams = np.linalg.eigvals(En[None] / omega[:, :, None])  # (P, 3): the pencil's degenerate members
    real = np.abs(lams.imag) <= 1e-9 * np.maximum(1.0, np.abs(lams))
    D = En - lams.real[:, :, None, None] * (omega[:, None, :, None] * np.eye(3))  # (P, 3, 3, 3)
    w = np.linalg.eigvalsh(D)
    score = np.where(real, np.minimum(-w[..., 0], w[..., 2]), 0.0)  # both signs present: a real line pair
    best = np.argmax(score, axis=1)  # (the first of equals)
    rows = np.arange(P)
    found = score[rows, best] > 0.0
    lines = np.zeros((P, 2, 3))
    if found.any():
        g, h = split_degenerate_conics(D[rows, best][found])
        gh = np.stack([g, h], axis=1)  # (F, 2, 3) complex, real up to a phase
        top = np.take_along_axis(gh, np.argmax(np.abs(gh), axis=2)[..., None], axis=2)
        gh = np.real(gh * np.conj(top) / np.abs(top))
        lines[found] = gh / np.linalg.norm(gh, axis=2, keepdims=True)
    return lines, found


def _g(En_inv: np.ndarray, ln: np.ndarray, lv: np.ndarray) -> float:
    p = En_inv @ lv
    return float(ln @ p / (np.linalg.norm(p) + 1e-300))


def solve_from_circle(
    E,
    halfway_line,
    principal_point,
    *,
    image_width: float,
    radius: float | None = None,
    f_range: tuple[float, float] = (0.25, 10.0),
    samples: int = 32,
) -> list[CircleSolution]:
    """Cameras from the imaged centre circle and halfway line (pole-polar relations).

    Parameters
    ----------
    E : (3, 3) conic of the imaged centre circle, pixels
    halfway_line : (3,) image line of the halfway line, pixels
    principal_point : (2,) pixels
    image_width : float, pixels (sets the numerical conditioning)
    radius : float, centreline radius of the centre circle (m); default from PitchModel
    f_range : (lo, hi) focal lengths searched, as multiples of ``image_width``
    samples : grid size of the 1-D search before root polishing

    Returns
    -------
    list of CircleSolution, best (smallest orthogonality residual) first.

    Raises
    ------
    ValueError
        ``E`` is not an ellipse; the halfway line misses it; the ellipse is so
        flat that the circle is seen edge-on; or no focal length in range
        satisfies the constraint.
    """
    radius = PitchModel()["centre_circle"].radius if radius is None else float(radius)
    e = ellipse_from_conic(E)  # raises for non-ellipses
    if e.axes[1] / e.axes[0] < 0.03 or e.axes[1] < 2.0:
        raise ValueError("ellipse too flat: the centre circle is seen edge-on")
    lh = normalize_line(np.asarray(halfway_line, dtype=np.float64))
    try:
        ends = intersect_line_conic(E, lh)
    except ValueError:
        raise ValueError("the halfway line does not cross the centre-circle ellipse") from None
    T = _normaliser(principal_point, image_width)
    Ti = np.linalg.inv(T)
    En = normalize_conic(Ti.T @ E @ Ti)
    ln = Ti.T @ lh
    ln = ln / np.linalg.norm(ln)
    En_inv = np.linalg.inv(En)
    phis = np.geomspace(f_range[0], f_range[1], samples)
    # follow the two candidate lines over the grid by continuity
    tracks: list[list] = []
    prev = None
    try:
        grid, found = _candidate_vanishing_lines_at(En, phis)
    except ValueError:  # no convergence at some phi (LinAlgError): each on its own
        grid, found = np.zeros((len(phis), 2, 3)), np.zeros(len(phis), bool)
        for j in range(len(phis)):
            with contextlib.suppress(ValueError):
                grid[j : j + 1], found[j : j + 1] = _candidate_vanishing_lines_at(En, phis[j : j + 1])
    for phi, lines, ok in zip(phis, grid, found):
        if not ok:
            prev = None
            tracks.append([None, None])
            continue
        cands = list(lines)
        if prev is not None and abs(cands[0] @ prev[1]) > abs(cands[0] @ prev[0]):
            cands = cands[::-1]
        # keep signs continuous
        if prev is not None:
            cands = [c if c @ p >= 0 else -c for c, p in zip(cands, prev)]
        prev = cands
        tracks.append([(phi, c, _g(En_inv, ln, c)) for c in cands])
    roots = []
    for k in range(2):
        for a, b in zip(tracks[:-1], tracks[1:]):
            if a[k] is None or b[k] is None:
                continue
            (pa, la, ga), (pb, _, gb) = a[k], b[k]
            if ga == 0 or np.sign(ga) != np.sign(gb):
                ref = la

                def gfun(phi, ref=ref):
                    cs = _candidate_vanishing_lines(En, phi)
                    c = max(cs, key=lambda c: abs(c @ ref))
                    c = c if c @ ref >= 0 else -c
                    return _g(En_inv, ln, c)

                try:
                    phi0 = scipy.optimize.brentq(gfun, pa, pb, xtol=1e-12, rtol=1e-12)
                except (ValueError, RuntimeError):
                    continue
                cs = _candidate_vanishing_lines(En, phi0)
                lv = max(cs, key=lambda c: abs(c @ ref))
                roots.append((phi0, lv))
    if not roots:
        # noise can turn a pair of close roots into a near-miss: take clear local minima of |g|
        for k in range(2):
            vals = [(t[k][0], abs(t[k][2]), t[k][1]) if t[k] is not None else (None, np.inf, None) for t in tracks]
            for j in range(1, len(vals) - 1):
                if vals[j][1] < min(vals[j - 1][1], vals[j + 1][1]) and vals[j][1] < 0.05:
                    ref = vals[j][2]

                    def absg(phi, ref=ref):
                        cs = _candidate_vanishing_lines(En, phi)
                        if not cs:
                            return 1.0
                        c = max(cs, key=lambda c: abs(c @ ref))
                        return abs(_g(En_inv, ln, c))

                    opt = scipy.optimize.minimize_scalar(absg, bounds=(vals[j - 1][0] or phis[j - 1], vals[j + 1][0] or phis[j + 1]), method="bounded")
                    if opt.fun < 0.02:
                        cs = _candidate_vanishing_lines(En, opt.x)
                        roots.append((opt.x, max(cs, key=lambda c: abs(c @ ref))))
    if not roots:
        raise ValueError("no focal length satisfies the pole-polar constraint for this ellipse and line")
    sols = []
    for phi, lv in roots:
        try:
            sols.append(_camera_from_circle_geometry(En, ln, lv, phi, T, ends, radius, principal_point, image_width))
        except ValueError:
            continue
    if not sols:
        raise ValueError("no physically valid camera (above the pitch, near side) for this ellipse and line")
    sols.sort(key=lambda s: s.orthogonality)
    return sols


def _camera_from_circle_geometry(En, ln, lv, phi, T, ends, radius, principal_point, image_width) -> CircleSolution:
    Kn_inv = np.diag([1 / phi, 1 / phi, 1.0])
    En_inv = np.linalg.inv(En)
    o = En_inv @ lv  # imaged centre (normalised coords)
    vx = En_inv @ ln  # pole of the halfway line: touchline direction
    vy = np.cross(ln, lv)  # halfway line direction
    d1 = Kn_inv @ vx
    d2 = Kn_inv @ vy
    d1 /= np.linalg.norm(d1)
    d2 /= np.linalg.norm(d2)
    ortho = abs(float(d1 @ d2))
    d = Kn_inv @ o
    d = d / np.linalg.norm(d)
    if d[2] < 0:
        d = -d
    if d[2] <= 1e-9:
        raise ValueError("the centre of the circle projects to infinity")
    q_ends = [Kn_inv @ (T @ p) for p in ends]
    f = phi * image_width
    K = intrinsic_matrix(f, principal_point[0], principal_point[1])
    best = None
    for s1 in (1.0, -1.0):
        for s2 in (1.0, -1.0):
            r1, r2 = s1 * d1, s2 * d2
            M = np.column_stack([r1, r2, np.cross(r1, r2)])
            U, _, Vt = np.linalg.svd(M)
            R = U @ Vt
            r2o = R[:, 1]
            # scale from the radius: the ends of the halfway chord are (0, +-r, 0)
            lam = []
            for q, sgn in zip(q_ends, (1.0, -1.0)):
                a = np.cross(q, d)
                b = np.cross(q, sgn * radius * r2o)
                lam.append(-(a @ b) / (a @ a))
            lam_alt = []
            for q, sgn in zip(q_ends, (-1.0, 1.0)):
                a = np.cross(q, d)
                b = np.cross(q, sgn * radius * r2o)
                lam_alt.append(-(a @ b) / (a @ a))
            for ls in (lam, lam_alt):
                if min(ls) <= 0:
                    continue
                t = np.mean(ls) * d
                C = -R.T @ t
                if C[2] > 0 and C[1] < 0:
                    spread = abs(ls[0] - ls[1]) / np.mean(ls)
                    if best is None or spread < best[0]:
                        best = (spread, R, t)
    if best is None:
        raise ValueError("no sign choice puts the camera above the pitch on the near side")
    _, R, t = best
    cam = Camera(K=K, R=R, t=t)
    o_px = np.linalg.solve(T, o)
    return CircleSolution(camera=cam, f=f, orthogonality=ortho, centre_image=o_px[:2] / o_px[2])


# ---------------------------------------------------------------------------
# model samples and the detected-line index
@dataclass(frozen=True)
class ModelSamples:
    """The pitch markings sampled for refinement.

    Attributes
    ----------
    points : (N, 3) float64, pitch frame (Z = 0), metres
    tangents : (N, 3) float64, unit tangent of the marking at each point
    marking : (N,) int, index into ``names``
    names : tuple of marking names
    """

    points: np.ndarray
    tangents: np.ndarray
    marking: np.ndarray
    names: tuple

    @classmethod
    def from_pitch(cls, pitch: PitchModel | None = None, spacing: float = 0.5) -> "ModelSamples":
        pitch = pitch or PitchModel()
        P, Tg, M, names = [], [], [], []
        for k, (name, m) in enumerate(pitch.markings.items()):
            pts = m.sample(spacing)
            if isinstance(m, Arc):
                d = pts - np.asarray(m.center)
                tg = np.column_stack([-d[:, 1], d[:, 0]])
            else:
                tg = np.tile(np.subtract(m.end, m.start), (len(pts), 1))
            tg = tg / np.linalg.norm(tg, axis=1, keepdims=True)
            P.append(np.column_stack([pts, np.zeros(len(pts))]))
            Tg.append(np.column_stack([tg, np.zeros(len(tg))]))
            M.append(np.full(len(pts), k))
            names.append(name)
        return cls(np.concatenate(P), np.concatenate(Tg), np.concatenate(M), tuple(names))


class LineIndex:
    """Nearest detected line pixel lookup.

    The points are bucketed in a grid of ``cell``-pixel squares over their
    bounding box (:func:`arstream.solve_kernels.point_grid`); a query searches the
    cells within its radius (:func:`arstream.solve_kernels.grid_nearest`): exact
    nearest neighbours, at a fraction of a k-d tree's build cost for the few
    thousand points and queries of a frame.

    Parameters
    ----------
    points : (M, 2) float64 line-pixel centres, pixels (finite)
    cell : grid cell size, pixels
    """

    def __init__(self, points: np.ndarray, *, cell: float = 8.0):
        p = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 2))
        if not np.isfinite(p).all():
            raise ValueError("line points must be finite")
        self.points = p
        if len(p):  # (at most about 1024 cells a side)
            self._order, self._starts, self._grid = point_grid(p, float(cell), 1024)

    def __len__(self) -> int:
        return len(self.points)

    def nearest(self, q: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
        """Distances (N,) and nearest points (N, 2) for queries (N, 2); inf / NaN
        where no point is closer than ``radius`` (or the query is not finite)."""
        q = np.ascontiguousarray(np.asarray(q, dtype=np.float64).reshape(-1, 2))
        if len(self.points) == 0 or len(q) == 0:
            return np.full(len(q), np.inf), np.full((len(q), 2), np.nan)
        d, idx = grid_nearest(self.points, self._order, self._starts, *self._grid, q, float(radius))
        out = np.full((len(q), 2), np.nan)
        ok = idx >= 0
        out[ok] = self.points[idx[ok]]
        return d, out


# ---------------------------------------------------------------------------
@dataclass
class LMResult:
    """Solution of :func:`arstream.solve_kernels.refine_pose`: parameters, residuals and
    Jacobian at the solution, its cost and the steps taken."""

    x: np.ndarray
    fun: np.ndarray
    jac: np.ndarray
    cost: float
    iterations: int


# ---------------------------------------------------------------------------
@dataclass
class Refinement:
    """Result of :func:`refine_camera`.

    Attributes
    ----------
    camera : Camera
    confidence : float in [0, 1]: share of the in-view model points with a
        detected line pixel within 2.5 px after refinement
    rms : float, RMS of the inlier point-to-line residuals (px)
    n_visible : int, model points in view
    n_inliers : int
    covariance : (k, k) parameter covariance (pan/tilt/roll rad, log f, ...)
    params : tuple of parameter names matching ``covariance``
    """

    camera: Camera
    confidence: float
    rms: float
    n_visible: int
    n_inliers: int
    covariance: np.ndarray = field(repr=False)
    params: tuple = ()


def _visible(cam: Camera, model: ModelSamples, size, margin=2.0):
    """Which model samples ``cam`` sees at least 0.5 m in front and ``margin``
    px inside the frame: (inside (N,) bool, pixels (N, 2), NaN where the
    projection has none: behind, or past the lens model's fold)."""
    W, H = size
    px, inside = project_points(model.points, *_lens_args(cam), int(W), int(H), float(margin), 0.5)
    return inside, px


def _lens_args(cam: Camera) -> tuple:
    """``cam``'s R, t, K and radial coefficients as the compiled projection takes them."""
    c = np.ascontiguousarray
    return c(cam.R, np.float64), c(cam.t, np.float64), c(cam.K, np.float64), np.asarray(cam.dist, np.float64)


def explained_share(camera: Camera, index: LineIndex, size: tuple[int, int], model: ModelSamples, radius: float = 2.5) -> float:
    """Share of the detected line pixels that lie within ``radius`` px of a
    projected marking: the precision of a camera, where the refinement's
    confidence is its recall. A right camera explains nearly every detected
    line pixel even when blur or occlusion hides most markings (low recall);
    a wrong one does not.

    Parameters
    ----------
    camera : Camera (frame pixels)
    index : LineIndex of the detected line pixels (M, 2)
    size : (W, H) frame size, pixels
    model : ModelSamples (consecutive samples of a marking are joined)
    radius : px

    Returns
    -------
    float in [0, 1] (0 when there are no line pixels or no marking in view)
    """
    W, H = size
    if len(index) == 0:
        return 0.0
    inside, px = _visible(camera, model, size, margin=-W)  # whole segments, clipped by the raster
    mask = np.zeros((H, W), np.uint8)
    th = 2 * int(np.ceil(radius)) + 1
    m = model.marking
    for k in np.unique(m[inside]):
        sel = (m == k) & inside
        q = np.round(px[sel] * 16).astype(np.int32)
        cv2.polylines(mask, [q.reshape(-1, 1, 2)], False, 255, thickness=th, lineType=cv2.LINE_8, shift=4)
    p = np.round(index.points).astype(np.intp)
    ok = (p[:, 0] >= 0) & (p[:, 0] < W) & (p[:, 1] >= 0) & (p[:, 1] < H)
    return float(np.count_nonzero(mask[p[ok, 1], p[ok, 0]])) / len(p)


def refine_camera(
    camera: Camera,
    index: LineIndex,
    size: tuple[int, int],
    model: ModelSamples,
    *,
    center: np.ndarray | None = None,
    estimate_k1: bool = False,
    radii=(30.0, 15.0, 6.0, 3.0),
    max_points: int = 700,
    staged: bool = True,
    fixed_pan: bool = False,
) -> Refinement:
    """Refine a camera against detected line pixels.

    Parameters
    ----------
    camera : Camera, initial estimate (its principal point is kept)
    index : LineIndex over the frame's line pixels
    size : (width, height), pixels
    model : ModelSamples
    center : (3,) metres, optional fixed camera centre (tripod): then only pan,
        tilt, roll, f (and k1) are estimated
    estimate_k1 : bool, also estimate one radial distortion coefficient
    radii : matching radii (px) of the successive re-association rounds
    max_points : at most this many model points are used per round (evenly thinned)
    staged : without a fixed ``center``, first refine rotation and f about the
        initial centre, then the full pose
    fixed_pan : with a fixed ``center``, keep the pan angle (the optical axis's
        azimuth about the pitch's vertical) and solve only tilt, roll and f (and
        k1): for a frame whose pan was set otherwise (a whip pan's brightness)

    Returns
    -------
    Refinement

    Raises
    ------
    ValueError
        If fewer than 8 model points are in view or matched.
    """
    if center is None and staged:
        # rotation and focal first (well conditioned), then the full pose
        try:
            first = refine_camera(camera, index, size, model, center=camera.center, estimate_k1=False, radii=radii[:2], max_points=max_points, staged=False)
            camera = first.camera
        except ValueError:
            pass
        radii = radii[1:] or radii  # (a single radius: the full pose at that radius too)
    pp = camera.K[:2, 2].copy()
    if center is not None:
        c0 = np.asarray(center, dtype=np.float64)
        cam0 = Camera(K=camera.K, R=camera.R, t=-camera.R @ c0, dist=camera.dist)
    else:
        c0 = camera.center
        cam0 = camera
    k1_0 = cam0.dist[0] if cam0.dist else 0.0
    if fixed_pan and center is None:
        raise ValueError("fixed_pan needs a fixed center")
    rot = ["tilt", "roll"] if fixed_pan else ["rx", "ry", "rz"]
    nr = len(rot)
    names = rot + ([] if center is not None else ["cx", "cy", "cz"]) + ["logf"] + (["k1"] if estimate_k1 else [])
    i_f = names.index("logf")
    i_k = names.index("k1") if estimate_k1 else None
    free = center is None
    # state: rotation (left perturbation about R_ref, reset every round), centre, log f, k1
    R_ref = cam0.R
    Bw = np.eye(3)  # rotation parameters -> left perturbation (camera frame)
    C_cur = np.array(c0, dtype=np.float64)
    logf = float(np.log(cam0.focal))
    k1_cur = float(k1_0)

    def theta0():
        th = np.zeros(len(names))
        if free:
            th[3:6] = C_cur
        th[i_f] = logf
        if estimate_k1:
            th[i_k] = k1_cur
        return th

    def camera_of(R, C, f, k1) -> Camera:
        K = np.array([[f, 0, pp[0]], [0, f, pp[1]], [0, 0, 1.0]])
        return Camera.trusted(K, R, -R @ C, (k1,) if k1 else ())

    cam = cam0
    res_fin = None
    for radius in radii:
        inside, px = _visible(cam, model, size)
        idx = np.flatnonzero(inside)
        if len(idx) < 8:
            raise ValueError("fewer than 8 pitch-marking points in view")
        if len(idx) > max_points:
            idx = idx[np.linspace(0, len(idx) - 1, max_points).astype(int)]
        d, q = index.nearest(px[idx], radius)
        ok = np.isfinite(d)
        if ok.sum() < 8:
            raise ValueError("fewer than 8 pitch-marking points matched to detected lines")
        X = model.points[idx[ok]]
        Q = q[ok]
        # image normals of the projected markings at the current estimate
        p_ab, _ = project_points(np.concatenate([X, X + 0.05 * model.tangents[idx[ok]]]), *_lens_args(cam), int(size[0]), int(size[1]), 0.0, 0.0)
        tg = p_ab[len(X) :] - p_ab[: len(X)]
        nrm = np.column_stack([-tg[:, 1], tg[:, 0]])
        nrm /= np.linalg.norm(nrm, axis=1, keepdims=True) + 1e-12
        R_ref = cam.R
        if fixed_pan:
            # tilt: about the horizontal axis across the optical axis; roll: about the
            # optical axis (camera z); neither turns the axis about the vertical
            d = R_ref[2]  # optical axis in the pitch frame
            h = np.cross([0.0, 0.0, 1.0], d)
            Bw = np.column_stack([R_ref @ (h / max(np.linalg.norm(h), 1e-12)), [0.0, 0.0, 1.0]])
        # the parameters -> the kernel's (rotation, centre, log f, k1), and so its Jacobian's columns
        M = np.zeros((8, len(names)))
        M[:3, :nr] = Bw if fixed_pan else np.eye(3)
        if free:
            M[3:6, 3:6] = np.eye(3)
        M[6, i_f] = 1.0
        if estimate_k1:
            M[7, i_k] = 1.0
        R_ref = np.ascontiguousarray(R_ref, np.float64)
        res_fin = LMResult(*refine_pose(X, Q, nrm, R_ref, M, theta0(), C_cur, k1_cur, float(pp[0]), float(pp[1]), 1.0, 12, 1e-10))
        R, C_cur, f, k1_cur = pose_from_params(res_fin.x, R_ref, M, C_cur, k1_cur)
        logf = float(np.log(f))
        cam = camera_of(R, C_cur, f, k1_cur)
    # confidence: support of the in-view model after refinement
    inside, px = _visible(cam, model, size)
    vis = np.flatnonzero(inside)
    n_vis = len(vis)
    if n_vis > 800:  # an even subsample estimates the share as well (consecutive samples are alike)
        vis = vis[:: int(np.ceil(n_vis / 800))]
    d, _ = index.nearest(px[vis], 2.5) if n_vis else (np.zeros(0), None)
    conf = float(np.isfinite(d).mean()) if n_vis else 0.0
    n_in = int(round(conf * n_vis))
    r = res_fin.fun
    inl = np.abs(r) < 2.5
    rms = float(np.sqrt(np.mean(r[inl] ** 2))) if inl.any() else float("inf")
    J = res_fin.jac[inl] if inl.any() else res_fin.jac
    try:
        cov = np.linalg.pinv(J.T @ J) * max(rms, 0.3) ** 2
    except np.linalg.LinAlgError:
        cov = np.full((len(names), len(names)), np.inf)
    return Refinement(camera=cam, confidence=float(conf), rms=rms, n_visible=n_vis, n_inliers=n_in, covariance=cov, params=tuple(names))


# ---------------------------------------------------------------------------
# initialiser from line correspondences (penalty-area views, stills)
def _vp_family(L: list[np.ndarray], mids: np.ndarray, tol_deg: float = 1.5, ends: np.ndarray | None = None) -> tuple[np.ndarray | None, list[int]]:
    """The vanishing point shared by the most lines (pairwise intersections as
    hypotheses); returns (point (3,), inlier indices). With ``ends``, "most"
    is the largest total length of the segments (two long markings outweigh
    three players' legs).

    With the segments' endpoints ``ends`` (N, 2, 2), a line counts only when the
    point lies beyond its segment: parallel pitch lines meet on the horizon,
    above every pitch pixel, never between a segment's ends (where lines of
    both directions meet at a corner of the markings, which is no vanishing
    point)."""
    best_v, best_in = None, []
    n = len(L)
    tol = np.sin(np.radians(tol_deg))
    seg_len = None if ends is None else np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1)

    def weight(idx):
        return len(idx) if seg_len is None else float(seg_len[idx].sum())

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


def _line_families(L: np.ndarray, ends: np.ndarray, tol_deg: float) -> tuple[list[int], list[int]]:
    """Split lines (N, 3) with segment ends (N, 2, 2) into the pitch's two
    directions: (along the touchlines, across them), by the two vanishing
    points with the most lines (:func:`_vp_family`); the flatter family is "along"."""
    mids = ends.mean(axis=1)
    _, in1 = _vp_family(list(L), mids, tol_deg, ends)
    rest = [k for k in range(len(L)) if k not in in1]
    if len(in1) < 2 or not rest:
        return [], []
    _, in2r = _vp_family([L[k] for k in rest], mids[rest], tol_deg, ends[rest])
    in2 = [rest[k] for k in in2r] if len(rest) >= 2 else rest
    if not in2:
        return [], []

    def flatness(idx):
        return float(np.median([abs(L[k][1]) for k in idx]))  # |b| ~ 1 for a horizontal line

    a, b = (in1, in2) if flatness(in1) >= flatness(in2) else (in2, in1)
    return a, b


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
    With the principal point it gives a camera (:func:`decompose_homographies`),
    kept when plausible (above the pitch, outside the near touchline, a focal
    length from 0.3 to 12 widths). Each is scored by the model's markings
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
    along, across = _line_families(L, E, tol_deg)
    if len(along) < 2 or len(across) < 2:
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
    ia = list(combinations(across, 2))
    ib = list(combinations(along, 2))
    ma = list(combinations(range(len(xs)), 2))
    mb = list(combinations(range(len(ys)), 2))
    # every (image pair, model pair) of each direction: (K, 4, 3) lines
    MA, MB = np.array(m_across), np.array(m_along)
    ia_, ib_, ma_, mb_ = (np.array(x, dtype=np.int64).reshape(-1, 2) for x in (ia, ib, ma, mb))
    g = np.stack(np.meshgrid(np.arange(len(ia_)), np.arange(len(ib_)), np.arange(len(ma_)), np.arange(len(mb_)), indexing="ij"), -1).reshape(-1, 4)
    n = len(g)
    src = np.concatenate([MA[ma_[g[:, 2]]], MB[mb_[g[:, 3]]]], axis=1)
    dst = np.concatenate([L[ia_[g[:, 0]]], L[ib_[g[:, 1]]]], axis=1)
    Hs, ok = homographies_from_lines(src, dst)
    poses = decompose_homographies(Hs[ok], principal_point)
    C, f = poses.centre, poses.focal
    good = poses.ok & (C[:, 1] < -hw - 3) & (C[:, 2] > 3) & (C[:, 2] < 80) & (np.abs(C[:, 0]) < hl + 20) & (f > 0.3 * W) & (f < 12 * W)
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
    fam = [(k, m_across) for k in across] + [(k, m_along) for k in along]
    reach = 0.012 * W
    Hx, cand = [], []
    for j in top:
        Hj = Hg[j]
        try:
            Hit = np.linalg.inv(Hj).T  # model line -> image line
        except np.linalg.LinAlgError:
            continue
        src_l, dst_l = [], []
        for k, models in fam:
            best_m, best_d = None, reach
            for mline in models:
                li = Hit @ mline
                nrm = np.hypot(li[0], li[1])
                if nrm < 1e-12:
                    continue
                dd = max(abs(li[:2] @ E[k, 0] + li[2]), abs(li[:2] @ E[k, 1] + li[2])) / nrm
                if dd < best_d:
                    best_m, best_d = mline, dd
            if best_m is not None:
                src_l.append(best_m)
                dst_l.append(L[k])
        if len(src_l) > 4:
            H2, ok2 = homographies_from_lines(np.array(src_l)[None], np.array(dst_l)[None])
            if ok2[0]:
                Hx.append(H2[0])
                cand.append(j)
    if Hx:
        Hx = np.array(Hx)
        p2 = decompose_homographies(Hx, principal_point)
        C2, f2 = p2.centre, p2.focal
        ok = p2.ok & (C2[:, 1] < -hw - 3) & (C2[:, 2] > 3) & (C2[:, 2] < 80) & (np.abs(C2[:, 0]) < hl + 20) & (f2 > 0.3 * W) & (f2 < 12 * W)
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
        if any(np.linalg.norm(cam.center - o.center) < 1.0 and abs(np.log(cam.focal / o.focal)) < 0.02 for o in cams):
            continue
        cams.append(cam)
        sc.append(scores[j])
        if len(cams) >= keep:
            break
    return LineHypotheses(cams, np.array(sc), n, int(len(idx)))
