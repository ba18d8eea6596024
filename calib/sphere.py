"""Camera calibration from images of spheres (thesis contribution 1).

A sphere's outline in an image is a conic ``C`` that has *double contact*
with the image of the absolute conic ``omega = K^-T K^-1``: for the right
scalar ``lambda`` the member ``omega - lambda C`` of their pencil has rank 1.
From that:

* **Forward model** (:func:`outline_conic`). A sphere of radius ``r`` with
  centre ``X`` (camera frame) is seen under the tangent cone
  ``Q = X X^T - (|X|^2 - r^2) I``; its outline is ``C ~ K^-T Q K^-1``, i.e.
  ``C ~ omega - mu (omega x_c)(omega x_c)^T`` with ``x_c = K X`` the *imaged
  centre* (not the ellipse centre) and ``mu > 0``.
* **Sphere from K and C** (:func:`centre_direction`, :func:`imaged_centre`,
  :func:`sphere_centre`). ``K^T C K ~ cos^2(a) I - d d^T``: the distinct
  eigenvector is the centre direction ``d``; the eigenvalue ratio is
  ``-tan^2(a)``, ``a`` the cone's half-angle, so the depth is ``r / sin(a)``.
* **Intrinsics from >= 3 spheres** (:func:`intrinsics_from_spheres`).
  Linear: for a pair ``(C1, C2)`` the generalised eigenvector ``x0`` whose
  degenerate conic ``C1 - lambda C2`` is a *real line pair* is the meeting
  point of the polars of the two imaged centres, hence ``omega x0 ~ C1 x0``:
  two linear constraints on ``omega`` per pair. Then refinement under the
  rank-1 constraint (``lambda_i C_i = omega - v_i v_i^T`` for every image),
  then — with edge points — the geometric (maximum-likelihood) refinement of
  ``K`` and the sphere centres on the points' distances to the outlines.
* **Rig extrinsics** (:func:`rig_extrinsics`): per-camera sphere centres,
  absolute orientation to the reference camera, bundle adjustment.
* **Outline extraction** (:func:`fit_sphere_outline`): sub-pixel edge points
  of the silhouette in an image, robust conic fit.

Conventions (docs/formats.md): OpenCV camera ``x ~ K (R X + t)``, camera
looks down +z, pixels with integer pixel centres; ``K`` upper triangular with
``K[2, 2] = 1``; conics are normalised symmetric 3x3 matrices (unit Frobenius
norm, negative inside an ellipse) as in :mod:`geometry.conics`. Points are
``(N, 2)`` float64 pixels. Distances of the sphere are in the units of the
radius you give.

Accuracy (bench/sphere_calibration.py, figures in bench/README.md): 640 x 480
images, f = 1000, 5 spheres of 40-70 px radius, 200 outline points each,
median focal error 1.4 % at 0.5 px and 2.7 % at 1 px of point noise — the
maximum-likelihood value; the linear estimate alone gives 2.2 % and 4.5 %.
Spheres constrain K less than a chessboard does (OpenCV's calibrateCamera on
5 views of a 9 x 6 board with the same noise: 0.6 % and 1.2 %): an outline
point only measures its normal displacement, and the focal length shows only
in the outlines' small perspective eccentricity. Use more images, larger
spheres, spheres near the image corners. ``SphereIntrinsics.focal_sigma``
predicts the error (first order). A rig of 3 cameras and 20 sphere
positions at 0.5 px gets its rotations to about 0.03 degrees.

References: H. Zhang, K.-Y. K. Wong, G. Zhang, "Camera calibration from
images of spheres", PAMI 2007; X. Ying, H. Zha, "Geometric interpretations of
the relation between the image of the absolute conic and sphere images",
PAMI 2006; K.-Y. K. Wong, G. Zhang, Z. Chen, "A stratified approach for
camera calibration using spheres", TIP 2011.

Round trip of the forward model:

>>> K = np.array([[1000.0, 0.0, 320.0], [0.0, 1000.0, 240.0], [0.0, 0.0, 1.0]])
>>> X = np.array([0.3, -0.2, 4.0])
>>> bool(np.allclose(sphere_centre(K, outline_conic(K, X, 0.25), 0.25), X))
True
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import cv2
import numpy as np
import scipy.linalg
import scipy.optimize

from calib._fit import (
    absolute_orientation,
    central_difference,
    conic_to_vec6,
    rotation_from_rotvec,
    rotvec_from_rotation,
    sampson_with_jacobian,
)
from geometry.conics import (
    Ellipse,
    conic_conditioning,
    ellipse_distance,
    ellipse_from_conic,
    fit_ellipse,
    fit_ellipse_direct,
    normalize_conic,
    sampson_distance,
)
from geometry.camera import K_from_iac
from geometry.lines import hartley_normalization, skew

__all__ = [
    "SphereOutline",
    "SphereIntrinsics",
    "RigExtrinsics",
    "outline_conic",
    "centre_direction",
    "imaged_centre",
    "sphere_centre",
    "fit_sphere_outline",
    "intrinsics_from_spheres",
    "refine_intrinsics",
    "rig_extrinsics",
]

# --------------------------------------------------------------------------
# result types
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class SphereOutline:
    """A sphere's silhouette found in an image (:func:`fit_sphere_outline`).

    Attributes
    ----------
    conic : (3, 3) float64, normalised conic of the outline, pixels
    ellipse : geometry.conics.Ellipse, the same outline by its parameters
    edge_points : (N, 2) float64, sub-pixel edge points (inliers of the fit), pixels
    rms : float, RMS orthogonal distance of ``edge_points`` to the ellipse, pixels
    support : float, fraction of the outline (by angle) that has edge points, in [0, 1]
    """

    conic: np.ndarray
    ellipse: Ellipse
    edge_points: np.ndarray
    rms: float
    support: float


@dataclass(frozen=True)
class SphereIntrinsics:
    """Intrinsics estimated from sphere images (:func:`intrinsics_from_spheres`).

    Attributes
    ----------
    K : (3, 3) float64, the final estimate (pixels), upper triangular, ``K[2, 2] = 1``
    centre_directions : (M, 3) float64, unit vectors from the camera centre to the
        sphere centres, camera frame, one per image
    half_angles : (M,) float64, half-angle of each sphere's tangent cone, radians;
        a sphere of radius ``r`` is at distance ``r / sin(half_angle)``
    imaged_centres : (M, 2) float64, projections of the sphere centres, pixels
    residuals : (M,) float64, per image RMS distance (pixels) of the edge points
        (or, without edge points, of points sampled on the measured outline) to
        the outline predicted by ``K`` and the sphere
    rms : float, RMS over all images, pixels
    constraint_set : str, the stage that produced ``K``: ``"linear"``,
        ``"rank1"`` or ``"geometric"``
    model : str, ``"square_pixels"`` (f, cx, cy), ``"zero_skew"`` (fx, fy, cx, cy)
        or ``"general"`` (fx, fy, skew, cx, cy)
    weak : bool, True when the data constrain the focal length poorly:
        ``focal_sigma > weak_threshold`` (near-circular outlines of an almost
        parallel projection, nearly collinear imaged centres, too few points)
    focal_sigma : float, first-order relative standard deviation of the focal
        length(s) (largest of fx, fy) at the estimate
    K_linear : (3, 3) float64 or None, the linear estimate (None from
        :func:`refine_intrinsics`)
    K_rank1 : (3, 3) float64 or None, the rank-1-refined estimate (None from
        :func:`refine_intrinsics`, which starts from a given K)
    n_pairs : int, number of image pairs whose constraints entered the linear step
    """

    K: np.ndarray
    centre_directions: np.ndarray
    half_angles: np.ndarray
    imaged_centres: np.ndarray
    residuals: np.ndarray
    rms: float
    constraint_set: str
    model: str
    weak: bool
    focal_sigma: float
    K_linear: np.ndarray | None = None
    K_rank1: np.ndarray | None = None
    n_pairs: int = 0

    @property
    def focal(self) -> float:
        """Mean focal length ``(fx + fy) / 2``, pixels."""
        return float(0.5 * (self.K[0, 0] + self.K[1, 1]))

    def centres(self, radius: float) -> np.ndarray:
        """(M, 3) float64 sphere centres in the camera frame, units of ``radius``."""
        if not (np.isfinite(radius) and radius > 0):
            raise ValueError(f"radius must be positive and finite, got {radius}")
        return self.centre_directions * (radius / np.sin(self.half_angles))[:, None]


@dataclass(frozen=True)
class RigExtrinsics:
    """Poses of a multi-camera rig from a sphere moved through its common view
    (:func:`rig_extrinsics`). The world frame is the reference camera's (camera 0).

    Attributes
    ----------
    R : (N, 3, 3) float64, ``R_cam_from_ref`` of each camera (``R[0] = I``)
    t : (N, 3) float64, ``t_cam_from_ref`` (units of the radius; ``t[0] = 0``):
        ``X_cam = R X_ref + t``
    centres : (M, 3) float64, sphere centres in the reference camera frame
    Ks : (N, 3, 3) float64, intrinsics (refined if asked, else as given)
    residuals : (N, M) float64, RMS outline distance per observation, pixels
        (NaN where the camera did not see the sphere)
    rms : float, RMS over all observations, pixels
    R_init, t_init : the absolute-orientation estimates before bundle adjustment
    """

    R: np.ndarray
    t: np.ndarray
    centres: np.ndarray
    Ks: np.ndarray
    residuals: np.ndarray
    rms: float
    R_init: np.ndarray = field(repr=False, default=None)
    t_init: np.ndarray = field(repr=False, default=None)

    @property
    def camera_centres(self) -> np.ndarray:
        """(N, 3) float64 camera centres in the reference frame, ``-R^T t``."""
        return -np.einsum("nji,nj->ni", self.R, self.t)


# --------------------------------------------------------------------------
# validation
# --------------------------------------------------------------------------


def _check_K(K, name: str = "K") -> np.ndarray:
    K = np.asarray(K, dtype=np.float64)
    if K.shape != (3, 3):
        raise ValueError(f"{name} must be a 3x3 calibration matrix, got shape {K.shape}")
    if not np.all(np.isfinite(K)):
        raise ValueError(f"{name} has non-finite entries")
    if np.any(np.abs(K[[1, 2, 2], [0, 0, 1]]) > 1e-9 * abs(K[0, 0])) or K[0, 0] <= 0 or K[1, 1] <= 0:
        raise ValueError(f"{name} must be upper triangular with positive focal lengths")
    if abs(K[2, 2]) < 1e-300:
        raise ValueError(f"{name}[2, 2] must be non-zero")
    return K / K[2, 2]


def _check_conic(C, name: str = "conic", *, ellipse: bool = True) -> np.ndarray:
    C = np.asarray(C, dtype=np.float64)
    if C.shape != (3, 3):
        raise ValueError(f"{name} must be a 3x3 conic matrix, got shape {C.shape}")
    if not np.all(np.isfinite(C)):
        raise ValueError(f"{name} has non-finite entries")
    if np.linalg.norm(C) == 0:
        raise ValueError(f"{name} is zero")
    Cn = normalize_conic(C)
    if ellipse:
        try:
            ellipse_from_conic(Cn)
        except ValueError:
            raise ValueError(f"{name} is not a real ellipse, so not the outline of a sphere") from None
    return Cn


def _check_radius(radius) -> float:
    """A positive, finite sphere radius (ValueError otherwise)."""
    try:
        r = float(radius)
    except (TypeError, ValueError):
        raise ValueError(f"radius must be a positive number, got {radius!r}") from None
    if not (np.isfinite(r) and r > 0):
        raise ValueError(f"radius must be positive and finite, got {radius}")
    return r


def _check_points(p, name: str, min_count: int = 5) -> np.ndarray:
    """Finite pixel coordinates (N, 2), at least ``min_count`` of them (ValueError naming ``name``)."""
    p = np.asarray(p, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"{name} must have shape (N, 2), got {p.shape}")
    if len(p) < min_count:
        raise ValueError(f"{name} needs at least {min_count} points, got {len(p)}")
    if not np.all(np.isfinite(p)):
        raise ValueError(f"{name} has non-finite coordinates")
    return p


def _model_name(square_pixels: bool, zero_skew: bool) -> str:
    if square_pixels and not zero_skew:
        raise ValueError("square_pixels=True requires zero_skew=True (square pixels have no skew)")
    return "square_pixels" if square_pixels else ("zero_skew" if zero_skew else "general")


# --------------------------------------------------------------------------
# intrinsics models
# --------------------------------------------------------------------------


def _K_from_params(p: np.ndarray, model: str) -> np.ndarray:
    """Calibration matrix from the model's parameter vector (pixels)."""
    if model == "square_pixels":
        f, u, v = p
        return np.array([[f, 0.0, u], [0.0, f, v], [0.0, 0.0, 1.0]])
    if model == "zero_skew":
        fx, fy, u, v = p
        return np.array([[fx, 0.0, u], [0.0, fy, v], [0.0, 0.0, 1.0]])
    fx, fy, s, u, v = p
    return np.array([[fx, s, u], [0.0, fy, v], [0.0, 0.0, 1.0]])


def _params_from_K(K: np.ndarray, model: str) -> np.ndarray:
    """Model parameters of ``K`` (projected onto the model: mean focal for square pixels)."""
    K = K / K[2, 2]
    if model == "square_pixels":
        return np.array([0.5 * (K[0, 0] + K[1, 1]), K[0, 2], K[1, 2]])
    if model == "zero_skew":
        return np.array([K[0, 0], K[1, 1], K[0, 2], K[1, 2]])
    return np.array([K[0, 0], K[1, 1], K[0, 1], K[0, 2], K[1, 2]])


def _project_K(K: np.ndarray, model: str) -> np.ndarray:
    """Force ``K`` into the model (e.g. fy = fx for square pixels)."""
    return _K_from_params(_params_from_K(K, model), model)


def _omega_basis(model: str) -> list[np.ndarray]:
    """Symmetric 3x3 basis spanning the IACs of the model (a similarity keeps them in it)."""
    E = np.zeros((3, 3, 3, 3))
    for i in range(3):
        for j in range(3):
            E[i, j, i, j] = 1.0
    S = {(i, j): E[i, j] + E[j, i] if i != j else E[i, i] for i in range(3) for j in range(i, 3)}
    if model == "square_pixels":
        return [S[0, 0] + S[1, 1], S[0, 2], S[1, 2], S[2, 2]]
    if model == "zero_skew":
        return [S[0, 0], S[1, 1], S[0, 2], S[1, 2], S[2, 2]]
    return [S[0, 0], S[0, 1], S[1, 1], S[0, 2], S[1, 2], S[2, 2]]


# --------------------------------------------------------------------------
# forward model and the sphere from K and its outline
# --------------------------------------------------------------------------


def _outline_conics(Kinv: np.ndarray, X: np.ndarray, r) -> np.ndarray:
    """Unnormalised outline conics (M, 3, 3) of spheres ``X`` (M, 3), radii ``r``
    (scalar or (M,)), for ``Kinv`` (3, 3) or (M, 3, 3); negative inside."""
    X = np.atleast_2d(X)
    r = np.broadcast_to(np.asarray(r, dtype=np.float64), (len(X),))
    q = (X * X).sum(axis=1) - r * r
    Q = q[:, None, None] * np.eye(3) - X[:, :, None] * X[:, None, :]
    Ki = np.broadcast_to(Kinv, (len(X), 3, 3))
    C = np.einsum("mki,mkl,mlj->mij", Ki, Q, Ki)
    return C / np.linalg.norm(C, axis=(1, 2))[:, None, None]


def outline_conic(K, centre, radius) -> np.ndarray:
    """Image of a sphere's outline (the forward model).

    Parameters
    ----------
    K : (3, 3) float64, intrinsics (pixels)
    centre : (3,) float64, sphere centre in the camera frame (units of ``radius``)
    radius : float, > 0

    Returns
    -------
    (3, 3) float64, normalised conic (pixels), negative inside.

    Raises
    ------
    ValueError
        Bad ``K``; the camera is inside the sphere; or the sphere is not
        entirely in front of the camera (its outline would not be an ellipse).
    """
    K = _check_K(K)
    r = _check_radius(radius)
    X = np.asarray(centre, dtype=np.float64)
    if X.shape != (3,) or not np.all(np.isfinite(X)):
        raise ValueError(f"centre must be a finite (3,) vector, got shape {X.shape}")
    if X @ X <= r * r:
        raise ValueError("the camera centre is inside the sphere: no outline")
    if X[2] <= r:
        raise ValueError("the sphere must lie entirely in front of the camera (centre z > radius)")
    return normalize_conic(_outline_conics(np.linalg.inv(K), X, r)[0])


def centre_direction(K, conic) -> tuple[np.ndarray, float]:
    """Direction of a sphere's centre and the half-angle of its tangent cone.

    The cone ``K^T C K`` is circular, ``~ cos^2(a) I - d d^T``: its distinct
    eigenvector is the unit direction ``d`` to the centre and the ratio of
    the distinct eigenvalue to the mean of the other two is ``-tan^2(a)``.

    Parameters
    ----------
    K : (3, 3) float64, intrinsics (pixels)
    conic : (3, 3) float64, the sphere's outline (pixels), any scale and sign

    Returns
    -------
    direction : (3,) float64, unit vector in the camera frame, ``z > 0``
    half_angle : float, radians, in (0, pi/2)

    Raises
    ------
    ValueError
        If the conic's cone has no distinct eigenvalue of opposite sign (not
        the outline of a sphere seen by this camera).
    """
    K = _check_K(K)
    C = _check_conic(conic, ellipse=False)
    d, a = _cone_axes(K, C[None])
    if not np.isfinite(a[0]):
        raise ValueError("the conic's cone K^T C K is not that of a sphere (no eigenvalue of opposite sign)")
    return d[0], float(a[0])


def _cone_axes(K: np.ndarray, C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centre directions (M, 3) and half-angles (M,) for conics ``C`` (M, 3, 3)
    (NaN half-angle where the cone is not a sphere's)."""
    Q = np.einsum("ki,mkl,lj->mij", K, C, K)
    Q = 0.5 * (Q + np.swapaxes(Q, 1, 2))
    e, V = np.linalg.eigh(Q)
    dirs = np.empty((len(C), 3))
    ang = np.empty(len(C))
    for m in range(len(C)):
        ev = e[m]
        neg = np.count_nonzero(ev < 0)
        if neg == 1:
            k, pair = 0, ev[1:]
        elif neg == 2:
            k, pair = 2, ev[:2]
            ev = ev.copy()
        else:
            dirs[m] = np.nan
            ang[m] = np.nan
            continue
        d = V[m][:, k]
        if d[2] < 0:
            d = -d
        dirs[m] = d / np.linalg.norm(d)
        ratio = -ev[k] / pair.mean()
        ang[m] = np.arctan(np.sqrt(ratio)) if ratio > 0 else np.nan
    return dirs, ang


def imaged_centre(K, conic) -> np.ndarray:
    """Projection of the sphere's centre (not the ellipse's centre): ``K d``.

    Parameters
    ----------
    K : (3, 3) float64, conic : (3, 3) float64, pixels

    Returns
    -------
    (2,) float64, pixels.
    """
    K = _check_K(K)
    d, _ = centre_direction(K, conic)
    x = K @ d
    return x[:2] / x[2]


def sphere_centre(K, conic, radius) -> np.ndarray:
    """Sphere centre in the camera frame from its outline and radius.

    Parameters
    ----------
    K : (3, 3) float64, intrinsics (pixels)
    conic : (3, 3) float64, the sphere's outline (pixels)
    radius : float, > 0, the sphere's radius (sets the units of the answer)

    Returns
    -------
    (3,) float64, ``X = d r / sin(a)`` with ``d``, ``a`` from :func:`centre_direction`.
    """
    r = _check_radius(radius)
    d, a = centre_direction(K, conic)
    return d * (r / np.sin(a))


# --------------------------------------------------------------------------
# intrinsics: linear step
# --------------------------------------------------------------------------


def _pair_point(Ci: np.ndarray, Cj: np.ndarray):
    """The generalised eigenvector ``x0`` of ``(Ci, Cj)`` whose degenerate
    member ``Ci - lam Cj`` is a real line pair (``lam > 0``), or None when no
    or more than one eigenvector qualifies."""
    try:
        w = scipy.linalg.eigvals(Ci, Cj)
    except (np.linalg.LinAlgError, ValueError):
        return None
    cands = []
    for lam in w:
        if not np.isfinite(lam) or abs(lam.imag) > 1e-8 * max(1.0, abs(lam)):
            continue
        lam = lam.real
        if lam <= 0:
            continue
        D = Ci - lam * Cj
        ev = np.linalg.eigvalsh(D)
        rest = np.delete(ev, np.argmin(np.abs(ev)))
        if rest[0] * rest[1] >= 0:  # complex-conjugate line pair (or a double line)
            continue
        _, _, Vt = np.linalg.svd(D)
        x0 = Vt[-1]
        cands.append((x0, x0 @ Ci @ x0 > 0 and x0 @ Cj @ x0 > 0))
    if len(cands) > 1:  # four real intersections: keep the point outside both conics
        cands = [c for c in cands if c[1]]
    if len(cands) != 1:
        return None
    return cands[0][0]


def _linear_omega(Cs: np.ndarray, model: str):
    """Linear estimate of omega (conditioned frame) from all pairs.

    Returns (omega, n_pairs, x0s, singular values of the system)."""
    basis = _omega_basis(model)
    rows, x0s = [], []
    for i, j in itertools.combinations(range(len(Cs)), 2):
        x0 = _pair_point(Cs[i], Cs[j])
        if x0 is None:
            continue
        x0 = x0 / np.linalg.norm(x0)
        c = Cs[i] @ x0
        c = c / np.linalg.norm(c)
        B = np.stack([b @ x0 for b in basis], axis=1)  # omega x0 = B p
        rows.append(skew(c) @ B)
        x0s.append(x0)
    if not rows:
        return None, 0, np.zeros((0, 3)), None
    A = np.concatenate(rows)
    _, s, Vt = np.linalg.svd(A)
    p = Vt[-1]
    omega = sum(pk * b for pk, b in zip(p, basis))
    if np.trace(omega) < 0:
        omega = -omega
    return omega, len(rows), np.array(x0s), s


def _condition_frame(Cs: np.ndarray) -> np.ndarray:
    """Similarity T (pixels -> conditioned) from points sampled on all outlines."""
    pts = np.concatenate([ellipse_from_conic(C).points(8) for C in Cs])
    return hartley_normalization(pts)


def _to_frame(T: np.ndarray, C: np.ndarray) -> np.ndarray:
    Ti = np.linalg.inv(T)
    return np.array([normalize_conic(Ti.T @ c @ Ti) for c in np.atleast_3d(C).reshape(-1, 3, 3)])


def _diagnose_linear(x0s: np.ndarray, s, n_params: int) -> None:
    """Raise the ValueError that names the degeneracy of the linear system."""
    n_pairs = len(x0s)
    if n_pairs * 2 < n_params - 1:
        raise ValueError(
            f"not enough usable sphere pairs: {n_pairs} pair(s) give {2 * n_pairs} constraints, "
            f"the model needs {n_params - 1}"
        )
    if n_pairs >= 2:
        X = x0s * np.sign(x0s[:, [np.argmax(np.abs(x0s).sum(axis=0))]])
        sv = np.linalg.svd(X, compute_uv=False)
        if sv[1] < 1e-7 * sv[0]:
            raise ValueError(
                "the imaged sphere centres are collinear (all centres on one plane through the "
                "camera centre): the pairwise linear constraints are degenerate; move the sphere "
                "off that plane"
            )
    if s is not None and (len(s) < n_params or s[n_params - 2] < 1e-9 * s[0]):
        raise ValueError("the sphere images do not determine K (degenerate configuration)")


# --------------------------------------------------------------------------
# intrinsics: rank-1 refinement
# --------------------------------------------------------------------------


def _rank1_decompose(omega: np.ndarray, C: np.ndarray) -> tuple[float, np.ndarray]:
    """``lam``, ``v`` with ``omega - lam C ~ v v^T`` (best rank-1 member of the pencil)."""
    best = (np.inf, 1.0)
    for lam in scipy.linalg.eigvals(omega, C):
        if not np.isfinite(lam):
            continue
        lam = lam.real
        s = np.linalg.svd(omega - lam * C, compute_uv=False)
        if s[1] / max(s[0], 1e-300) < best[0]:
            best = (s[1] / max(s[0], 1e-300), lam)
    lam = best[1]
    e, V = np.linalg.eigh(omega - lam * C)
    k = np.argmax(np.abs(e))
    v = V[:, k] * np.sqrt(abs(e[k]))
    return float(lam), v


def _rank1_refine(Kc: np.ndarray, Cs: np.ndarray, model: str, max_nfev: int = 200) -> np.ndarray:
    """Refine ``Kc`` (conditioned frame) so that ``lam_i C_i = omega - v_i v_i^T``.

    The residual of image ``i`` is the misfit ``lam_i C_i - omega + v_i v_i^T``
    expressed in the image's own normalised frame (outline centred, major
    semi-axis 1), relative to the conic's norm: a dimensionless algebraic
    distance that weighs every image alike, whatever its size or position.
    """
    M = len(Cs)
    frames = [conic_conditioning(C) for C in Cs]
    Fi = np.array([np.linalg.inv(F) for F in frames])
    nK = {"square_pixels": 3, "zero_skew": 4, "general": 5}[model]

    def omega_of(pk):
        Ki = np.linalg.inv(_K_from_params(pk, model))
        w = Ki.T @ Ki
        return w / np.linalg.norm(w)

    omega0 = omega_of(_params_from_K(Kc, model))
    x0 = [_params_from_K(Kc, model)]
    for C in Cs:
        lam, v = _rank1_decompose(omega0, C)
        x0.append(np.concatenate([[lam], v]))
    x0 = np.concatenate(x0)
    iu = np.triu_indices(3)
    wts = np.where(iu[0] == iu[1], 1.0, np.sqrt(2.0))
    Cf = np.einsum("mki,mkl,mlj->mij", Fi, Cs, Fi)
    Cf_norm = np.linalg.norm(Cf, axis=(1, 2))

    def fun(x):
        w = omega_of(x[:nK])
        res = np.empty((M, 6))
        for m in range(M):
            lam = x[nK + 4 * m]
            v = x[nK + 4 * m + 1 : nK + 4 * m + 4]
            E = lam * Cs[m] - w + np.outer(v, v)
            Ef = Fi[m].T @ E @ Fi[m]
            res[m] = Ef[iu] * wts / (abs(lam) * Cf_norm[m] + 1e-300)
        return res.ravel()

    sol = scipy.optimize.least_squares(fun, x0, method="lm", x_scale="jac", xtol=1e-14, ftol=1e-14, gtol=1e-14, max_nfev=max_nfev * len(x0))
    return _K_from_params(sol.x[:nK], model)


# --------------------------------------------------------------------------
# intrinsics: geometric refinement (maximum likelihood on edge points)
# --------------------------------------------------------------------------


def _sphere_params(K: np.ndarray, Cs: np.ndarray) -> np.ndarray:
    """Per image ``(u, v, tan a)``: imaged centre (pixels) and cone half-angle."""
    d, a = _cone_axes(K, Cs)
    if not np.all(np.isfinite(a)):
        bad = int(np.flatnonzero(~np.isfinite(a))[0])
        raise ValueError(f"conics[{bad}] is not the outline of a sphere for this K")
    x = d @ K.T
    return np.column_stack([x[:, 0] / x[:, 2], x[:, 1] / x[:, 2], np.tan(a)])


def _conics_from_sphere_params(pk: np.ndarray, sp: np.ndarray, model: str) -> np.ndarray:
    """Outline conics (M, 3, 3) for K params ``pk`` and sphere params ``sp`` (M, 3)."""
    Ki = np.linalg.inv(_K_from_params(pk, model))
    d = np.column_stack([sp[:, 0], sp[:, 1], np.ones(len(sp))]) @ Ki.T
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    r = np.sin(np.arctan(sp[:, 2]))
    return _outline_conics(Ki, d, r)


def _geometric_problem(pts_list):
    pts = np.concatenate(pts_list)
    idx = np.concatenate([np.full(len(p), m) for m, p in enumerate(pts_list)])
    return pts, idx


def _geometric_jacobian(x, pts, idx, M, model, nK):
    pk, sp = x[:nK], x[nK:].reshape(M, 3)
    C = _conics_from_sphere_params(pk, sp, model)
    d, J6 = sampson_with_jacobian(pts, idx, C)
    hK = 1e-6 * np.maximum(np.abs(pk), 1.0)
    dCdK = central_difference(lambda q: conic_to_vec6(_conics_from_sphere_params(q, sp, model)), pk, hK)  # (M, 6, nK)
    J = np.zeros((len(pts), nK + 3 * M))
    J[:, :nK] = np.einsum("nc,nck->nk", J6, dCdK[idx])
    hs = np.array([1e-6 * max(1.0, np.abs(sp[:, 0]).max()), 1e-6 * max(1.0, np.abs(sp[:, 1]).max()), 1e-7])
    dCds = np.empty((M, 6, 3))
    for k in range(3):
        e = np.zeros_like(sp)
        e[:, k] = hs[k]
        dCds[:, :, k] = (
            conic_to_vec6(_conics_from_sphere_params(pk, sp + e, model))
            - conic_to_vec6(_conics_from_sphere_params(pk, sp - e, model))
        ) / (2 * hs[k])
    Js = np.einsum("nc,nck->nk", J6, dCds[idx])
    cols = nK + 3 * idx[:, None] + np.arange(3)[None, :]
    np.put_along_axis(J, cols, Js, axis=1)
    return d, J


def _focal_sigma(J: np.ndarray, sigma: float, pk: np.ndarray, model: str) -> float:
    """First-order relative std of the focal length(s) from the Jacobian."""
    D = np.linalg.norm(J, axis=0)
    D[D == 0] = 1.0
    Js = J / D
    try:
        cov = np.linalg.pinv(Js.T @ Js, rcond=1e-15, hermitian=True) / np.outer(D, D) * sigma**2
    except np.linalg.LinAlgError:
        return float("inf")
    nf = 1 if model == "square_pixels" else 2
    rel = [np.sqrt(max(cov[k, k], 0.0)) / abs(pk[k]) for k in range(nf)]
    s = float(max(rel))
    return s if np.isfinite(s) else float("inf")


def _run_geometric(K0, Cs_px, pts_list, model, *, max_nfev=100, loss="linear", f_scale=1.0):
    M = len(Cs_px)
    nK = len(_params_from_K(K0, model))
    pts, idx = _geometric_problem(pts_list)
    x0 = np.concatenate([_params_from_K(K0, model), _sphere_params(K0, Cs_px).ravel()])

    def fun(x):
        pk, sp = x[:nK], x[nK:].reshape(M, 3)
        return sampson_with_jacobian(pts, idx, _conics_from_sphere_params(pk, sp, model), jac=False)

    def jac(x):
        return _geometric_jacobian(x, pts, idx, M, model, nK)[1]

    method = "lm" if loss == "linear" else "trf"
    sol = scipy.optimize.least_squares(
        fun, x0, jac=jac, method=method, loss=loss, f_scale=f_scale, x_scale="jac",
        xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=max_nfev,
    )
    return sol.x, pts, idx


def _result_from_params(x, pts, idx, model, *, constraint_set, edge_given, noise_floor, weak_threshold, K_linear, K_rank1, n_pairs):
    M = int(idx.max()) + 1
    nK = len(x) - 3 * M
    pk, sp = x[:nK], x[nK:].reshape(M, 3)
    K = _K_from_params(pk, model)
    C = _conics_from_sphere_params(pk, sp, model)
    d, J = _geometric_jacobian(x, pts, idx, M, model, nK)
    # exact orthogonal distances for the report
    res = np.empty(M)
    for m in range(M):
        e = ellipse_from_conic(C[m])
        dist = ellipse_distance(pts[idx == m], e)
        res[m] = np.sqrt(np.mean(dist * dist))
    dof = max(len(pts) - len(x), 1)
    sigma = np.sqrt((d @ d) / dof) if edge_given else 0.0
    fs = _focal_sigma(J, max(sigma, noise_floor), pk, model)
    Ki = np.linalg.inv(K)
    dirs = np.column_stack([sp[:, 0], sp[:, 1], np.ones(M)]) @ Ki.T
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    counts = np.bincount(idx, minlength=M)
    rms = float(np.sqrt(np.sum(res * res * counts) / counts.sum()))
    return SphereIntrinsics(
        K=K,
        centre_directions=dirs,
        half_angles=np.arctan(sp[:, 2]),
        imaged_centres=sp[:, :2].copy(),
        residuals=res,
        rms=rms,
        constraint_set=constraint_set,
        model=model,
        weak=bool(not fs <= weak_threshold),
        focal_sigma=fs,
        K_linear=K_linear,
        K_rank1=K_rank1,
        n_pairs=n_pairs,
    )


def _sampled_outline_points(Cs_px: np.ndarray, n: int = 100) -> list[np.ndarray]:
    return [ellipse_from_conic(C).points(n) for C in Cs_px]


def _check_conic_list(conics) -> np.ndarray:
    try:
        n = len(conics)
    except TypeError:
        raise ValueError("conics must be a sequence of 3x3 conic matrices") from None
    if n < 3:
        raise ValueError(f"intrinsics from spheres need at least 3 sphere images, got {n}")
    Cs = np.array([_check_conic(C, f"conics[{i}]") for i, C in enumerate(conics)])
    for i, j in itertools.combinations(range(n), 2):
        if min(np.linalg.norm(Cs[i] - Cs[j]), np.linalg.norm(Cs[i] + Cs[j])) < 1e-12:
            raise ValueError(f"conics[{i}] and conics[{j}] are the same outline: each image must show the sphere elsewhere")
    return Cs


def _check_edge_list(edge_points, n: int) -> list[np.ndarray] | None:
    if edge_points is None:
        return None
    if len(edge_points) != n:
        raise ValueError(f"edge_points must hold one (N, 2) array per conic: {n} conics, {len(edge_points)} arrays")
    return [_check_points(p, f"edge_points[{i}]") for i, p in enumerate(edge_points)]


def intrinsics_from_spheres(
    conics,
    *,
    edge_points=None,
    square_pixels: bool = False,
    zero_skew: bool = True,
    weak_threshold: float = 0.1,
    noise_floor: float = 0.1,
    max_nfev: int = 100,
) -> SphereIntrinsics:
    """Intrinsics from three or more images of a sphere (or of several spheres).

    Three stages, each started from the previous one:

    1. **linear** — for every pair of outlines the generalised eigenvector
       ``x0`` of ``(C_i, C_j)`` whose degenerate conic ``C_i - lam C_j`` is a
       real line pair gives ``omega x0 ~ C_i x0`` (two linear equations in
       ``omega``); all pairs are solved together by SVD in Hartley-normalised
       coordinates and ``K`` follows by Cholesky.
    2. **rank1** — ``K`` and, per image, ``lam_i`` and ``v_i`` refined so that
       ``lam_i C_i = omega - v_i v_i^T`` (the rank-1 constraint), the misfit
       measured in each outline's own normalised frame.
    3. **geometric** (only with ``edge_points``) — maximum likelihood under
       isotropic Gaussian edge noise: ``K`` and every sphere (imaged centre,
       cone half-angle) refined to minimise the edge points' (Sampson)
       distances to the predicted outlines.

    Parameters
    ----------
    conics : sequence of M >= 3 (3, 3) float64 conics, pixels; one outline per
        image, all taken with the same camera (fixed intrinsics)
    edge_points : sequence of M (N_i, 2) float64, optional, the edge points the
        conics were fitted to (pixels). Without them the answer is stage 2.
    square_pixels : bool, model ``fx = fy`` and zero skew (3 unknowns)
    zero_skew : bool, model zero skew (4 unknowns, the default); False: 5 unknowns
    weak_threshold : float, ``weak`` is set when the first-order relative standard
        deviation of the focal length exceeds this
    noise_floor : float, pixels, smallest edge-noise level assumed for that
        standard deviation (without edge points: ``noise_floor`` at 100 points per
        outline)
    max_nfev : int, iteration cap of the geometric refinement

    Returns
    -------
    SphereIntrinsics

    Raises
    ------
    ValueError
        Fewer than 3 conics; a conic that is not an ellipse; repeated outlines;
        all outlines circles (parallel projection: the focal length is
        unobservable); collinear imaged centres (the centres and the camera
        centre coplanar); too few usable pairs; no positive-definite IAC (the
        data are too weak or inconsistent); ``square_pixels`` without
        ``zero_skew``; mismatched ``edge_points``.
    """
    model = _model_name(square_pixels, zero_skew)
    Cs_px = _check_conic_list(conics)
    pts_list = _check_edge_list(edge_points, len(Cs_px))
    ell = [ellipse_from_conic(C) for C in Cs_px]
    if max(e.axes[0] / e.axes[1] - 1.0 for e in ell) < 1e-9:
        raise ValueError(
            "all sphere outlines are circles: the focal length is unobservable "
            "(parallel projection, or every sphere on the optical axis)"
        )
    T = _condition_frame(Cs_px)
    Cs = _to_frame(T, Cs_px)
    nparams = len(_omega_basis(model))
    omega, n_pairs, x0s, s = _linear_omega(Cs, model)
    _diagnose_linear(x0s, s, nparams)
    # noise can make the linear IAC indefinite when K is weakly constrained;
    # the fewer unknowns of a stricter model then give the initial K
    fallbacks = {"general": ["zero_skew", "square_pixels"], "zero_skew": ["square_pixels"], "square_pixels": []}[model]
    for alt in fallbacks:
        if np.all(np.linalg.eigvalsh(omega) > 0):
            break
        omega = _linear_omega(Cs, alt)[0]
    if not np.all(np.linalg.eigvalsh(omega) > 0):
        raise ValueError(
            "the linear estimate of the image of the absolute conic is not positive definite: "
            "the sphere images constrain K too weakly (near-circular outlines, nearly collinear "
            "centres) or are inconsistent"
        )
    Tinv = np.linalg.inv(T)
    Kc_lin = _project_K(K_from_iac(omega), model)
    K_lin = _normalise_K(Tinv @ Kc_lin, model)
    Kc_r1 = _rank1_refine(Kc_lin, Cs, model)
    K_r1 = _normalise_K(Tinv @ Kc_r1, model)
    if not np.all(np.isfinite(K_r1)) or K_r1[0, 0] <= 0 or K_r1[1, 1] <= 0:
        K_r1 = K_lin
    if pts_list is None:
        pts_list_eval = _sampled_outline_points(Cs_px)
        x = np.concatenate([_params_from_K(K_r1, model), _sphere_params(K_r1, Cs_px).ravel()])
        pts, idx = _geometric_problem(pts_list_eval)
        return _result_from_params(
            x, pts, idx, model, constraint_set="rank1", edge_given=False, noise_floor=noise_floor,
            weak_threshold=weak_threshold, K_linear=K_lin, K_rank1=K_r1, n_pairs=n_pairs,
        )
    x, pts, idx = _run_geometric(K_r1, Cs_px, pts_list, model, max_nfev=max_nfev)
    return _result_from_params(
        x, pts, idx, model, constraint_set="geometric", edge_given=True, noise_floor=noise_floor,
        weak_threshold=weak_threshold, K_linear=K_lin, K_rank1=K_r1, n_pairs=n_pairs,
    )


def _normalise_K(K: np.ndarray, model: str) -> np.ndarray:
    K = K / K[2, 2]
    K[1, 0] = K[2, 0] = K[2, 1] = 0.0
    return _project_K(K, model)


def refine_intrinsics(
    K,
    conics,
    edge_points,
    *,
    square_pixels: bool = False,
    zero_skew: bool = True,
    weak_threshold: float = 0.1,
    noise_floor: float = 0.1,
    max_nfev: int = 100,
) -> SphereIntrinsics:
    """Geometric (maximum-likelihood) refinement of ``K`` and the spheres from
    edge points, started from a given ``K`` (stage 3 of
    :func:`intrinsics_from_spheres` on its own).

    Parameters
    ----------
    K : (3, 3) float64, the starting intrinsics (pixels)
    conics : sequence of M >= 1 (3, 3) conics, pixels, starting outlines (the
        spheres are initialised from ``K`` and these by :func:`centre_direction`)
    edge_points : sequence of M (N_i, 2) float64, pixels
    square_pixels, zero_skew, weak_threshold, noise_floor, max_nfev :
        as in :func:`intrinsics_from_spheres`

    Returns
    -------
    SphereIntrinsics with ``constraint_set == "geometric"`` (``K_linear`` and
    ``K_rank1`` are None).
    """
    model = _model_name(square_pixels, zero_skew)
    K0 = _project_K(_check_K(K), model)
    if len(conics) < 1:
        raise ValueError("refine_intrinsics needs at least one conic")
    Cs_px = np.array([_check_conic(C, f"conics[{i}]") for i, C in enumerate(conics)])
    pts_list = _check_edge_list(edge_points, len(Cs_px))
    if pts_list is None:
        raise ValueError("refine_intrinsics needs edge_points")
    x, pts, idx = _run_geometric(K0, Cs_px, pts_list, model, max_nfev=max_nfev)
    return _result_from_params(
        x, pts, idx, model, constraint_set="geometric", edge_given=True, noise_floor=noise_floor,
        weak_threshold=weak_threshold, K_linear=None, K_rank1=None, n_pairs=0,
    )


# --------------------------------------------------------------------------
# outline extraction from an image
# --------------------------------------------------------------------------


def _as_float_image(image) -> np.ndarray:
    img = np.asarray(image)
    if img.ndim == 2:
        img = img[:, :, None]
    if img.ndim != 3 or img.shape[2] not in (1, 3, 4):
        raise ValueError(f"image must be H x W (grey) or H x W x 3 (BGR), got shape {img.shape}")
    if img.shape[0] < 16 or img.shape[1] < 16:
        raise ValueError(f"image is too small: {img.shape[1]} x {img.shape[0]} pixels")
    if img.shape[2] == 4:
        img = img[:, :, :3]
    if img.dtype == np.uint8:
        return img.astype(np.float32)
    if img.dtype == np.uint16:
        return img.astype(np.float32) / 257.0
    if np.issubdtype(img.dtype, np.floating):
        f = img.astype(np.float32)
        if not np.all(np.isfinite(f)):
            raise ValueError("image has non-finite values")
        return f * 255.0 if f.max() <= 1.0 else f
    raise ValueError(f"image must be uint8, uint16 or float, got dtype {img.dtype}")


def _check_roi(roi, w: int, h: int) -> tuple[int, int, int, int]:
    if roi is None:
        return 0, 0, w, h
    try:
        x, y, rw, rh = (int(round(float(v))) for v in roi)
    except (TypeError, ValueError):
        raise ValueError(f"roi must be (x, y, width, height) in pixels, got {roi!r}") from None
    if rw < 16 or rh < 16 or x < 0 or y < 0 or x + rw > w or y + rh > h:
        raise ValueError(f"roi {tuple(roi)} must be at least 16 x 16 and lie inside the {w} x {h} image")
    return x, y, rw, rh


def _edge_strength(img: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Colour gradient (Di Zenzo, largest eigenvalue) of an (H, W, C) float image:
    magnitude and the (gx, gy) of the strongest channel direction."""
    gxx = np.zeros(img.shape[:2], np.float32)
    gyy = np.zeros_like(gxx)
    gxy = np.zeros_like(gxx)
    for c in range(img.shape[2]):
        gx = cv2.Sobel(img[:, :, c], cv2.CV_32F, 1, 0, ksize=3) / 8.0
        gy = cv2.Sobel(img[:, :, c], cv2.CV_32F, 0, 1, ksize=3) / 8.0
        gxx += gx * gx
        gyy += gy * gy
        gxy += gx * gy
    tr = gxx + gyy
    disc = np.sqrt(np.maximum((gxx - gyy) ** 2 + 4 * gxy * gxy, 0))
    lam = 0.5 * (tr + disc)
    theta = 0.5 * np.arctan2(2 * gxy, gxx - gyy)
    mag = np.sqrt(np.maximum(lam, 0))
    return mag, np.cos(theta) * mag, np.sin(theta) * mag


def _circle_support(mag, gx, gy, circles: np.ndarray, thresh: float) -> np.ndarray:
    """Fraction of each circle's perimeter (360 samples) with a strong, radially
    oriented gradient within a band of +-max(1.5, 0.08 r) px: (K,) in [0, 1]."""
    h, w = mag.shape
    a = np.linspace(0, 2 * np.pi, 360, endpoint=False)
    ca, sa = np.cos(a), np.sin(a)
    cx, cy, rho = (circles[:, k][:, None, None] for k in range(3))
    band = np.maximum(1.5, 0.08 * rho)
    steps = np.linspace(-1.0, 1.0, 7)[None, :, None]
    rr = rho + band * steps  # (K, 7, 1)
    x = np.round(cx + rr * ca).astype(int)
    y = np.round(cy + rr * sa).astype(int)
    ok = (x >= 0) & (x < w) & (y >= 0) & (y < h)
    xs, ys = np.clip(x, 0, w - 1), np.clip(y, 0, h - 1)
    m = mag[ys, xs]
    radial = np.abs(gx[ys, xs] * ca + gy[ys, xs] * sa)
    hit = ok & (m > thresh) & (radial > 0.85 * m)
    return hit.any(axis=1).mean(axis=1)


def _candidate_circles(gray8: np.ndarray, rmin: int, rmax: int, *, thorough: bool = False) -> np.ndarray:
    """(K, 3) circle candidates (cx, cy, r), pixels, from OpenCV's circle Hough
    transform ("ALT" variant; with ``thorough`` also the classic gradient one)."""
    out = []
    c = cv2.HoughCircles(gray8, cv2.HOUGH_GRADIENT_ALT, dp=1.5, minDist=max(4, rmin), param1=60, param2=0.5, minRadius=rmin, maxRadius=rmax)
    if c is not None:
        out.append(c.reshape(-1, 3).astype(np.float64))
    if thorough:
        c = cv2.HoughCircles(gray8, cv2.HOUGH_GRADIENT, dp=1.0, minDist=max(4, rmin), param1=60, param2=15, minRadius=rmin, maxRadius=rmax)
        if c is not None:
            out.append(c.reshape(-1, 3)[:300].astype(np.float64))
    if not out:
        return np.zeros((0, 3))
    return np.concatenate(out)


def _contour_circles(gx: np.ndarray, gy: np.ndarray, thresh: float, rmin: int, rmax: int) -> np.ndarray:
    """(K, 3) circle candidates (cx, cy, r) from edge chains of the colour gradient.

    Canny on the colour gradient, edge chains by ``cv2.findContours``, then
    an algebraic (Kasa) circle fit on every chain and on overlapping pieces
    of 48 edge pixels (a ball's outline is cut into arcs by clutter crossing
    it, and chains can run on into the clutter); pieces that are tight arcs
    with a radius in range are kept."""
    sc = 8.0
    dx = np.clip(gx * sc, -32767, 32767).astype(np.int16)
    dy = np.clip(gy * sc, -32767, 32767).astype(np.int16)
    edges = cv2.Canny(dx, dy, thresh * sc, 2.0 * thresh * sc, L2gradient=True)
    contours, _ = cv2.findContours(edges, cv2.RETR_LIST, cv2.CHAIN_APPROX_NONE)
    win, stride = 48, 16
    pieces = []
    for c in contours:
        c = c.reshape(-1, 2).astype(np.float64)
        if len(c) < 24:
            continue
        if len(c) <= 2 * win:
            pieces.append(c[np.linspace(0, len(c) - 1, win).astype(int)])
        starts = np.arange(0, max(len(c) - win, 0) + 1, stride)
        if len(c) > win:
            pieces.extend(c[starts[:, None] + np.arange(win)[None, :]])
    if not pieces:
        return np.zeros((0, 3))
    P = np.array(pieces)  # (Q, win, 2)
    x, y = P[..., 0], P[..., 1]
    A = np.stack([x, y, np.ones_like(x)], axis=-1)
    b = -(x * x + y * y)
    AtA = np.einsum("qni,qnj->qij", A, A)
    Atb = np.einsum("qni,qn->qi", A, b)
    ok = np.abs(np.linalg.det(AtA)) > 1e-6
    sol = np.zeros((len(P), 3))
    sol[ok] = np.linalg.solve(AtA[ok], Atb[ok][..., None])[..., 0]
    cx, cy = -sol[:, 0] / 2, -sol[:, 1] / 2
    r2 = cx * cx + cy * cy - sol[:, 2]
    r = np.sqrt(np.maximum(r2, 0))
    dist = np.abs(np.hypot(x - cx[:, None], y - cy[:, None]) - r[:, None])
    rms = np.sqrt((dist * dist).mean(axis=1))
    keep = ok & (r2 > 0) & (r >= rmin) & (r <= rmax) & (rms < 0.75)
    return np.column_stack([cx, cy, r])[keep]


def _ranked_circles(images, mag, gx, gy, rmin, rmax, thresh, *, thorough: bool, extra=None):
    """Circle candidates from every 8-bit image in ``images`` (and ``extra``),
    deduplicated, scored by edge support, those with support >= 0.6 sorted
    by decreasing radius: (K, 4) rows (cx, cy, r, support)."""
    parts = [_candidate_circles(g, rmin, rmax, thorough=thorough) for g in images]
    if extra is not None:
        parts.append(extra)
    cands = np.concatenate(parts) if parts else np.zeros((0, 3))
    if len(cands) == 0:
        return np.zeros((0, 4))
    _, first = np.unique(np.round(cands / 2.0), axis=0, return_index=True)
    cands = cands[np.sort(first)]
    sc = _circle_support(mag, gx, gy, cands, thresh)
    rows = np.column_stack([cands, sc])[sc >= 0.6]
    rows = rows[np.lexsort((-rows[:, 3], -np.round(rows[:, 2])))]
    out = []
    for row in rows:  # drop near-duplicates
        if all(np.hypot(row[0] - o[0], row[1] - o[1]) > 2 or abs(row[2] - o[2]) > 2 for o in out):
            out.append(row)
    return np.array(out).reshape(-1, 4)


def _normal_profiles(img: np.ndarray, e: Ellipse, n: int, half_width: float, step: float = 0.25):
    """Sample the image along the outward normals of ``e`` at ``n`` angles.

    Returns (base points (n, 2), unit normals (n, 2), offsets (L,), samples (n, L, C))."""
    s = np.linspace(0, 2 * np.pi, n, endpoint=False)
    base = e.points_at(s)
    a, b = e.axes
    ca, sa = np.cos(e.angle), np.sin(e.angle)
    # outward normal of x = a cos s, y = b sin s in the ellipse frame: (b cos s, a sin s)
    nx, ny = b * np.cos(s), a * np.sin(s)
    nrm = np.stack([ca * nx - sa * ny, sa * nx + ca * ny], axis=1)
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    off = np.arange(-half_width, half_width + 1e-9, step)
    P = base[:, None, :] + off[None, :, None] * nrm[:, None, :]
    mx = P[..., 0].astype(np.float32)
    my = P[..., 1].astype(np.float32)
    chans = [cv2.remap(img[:, :, c], mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE) for c in range(img.shape[2])]
    return base, nrm, off, np.stack(chans, axis=-1)


def _edge_points_along_normals(img, e: Ellipse, half_width: float, n: int, min_strength: float):
    base, nrm, off, prof = _normal_profiles(img, e, n, half_width)
    step = off[1] - off[0]
    d = np.gradient(prof, step, axis=1)
    strength = np.sqrt((d * d).sum(axis=2))  # (n, L), colour edge strength per unit length
    L = strength.shape[1]
    k = np.argmax(strength[:, 1:-1], axis=1) + 1
    rows = np.arange(len(k))
    y0, y1, y2 = strength[rows, k - 1], strength[rows, k], strength[rows, k + 1]
    den = y0 - 2 * y1 + y2
    delta = np.where(den < 0, 0.5 * (y0 - y2) / np.where(den < 0, den, -1.0), 0.0)
    delta = np.clip(delta, -0.5, 0.5)
    pos = off[k] + delta * step
    peak = y1
    ok = (k > 1) & (k < L - 2) & (peak > min_strength)
    pts = base + pos[:, None] * nrm
    angles = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return pts[ok], peak[ok], angles[ok]


def _robust_direct_fit(pts: np.ndarray, iterations: int = 4):
    """Direct ellipse fit with Cauchy-weighted IRLS on Sampson distances.

    Returns (Ellipse, inlier mask (N,), robust sigma) or None."""
    w = np.ones(len(pts))
    try:
        for _ in range(iterations):
            e = fit_ellipse_direct(pts, w)
            d = sampson_distance(pts, e.conic)
            sig = max(1.4826 * np.median(np.abs(d - np.median(d))), 0.05)
            w = 1.0 / (1.0 + (d / (2.0 * sig)) ** 2)
    except ValueError:
        return None
    return e, np.abs(d) < max(min(3.0 * sig, 1.5), 0.25), sig


def _refine_outline(sm: np.ndarray, e: Ellipse, thresh: float):
    """Edge points along the normals of ``e`` and a robust fit, in three rounds
    with a narrowing search band. Returns (Ellipse, points (N, 2), support) or None."""
    rho = e.axes[0]
    pts = np.zeros((0, 2))
    ang = np.zeros(0)
    wide = float(np.clip(0.15 * rho, 3.0, 8.0))
    for k, half_width in enumerate((wide, wide, wide, 3.0, 2.0)):
        # coarse rounds: at most 360 normals; fine rounds: one per pixel of perimeter
        n = int(np.clip(2 * np.pi * e.axes[0], 90, 360 if k < 3 else 1440))
        pts, peak, ang = _edge_points_along_normals(sm, e, half_width, n, thresh)
        if len(pts) < 12:
            return None
        keep = peak > 0.25 * np.median(peak)
        pts, ang = pts[keep], ang[keep]
        fit = _robust_direct_fit(pts)
        if fit is None:
            return None
        e, inl, sig = fit
        if sig > 1.5:
            return None
        pts, ang = pts[inl], ang[inl]
        if len(pts) < 12 or e.axes[0] > 3 * rho or e.axes[1] < 0.3 * rho:
            return None
    if sig > 0.7:  # edge points scattered about the fit: not a sharp outline
        return None
    # support: angular coverage by points that lie tightly on the fit (a fit
    # pulled off the true outline by a clutter edge loses coverage here)
    tight = np.abs(sampson_distance(pts, e.conic)) < 0.6
    support = len(np.unique(np.floor(ang[tight] / (2 * np.pi) * 90))) / 90.0
    return e, pts, support


def fit_sphere_outline(
    image,
    *,
    roi=None,
    radius_range=None,
    smoothing: float = 1.0,
    min_support: float = 0.5,
) -> SphereOutline:
    """Find a sphere's silhouette in an image and fit its outline conic.

    1. Candidates: circles fitted to arcs of the colour-gradient edge chains
       (Canny on the Di Zenzo colour gradient, 48-pixel pieces of every
       chain) and OpenCV's circle Hough transform ("ALT") on the smoothed
       grey image; if none of them verifies, the Hough transform on each
       colour channel, then the classic gradient Hough transform. Clutter
       makes spurious circles win votes, so every candidate is scored by the
       fraction of its perimeter with a strong, radially oriented colour
       gradient, and those scoring at least 0.6 are verified by steps 2-3.
    2. Sub-pixel edge points: the smoothed colour image is sampled along the
       normals of the current outline (one normal per pixel of perimeter,
       0.25 px steps); the colour-gradient magnitude along each normal peaks
       at the silhouette whatever its polarity (shading can turn a bright
       limb on a dark background into a dark limb on a bright one); the peak
       is located to sub-pixel precision by a parabola. Normals without a
       clear edge (a shaded limb against a background of the same colour) are
       dropped.
    3. Robust fitting: direct ellipse fit with Cauchy-weighted IRLS on
       Sampson distances, rejection beyond three robust standard deviations;
       the search band narrows over five rounds (three wide, then 3 and 2 px
       either side), so specular highlights,
       texture and clutter edges drop out as outliers.
    4. Choice: candidates are tried from the largest down, and the first
       whose outline is covered by edge points lying within 0.6 px of the fit
       over at least ``min_support`` of its angle wins (a specular highlight
       or a small disc of clutter is a smaller "circle"); of the candidates
       for that same object, the best covered is kept. The final conic is
       the geometric (orthogonal-distance) least-squares fit of its points.

    Parameters
    ----------
    image : (H, W, 3) uint8 BGR or (H, W) grey image (uint8, uint16 or float)
    roi : (x, y, width, height), optional, pixels: search only there (the
        outline must lie inside it); the returned points are in full-image pixels
    radius_range : (2,) int, optional, apparent radius range in pixels
        (default: 8 to half the smaller side of the search area)
    smoothing : float, Gaussian sigma (pixels) applied before sampling
    min_support : float, smallest accepted fraction of the outline (by angle)
        with edge points

    Returns
    -------
    SphereOutline

    Raises
    ------
    ValueError
        Bad image or roi; no round outline found; too little of the outline
        visible (support below ``min_support``).
    """
    full = _as_float_image(image)
    H, W = full.shape[:2]
    x0, y0, rw, rh = _check_roi(roi, W, H)
    img = np.ascontiguousarray(full[y0 : y0 + rh, x0 : x0 + rw])
    if radius_range is None:
        rmin, rmax = 8, max(10, min(rw, rh) // 2)
    else:
        try:
            rmin, rmax = (int(round(float(v))) for v in radius_range)
        except (TypeError, ValueError):
            raise ValueError(f"radius_range must be (min, max) pixels, got {radius_range!r}") from None
        if not 2 <= rmin < rmax:
            raise ValueError(f"radius_range must satisfy 2 <= min < max, got {radius_range}")
    if not (np.isfinite(smoothing) and smoothing >= 0):
        raise ValueError(f"smoothing must be a non-negative number of pixels, got {smoothing}")
    sm = cv2.GaussianBlur(img, (0, 0), smoothing) if smoothing > 0 else img
    if sm.ndim == 2:
        sm = sm[:, :, None]
    mag, gx, gy = _edge_strength(sm)
    thresh = max(4.0 * float(np.median(mag)), 2.0)
    grey = sm.mean(axis=2)
    inputs = [grey] + ([sm[:, :, c] for c in range(sm.shape[2])] if sm.shape[2] > 1 else [])
    inputs = [np.clip(g, 0, 255).astype(np.uint8) for g in inputs]
    first = None
    group: list = []
    best_seen = 0.0
    passes = [
        dict(images=inputs[:1], thorough=False, extra=_contour_circles(gx, gy, thresh, rmin, rmax)),
        dict(images=inputs[1:], thorough=False, extra=None),
        dict(images=inputs[:1], thorough=True, extra=None),
    ]
    for kw in passes:
        if not kw["images"]:
            continue
        rows = _ranked_circles(kw["images"], mag, gx, gy, rmin, rmax, thresh, thorough=kw["thorough"], extra=kw["extra"])
        # largest first: a specular highlight or a small disc of clutter is a
        # smaller "circle"; the first convincing outline wins
        for k, (cx, cy, r, sc) in enumerate(rows):
            out = _refine_outline(sm, Ellipse(center=(cx, cy), axes=(r, r), angle=0.0), thresh)
            if out is None:
                continue
            best_seen = max(best_seen, out[2])
            if out[2] < min_support:
                continue
            first = out[0]
            group.append(out)
            # other seeds for the same object, best supported first: a seed
            # can converge onto a fit pulled aside by a clutter edge
            rest = rows[k + 1 :]
            same = rest[np.hypot(rest[:, 0] - first.center[0], rest[:, 1] - first.center[1]) < 0.3 * first.axes[0]]
            for cx2, cy2, r2, _ in same[np.argsort(-same[:, 3], kind="stable")][:4]:
                out2 = _refine_outline(sm, Ellipse(center=(cx2, cy2), axes=(r2, r2), angle=0.0), thresh)
                if out2 is not None and np.hypot(out2[0].center[0] - first.center[0], out2[0].center[1] - first.center[1]) < 0.3 * first.axes[0]:
                    group.append(out2)
            break
        if first is not None:
            break
    if first is None:
        if best_seen == 0.0:
            raise ValueError("no sphere outline found in the image (or roi)")
        raise ValueError(
            f"sphere outline support too small: edge points on {best_seen:.0%} of the best outline "
            f"(< {min_support:.0%})"
        )
    e, pts, support = max(group, key=lambda r: r[2])
    final = fit_ellipse(pts)
    e = final.ellipse
    e_full = Ellipse(center=(e.center[0] + x0, e.center[1] + y0), axes=e.axes, angle=e.angle)
    return SphereOutline(
        conic=e_full.conic,
        ellipse=e_full,
        edge_points=pts + np.array([x0, y0], dtype=np.float64),
        rms=float(final.rms),
        support=float(support),
    )


# --------------------------------------------------------------------------
# multi-camera rig
# --------------------------------------------------------------------------


def _Ks_from_params(P: np.ndarray, model: str) -> np.ndarray:
    """Batched :func:`_K_from_params`: (O, nK) -> (O, 3, 3)."""
    O = len(P)
    K = np.zeros((O, 3, 3))
    K[:, 2, 2] = 1.0
    if model == "square_pixels":
        K[:, 0, 0] = K[:, 1, 1] = P[:, 0]
        K[:, 0, 2], K[:, 1, 2] = P[:, 1], P[:, 2]
    elif model == "zero_skew":
        K[:, 0, 0], K[:, 1, 1], K[:, 0, 2], K[:, 1, 2] = P.T
    else:
        K[:, 0, 0], K[:, 1, 1], K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = P.T
    return K


def _obs_conics(rv, t, X, Kp, model, r) -> np.ndarray:
    """Outline conics (O, 3, 3) of spheres ``X`` (O, 3) (reference frame) seen by
    cameras with rotation vectors ``rv`` (O, 3), translations ``t`` (O, 3) and
    intrinsics params ``Kp`` (O, nK)."""
    from scipy.spatial.transform import Rotation

    R = Rotation.from_rotvec(rv).as_matrix()
    Xc = np.einsum("oij,oj->oi", R, X) + t
    Ki = np.linalg.inv(_Ks_from_params(Kp, model))
    return _outline_conics(Ki, Xc, r)


def _check_tracks(Ks, conic_tracks, edge_point_tracks):
    Ks = np.asarray(Ks, dtype=np.float64)
    if Ks.ndim != 3 or Ks.shape[1:] != (3, 3):
        raise ValueError(f"Ks must have shape (N, 3, 3), got {Ks.shape}")
    N = len(Ks)
    if N < 2:
        raise ValueError(f"a rig needs at least 2 cameras, got {N}")
    Ks = np.array([_check_K(K, f"Ks[{j}]") for j, K in enumerate(Ks)])
    if len(conic_tracks) != N:
        raise ValueError(f"conic_tracks must hold one track per camera: {N} cameras, {len(conic_tracks)} tracks")
    M = len(conic_tracks[0])
    if any(len(tr) != M for tr in conic_tracks):
        raise ValueError("every camera's conic track must have the same length (one entry per sphere position, None if unseen)")
    if M < 3:
        raise ValueError(f"rig extrinsics need at least 3 sphere positions, got {M}")
    conics = [[None if c is None else _check_conic(c, f"conic_tracks[{j}][{i}]") for i, c in enumerate(tr)] for j, tr in enumerate(conic_tracks)]
    edges = None
    if edge_point_tracks is not None:
        if len(edge_point_tracks) != N or any(len(tr) != M for tr in edge_point_tracks):
            raise ValueError("edge_point_tracks must have the same N x M layout as conic_tracks")
        edges = [[None if conics[j][i] is None else _check_points(edge_point_tracks[j][i], f"edge_point_tracks[{j}][{i}]") for i in range(M)] for j in range(N)]
    return Ks, conics, edges, N, M


def rig_extrinsics(
    Ks,
    conic_tracks,
    radius,
    *,
    edge_point_tracks=None,
    refine_intrinsics: bool = False,
    square_pixels: bool = False,
    zero_skew: bool = True,
    n_samples: int = 64,
    max_nfev: int = 100,
) -> RigExtrinsics:
    """Relative poses of N cameras that saw the same sphere at M positions.

    1. Per camera and position: the sphere centre in that camera's frame
       (:func:`sphere_centre`).
    2. Absolute orientation (Umeyama / Horn, rigid, no scale: the radius
       fixes it) of every camera's centres onto the reference camera's.
    3. Bundle adjustment over all poses (camera 0 fixed as the reference),
       all centres and, optionally, every camera's intrinsics, minimising the
       distances between the predicted outlines (forward model of
       :func:`outline_conic`) and the edge points — or, without edge points,
       ``n_samples`` points sampled on each measured outline.

    Parameters
    ----------
    Ks : (N, 3, 3) float64, intrinsics of the N >= 2 cameras (pixels)
    conic_tracks : N sequences of M (3, 3) conics (pixels), ``conic_tracks[j][i]``
        the outline of position ``i`` in camera ``j``, or None if not seen
    radius : float, the sphere's radius (sets the units of ``t`` and the centres)
    edge_point_tracks : optional, N sequences of M (n, 2) edge-point arrays (or None)
    refine_intrinsics : bool, also refine each camera's K (model set by
        ``square_pixels`` / ``zero_skew``)
    n_samples : int, points per outline when no edge points are given
    max_nfev : int, iteration cap of the bundle adjustment

    Returns
    -------
    RigExtrinsics (world frame = camera 0's frame).

    Raises
    ------
    ValueError
        Bad shapes; fewer than 2 cameras or 3 positions; a camera sharing
        fewer than 3 non-collinear positions with camera 0; a position seen
        by no camera.
    """
    r = _check_radius(radius)
    model = _model_name(square_pixels, zero_skew)
    Ks, conics, edges, N, M = _check_tracks(Ks, conic_tracks, edge_point_tracks)
    if int(n_samples) < 8:
        raise ValueError(f"n_samples must be at least 8, got {n_samples}")
    seen = np.array([[conics[j][i] is not None for i in range(M)] for j in range(N)])
    if not np.all(seen.any(axis=0)):
        raise ValueError(f"sphere position {int(np.flatnonzero(~seen.any(axis=0))[0])} is seen by no camera")
    Y = np.full((N, M, 3), np.nan)
    for j in range(N):
        for i in range(M):
            if seen[j, i]:
                Y[j, i] = sphere_centre(Ks[j], conics[j][i], r)
    R0 = np.zeros((N, 3, 3))
    t0 = np.zeros((N, 3))
    R0[0] = np.eye(3)
    for j in range(1, N):
        common = seen[0] & seen[j]
        if common.sum() < 3:
            raise ValueError(f"camera {j} shares only {int(common.sum())} sphere positions with camera 0; at least 3 are needed")
        try:
            R0[j], t0[j], _ = absolute_orientation(Y[0, common], Y[j, common])
        except ValueError:
            raise ValueError(f"the sphere positions camera {j} shares with camera 0 are collinear: its pose is undetermined") from None
    Xw = np.zeros((M, 3))
    for i in range(M):
        js = np.flatnonzero(seen[:, i])
        Xw[i] = np.mean([R0[j].T @ (Y[j, i] - t0[j]) for j in js], axis=0)

    # observations
    obs_j, obs_i, pts_l = [], [], []
    for j in range(N):
        for i in range(M):
            if not seen[j, i]:
                continue
            obs_j.append(j)
            obs_i.append(i)
            if edges is not None:
                pts_l.append(edges[j][i])
            else:
                pts_l.append(ellipse_from_conic(conics[j][i]).points(int(n_samples)))
    obs_j = np.array(obs_j)
    obs_i = np.array(obs_i)
    O = len(obs_j)
    pts = np.concatenate(pts_l)
    idx = np.concatenate([np.full(len(p), o) for o, p in enumerate(pts_l)])
    nK = len(_params_from_K(Ks[0], model))
    Kp0 = np.array([_params_from_K(_project_K(K, model), model) for K in Ks])
    npose = 6 * (N - 1)

    def unpack(x):
        pose = np.zeros((N, 6))
        pose[1:] = x[:npose].reshape(N - 1, 6)
        X = x[npose : npose + 3 * M].reshape(M, 3)
        Kp = x[npose + 3 * M :].reshape(N, nK) if refine_intrinsics else Kp0
        return pose, X, Kp

    def obs_args(x):
        pose, X, Kp = unpack(x)
        return pose[obs_j, :3], pose[obs_j, 3:], X[obs_i], Kp[obs_j]

    def fun(x):
        return sampson_with_jacobian(pts, idx, _obs_conics(*obs_args(x), model, r), jac=False)

    def jac(x):
        args = list(obs_args(x))
        C = _obs_conics(*args, model, r)
        _, J6 = sampson_with_jacobian(pts, idx, C)
        J = np.zeros((len(pts), len(x)))
        blocks = [(0, 3, 1e-7), (1, 3, 1e-7 * max(1.0, np.abs(args[1]).max())), (2, 3, 1e-7 * max(1.0, np.abs(args[2]).max()))]
        if refine_intrinsics:
            blocks.append((3, nK, None))
        for a, width, h in blocks:
            for k in range(width):
                hk = h if h is not None else 1e-6 * max(1.0, np.abs(args[3][:, k]).max())
                ap = [v.copy() for v in args]
                am = [v.copy() for v in args]
                ap[a][:, k] += hk
                am[a][:, k] -= hk
                dC = (conic_to_vec6(_obs_conics(*ap, model, r)) - conic_to_vec6(_obs_conics(*am, model, r))) / (2 * hk)
                col_vals = np.einsum("nc,nc->n", J6, dC[idx])
                if a in (0, 1):
                    cols = np.where(obs_j[idx] > 0, 6 * (obs_j[idx] - 1) + 3 * a + k, -1)
                elif a == 2:
                    cols = npose + 3 * obs_i[idx] + k
                else:
                    cols = npose + 3 * M + nK * obs_j[idx] + k
                ok = cols >= 0
                J[np.flatnonzero(ok), cols[ok]] = col_vals[ok]
        return J

    x0 = [np.concatenate([rotvec_from_rotation(R0[j]), t0[j]]) for j in range(1, N)]
    x0 = np.concatenate(x0 + [Xw.ravel()] + ([Kp0.ravel()] if refine_intrinsics else []))
    sol = scipy.optimize.least_squares(fun, x0, jac=jac, method="lm", x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=max_nfev)
    pose, X, Kp = unpack(sol.x)
    R = np.array([rotation_from_rotvec(p[:3]) for p in pose])
    t = pose[:, 3:].copy()
    Kout = np.array([_K_from_params(k, model) for k in Kp]) if refine_intrinsics else Ks.copy()
    C = _obs_conics(*obs_args(sol.x), model, r)
    res = np.full((N, M), np.nan)
    sq, cnt = 0.0, 0
    for o in range(O):
        d = ellipse_distance(pts[idx == o], ellipse_from_conic(C[o]))
        res[obs_j[o], obs_i[o]] = np.sqrt(np.mean(d * d))
        sq += float(d @ d)
        cnt += len(d)
    return RigExtrinsics(R=R, t=t, centres=X, Ks=Kout, residuals=res, rms=float(np.sqrt(sq / cnt)), R_init=R0, t_init=t0)
