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

import cv2
import numpy as np
import scipy.optimize
import scipy.spatial

from arstream.memo import ContentMemo, content_key
from arstream.solve_kernels import grid_nearest, point_grid, pose_from_params, project_points, refine_pose
from geometry.camera import Camera, camera_at_centre, intrinsic_matrix
from geometry.conics import ellipse_from_conic, intersect_line_conic, normalize_conic, split_degenerate_conics
from geometry.lines import normalize_line
from geometry.pitch import Arc, PitchModel

__all__ = [
    "CircleSolution",
    "solve_from_circle",
    "cameras_along_circle",
    "ModelSamples",
    "LineIndex",
    "Refinement",
    "refine_camera",
    "seated",
    "refinements_along_sight",
    "k1_observable",
    "MIN_FOCAL_PX",
]

#: A refinement whose focal length falls below this (pixels) has diverged: every
#: marking lies within a pixel of the principal point, which no camera of a pitch
#: shows (:func:`refine_camera` raises rather than hand it on).
MIN_FOCAL_PX = 1.0


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


def _normalised_circle_view(E, halfway_line, principal_point, image_width: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The ellipse and the halfway line in coordinates centred on the principal
    point and scaled by the image width: (T (3, 3) pixels -> normalised, E_n,
    l_n (unit), the line's two crossings with ``E`` (pixels)). Raises
    ValueError when the line misses the ellipse."""
    lh = normalize_line(np.asarray(halfway_line, dtype=np.float64))
    try:
        ends = intersect_line_conic(E, lh)
    except ValueError:
        raise ValueError("the halfway line does not cross the centre-circle ellipse") from None
    T = _normaliser(principal_point, image_width)
    Ti = np.linalg.inv(T)
    ln = Ti.T @ lh
    return T, normalize_conic(Ti.T @ E @ Ti), ln / np.linalg.norm(ln), ends


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
    T, En, ln, ends = _normalised_circle_view(E, halfway_line, principal_point, image_width)
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


#: :func:`cameras_along_circle`'s families of the last views asked for (a
#: still's scan registers it at up to nine pitch sizes, a clip's scan tracks
#: each frame at up to six, and a family does not depend on the pitch's size)
_FAMILIES = ContentMemo(64)


def cameras_along_circle(
    E,
    halfway_line,
    arc,
    halfway,
    principal_point,
    *,
    image_width: float,
    focals,
    radius: float | None = None,
    offset: float = 0.0,
    max_points: int = 120,
    max_rms: float = 2.0,
    polish: int = 3,
) -> list[Camera]:
    """Cameras of a centre-circle view at given focal lengths, fitted to the
    circle's and the halfway line's pixels (or, with an ``offset``, of a
    penalty-arc view, fitted to the arc's and the penalty area's front line's).

    The closed form (:func:`solve_from_circle`) takes its focal length from
    the ellipse alone. A real view that shows a short arc of the circle, or
    the circle nearly edge-on from a low camera far away, fits an ellipse
    whose unseen part (and so whose f) is far off, while the arc itself is
    well measured. This gives the one-parameter family such a view leaves:
    at each focal length, the pose whose image of the circle passes through
    the arc's pixels (Sampson distance to the projected circle ``H^-T C_w
    H^-1``) and whose halfway line passes through its pixels, by robust
    least squares (soft-L1, 1.5 px) over rotation and centre, started from
    the closed form's geometry at that f (the two candidate vanishing lines
    of ``E`` and ``omega(f)``; the better fit kept), or where that fits badly
    (far from the ellipse's own f), from the neighbouring focal length's fit
    moved along its line of sight. The markings out of the
    circle's reach (a touchline, a penalty area) then tell the family's
    members apart (:func:`arstream.initialise.initialise_from_paint`).

    Parameters
    ----------
    E : (3, 3) conic fitted to the arc, pixels (the starting poses)
    halfway_line : (3,) image line of the halfway line, pixels
    arc : (N, 2) pixels on the imaged circle
    halfway : (M, 2) pixels on the imaged halfway line
    principal_point : (2,) pixels
    image_width : float, pixels
    focals : (F,) focal lengths to fit at, pixels
    radius : centreline radius of the centre circle (m); default from PitchModel
    offset : X of the line in the circle's own frame (m; the circle's centre
        at the origin, the line X = ``offset``): 0 for the halfway line
        through the centre circle; a penalty area's front line lies 5.44 m
        from its penalty mark, towards the halfway line (+X). With an offset
        the cameras are in the circle's frame, and either side of it may be
        the main camera's (the caller places them on the pitch, a penalty
        mark at either end)
    max_points : most pixels of each kind used (evenly taken)
    max_rms : a fit whose pixels lie further from the circle and the line than
        this (px, RMS) is no member of the family
    polish : when no focal length's fit is a member, the nearest is fitted
        again from where it stopped, up to this many rounds, and seeds its
        neighbours (a penalty arc so flat that its ellipse is far off:
        ``israel_league_wide`` frame 275 flipped left to right fits 7.9 px at
        best from the closed form, 0.9 px polished; unflipped, one focal
        length happened to converge). 0: no polishing

    Returns
    -------
    list of Camera, one per focal length where a fit was found (in the order
    of ``focals``; square pixels, the given principal point, no distortion;
    pitch frame, or the circle's frame with an ``offset``).

    Raises
    ------
    ValueError
        ``E`` is not an ellipse, the halfway line misses it, or fewer than 6
        arc or 2 halfway pixels are given.
    """
    radius = PitchModel()["centre_circle"].radius if radius is None else float(radius)
    arc = np.asarray(arc, dtype=np.float64).reshape(-1, 2)
    halfway = np.asarray(halfway, dtype=np.float64).reshape(-1, 2)
    focals = np.asarray(focals, dtype=np.float64).ravel()
    # (the same view's family asked for again: a scan registers a still, and
    # its trackers a frame, at several pitch sizes, and the family does not
    # depend on the size)
    key = content_key(E, halfway_line, arc, halfway, principal_point, focals, (float(image_width), radius, float(offset), int(max_points), float(max_rms), int(polish)))
    return _FAMILIES.answer(key, lambda: _cameras_along_circle(E, halfway_line, arc, halfway, principal_point, float(image_width), focals, radius, float(offset), max_points, max_rms, polish))


def _cameras_along_circle(E, halfway_line, arc: np.ndarray, halfway: np.ndarray, principal_point, image_width: float, focals: np.ndarray, radius: float, offset: float, max_points: int, max_rms: float, polish: int) -> list[Camera]:
    """:func:`cameras_along_circle`'s work, its arguments converted."""
    if len(arc) < 6 or len(halfway) < 2:
        raise ValueError(f"need at least 6 arc and 2 halfway-line pixels, got {len(arc)} and {len(halfway)}")
    offset = float(offset)
    if not abs(offset) < radius:
        raise ValueError(f"the line must cross the circle: offset {offset:g} m, radius {radius:g} m")
    ellipse_from_conic(E)  # raises for non-ellipses
    W = float(image_width)
    pp = np.asarray(principal_point, dtype=np.float64)
    T, En, ln, ends = _normalised_circle_view(E, halfway_line, pp, W)
    arc, halfway = arc[:: max(1, len(arc) // max_points)], halfway[:: max(1, len(halfway) // max_points)]
    A, B = np.column_stack([arc, np.ones(len(arc))]), np.column_stack([halfway, np.ones(len(halfway))])
    Cw = np.diag([1.0, 1.0, -radius * radius])
    fits: list[tuple[Camera, float] | None] = []
    for f in focals:
        best = None
        for lv in _candidate_vanishing_lines(En, f / W):
            try:
                start = _camera_from_circle_geometry(En, ln, lv, f / W, T, ends, radius, pp, W, offset).camera
            except ValueError:
                continue
            fit = _fit_circle_view(start, A, B, Cw, offset)
            if fit is not None and (best is None or fit[1] < best[1]):
                best = fit
        fits.append(best)
    if not any(fit is not None and fit[1] <= max_rms for fit in fits):
        # no fit converged from the closed form's geometry (an arc so flat that
        # its ellipse, and so that geometry, is far off at every focal length):
        # the fit that came nearest, fitted again from where it stopped (at
        # most ``polish`` more rounds, while each gains a tenth), to seed the
        # neighbours below
        j = min((j for j, fit in enumerate(fits) if fit is not None), key=lambda j: fits[j][1], default=None)
        for _ in range(polish if j is not None else 0):
            again = _fit_circle_view(fits[j][0], A, B, Cw, offset)
            if again is None or again[1] >= 0.9 * fits[j][1]:
                break
            fits[j] = again
            if again[1] <= max_rms:
                break
    # far from the ellipse's own focal length its geometry starts the fit badly: start
    # such a focal length from its neighbour's fit instead, dollied (the centre moved
    # along its ray from the circle's centre by the ratio of the focal lengths)
    for order in (range(len(focals)), range(len(focals) - 1, -1, -1)):
        prev = None
        for j in order:
            if prev is not None and fits[prev] is not None and fits[prev][1] <= max_rms and (fits[j] is None or fits[j][1] > max_rms):
                near = fits[prev][0]
                k = focals[j] / near.focal
                start = Camera(K=intrinsic_matrix(focals[j], pp[0], pp[1]), R=near.R, t=-near.R @ (near.center * k))
                fit = _fit_circle_view(start, A, B, Cw, offset)
                if fit is not None and (fits[j] is None or fit[1] < fits[j][1]):
                    fits[j] = fit
            prev = j
    return [fit[0] for fit in fits if fit is not None and fit[1] <= max_rms]


class _CircleViewFit:
    """:func:`_fit_circle_view`'s residuals and their Jacobian in ``x`` (6,):
    a rotation vector ``x[:3]`` (the rotation ``Rodrigues(x[:3]) @ R0``) and
    the camera centre ``x[3:6]`` (metres), at the calibration ``K``.

    The residuals (N + M,): the distance (px) of each ``B`` (M, 3,
    homogeneous pixels) from the image of the line X = ``offset``, then the
    first-order distance of each ``A`` (N, 3) from the image of the circle
    ``Cw`` (3 x 3, pitch-plane conic); 1e3 each where the homography is
    singular or a residual is not finite (Jacobian: zeros)."""

    def __init__(self, K: np.ndarray, R0: np.ndarray, A: np.ndarray, B: np.ndarray, Cw: np.ndarray, offset: float = 0.0):
        self.K, self.R0, self.A, self.B, self.Cw = K, R0, A, B, Cw
        self.line = np.array([1.0, 0.0, -offset])  # X = offset, homogeneous pitch-plane line
        self.n = len(A) + len(B)
        self._last: tuple[bytes, tuple | None] | None = None  # (x, its _parts): the solver asks for both at one x

    def _parts(self, x):
        """(R, dR/dx[:3] (3, 3, 3), H^-1, the line's image (3,), ``A`` times
        the circle's image (N, 3)), or None where H is singular."""
        key = x.tobytes()
        if self._last is not None and self._last[0] == key:
            return self._last[1]
        Rr, J = cv2.Rodrigues(x[:3])
        R = Rr @ self.R0
        H = self.K @ np.column_stack([R[:, 0], R[:, 1], -R @ x[3:6]])
        try:
            Hi = np.linalg.inv(H)
        except np.linalg.LinAlgError:
            out = None
        else:
            Ci = Hi.T @ self.Cw @ Hi
            out = (R, J.reshape(3, 3, 3) @ self.R0, Hi, self.line @ Hi, self.A @ Ci)  # (the line's image: H^-T (1, 0, -offset))
        self._last = (key, out)
        return out

    def residuals(self, x: np.ndarray) -> np.ndarray:
        p = self._parts(x)
        if p is None:
            return np.full(self.n, 1e3)
        lx, CA = p[3], p[4]
        out = np.concatenate([(self.B @ lx) / np.hypot(lx[0], lx[1]), np.einsum("ij,ij->i", CA, self.A) / (2.0 * np.hypot(CA[:, 0], CA[:, 1]))])
        return out if np.all(np.isfinite(out)) else np.full(self.n, 1e3)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """(N + M, 6): d(H^-1) = -H^-1 dH H^-1 for each parameter's dH (the
        rotation vector through OpenCV's Rodrigues Jacobian; the centre
        through H's third column), then the residuals' quotient rule."""
        p = self._parts(x)
        if p is None:
            return np.zeros((self.n, 6))
        R, dR, Hi, lx, CA = p
        K, A, B, Cw, line = self.K, self.A, self.B, self.Cw, self.line
        dH = np.zeros((6, 3, 3))
        dH[:3, :, 0], dH[:3, :, 1], dH[:3, :, 2] = dR[:, :, 0] @ K.T, dR[:, :, 1] @ K.T, -(dR @ x[3:6]) @ K.T
        dH[3:, :, 2] = -(K @ R).T
        dHi = -np.einsum("ij,pjk,kl->pil", Hi, dH, Hi)
        dlx = dHi.transpose(0, 2, 1) @ line  # (6, 3)
        n = np.hypot(lx[0], lx[1])
        dline = (B @ dlx.T) / n - np.outer(B @ lx, dlx[:, :2] @ lx[:2]) / n**3
        q, g = np.einsum("ij,ij->i", CA, A), np.hypot(CA[:, 0], CA[:, 1])
        M = np.einsum("pji,jk,kl->pil", dHi, Cw, Hi)
        dCA = np.einsum("nj,pjk->pnk", A, M + M.transpose(0, 2, 1))  # (6, N, 3)
        dq = np.einsum("pnk,nk->pn", dCA, A)
        dg = (CA[:, 0] * dCA[:, :, 0] + CA[:, 1] * dCA[:, :, 1]) / g
        out = np.vstack([dline, (dq / (2.0 * g) - q * dg / (2.0 * g * g)).T])
        return out if np.all(np.isfinite(out)) else np.zeros((self.n, 6))


def _fit_circle_view(start: Camera, A: np.ndarray, B: np.ndarray, Cw: np.ndarray, offset: float = 0.0) -> tuple[Camera, float] | None:
    """:func:`cameras_along_circle`'s fit at ``start``'s focal length: rotation
    (a perturbation of ``start``'s) and centre, so that the projected circle
    ``Cw`` passes through ``A`` (N, 3) and the line X = ``offset`` (the
    halfway line: 0) through ``B`` (M, 3), homogeneous pixels
    (:class:`_CircleViewFit`, with its exact Jacobian: a still's circle
    families fit about 700 times). Returns (camera, RMS distance of the
    pixels, px), or None when the fit leaves the cameras that see the pitch's
    plane, or (with an offset) is upside down or lays the arc on the
    circle's part behind the line."""
    K, R0 = start.K, start.R
    fit = _CircleViewFit(K, R0, A, B, Cw, offset)
    x0 = np.concatenate([np.zeros(3), start.center])
    try:
        sol = scipy.optimize.least_squares(fit.residuals, x0, jac=fit.jacobian, loss="soft_l1", f_scale=1.5, x_scale=np.array([0.01, 0.01, 0.01, 5.0, 5.0, 2.0]), max_nfev=40, ftol=1e-6, xtol=1e-6)
    except (ValueError, np.linalg.LinAlgError):
        return None
    R = cv2.Rodrigues(sol.x[:3])[0] @ R0
    C = sol.x[3:6]
    if not np.all(np.isfinite(C)) or C[2] <= 0:
        return None
    if offset != 0.0:
        # an upright camera (the pitch's up is the image's up: a camera on
        # either side of the circle is no longer held to the near side), and
        # the arc's pixels beyond the line (X > offset), not on the circle's
        # part behind it: the circle's centre and the arc on opposite sides
        if R[1, 2] >= 0:
            return None
        H = K @ np.column_stack([R[:, 0], R[:, 1], -R @ C])
        lx = np.linalg.inv(H).T @ np.array([1.0, 0.0, -offset])
        if np.sign(lx @ H[:, 2]) == np.sign(np.median(A @ lx)):
            return None
    return Camera(K=K, R=R, t=-R @ C), float(np.sqrt(np.mean(sol.fun**2)))


def _camera_from_circle_geometry(En, ln, lv, phi, T, ends, radius, principal_point, image_width, offset: float = 0.0) -> CircleSolution:
    """The camera of a circle's view from its ellipse ``En``, a line ``ln``
    (X = ``offset`` in the circle's frame) and a vanishing line ``lv``
    (normalised coordinates, focal length ``phi`` widths): the pole-polar
    geometry. With no offset (the halfway line) the camera is placed on the
    near side (Y < 0); with one, in the circle's frame on either side."""
    Kn_inv = np.diag([1 / phi, 1 / phi, 1.0])
    En_inv = np.linalg.inv(En)
    o = En_inv @ lv  # imaged centre (normalised coords)
    if offset == 0.0:
        vx = En_inv @ ln  # pole of the halfway line: touchline direction
    else:
        # the line's pole is the image of (radius^2 / offset, 0): on the X axis
        # through the centre, which meets the vanishing line in X's direction
        vx = np.cross(np.cross(o, En_inv @ ln), lv)
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
            half = radius if offset == 0.0 else np.sqrt(radius * radius - offset * offset)
            side = offset * R[:, 0]
            # scale from the radius: the ends of the chord are (offset, +-h, 0)
            lam = []
            for q, sgn in zip(q_ends, (1.0, -1.0)):
                a = np.cross(q, d)
                b = np.cross(q, sgn * half * r2o + side)
                lam.append(-(a @ b) / (a @ a))
            lam_alt = []
            for q, sgn in zip(q_ends, (-1.0, 1.0)):
                a = np.cross(q, d)
                b = np.cross(q, sgn * half * r2o + side)
                lam_alt.append(-(a @ b) / (a @ a))
            for ls in (lam, lam_alt):
                if min(ls) <= 0:
                    continue
                t = np.mean(ls) * d
                C = -R.T @ t
                if C[2] > 0 and (C[1] < 0 or offset != 0.0):
                    spread = abs(ls[0] - ls[1]) / np.mean(ls)
                    if best is None or spread < best[0]:
                        best = (spread, R, t)
    if best is None:
        raise ValueError("no sign choice puts the camera above the pitch on the near side")
    _, R, t = best
    cam = Camera(K=K, R=R, t=t)
    o_px = np.linalg.solve(T, o)
    return CircleSolution(camera=cam, f=f, orthogonality=ortho, centre_image=o_px[:2] / o_px[2])


def k1_observable(focal: float, size, *, k1: float = 0.1, px: float = 4.0) -> bool:
    """Whether one radial coefficient as large as ``k1`` (a broadcast zoom's
    barrel at its wide end) moves the frame's corners by at least ``px`` pixels
    at this focal length: ``|k1| r^3 f >= px``, r the corner's normalised radius
    (the half-diagonal over f).

    At a long focal length the frame shows too little of the lens's field:
    k1 cannot be told from a change of the focal length or of the centre, and a
    refinement that estimates it fits the noise (and lets the markings slide
    along their lines). 640 x 360: up to f = 1.7 widths; 1280 x 720: 2.5."""
    d = 0.5 * float(np.hypot(size[0], size[1]))
    return abs(k1) * d**3 / float(focal) ** 2 >= px


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
        If fewer than 8 model points are in view or matched, or the
        refinement diverged: a focal length below :data:`MIN_FOCAL_PX` (or
        not finite), where the steps shrink every marking onto the principal
        point to meet the pixels matched in the round.
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
        if not (np.isfinite(f) and f >= MIN_FOCAL_PX and np.isfinite(R).all() and np.isfinite(C_cur).all() and np.isfinite(k1_cur)):
            raise ValueError(f"the refinement diverged (focal length {f:.3g} px)")
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


def refinements_along_sight(
    camera: Camera,
    index: LineIndex,
    size: tuple[int, int],
    model: ModelSamples,
    *,
    scales=(0.8, 0.9, 1.1),
    estimate_k1: bool = False,
    radii=(20.0, 10.0, 5.0, 3.0, 2.5),
    max_points: int = 400,
) -> list[Refinement]:
    """Free-pose refinements of ``camera`` started from it moved along its line
    of sight: to ``scales`` times its distance from the pitch point under the
    image centre, keeping its picture of the markings in view
    (:func:`geometry.camera.camera_at_centre`).

    A view through a long lens fits a family of cameras along its line of
    sight (focal length and distance together), and a refinement started
    from one member stays near it: a camera tracked about a wrong tripod
    centre, freed, keeps most of that centre's error. Started from members
    nearer and farther, the refinements reach the view's own basin where
    the frame's markings fix it (a penalty area's lines at several depths).

    Parameters
    ----------
    camera : Camera (frame pixels), e.g. a measurement about a frozen centre
    index : LineIndex of the frame's line pixels
    size : (W, H) frame size, pixels
    model : ModelSamples
    scales : distances to try, as multiples of ``camera``'s
    estimate_k1, radii, max_points : as :func:`refine_camera`

    Returns
    -------
    list of Refinement (centre free), one per scale where the start and the
    refinement could be made (empty when the image centre's ray misses the
    pitch)
    """
    W, H = size
    g = camera.backproject_to_pitch(np.array([[(W - 1) / 2, (H - 1) / 2]]))[0]
    if not np.all(np.isfinite(g)):
        return []
    g3 = np.append(g, 0.0)
    out = []
    for s in scales:
        try:
            start = seated(camera, g3 + float(s) * (camera.center - g3), model, size)
            out.append(refine_camera(start, index, size, model, center=None, estimate_k1=estimate_k1, radii=radii, max_points=max_points))
        except ValueError:
            continue
    return out


def seated(camera: Camera, center, model: ModelSamples, size: tuple[int, int]) -> Camera:
    """``camera`` moved to ``center`` (3,) keeping its picture of the model's
    samples in view (:func:`geometry.camera.camera_at_centre`): the start of a
    refinement about another centre.

    Raises
    ------
    ValueError
        As :func:`geometry.camera.camera_at_centre` (fewer than 3 samples in
        view, a centre that is not finite, samples behind either centre).
    """
    inside, _ = _visible(camera, model, size)
    return camera_at_centre(camera, center, model.points[inside, :2])
