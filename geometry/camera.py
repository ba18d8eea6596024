"""Pinhole cameras: K, R, t <-> P, plane homographies, the IAC, and the
pan/tilt/roll/focal parametrisation of a broadcast camera on a tripod.

Convention (OpenCV): a world point ``X`` (3,) projects to ``x ~ K (R X + t)``
with ``R = R_cam_from_world``; the camera looks down +z, image x right, y
down, pixel centres at integer coordinates.
``K = [[f, s, cx], [0, a f, cy], [0, 0, 1]]``. The world is the pitch frame
(metres, origin at the centre spot, X along the touchlines, Y away from the
main camera, Z up; the pitch is Z = 0), so ``H_img_from_pitch = K [r1 r2 t]``.

Optional radial distortion ``dist = (k1, k2, ...)`` follows OpenCV's model on
normalised coordinates: ``x_d = x_u (1 + k1 r^2 + k2 r^4 + ...)``.

Round trips of the core transforms:

>>> K = intrinsic_matrix(1200.0, 640.0, 360.0)
>>> R = rotation_from_ptr(0.2, 0.3, 0.01)
>>> t = np.array([1.0, 2.0, 60.0])
>>> K2, R2, t2 = KRt_from_P(P_from_KRt(K, R, t))
>>> bool(np.allclose(K2, K) and np.allclose(R2, R) and np.allclose(t2, t))
True
>>> bool(np.allclose(rotation_from_ptr(*ptr_from_rotation(R)), R))
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
from scipy.spatial.transform import Rotation

from geometry.conics import normalize_conic
from geometry.lines import skew

__all__ = [
    "Camera",
    "PTZ",
    "intrinsic_matrix",
    "P_from_KRt",
    "KRt_from_P",
    "camera_from_homography",
    "camera_turned",
    "camera_near_homography",
    "camera_at_centre",
    "HomographyPoses",
    "decompose_homographies",
    "homographies_from_parallel_lines",
    "homographies_from_parallel_lines_batch",
    "iac",
    "K_from_iac",
    "rotation_from_ptr",
    "ptr_from_rotation",
    "camera_from_ptz",
    "ptz_from_camera",
    "distort_normalized",
    "undistort_normalized",
]

# Camera axes in the world at pan = tilt = roll = 0: image x along +X, image y
# along -Z (down), optical axis along +Y (toward the far touchline).
_R_BASE = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def intrinsic_matrix(f: float, cx: float, cy: float, aspect: float = 1.0, skew: float = 0.0) -> np.ndarray:
    """Calibration matrix ``[[f, skew, cx], [0, aspect f, cy], [0, 0, 1]]`` (3, 3) float64, pixels."""
    if not (np.isfinite(f) and f > 0):
        raise ValueError(f"focal length must be positive and finite, got {f}")
    if not (np.isfinite(aspect) and aspect > 0):
        raise ValueError(f"aspect ratio must be positive, got {aspect}")
    return np.array([[f, skew, cx], [0.0, aspect * f, cy], [0.0, 0.0, 1.0]], dtype=np.float64)


def _check_K(K) -> np.ndarray:
    K = np.asarray(K, dtype=np.float64)
    if K.shape != (3, 3):
        raise ValueError(f"K must be 3x3, got {K.shape}")
    if not np.all(np.isfinite(K)):
        raise ValueError("K has non-finite entries")
    if abs(K[1, 0]) > 1e-9 * abs(K[1, 1]) or abs(K[2, 0]) > 1e-12 or abs(K[2, 1]) > 1e-12 or K[0, 0] <= 0 or K[1, 1] <= 0:
        raise ValueError("K must be upper triangular with positive focal lengths")
    if abs(K[2, 2] - 1.0) > 1e-9:
        raise ValueError("K must have K[2, 2] == 1")
    return K


def _check_R(R) -> np.ndarray:
    R = np.asarray(R, dtype=np.float64)
    if R.shape != (3, 3):
        raise ValueError(f"R must be a finite 3x3 matrix, got shape {R.shape}")
    # on plain floats (cameras are made and taken apart several times a frame)
    a, b, c = R.tolist()
    if not all(map(math.isfinite, a + b + c)):
        raise ValueError(f"R must be a finite 3x3 matrix, got shape {R.shape}")
    aa, bb, cc = a[0] * a[0] + a[1] * a[1] + a[2] * a[2], b[0] * b[0] + b[1] * b[1] + b[2] * b[2], c[0] * c[0] + c[1] * c[1] + c[2] * c[2]
    ab, ac, bc = a[0] * b[0] + a[1] * b[1] + a[2] * b[2], a[0] * c[0] + a[1] * c[1] + a[2] * c[2], b[0] * c[0] + b[1] * c[1] + b[2] * c[2]
    det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])
    if not max(abs(aa - 1.0), abs(bb - 1.0), abs(cc - 1.0), abs(ab), abs(ac), abs(bc)) <= 1e-6 or det < 0:  # R R^T = I, det +1
        raise ValueError("R must be a rotation (orthonormal, det +1)")
    return R


@dataclass(frozen=True)
class Camera:
    """A pinhole camera ``x ~ K (R X + t)`` (OpenCV convention), world = pitch frame.

    Attributes
    ----------
    K : (3, 3) float64, intrinsics in pixels
    R : (3, 3) float64, ``R_cam_from_world``
    t : (3,) float64, ``t_cam_from_world`` (metres): the world origin in camera coordinates
    dist : tuple of float, radial coefficients ``(k1, k2, ...)``; empty for none
    """

    K: np.ndarray
    R: np.ndarray
    t: np.ndarray
    dist: tuple = field(default=())

    def __post_init__(self) -> None:
        K = _check_K(self.K)
        R = _check_R(self.R)
        t = np.asarray(self.t, dtype=np.float64).reshape(-1)
        if t.shape != (3,) or not np.all(np.isfinite(t)):
            raise ValueError(f"t must be a finite (3,) vector, got {t.shape}")
        dist = tuple(float(k) for k in self.dist)
        if not all(np.isfinite(dist)):
            raise ValueError("distortion coefficients must be finite")
        object.__setattr__(self, "K", K.copy())
        object.__setattr__(self, "R", R.copy())
        object.__setattr__(self, "t", t.copy())
        object.__setattr__(self, "dist", dist)

    @classmethod
    def trusted(cls, K: np.ndarray, R: np.ndarray, t: np.ndarray, dist: tuple = ()) -> "Camera":
        """Build without validation, for hot loops whose inputs are valid by
        construction (K upper triangular, R a rotation): float64 arrays of the
        right shapes; the arrays are not copied."""
        cam = object.__new__(cls)
        object.__setattr__(cam, "K", K)
        object.__setattr__(cam, "R", R)
        object.__setattr__(cam, "t", t)
        object.__setattr__(cam, "dist", tuple(float(k) for k in dist))
        return cam

    # --- derived quantities -------------------------------------------------
    @property
    def P(self) -> np.ndarray:
        """(3, 4) projection matrix ``K [R | t]`` (no distortion)."""
        return P_from_KRt(self.K, self.R, self.t)

    @property
    def center(self) -> np.ndarray:
        """(3,) camera centre in the world frame, ``-R^T t`` (metres)."""
        return -self.R.T @ self.t

    @property
    def focal(self) -> float:
        """Horizontal focal length ``K[0, 0]`` in pixels."""
        return float(self.K[0, 0])

    @property
    def principal_point(self) -> np.ndarray:
        """(2,) principal point ``(cx, cy)`` in pixels."""
        return self.K[:2, 2].copy()

    @property
    def H_img_from_pitch(self) -> np.ndarray:
        """(3, 3) ``K [r1 r2 t]``: pitch (X, Y, 1) -> pixels (ignores distortion)."""
        return self.K @ np.column_stack([self.R[:, 0], self.R[:, 1], self.t])

    @property
    def horizon(self) -> np.ndarray:
        """(3,) vanishing line of the pitch plane in the image, ``K^-T R e3``, normalised
        (a^2 + b^2 = 1, sign such that the pitch's image has positive values)."""
        # for a pitch point x ~ K (R X + t) with depth w > 0: (K^-T R e3) . x = -C_z w,
        # so the minus sign puts the pitch (seen from above) on the positive side
        l = -np.linalg.solve(self.K.T, self.R[:, 2])
        return l / np.hypot(l[0], l[1])

    # --- projection -----------------------------------------------------------
    def to_camera(self, X) -> np.ndarray:
        """World points (N, 3) -> camera coordinates (N, 3), metres."""
        X = np.asarray(X, dtype=np.float64)
        if X.ndim != 2 or X.shape[1] != 3:
            raise ValueError(f"X must have shape (N, 3), got {X.shape}")
        return X @ self.R.T + self.t

    def project(self, X) -> np.ndarray:
        """Project world points (N, 3) to pixels (N, 2), applying ``dist``.

        Points behind the camera (z <= 0) come out as NaN; use :meth:`in_front`.
        So do points beyond the radius where the distortion polynomial stops
        growing (``d r_d / d r <= 0``): there the model folds far-off points back
        into the image, which no lens does.
        """
        Xc = self.to_camera(X)
        z = Xc[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            xn = Xc[:, :2] / np.where(z > 0, z, np.nan)[:, None]
        if self.dist:
            r2 = (xn * xn).sum(axis=1)
            slope = np.ones_like(r2)
            for k, c in enumerate(self.dist, start=1):
                slope = slope + (2 * k + 1) * c * r2**k
            xn = distort_normalized(xn, self.dist)
            xn[~(slope > 0)] = np.nan
        return xn @ self.K[:2, :2].T + self.K[:2, 2]

    def project_pitch(self, XY) -> np.ndarray:
        """Project pitch points (N, 2) (Z = 0, metres) to pixels (N, 2)."""
        XY = np.asarray(XY, dtype=np.float64)
        if XY.ndim != 2 or XY.shape[1] != 2:
            raise ValueError(f"XY must have shape (N, 2), got {XY.shape}")
        return self.project(np.column_stack([XY, np.zeros(len(XY))]))

    def in_front(self, X) -> np.ndarray:
        """(N,) bool: world points (N, 3) with positive depth."""
        return self.to_camera(X)[:, 2] > 0

    def backproject_to_pitch(self, pts) -> np.ndarray:
        """Intersect the rays of pixels (N, 2) with the pitch plane Z = 0.

        Distortion is removed first. Returns (N, 2) pitch coordinates (metres);
        rays that miss the pitch in front of the camera (at or above the
        horizon) give NaN rows.
        """
        p = np.asarray(pts, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 2:
            raise ValueError(f"pts must have shape (N, 2), got {p.shape}")
        xn = (p - self.K[:2, 2]) @ np.linalg.inv(self.K[:2, :2]).T
        if self.dist:
            xn = undistort_normalized(xn, self.dist)
        rays_cam = np.column_stack([xn, np.ones(len(xn))])
        rays_w = rays_cam @ self.R  # R^T d, as rows
        c = self.center
        with np.errstate(divide="ignore", invalid="ignore"):
            s = -c[2] / rays_w[:, 2]
        out = c[:2] + s[:, None] * rays_w[:, :2]
        out[~(s > 0)] = np.nan
        return out

    # --- serialisation ----------------------------------------------------------
    def to_dict(self) -> dict:
        """JSON-ready dict with ``K``, ``R``, ``t``, ``dist`` and ``H`` (docs/formats.md)."""
        H = self.H_img_from_pitch
        H = H / H[2, 2] if abs(H[2, 2]) > 1e-12 else H / np.linalg.norm(H)
        return {
            "K": self.K.tolist(),
            "R": self.R.tolist(),
            "t": self.t.tolist(),
            "dist": list(self.dist),
            "H": H.tolist(),
        }

    @classmethod
    def from_dict(cls, d: dict) -> "Camera":
        """Inverse of :meth:`to_dict` (``H`` is ignored; ``dist`` optional)."""
        try:
            return cls(K=np.array(d["K"], float), R=np.array(d["R"], float), t=np.array(d["t"], float), dist=tuple(d.get("dist") or ()))
        except (KeyError, TypeError) as exc:
            raise ValueError(f"camera record lacks K, R or t: {exc}") from None


@dataclass(frozen=True)
class PTZ:
    """Pan, tilt, roll (radians) and focal length (pixels) of a camera on a tripod.

    ``pan`` turns the optical axis from +Y toward +X about the world Z axis;
    ``tilt`` > 0 looks down; ``roll`` turns the image about the optical axis
    (image x toward image y). See :func:`rotation_from_ptr`.
    """

    pan: float
    tilt: float
    roll: float
    f: float


def P_from_KRt(K, R, t) -> np.ndarray:
    """``P = K [R | t]``: (3, 3), (3, 3), (3,) -> (3, 4) float64."""
    K = np.asarray(K, dtype=np.float64)
    R = np.asarray(R, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64).reshape(3)
    return K @ np.column_stack([R, t])


def KRt_from_P(P) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Decompose a finite projection matrix (3, 4) into ``K`` (K[2,2] = 1, positive
    diagonal), a rotation ``R`` and ``t`` (RQ decomposition)."""
    P = np.asarray(P, dtype=np.float64)
    if P.shape != (3, 4):
        raise ValueError(f"P must be 3x4, got {P.shape}")
    M = P[:, :3]
    if not abs(np.linalg.det(M)) > 1e-12 * np.linalg.norm(M) ** 3:
        raise ValueError("P has a singular left 3x3 block (camera at infinity)")
    K, R = scipy.linalg.rq(M)
    S = np.diag(np.sign(np.diag(K)))
    K, R = K @ S, S @ R
    t = np.linalg.solve(K, P[:, 3])
    if np.linalg.det(R) < 0:
        R, t = -R, -t
    scale = K[2, 2]
    return K / scale, R, t


def iac(K) -> np.ndarray:
    """Image of the absolute conic ``omega = K^-T K^-1`` (3, 3), normalised conic."""
    Ki = np.linalg.inv(_check_K(K))
    return normalize_conic(Ki.T @ Ki)


def K_from_iac(omega) -> np.ndarray:
    """Calibration matrix from the IAC (3, 3) by Cholesky: ``omega ~ K^-T K^-1``.

    Raises ``ValueError`` if ``omega`` is not (a multiple of) a positive-definite matrix.
    """
    w = np.asarray(omega, dtype=np.float64)
    if w.shape != (3, 3):
        raise ValueError(f"omega must be 3x3, got {w.shape}")
    w = 0.5 * (w + w.T)
    if w[2, 2] < 0 or np.trace(w) < 0:
        w = -w
    try:
        L = np.linalg.cholesky(w)  # w = L L^T, and w = K^-T K^-1 so K^-T = L up to scale
    except np.linalg.LinAlgError:
        raise ValueError("omega is not positive definite: not the image of the absolute conic") from None
    K = np.linalg.inv(L.T)
    return K / K[2, 2]


def _inverse_focal_sq(H: np.ndarray, cx: float, cy: float, aspect: float) -> np.ndarray:
    """``w = 1 / f^2`` (K,) of pitch-to-image homographies H (K, 3, 3) from the two
    orthogonality constraints of ``r1``, ``r2`` on the IAC ``diag(w, w, 1)`` (least
    squares); NaN where unobservable."""
    T = np.array([[1.0, 0.0, -cx], [0.0, 1.0 / aspect, -cy / aspect], [0.0, 0.0, 1.0]])
    G = T @ H
    G = G / np.linalg.norm(G, axis=(1, 2), keepdims=True)
    g1, g2 = G[:, :, 0], G[:, :, 1]
    # omega = diag(w, w, 1):  g1^T omega g2 = 0, g1^T omega g1 = g2^T omega g2
    a1, b1 = g1[:, 0] * g2[:, 0] + g1[:, 1] * g2[:, 1], g1[:, 2] * g2[:, 2]
    a2, b2 = g1[:, 0] ** 2 + g1[:, 1] ** 2 - g2[:, 0] ** 2 - g2[:, 1] ** 2, g1[:, 2] ** 2 - g2[:, 2] ** 2
    den = a1 * a1 + a2 * a2
    ok = den >= 1e-300
    return np.where(ok, -(a1 * b1 + a2 * b2) / np.where(ok, den, 1.0), np.nan)


_HOMOGRAPHY_FAILURES = (
    None,
    "homography is singular",
    "focal length unobservable from this homography",
    "no positive focal length fits this homography (fronto-parallel or inconsistent)",
    "homography is a mirror image: camera would be below the pitch",
    "camera below the pitch: this homography does not see the pitch from above",
)


@dataclass(frozen=True)
class HomographyPoses:
    """Cameras of K pitch-to-image homographies (:func:`decompose_homographies`).

    Attributes
    ----------
    focal : (K,) pixels (1 where undefined)
    R : (K, 3, 3) ``R_cam_from_world``
    t : (K, 3)
    centre : (K, 3) camera centres, pitch frame (metres)
    status : (K,) int, 0 for a valid camera, else the index of the failure in
        ``_HOMOGRAPHY_FAILURES`` (singular, unobservable or no positive focal
        length, mirror image, camera below the pitch)
    """

    focal: np.ndarray
    R: np.ndarray
    t: np.ndarray
    centre: np.ndarray
    status: np.ndarray

    @property
    def ok(self) -> np.ndarray:
        """(K,) bool: the valid cameras."""
        return self.status == 0


def decompose_homographies(H_img_from_pitch, principal_point, *, aspect: float = 1.0) -> HomographyPoses:
    """:func:`camera_from_homography` for K homographies (K, 3, 3) at once: a
    failure is a status per homography, not an exception (for screening the
    many hypotheses of a line initialiser)."""
    H = np.asarray(H_img_from_pitch, dtype=np.float64).reshape(-1, 3, 3)
    k = len(H)
    cx, cy = np.asarray(principal_point, dtype=np.float64)
    status = np.zeros(k, np.int64)
    sv = np.linalg.svd(H, compute_uv=False)
    status[sv[:, -1] < 1e-10 * sv[:, 0]] = 1
    w = _inverse_focal_sq(H, cx, cy, aspect)
    status[(status == 0) & np.isnan(w)] = 2
    with np.errstate(invalid="ignore"):
        status[(status == 0) & ~(w > 0)] = 3
    f = np.where(status == 0, 1.0 / np.sqrt(np.where(status == 0, w, 1.0)), 1.0)
    # [r1 r2 t] = K^-1 H / lambda
    M = np.empty_like(H)
    M[:, 0] = (H[:, 0] - cx * H[:, 2]) / f[:, None]
    M[:, 1] = (H[:, 1] - cy * H[:, 2]) / (aspect * f[:, None])
    M[:, 2] = H[:, 2]
    lam = 0.5 * (np.linalg.norm(M[:, :, 0], axis=1) + np.linalg.norm(M[:, :, 1], axis=1))
    M /= np.where(lam > 0, lam, 1.0)[:, None, None]
    M *= np.where(M[:, 2, 2] < 0, -1.0, 1.0)[:, None, None]
    r1, r2, t = M[:, :, 0], M[:, :, 1], M[:, :, 2]
    Rm = np.stack([r1, r2, np.cross(r1, r2)], axis=2)
    U, _, Vt = np.linalg.svd(Rm)
    R = U @ Vt
    status[(status == 0) & (np.linalg.det(R) < 0)] = 4
    centre = -np.einsum("kji,kj->ki", R, t)  # -R^T t
    status[(status == 0) & ~(centre[:, 2] > 0)] = 5
    return HomographyPoses(focal=f, R=R, t=np.ascontiguousarray(t), centre=centre, status=status)


def camera_from_homography(H_img_from_pitch, principal_point, *, aspect: float = 1.0) -> Camera:
    """Decompose a pitch-to-image homography into ``K``, ``R``, ``t``.

    Assumes zero skew, known aspect ratio and principal point; solves the focal
    length from the two orthogonality constraints of ``r1``, ``r2`` on the IAC
    (least squares in ``1/f^2``), then ``[r1 r2 t] = K^-1 H / lambda``.

    Parameters
    ----------
    H_img_from_pitch : (3, 3) maps pitch (X, Y, 1) in metres to pixels
    principal_point : (2,) pixels
    aspect : float, ``fy / fx``

    Returns
    -------
    Camera (pitch in front of the camera, camera above it).

    Raises
    ------
    ValueError
        Singular ``H``; no positive focal length (e.g. a fronto-parallel view,
        where f is unobservable); or the camera would be below the pitch.
    """
    H = np.asarray(H_img_from_pitch, dtype=np.float64)
    if H.shape != (3, 3) or not np.all(np.isfinite(H)):
        raise ValueError("H_img_from_pitch must be a finite 3x3 matrix")
    poses = decompose_homographies(H[None], principal_point, aspect=aspect)
    if poses.status[0]:
        raise ValueError(_HOMOGRAPHY_FAILURES[poses.status[0]])
    cx, cy = np.asarray(principal_point, dtype=np.float64)
    return Camera(K=intrinsic_matrix(float(poses.focal[0]), cx, cy, aspect), R=poses.R[0], t=poses.t[0])


def camera_near_homography(H_img_from_pitch, principal_point, XY, *, aspect: float = 1.0) -> Camera:
    """The camera (known principal point, square pixels up to ``aspect``, no
    skew) whose pitch-to-image map is closest to a homography on given pitch points.

    A homography from four line correspondences has eight degrees of freedom,
    a camera with a known principal point seven: :func:`camera_from_homography`
    reads the camera off two columns of ``H`` and can land far from the
    picture ``H`` draws. This fits the camera to that picture instead: it
    minimises the pixel distances between ``K [r1 r2 t] (X, Y, 1)`` and
    ``H (X, Y, 1)`` over the points ``XY`` (Levenberg-Marquardt on rotation
    vector, centre and log focal, from the decomposition).

    Parameters
    ----------
    H_img_from_pitch : (3, 3) pitch (X, Y, 1), metres -> pixels
    principal_point : (2,) pixels
    XY : (N, 2) pitch points, metres, N >= 4 (e.g. those ``H`` maps into the frame)
    aspect : float, ``fy / fx``

    Returns
    -------
    Camera

    Raises
    ------
    ValueError
        As :func:`camera_from_homography`, or fewer than 4 points.
    """
    import scipy.optimize
    from scipy.spatial.transform import Rotation

    XY = np.asarray(XY, dtype=np.float64).reshape(-1, 2)
    if len(XY) < 4:
        raise ValueError(f"need at least 4 pitch points, got {len(XY)}")
    H = np.asarray(H_img_from_pitch, dtype=np.float64)
    cam0 = camera_from_homography(H, principal_point, aspect=aspect)
    Xh = np.column_stack([XY, np.ones(len(XY))]) @ H.T
    target = Xh[:, :2] / Xh[:, 2:]
    X3 = np.column_stack([XY, np.zeros(len(XY))])
    cx, cy = np.asarray(principal_point, dtype=np.float64)
    rv0 = Rotation.from_matrix(cam0.R).as_rotvec()
    fit = _HomographyCameraFit(X3, target, cx, cy, aspect)
    p0 = np.concatenate([rv0, cam0.center, [math.log(cam0.focal)]])
    with np.errstate(all="ignore"):
        r0 = fit.residuals(p0)
    if not np.all(np.isfinite(r0)):
        return cam0
    with np.errstate(all="ignore"):
        sol = scipy.optimize.least_squares(fit.residuals, p0, jac=fit.jacobian, method="lm", max_nfev=200)
    if not (np.all(np.isfinite(sol.x)) and sol.cost <= 0.5 * float(r0 @ r0)):
        return cam0
    R = Rotation.from_rotvec(sol.x[:3]).as_matrix()
    return Camera.trusted(intrinsic_matrix(math.exp(sol.x[6]), cx, cy, aspect), R, -R @ sol.x[3:6])


def rotation_with_derivatives(rotvec) -> tuple[np.ndarray, np.ndarray]:
    """The rotation matrix of a rotation vector and its derivatives.

    Parameters
    ----------
    rotvec : (3,) rotation vector v (axis times angle, radians)

    Returns
    -------
    (R (3, 3), dR (3, 3, 3)): ``dR[i] = dR / dv_i``, by the closed form of
    Gallego and Yezzi (2015), ``(v_i [v]x + [v x (I - R) e_i]x) R / |v|^2``
    (``[e_i]x`` at v = 0).

    >>> R, dR = rotation_with_derivatives([0.1, -0.2, 0.3])
    >>> e = 1e-6
    >>> num = (Rotation.from_rotvec([0.1 + e, -0.2, 0.3]).as_matrix() - Rotation.from_rotvec([0.1 - e, -0.2, 0.3]).as_matrix()) / (2 * e)
    >>> bool(np.allclose(dR[0], num, atol=1e-8))
    True
    """
    v = np.asarray(rotvec, dtype=np.float64).reshape(3)
    R = Rotation.from_rotvec(v).as_matrix()
    n2 = float(v @ v)
    E = np.eye(3)
    if n2 < 1e-24:
        return R, skew(E)
    IR = E - R
    dR = (v[:, None, None] * skew(v) + skew(np.cross(v, IR.T))) @ R / n2
    return R, dR


class _HomographyCameraFit:
    """:func:`camera_near_homography`'s residuals (2N,: the pixels of the
    pitch points ``X`` (N, 3) through the camera, less ``target`` (N, 2), u
    and v of each point in turn) and their Jacobian (2N, 7) in ``p``: a
    rotation vector (3,), the centre (3,) metres and the log focal length,
    at the principal point (``cx``, ``cy``) and ``aspect``. The rotation's
    derivative: :func:`rotation_with_derivatives`."""

    def __init__(self, X: np.ndarray, target: np.ndarray, cx: float, cy: float, aspect: float):
        self.X, self.target, self.cx, self.cy, self.aspect = X, target, cx, cy, aspect

    def _camera_points(self, p):
        R, dR = rotation_with_derivatives(p[:3])
        D = self.X - p[3:6]  # (N, 3) from the centre
        return R, dR, D, D @ R.T  # camera-frame points

    def residuals(self, p) -> np.ndarray:
        _, _, _, Xc = self._camera_points(p)
        f = math.exp(p[6])
        u = f * Xc[:, 0] / Xc[:, 2] + self.cx
        v = self.aspect * f * Xc[:, 1] / Xc[:, 2] + self.cy
        return (np.column_stack([u, v]) - self.target).ravel()

    def jacobian(self, p) -> np.ndarray:
        R, dR, D, Xc = self._camera_points(p)
        f = math.exp(p[6])
        a, b, c = Xc[:, 0], Xc[:, 1], Xc[:, 2]
        dXc = np.empty((len(D), 6, 3))  # d(camera-frame point) / d(rotation vector, centre)
        dXc[:, :3] = np.einsum("kij,nj->nki", dR, D)
        dXc[:, 3:] = -R.T[None]  # (row k: d/dC_k, the column -R[:, k])
        du = f * (dXc[..., 0] / c[:, None] - a[:, None] * dXc[..., 2] / (c * c)[:, None])
        dv = self.aspect * f * (dXc[..., 1] / c[:, None] - b[:, None] * dXc[..., 2] / (c * c)[:, None])
        J = np.empty((2 * len(D), 7))
        J[0::2, :6], J[1::2, :6] = du, dv
        J[0::2, 6], J[1::2, 6] = f * a / c, self.aspect * f * b / c
        return J


def camera_turned(camera: Camera, rotvec, dlogf: float, center, dist: tuple | None = None) -> Camera:
    """``camera`` turned by the rotation vector ``rotvec`` (3,) about the pitch
    frame's axes (``R' = exp(rotvec) R``), zoomed by ``exp(dlogf)`` (its
    focal lengths and skew scaled, the principal point kept) and placed at
    ``center`` (3,) metres; lens terms ``dist`` (None: the camera's own)."""
    R = Rotation.from_rotvec(np.asarray(rotvec, np.float64).reshape(3)).as_matrix() @ camera.R
    K = camera.K.copy()
    s = math.exp(dlogf)
    K[0, 0] *= s
    K[1, 1] *= s
    K[0, 1] *= s
    C = np.asarray(center, np.float64)
    return Camera.trusted(K, R, -R @ C, camera.dist if dist is None else tuple(dist))


def camera_at_centre(camera: Camera, center, XY) -> Camera:
    """The camera at another centre whose picture of given pitch points is
    closest to ``camera``'s: the same principal point, aspect, skew and
    distortion; rotation and focal length fitted.

    A view of a distant part of the pitch is drawn almost the same from
    anywhere along its line of sight, the focal length growing with the
    distance (the depth-zoom ambiguity of a long lens). A camera that a
    single frame places 30 m too far back along that line, moved to the
    tripod's known centre, keeps its picture rather than its rotation: this
    minimises the pixel distances between the two cameras' projections of
    ``XY`` over rotation and log focal length (Levenberg-Marquardt), from the
    rotation that turns the optical axis onto the points' centroid and the
    focal length scaled by the ratio of the distances to it.

    Parameters
    ----------
    camera : Camera, the picture to keep
    center : (3,) metres, pitch frame: the new camera's centre
    XY : (N, 2) pitch points, metres, N >= 3 (e.g. points the camera sees)

    Returns
    -------
    Camera with centre ``center``

    Raises
    ------
    ValueError
        With fewer than 3 points, a centre that is not finite, or points
        behind either centre (along ``camera``'s optical axis).
    """
    import scipy.optimize
    from scipy.spatial.transform import Rotation

    c0 = np.asarray(center, dtype=np.float64).reshape(-1)
    if c0.shape != (3,) or not np.all(np.isfinite(c0)):
        raise ValueError(f"center must be a finite (3,) vector, got {c0}")
    XY = np.asarray(XY, dtype=np.float64).reshape(-1, 2)
    if len(XY) < 3:
        raise ValueError(f"need at least 3 pitch points, got {len(XY)}")
    X3 = np.column_stack([XY, np.zeros(len(XY))])
    if not (np.all(camera.in_front(X3)) and np.all((X3 - c0) @ camera.R[2] > 0)):
        raise ValueError("the pitch points must lie in front of both centres")
    target = camera.project(X3)
    # start: the optical axis turned onto the same pitch point, f by the distances
    c1 = camera.center
    g = X3.mean(axis=0)
    a1 = (g - c1) / np.linalg.norm(g - c1)
    a0 = (g - c0) / np.linalg.norm(g - c0)
    turn, _ = Rotation.align_vectors(a1[None], a0[None])  # takes a0 onto a1
    R0 = camera.R @ turn.as_matrix()
    p0 = np.array([0.0, 0.0, 0.0, math.log(camera.focal * np.linalg.norm(g - c0) / np.linalg.norm(g - c1))])
    K = camera.K
    shape = K / K[0, 0]  # (aspect and skew kept as ratios to f)
    shape[:, 2] = 0.0

    def cam(p):
        R = Rotation.from_rotvec(p[:3]).as_matrix() @ R0
        Kp = shape * math.exp(p[3])
        Kp[:, 2] = K[:, 2]
        return Camera.trusted(Kp, R, -R @ c0, camera.dist)

    def residual(p):
        return (cam(p).project(X3) - target).ravel()

    sol = scipy.optimize.least_squares(residual, p0, method="lm", max_nfev=200)
    return cam(sol.x if np.all(np.isfinite(sol.x)) else p0)


def rotation_from_ptr(pan: float, tilt: float, roll: float) -> np.ndarray:
    """``R_cam_from_world`` (3, 3) for pan, tilt, roll (radians).

    ``R = Rz(roll) Rx(tilt) R0 Rz(pan)`` where ``R0`` looks along +Y with image
    y pointing down (-Z). The optical axis in the world is
    ``(sin(pan) cos(tilt), cos(pan) cos(tilt), -sin(tilt))``.
    """
    cp, sp = np.cos(pan), np.sin(pan)
    ct, st = np.cos(tilt), np.sin(tilt)
    cr, sr = np.cos(roll), np.sin(roll)
    Rz_pan = np.array([[cp, -sp, 0.0], [sp, cp, 0.0], [0.0, 0.0, 1.0]])
    Rx_tilt = np.array([[1.0, 0.0, 0.0], [0.0, ct, -st], [0.0, st, ct]])
    Rz_roll = np.array([[cr, -sr, 0.0], [sr, cr, 0.0], [0.0, 0.0, 1.0]])
    # (the matrix product as it is, not written out: synthetic clips' exact truth
    # is made with it, and the last bits of their committed cameras must not move)
    return Rz_roll @ Rx_tilt @ _R_BASE @ Rz_pan


def ptr_from_rotation(R) -> tuple[float, float, float]:
    """Inverse of :func:`rotation_from_ptr`: ``(pan, tilt, roll)`` radians, tilt in [-pi/2, pi/2]."""
    (r00, r01, _), (r10, r11, _), (r20, r21, r22) = _check_R(R).tolist()
    pan = math.atan2(r20, r21)
    tilt = math.atan2(-r22, math.hypot(r20, r21))
    # roll: R times the inverse of Rx(tilt) R_BASE Rz(pan), whose first row is (cos pan, -sin pan, 0)
    cp, sp = math.cos(pan), math.sin(pan)
    roll = math.atan2(r10 * cp - r11 * sp, r00 * cp - r01 * sp)
    return pan, tilt, roll


def camera_from_ptz(center, ptz: PTZ, principal_point, *, dist: tuple = ()) -> Camera:
    """Camera with centre ``center`` (3,) metres in the pitch frame, orientation and
    focal length from ``ptz``, square pixels and the given principal point (2,)."""
    c = np.asarray(center, dtype=np.float64)
    if c.shape != (3,):
        raise ValueError(f"center must be (3,), got {c.shape}")
    R = rotation_from_ptr(ptz.pan, ptz.tilt, ptz.roll)
    K = intrinsic_matrix(ptz.f, principal_point[0], principal_point[1])
    if not (np.all(np.isfinite(c)) and np.all(np.isfinite(K)) and all(np.isfinite(dist))):
        raise ValueError("camera_from_ptz needs finite centre, angles, focal length and distortion")
    return Camera.trusted(K, R, -R @ c, tuple(dist))  # valid by construction


def ptz_from_camera(cam: Camera) -> tuple[np.ndarray, PTZ]:
    """``(center (3,), PTZ)`` of a camera (inverse of :func:`camera_from_ptz`)."""
    pan, tilt, roll = ptr_from_rotation(cam.R)
    return cam.center, PTZ(pan=pan, tilt=tilt, roll=roll, f=cam.focal)


def distort_normalized(xn, dist) -> np.ndarray:
    """Apply radial distortion to normalised coordinates (N, 2): ``x (1 + k1 r^2 + k2 r^4 + ...)``."""
    xn = np.asarray(xn, dtype=np.float64)
    r2 = (xn * xn).sum(axis=1)
    factor = np.ones_like(r2)
    rp = np.ones_like(r2)
    for k in dist:
        rp = rp * r2
        factor = factor + k * rp
    return xn * factor[:, None]


def undistort_normalized(xd, dist, iterations: int = 20) -> np.ndarray:
    """Invert :func:`distort_normalized` (N, 2) by fixed-point iteration (exact for
    the mild distortion of broadcast lenses)."""
    xd = np.asarray(xd, dtype=np.float64)
    xu = xd.copy()
    for _ in range(iterations):
        r2 = (xu * xu).sum(axis=1)
        factor = np.ones_like(r2)
        rp = np.ones_like(r2)
        for k in dist:
            rp = rp * r2
            factor = factor + k * rp
        xu = xd / factor[:, None]
    return xu


def homographies_from_parallel_lines(lines, values, transversal, value: float, principal_point, *, axis: int) -> np.ndarray:
    """Plane-to-image homographies of a camera with square pixels and a known
    principal point from three parallel plane lines and one across them.

    The plane lines are ``X[axis] = values[i]`` (three, parallel) and
    ``X[1 - axis] = value`` (perpendicular to them); ``lines`` and
    ``transversal`` are their images. The three parallel lines meet in their
    vanishing point; they cut the transversal in three points whose places
    along the plane line are known, so the 1-D projective map along it, and
    with it the transversal's vanishing point, follow (cross-ratio). The two
    vanishing points of perpendicular directions give the focal length
    (``f^2 = -(v1 - p) . (v2 - p)``) and the rotation's first two columns, and
    the three points the translation (least squares over their depths).
    Four line correspondences fix a homography only with four independent
    lines; three parallel ones and a transversal leave one degree of freedom,
    which the camera's known principal point and square pixels take up.
    (One transversal of :func:`homographies_from_parallel_lines_batch`.)

    Parameters
    ----------
    lines : (3, 3) image lines of the parallel plane lines, in the order of ``values``
    values : (3,) their coordinates (distinct)
    transversal : (3,) image line of the perpendicular plane line
    value : its coordinate
    principal_point : (2,) pixels
    axis : 0 when the parallel lines are ``X = values[i]``, 1 when ``Y = values[i]``

    Returns
    -------
    (k, 3, 3) float64 homographies ``x_img ~ H (X, Y, 1)``, k from 0 (degenerate:
    a vanishing point at infinity, no real focal length, points behind the
    camera) to 4 (the directions' signs, which the lines do not tell; the
    translation takes up either sign of the parallel lines' direction)
    """
    H, ok = homographies_from_parallel_lines_batch(lines, values, np.reshape(transversal, (1, 3)), [value], principal_point, axis=axis)
    return H[0][ok[0]]


def homographies_from_parallel_lines_batch(lines, values, transversals, transversal_values, principal_point, *, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`homographies_from_parallel_lines` for one triple of parallel
    lines and T transversals at once.

    Parameters
    ----------
    lines : (3, 3) image lines of the parallel plane lines ``X[axis] = values[i]``
    values : (3,) their coordinates (distinct)
    transversals : (T, 3) image lines of perpendicular plane lines
    transversal_values : (T,) their coordinates ``X[1 - axis]``
    principal_point : (2,) pixels
    axis : 0 or 1, as in :func:`homographies_from_parallel_lines`

    Returns
    -------
    H : (T, 4, 3, 3) float64 homographies ``x_img ~ H (X, Y, 1)`` (unit
        Frobenius norm), one per sign pair of the two directions
    ok : (T, 4) bool, which of them are cameras (a degenerate transversal,
        no real focal length or points behind the camera: False)
    """
    L = np.asarray(lines, dtype=np.float64).reshape(3, 3)
    vals = np.asarray(values, dtype=np.float64).reshape(3)
    LT = np.asarray(transversals, dtype=np.float64).reshape(-1, 3)
    VT = np.asarray(transversal_values, dtype=np.float64).reshape(-1)
    p = np.asarray(principal_point, dtype=np.float64)
    T = len(LT)
    Hs = np.zeros((T, 4, 3, 3))
    oks = np.zeros((T, 4), dtype=bool)
    if T == 0:
        return Hs, oks
    # the parallel lines' vanishing point: the null vector of the three (normalised) lines
    Ln = L / np.linalg.norm(L[:, :2], axis=1, keepdims=True)
    v_par = np.linalg.svd(Ln)[2][-1]
    if abs(v_par[2]) < 1e-12 * np.linalg.norm(v_par):
        return Hs, oks
    q_par = v_par[:2] / v_par[2] - p
    # their crossings with each transversal (T, 3, 2), and the 1-D map along it
    A = np.cross(Ln[None, :, :], LT[:, None, :])
    good = np.all(np.abs(A[..., 2]) >= 1e-12, axis=1)
    A = A[..., :2] / np.where(good[:, None, None], A[..., 2:], 1.0)
    d = np.column_stack([LT[:, 1], -LT[:, 0]]) / np.maximum(np.hypot(LT[:, 0], LT[:, 1]), 1e-300)[:, None]
    s = np.einsum("tij,tj->ti", A - A[:, :1], d)
    # s = (a v + b) / (c v + 1): a v_i + b - c v_i s_i = s_i
    M = np.stack([np.broadcast_to(vals, (T, 3)), np.ones((T, 3)), -vals * s], axis=2)
    with np.errstate(invalid="ignore", over="ignore"):
        cond = np.linalg.cond(M)
    good &= np.isfinite(cond) & (cond < 1e12)
    M[~good] = np.eye(3)
    a, b, c = np.linalg.solve(M, np.where(good[:, None], s, 0.0)[..., None])[..., 0].T
    v_tr = np.column_stack([A[:, 0, 0] * c + d[:, 0] * a, A[:, 0, 1] * c + d[:, 1] * a, c])  # image of value -> infinity
    good &= np.abs(v_tr[:, 2]) >= 1e-12 * np.linalg.norm(v_tr, axis=1)
    q_tr = v_tr[:, :2] / np.where(good, v_tr[:, 2], 1.0)[:, None] - p
    f2 = -(q_tr @ q_par)
    good &= f2 > 0
    f = np.sqrt(np.where(good, f2, 1.0))

    def ray(q):  # K^-1 (q + p, 1), normalised: (T, 3)
        r = np.column_stack([q[..., 0] / f, q[..., 1] / f, np.ones(T)])
        return r / np.linalg.norm(r, axis=1, keepdims=True)

    r_par, r_tr = ray(np.broadcast_to(q_par, (T, 2))), ray(q_tr)
    # plane X direction is the parallel lines' direction when they are Y = const
    # points (X, Y) on the transversal: depth_i * K^-1 a_i - t = rx X_i + ry Y_i
    P = np.zeros((T, 3, 2))
    P[:, :, axis] = vals
    P[:, :, 1 - axis] = VT[:, None]
    rays = np.stack([(A[..., 0] - p[0]) / f[:, None], (A[..., 1] - p[1]) / f[:, None], np.ones((T, 3))], axis=2)
    G = np.zeros((T, 9, 6))
    for i in range(3):
        G[:, 3 * i : 3 * i + 3, i] = rays[:, i]
        G[:, 3 * i : 3 * i + 3, 3:] = -np.eye(3)
    G[~good] = np.eye(9, 6)
    G_pinv = np.linalg.pinv(G)
    K = np.zeros((T, 3, 3))
    K[:, 0, 0] = K[:, 1, 1] = f
    K[:, :2, 2] = p
    K[:, 2, 2] = 1.0
    for k, (s1, s2) in enumerate(((1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0))):
        rx, ry = (s1 * r_par, s2 * r_tr) if axis == 1 else (s2 * r_tr, s1 * r_par)
        U, _, Vt = np.linalg.svd(np.stack([rx, ry], axis=2), full_matrices=False)
        Q = U @ Vt  # (T, 3, 2): the nearest orthonormal pair
        rx, ry = Q[..., 0], Q[..., 1]
        rhs = (P[..., 0, None] * rx[:, None, :] + P[..., 1, None] * ry[:, None, :]).reshape(T, 9)
        sol = np.einsum("tij,tj->ti", G_pinv, rhs)
        Hk = K @ np.stack([rx, ry, sol[:, 3:]], axis=2)
        Hs[:, k] = Hk / np.linalg.norm(Hk, axis=(1, 2))[:, None, None]
        oks[:, k] = good & np.all(sol[:, :3] > 0, axis=1)
    return Hs, oks
