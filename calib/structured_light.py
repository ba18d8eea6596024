"""Calibration of a camera and a laser line projector (a light plane) with a
sphere (thesis contribution 3).

A laser line projector spreads its light in a plane ``n . X = d`` (camera
frame). A sphere of known radius ``r`` placed in the light cuts it in a
circle; the camera sees the sphere's outline ``C`` and the laser stripe, the
image ``S`` of that circle.

* **Double contact.** The circle crosses the sphere's rim (the contour
  generator seen from the camera) in two points, where the stripe's image
  touches the outline: ``S ~ C + m m^T`` (``C`` negative inside), ``m`` the
  image of the line where the light plane meets the rim's plane (the two
  contact points may be complex, when the whole circle faces the camera).
  Given the outline, the stripe conic therefore has 3 unknowns and is fitted
  *linearly* from stripe pixels: ``m . x = sqrt(-x^T C x)``
  (:func:`fit_stripe_conic`) — the visible arc lies on one side of ``m``.
* **Intrinsics.** From the outlines (:func:`calib.sphere.intrinsics_from_spheres`,
  the rank-1 constraint of each outline and the IAC); the stripes add
  constraints: every stripe is the image of a circle in the *same* plane, so
  all stripe conics pass through the plane's imaged circular points, which
  lie on the IAC. They enter through the joint refinement below.
* **The spheres, the plane.** Each sphere centre from ``K``, its outline and
  ``r`` (:func:`calib.sphere.sphere_centre`); each stripe pixel's ray meets
  its sphere (first intersection) in a point of the light plane; the plane is
  the total-least-squares fit to all those points.
* **Joint refinement.** Maximum likelihood over ``K``, every sphere centre
  and the plane: Sampson distances of the outline points to the predicted
  outlines and of the stripe points to the predicted stripe conics (the cone
  over the circle, :func:`stripe_conic`).
* **Use.** :func:`triangulate` intersects pixel rays with the plane;
  :func:`measure_sphere` sizes an unknown ball from its outline and stripe.
* **Stripe extraction** (:func:`extract_stripe`): ridge pixels of the laser
  response (Hessian of the smoothed response), then the centre of gravity of
  the response across the stripe (along the ridge normal), sub-pixel.

Conventions (docs/formats.md): OpenCV camera ``x ~ K X``, ``X`` in the
camera frame (looking down +z), pixels with integer pixel centres; conics
normalised as in :mod:`geometry.conics`; images uint8 H x W x 3 BGR; the
light plane is :class:`LightPlane` ``(normal, d)`` with ``normal . X = d``,
unit normal, ``d > 0`` (the camera centre is off the plane). Lengths are in
the units of the radius.

>>> K = np.array([[1000.0, 0.0, 320.0], [0.0, 1000.0, 240.0], [0.0, 0.0, 1.0]])
>>> plane = LightPlane.from_point_normal([0.0, 0.0, 1.0], [1.0, 0.0, 0.3])
>>> X = triangulate(K, plane, [[320.0, 240.0], [400.0, 200.0]])
>>> bool(np.allclose(X[0], [0.0, 0.0, 1.0]) and np.allclose(plane.distance(X), 0.0))
True
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
import scipy.optimize

from calib._fit import conic_to_vec6, sampson_with_jacobian
from calib.one_d import _K_of, _N_PARAMS, _cone_conics, _model_name, _params_of, _tangent_basis
from calib.sphere import _check_points, _check_radius, centre_direction, fit_sphere_outline, intrinsics_from_spheres, sphere_centre
from geometry.conics import (
    conic_conditioning,
    ellipse_distance,
    ellipse_from_conic,
    normalize_conic,
    sampson_distance,
)

__all__ = [
    "LightPlane",
    "StripeFit",
    "LaserCalibration",
    "SphereMeasurement",
    "stripe_conic",
    "stripe_points",
    "fit_stripe_conic",
    "triangulate",
    "backproject_to_sphere",
    "fit_plane",
    "extract_stripe",
    "calibrate",
    "measure_sphere",
    "render_laser_image",
]


# --------------------------------------------------------------------------
# types
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class LightPlane:
    """The light plane ``normal . X = d`` in the camera frame.

    Attributes
    ----------
    normal : (3,) float64, unit normal, oriented so that ``d > 0``
    d : float, distance of the camera centre from the plane (units of the radius)
    """

    normal: np.ndarray
    d: float

    def __post_init__(self) -> None:
        n = np.asarray(self.normal, dtype=np.float64).reshape(-1)
        if n.shape != (3,) or not np.all(np.isfinite(n)) or not np.isfinite(self.d):
            raise ValueError("LightPlane needs a finite normal (3,) and a finite d")
        s = np.linalg.norm(n)
        if s == 0:
            raise ValueError("LightPlane normal is zero")
        n, d = n / s, float(self.d) / s
        if d < 0:
            n, d = -n, -d
        if d < 1e-12:
            raise ValueError("the light plane passes through the camera centre: stripes are lines, nothing to triangulate")
        object.__setattr__(self, "normal", n)
        object.__setattr__(self, "d", d)

    @classmethod
    def from_vector(cls, v) -> "LightPlane":
        """From ``(a, b, c, e)`` with ``a x + b y + c z + e = 0`` (any scale)."""
        v = np.asarray(v, dtype=np.float64).reshape(-1)
        if v.shape != (4,):
            raise ValueError(f"a plane vector must have 4 entries, got {v.shape}")
        return cls(normal=v[:3], d=-v[3])

    @classmethod
    def from_point_normal(cls, point, normal) -> "LightPlane":
        """The plane through ``point`` (3,) with normal ``normal`` (3,), camera frame."""
        n = np.asarray(normal, dtype=np.float64).reshape(3)
        return cls(normal=n, d=float(n @ np.asarray(point, dtype=np.float64).reshape(3)))

    @property
    def vector(self) -> np.ndarray:
        """(4,) ``(n, -d)``: ``vector . (X, 1) = 0`` on the plane."""
        return np.append(self.normal, -self.d)

    def distance(self, X) -> np.ndarray:
        """Signed distances (N,) of camera-frame points (N, 3) from the plane."""
        X = np.atleast_2d(np.asarray(X, dtype=np.float64))
        return X @ self.normal - self.d

    def angle_to(self, other: "LightPlane") -> float:
        """Angle between the normals of two planes, radians, in [0, pi/2].

        ``atan2(|n x n'|, |n . n'|)``: unlike ``arccos(|n . n'|)``, whose
        smallest non-zero answer is about 1.5e-8 rad (the spacing of doubles
        below 1), it resolves angles down to about 1e-16 rad.
        """
        n0 = np.asarray(self.normal, dtype=np.float64)
        n1 = np.asarray(other.normal, dtype=np.float64)
        s = float(np.linalg.norm(np.cross(n0, n1)))
        c = abs(float(n0 @ n1))
        return float(np.arctan2(s, c))


@dataclass(frozen=True)
class StripeFit:
    """A stripe conic fitted under double contact with its outline (:func:`fit_stripe_conic`).

    Attributes
    ----------
    conic : (3, 3) float64, normalised stripe conic ``S ~ C + m m^T``, pixels
    chord : (3,) float64, the line ``m`` through the two contact points with
        the outline (``a^2 + b^2 = 1``; the contact points may be complex)
    rms : float, RMS Sampson distance of the stripe pixels to ``conic``, pixels
    n_points : int
    """

    conic: np.ndarray
    chord: np.ndarray
    rms: float
    n_points: int


@dataclass(frozen=True)
class LaserCalibration:
    """A calibrated camera + light plane (:func:`calibrate`).

    Attributes
    ----------
    K : (3, 3) float64, intrinsics (pixels)
    plane : LightPlane, camera frame
    centres : (M, 3) float64, the sphere centres, camera frame
    stripe_conics : list of M (3, 3) float64 or None, predicted stripe conics
        (None where an image had no stripe)
    outline_rms : float, RMS distance of the outline points to the predicted outlines, pixels
    stripe_rms : float, RMS distance of the stripe points to the predicted stripe conics, pixels
    rms : float, RMS over both kinds of points, pixels
    plane_rms : float, RMS distance of the back-projected stripe points from
        the plane (before refinement), units of the radius
    K_spheres : (3, 3) float64, ``K`` from the outlines alone (or the given K)
    plane_init : LightPlane, the plane fitted to the back-projected points
    stage : str, ``"refined"`` or ``"initial"``
    model : str, intrinsics model (``"fixed"`` when ``K`` was given)
    n_stripe_points : int
    skipped : tuple of int, images left out (outline not clear enough); the
        per-image fields above follow the images that were used
    """

    K: np.ndarray
    plane: LightPlane
    centres: np.ndarray
    stripe_conics: list
    outline_rms: float
    stripe_rms: float
    rms: float
    plane_rms: float
    K_spheres: np.ndarray
    plane_init: LightPlane
    stage: str
    model: str
    n_stripe_points: int = 0
    skipped: tuple = ()


@dataclass(frozen=True)
class SphereMeasurement:
    """An unknown sphere measured with a calibrated system (:func:`measure_sphere`).

    Attributes
    ----------
    centre : (3,) float64, camera frame
    radius : float
    points : (N, 3) float64, triangulated stripe points (camera frame)
    rms : float, RMS distance of ``points`` from the fitted sphere
    """

    centre: np.ndarray
    radius: float
    points: np.ndarray
    rms: float = field(default=0.0)


# --------------------------------------------------------------------------
# validation helpers
# --------------------------------------------------------------------------


def _check_K(K, name: str = "K") -> np.ndarray:
    K = np.asarray(K, dtype=np.float64)
    if K.shape != (3, 3) or not np.all(np.isfinite(K)):
        raise ValueError(f"{name} must be a finite 3x3 calibration matrix, got shape {K.shape}")
    if abs(K[1, 0]) > 1e-9 * abs(K[0, 0]) or abs(K[2, 0]) > 1e-12 or abs(K[2, 1]) > 1e-12 or K[0, 0] <= 0 or K[1, 1] <= 0 or K[2, 2] == 0:
        raise ValueError(f"{name} must be upper triangular with positive focal lengths")
    return K / K[2, 2]


def _as_plane(plane) -> LightPlane:
    if isinstance(plane, LightPlane):
        return plane
    return LightPlane.from_vector(plane)






# --------------------------------------------------------------------------
# forward model
# --------------------------------------------------------------------------


def _circle_cones(X: np.ndarray, r: float, n: np.ndarray, d: float) -> np.ndarray:
    """Cones (M, 3, 3) over the circles where the plane ``n . X = d`` cuts spheres
    ``X`` (M, 3) of radius ``r``: for a ray ``t x`` on the plane ``t = d / (n . x)``,
    so ``|d x - (n . x) X|^2 = r^2 (n . x)^2``."""
    q = (X * X).sum(axis=1) - r * r
    nX = n[None, :, None] * X[:, None, :]  # n X^T
    return d * d * np.eye(3)[None] - d * (nX + np.swapaxes(nX, 1, 2)) + q[:, None, None] * np.outer(n, n)[None]


def _stripe_conics(Kinv: np.ndarray, X: np.ndarray, r: float, n: np.ndarray, d: float) -> np.ndarray:
    C = np.einsum("ki,mkl,lj->mij", Kinv, _circle_cones(X, r, n, d), Kinv)
    return C / np.linalg.norm(C, axis=(1, 2))[:, None, None]


def stripe_conic(K, centre, radius, plane) -> np.ndarray:
    """Image of the circle where the light plane cuts a sphere (forward model).

    Parameters
    ----------
    K : (3, 3) float64, intrinsics (pixels)
    centre : (3,) float64, sphere centre, camera frame
    radius : float, > 0
    plane : LightPlane or (4,) plane vector, camera frame

    Returns
    -------
    (3, 3) float64, normalised conic (pixels) of the whole circle (the visible
    stripe is an arc of it).

    Raises
    ------
    ValueError
        Bad inputs, or the light plane misses the sphere.
    """
    K = _check_K(K)
    r = _check_radius(radius)
    pl = _as_plane(plane)
    X = np.asarray(centre, dtype=np.float64).reshape(-1)
    if X.shape != (3,) or not np.all(np.isfinite(X)):
        raise ValueError(f"centre must be a finite (3,) vector, got shape {X.shape}")
    if abs(float(pl.distance(X)[0])) >= r:
        raise ValueError("the light plane misses the sphere: no stripe")
    return normalize_conic(_stripe_conics(np.linalg.inv(K), X[None], r, pl.normal, pl.d)[0])


def _circle_frame(X, r, pl: LightPlane):
    delta = float(pl.distance(X)[0])
    if abs(delta) >= r:
        raise ValueError("the light plane misses the sphere: no stripe")
    c0 = X - delta * pl.normal
    rho = np.sqrt(r * r - delta * delta)
    e1, e2 = _tangent_basis(pl.normal[None])
    return c0, rho, e1[0], e2[0]


def stripe_points(K, centre, radius, plane, n: int = 100, *, projector=None, noise: float = 0.0, rng=None) -> np.ndarray:
    """Pixels of the visible laser stripe on a sphere (synthetic data).

    The stripe is the part of the circle (plane ∩ sphere) that faces the
    camera and, if ``projector`` is given, also faces the projector.

    Parameters
    ----------
    K : (3, 3) float64, intrinsics (pixels)
    centre : (3,) float64, sphere centre, camera frame
    radius : float
    plane : LightPlane or (4,)
    n : int, number of points, evenly spread over the visible arc
    projector : (3,) float64, optional, the projector's centre (on the plane), camera frame
    noise : float, standard deviation of Gaussian pixel noise (per coordinate)
    rng : numpy Generator or seed

    Returns
    -------
    (n, 2) float64, pixels.

    Raises
    ------
    ValueError
        The plane misses the sphere, or no part of the circle is visible (and lit).
    """
    K = _check_K(K)
    r = _check_radius(radius)
    pl = _as_plane(plane)
    X = np.asarray(centre, dtype=np.float64).reshape(3)
    c0, rho, e1, e2 = _circle_frame(X, r, pl)
    th = np.linspace(0.0, 2 * np.pi, 4096, endpoint=False)
    P = c0 + rho * (np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2)
    N = P - X
    ok = (N * P).sum(axis=1) < 0  # faces the camera (normal toward the origin)
    if projector is not None:
        pr = np.asarray(projector, dtype=np.float64).reshape(3)
        ok &= (N * (pr - P)).sum(axis=1) > 0
    if not np.any(ok):
        raise ValueError("no part of the laser circle is visible (and lit) from the camera")
    idx = np.flatnonzero(ok)
    if not ok.all():  # rotate so the visible arc is contiguous in idx
        start = np.flatnonzero(ok & ~np.roll(ok, 1))[0]
        idx = (start + np.arange(ok.sum())) % len(th)
    pick = idx[np.round(np.linspace(0, len(idx) - 1, int(n))).astype(int)]
    x = P[pick] @ K.T
    px = x[:, :2] / x[:, 2:3]
    if noise > 0:
        g = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        px = px + g.normal(0.0, noise, px.shape)
    return px


# --------------------------------------------------------------------------
# stripe conic under double contact, triangulation, plane fit
# --------------------------------------------------------------------------


def fit_stripe_conic(outline, pixels) -> StripeFit:
    """Fit the stripe conic with double contact to the sphere's outline.

    ``S = C + m m^T`` with ``C`` the outline (normalised, negative inside): for
    stripe pixels ``x = (u, v, 1)``, ``(m . x)^2 = -x^T C x``, and all visible
    stripe pixels lie on one side of ``m``, so ``m . x = sqrt(-x^T C x)`` is
    linear in ``m`` (3 unknowns; solved in the outline's normalised frame).

    Parameters
    ----------
    outline : (3, 3) conic of the sphere's outline, pixels
    pixels : (N, 2) float64, N >= 3, stripe pixels

    Returns
    -------
    StripeFit

    Raises
    ------
    ValueError
        Fewer than 3 pixels; the outline is not an ellipse; most pixels lie
        outside the outline (the stripe misses the sphere); collinear pixels.
    """
    C = normalize_conic(np.asarray(outline, dtype=np.float64))
    try:
        ellipse_from_conic(C)
    except ValueError:
        raise ValueError("outline is not a real ellipse, so not the outline of a sphere") from None
    p = _check_points(pixels, "pixels", 3)
    T = conic_conditioning(C)
    Ti = np.linalg.inv(T)
    Cc = normalize_conic(Ti.T @ C @ Ti)
    X = np.column_stack([p, np.ones(len(p))]) @ T.T
    q = -np.einsum("ni,ij,nj->n", X, Cc, X)
    outside = np.count_nonzero(q < 0)
    if outside > 0.5 * len(p):
        raise ValueError(
            f"{outside} of {len(p)} stripe pixels lie outside the sphere's outline: the stripe misses the sphere"
        )
    s = np.linalg.svd(X - X.mean(axis=0), compute_uv=False)
    if s[1] < 1e-9 * max(s[0], 1e-300):
        raise ValueError("the stripe pixels are collinear: no stripe conic")
    m, *_ = np.linalg.lstsq(X, np.sqrt(np.clip(q, 0.0, None)), rcond=None)
    S = T.T @ Cc @ T + np.outer(T.T @ m, T.T @ m)
    S = normalize_conic(S)
    chord = T.T @ m
    chord = chord / max(np.hypot(chord[0], chord[1]), 1e-300)
    d = sampson_distance(p, S)
    return StripeFit(conic=S, chord=chord, rms=float(np.sqrt(np.mean(d * d))), n_points=len(p))


def triangulate(K, plane, pixels) -> np.ndarray:
    """3-D points on the light plane seen at ``pixels``: ray-plane intersection.

    Parameters
    ----------
    K : (3, 3) float64, intrinsics (pixels)
    plane : LightPlane or (4,) plane vector ``(a, b, c, e)``, camera frame
    pixels : (N, 2) float64, pixels

    Returns
    -------
    (N, 3) float64, camera frame (units of the plane's ``d``); NaN rows for
    rays parallel to the plane or meeting it behind the camera.
    """
    K = _check_K(K)
    pl = _as_plane(plane)
    p = _check_points(pixels, "pixels", 1)
    rays = np.column_stack([p, np.ones(len(p))]) @ np.linalg.inv(K).T
    den = rays @ pl.normal
    with np.errstate(divide="ignore", invalid="ignore"):
        t = pl.d / den
    out = rays * t[:, None]
    out[~(np.abs(den) > 1e-12) | ~(t > 0)] = np.nan
    return out


def backproject_to_sphere(K, centre, radius, pixels, *, tolerance: float = 0.0) -> np.ndarray:
    """First intersections of pixel rays with a sphere (the visible surface).

    Parameters
    ----------
    K : (3, 3), centre : (3,) camera frame, radius : float, pixels : (N, 2)
    tolerance : float, rays that miss the sphere by less than this fraction of
        the radius are snapped to the tangent point (noise at the rim)

    Returns
    -------
    (N, 3) float64, camera frame; NaN rows for rays that miss.
    """
    K = _check_K(K)
    r = _check_radius(radius)
    X = np.asarray(centre, dtype=np.float64).reshape(3)
    p = _check_points(pixels, "pixels", 1)
    rays = np.column_stack([p, np.ones(len(p))]) @ np.linalg.inv(K).T
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    b = rays @ X
    disc = b * b - (X @ X - r * r)
    snap = (disc < 0) & (disc > -((tolerance * r) ** 2) * 4)
    disc = np.where(snap, 0.0, disc)
    with np.errstate(invalid="ignore"):
        t = b - np.sqrt(disc)
    out = rays * t[:, None]
    out[~(disc >= 0) | ~(t > 0)] = np.nan
    return out


def fit_plane(points) -> tuple[LightPlane, float]:
    """Total-least-squares plane through 3-D points (N, 3), N >= 3.

    Returns
    -------
    (LightPlane, rms distance of the points from it)

    Raises
    ------
    ValueError
        Fewer than 3 finite points, or collinear points.
    """
    P = np.asarray(points, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {P.shape}")
    P = P[np.all(np.isfinite(P), axis=1)]
    if len(P) < 3:
        raise ValueError(f"a plane needs at least 3 points, got {len(P)}")
    c = P.mean(axis=0)
    _, s, Vt = np.linalg.svd(P - c)
    if s[1] < 1e-9 * max(s[0], 1e-300):
        raise ValueError("the points are collinear: the plane is undetermined")
    n = Vt[2]
    pl = LightPlane(normal=n, d=float(n @ c))
    return pl, float(np.sqrt(np.mean(pl.distance(P) ** 2)))


# --------------------------------------------------------------------------
# stripe extraction
# --------------------------------------------------------------------------


def _laser_response(image, channel, background) -> np.ndarray:
    img = np.asarray(image)
    if img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[2] not in (1, 3, 4)):
        raise ValueError(f"image must be H x W (grey) or H x W x 3 (BGR), got shape {img.shape}")
    if img.shape[0] < 8 or img.shape[1] < 8:
        raise ValueError(f"image is too small: {img.shape[1]} x {img.shape[0]} pixels")
    f = img.astype(np.float32)
    if f.ndim == 3 and f.shape[2] == 1:
        f = f[:, :, 0]
    if f.ndim == 3:
        f = f[:, :, :3]
    if background is not None:
        bg = np.asarray(background).astype(np.float32)
        if bg.shape[:2] != f.shape[:2]:
            raise ValueError(f"background must have the image's size {f.shape[:2]}, got {bg.shape[:2]}")
        if bg.ndim == 3 and f.ndim == 3:
            bg = bg[:, :, :3]
        f = f - bg
    if f.ndim == 2:
        return np.clip(f, 0, None)
    ch = {"blue": 0, "green": 1, "red": 2}
    if channel == "grey":
        return np.clip(f.mean(axis=2), 0, None)
    if channel not in ch:
        raise ValueError(f"channel must be 'red', 'green', 'blue' or 'grey', got {channel!r}")
    k = ch[channel]
    others = [i for i in range(3) if i != k]
    if background is not None:
        return np.clip(f[:, :, k], 0, None)
    return np.clip(f[:, :, k] - 0.5 * (f[:, :, others[0]] + f[:, :, others[1]]), 0, None)


def _bilinear(img: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    H, W = img.shape
    x = np.clip(x, 0, W - 1.001)
    y = np.clip(y, 0, H - 1.001)
    x0 = np.floor(x).astype(int)
    y0 = np.floor(y).astype(int)
    fx, fy = x - x0, y - y0
    return (
        img[y0, x0] * (1 - fx) * (1 - fy)
        + img[y0, x0 + 1] * fx * (1 - fy)
        + img[y0 + 1, x0] * (1 - fx) * fy
        + img[y0 + 1, x0 + 1] * fx * fy
    )


def extract_stripe(
    image,
    *,
    channel: str = "red",
    background=None,
    mask=None,
    sigma: float = 1.5,
    threshold: float | None = None,
    half_width: float | None = None,
) -> np.ndarray:
    """Sub-pixel centre line of a laser stripe.

    1. Laser response: the chosen channel minus the mean of the other two
       (or minus a ``background`` image taken without the laser), clipped at 0.
    2. Ridge pixels: on the response smoothed with ``sigma``, the Hessian's
       most negative eigenvalue gives the normal across the stripe; a pixel is
       a ridge pixel if its smoothed response exceeds ``threshold`` and is a
       maximum along that normal (compared with the bilinear samples one
       pixel to either side).
    3. Sub-pixel: the centre of gravity of the (lightly smoothed) response
       along the normal, over ``+-half_width`` pixels, above the window's
       minimum; points that move more than a pixel are dropped.

    Parameters
    ----------
    image : (H, W, 3) uint8 BGR or (H, W) grey
    channel : "red" (default), "green", "blue" or "grey"
    background : optional image of the same scene without the laser
    mask : (H, W) bool, optional: only ridge pixels where True (e.g. inside
        the sphere's outline)
    sigma : float, smoothing of the ridge detector, pixels (about the stripe's
        half-width)
    threshold : float, optional, minimum smoothed response (default: a
        quarter of the 99.9th percentile of the response, at least 12 grey
        levels, so that sensor noise alone gives no stripe)
    half_width : float, optional, half-width of the centre-of-gravity window,
        pixels (default ``2.5 sigma``)

    Returns
    -------
    (N, 2) float64, pixels (possibly empty).

    Raises
    ------
    ValueError
        Bad image, channel, mask or parameters.
    """
    if not (np.isfinite(sigma) and sigma > 0):
        raise ValueError(f"sigma must be positive, got {sigma}")
    R = _laser_response(image, channel, background)
    H, W = R.shape
    if mask is not None:
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != (H, W):
            raise ValueError(f"mask must have shape {(H, W)}, got {mask.shape}")
    G = cv2.GaussianBlur(R, (0, 0), sigma)
    R1 = cv2.GaussianBlur(R, (0, 0), 0.7)
    if threshold is None:
        threshold = max(0.25 * float(np.percentile(G, 99.9)), 12.0)
    gxx = cv2.Sobel(G, cv2.CV_32F, 2, 0, ksize=3) / 4.0
    gyy = cv2.Sobel(G, cv2.CV_32F, 0, 2, ksize=3) / 4.0
    gxy = cv2.Sobel(G, cv2.CV_32F, 1, 1, ksize=3) / 4.0
    cand = G > threshold
    if mask is not None:
        cand &= mask
    ys, xs = np.nonzero(cand)
    if len(xs) == 0:
        return np.zeros((0, 2))
    a, b, c = gxx[ys, xs], gxy[ys, xs], gyy[ys, xs]
    # most negative eigenvalue of [[a, b], [b, c]] and its eigenvector (the normal)
    tr2 = 0.5 * (a + c)
    disc = np.sqrt(0.25 * (a - c) ** 2 + b * b)
    lam = tr2 - disc
    nx, ny = b, lam - a
    alt = np.abs(nx) + np.abs(ny) < 1e-12
    nx = np.where(alt, lam - c, nx)
    ny = np.where(alt, b, ny)
    nn = np.hypot(nx, ny)
    ok = (lam < 0) & (nn > 0)
    nx, ny = nx / np.where(nn > 0, nn, 1), ny / np.where(nn > 0, nn, 1)
    g0 = G[ys, xs]
    gp = _bilinear(G, xs + nx, ys + ny)
    gm = _bilinear(G, xs - nx, ys - ny)
    ok &= (g0 >= gp) & (g0 >= gm)
    xs, ys, nx, ny = xs[ok], ys[ok], nx[ok], ny[ok]
    if len(xs) == 0:
        return np.zeros((0, 2))
    hw = 2.5 * sigma if half_width is None else float(half_width)
    t = np.arange(-hw, hw + 1e-9, 0.25)
    sx = xs[:, None] + t[None] * nx[:, None]
    sy = ys[:, None] + t[None] * ny[:, None]
    v = _bilinear(R1, sx.ravel(), sy.ravel()).reshape(sx.shape)
    v = v - v.min(axis=1, keepdims=True)
    wsum = v.sum(axis=1)
    good = wsum > 0
    off = np.where(good, (v * t[None]).sum(axis=1) / np.where(good, wsum, 1), 0.0)
    good &= np.abs(off) <= 1.0
    pts = np.column_stack([xs + off * nx, ys + off * ny])[good]
    # one point per cross-section: drop near-duplicates (two ridge pixels of one profile)
    if len(pts) > 1:
        key = np.round(pts * 4).astype(np.int64)
        _, first = np.unique(key, axis=0, return_index=True)
        pts = pts[np.sort(first)]
    return pts


# --------------------------------------------------------------------------
# calibration
# --------------------------------------------------------------------------


def _is_conic_like(x) -> bool:
    a = np.asarray(x)
    return a.shape == (3, 3)


def _inside_mask(shape, conic, shrink: float) -> np.ndarray:
    e = ellipse_from_conic(conic)
    H, W = shape
    mask = np.zeros((H, W), np.uint8)
    ax = (max(e.axes[0] - shrink, 1.0), max(e.axes[1] - shrink, 1.0))
    cv2.ellipse(
        mask,
        (int(round(e.center[0] * 16)), int(round(e.center[1] * 16))),
        (int(round(ax[0] * 16)), int(round(ax[1] * 16))),
        np.degrees(e.angle),
        0,
        360,
        1,
        -1,
        cv2.LINE_8,
        4,
    )
    return mask.astype(bool)


def _joint_ml(K0, X0, plane0, out_pts, str_pts, r, model, fix_K, max_nfev):
    """ML over K (unless fixed), sphere centres and the plane.

    ``out_pts`` / ``str_pts``: lists (one per sphere) of (n, 2) arrays or None."""
    M = len(X0)
    nK = 0 if fix_K else _N_PARAMS[model]
    n0 = plane0.normal
    e1, e2 = _tangent_basis(n0[None])
    e1, e2 = e1[0], e2[0]
    pts, idx = [], []
    for j, p in enumerate(out_pts):
        if p is not None:
            pts.append(p)
            idx.append(np.full(len(p), j))
    n_out = sum(len(p) for p in pts)
    for j, p in enumerate(str_pts):
        if p is not None:
            pts.append(p)
            idx.append(np.full(len(p), M + j))
    pts = np.concatenate(pts)
    idx = np.concatenate(idx)

    def unpack(x):
        K = K0 if fix_K else _K_of(x[:nK], model)
        X = x[nK : nK + 3 * M].reshape(M, 3)
        w1, w2, d = x[nK + 3 * M :]
        g = n0 + w1 * e1 + w2 * e2
        return K, X, g / np.linalg.norm(g), d

    def conics(x):
        K, X, n, d = unpack(x)
        Ki = np.linalg.inv(K)
        return np.concatenate([_cone_conics(Ki, X, r), _stripe_conics(Ki, X, r, n, d)])

    def fun(x):
        return sampson_with_jacobian(pts, idx, conics(x), jac=False)

    def jac(x):
        _, J6 = sampson_with_jacobian(pts, idx, conics(x))
        J = np.zeros((len(pts), len(x)))
        for k in range(len(x)):
            h = 1e-6 * max(1.0, abs(x[k])) if k < nK else 1e-7 * max(1.0, abs(x[k]))
            xp, xm = x.copy(), x.copy()
            xp[k] += h
            xm[k] -= h
            dC = (conic_to_vec6(conics(xp)) - conic_to_vec6(conics(xm))) / (2 * h)
            J[:, k] = np.einsum("nc,nc->n", J6, dC[idx])
        return J

    x0 = np.concatenate([np.zeros(0) if fix_K else _params_of(K0, model), X0.ravel(), [0.0, 0.0, plane0.d]])
    sol = scipy.optimize.least_squares(fun, x0, jac=jac, method="lm", x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=max_nfev)
    K, X, n, d = unpack(sol.x)
    return K, X, LightPlane(normal=n, d=d), n_out


def _rms_to(conic, p) -> np.ndarray:
    try:
        return ellipse_distance(p, ellipse_from_conic(conic))
    except ValueError:
        return np.abs(sampson_distance(p, conic))


def _focal_scan(conics: np.ndarray, outline_points=None) -> np.ndarray | None:
    """Fallback initial ``K``: square pixels, the principal point at the mean of
    the outline centres, the focal length (log grid) whose spheres best
    explain the outlines (RMS distance of the outline points to the outlines
    predicted from each conic's cone). None if nothing fits."""
    ells = [ellipse_from_conic(C) for C in conics]
    c = np.mean([e.center for e in ells], axis=0)
    spread = max(float(np.max([np.hypot(*(np.subtract(e.center, c))) + e.axes[0] for e in ells])), 1.0)
    pts = outline_points if outline_points is not None else [e.points(60) for e in ells]
    best = (np.inf, None)
    for f in spread * np.geomspace(0.3, 30.0, 60):
        K = np.array([[f, 0.0, c[0]], [0.0, f, c[1]], [0.0, 0.0, 1.0]])
        try:
            X = np.array([sphere_centre(K, C, 1.0) for C in conics])
        except ValueError:
            continue
        Cp = _cone_conics(np.linalg.inv(K), X, 1.0)
        err = np.concatenate([sampson_distance(p, Cp[j]) for j, p in enumerate(pts)])
        score = float(np.sqrt(np.mean(err * err)))
        if score < best[0]:
            best = (score, K)
    return best[1]


def _initial_spheres_and_plane(K0, conics, str_list, r):
    """Sphere centres from ``K0`` and the outlines; the plane through the stripe
    pixels back-projected onto their spheres. Returns (X0, plane, plane rms)."""
    X0 = np.array([sphere_centre(K0, C, r) for C in conics])
    P3 = []
    for j, s in enumerate(str_list):
        if s is None:
            continue
        Pj = backproject_to_sphere(K0, X0[j], r, s, tolerance=0.05)
        miss = np.count_nonzero(~np.isfinite(Pj[:, 0]))
        if miss > 0.5 * len(s):
            raise ValueError(f"stripe_points[{j}]: {miss} of {len(s)} rays miss the sphere: the stripe misses the sphere")
        P3.append(Pj)
    plane0, plane_rms = fit_plane(np.concatenate(P3))
    return X0, plane0, plane_rms


def _total_rms(K, X, plane, r, outline_pts, str_list) -> float:
    """RMS Sampson distance (pixels) of all outline and stripe points to the model."""
    Ki = np.linalg.inv(K)
    Co = _cone_conics(Ki, X, r)
    Cs = _stripe_conics(Ki, X, r, plane.normal, plane.d)
    d = [sampson_distance(p, Co[j]) for j, p in enumerate(outline_pts)]
    d += [sampson_distance(s, Cs[j]) for j, s in enumerate(str_list) if s is not None]
    d = np.concatenate(d)
    return float(np.sqrt(np.mean(d * d)))


def _focal_candidates(conics: np.ndarray, outline_pts) -> list[np.ndarray]:
    """Fallback starting points: square pixels, the principal point at the mean of
    the outline centres, focal lengths of 0.5 to 4 times the outlines' spread
    plus the best of a scan (:func:`_focal_scan`)."""
    ells = [ellipse_from_conic(C) for C in conics]
    c = np.mean([e.center for e in ells], axis=0)
    spread = max(float(np.max([np.hypot(*(np.subtract(e.center, c))) + e.axes[0] for e in ells])), 1.0)
    out = [np.array([[f, 0.0, c[0]], [0.0, f, c[1]], [0.0, 0.0, 1.0]]) for f in spread * np.array([0.5, 1.0, 2.0, 4.0])]
    scan = _focal_scan(conics, outline_pts)
    return out + ([scan] if scan is not None else [])


def _clean_stripe(outline: np.ndarray, pts: np.ndarray, rounds: int = 3) -> np.ndarray:
    """Drop stripe pixels far from the stripe conic fitted under double contact
    with the outline (beyond 3 robust standard deviations, at least 1 pixel)."""
    keep = np.ones(len(pts), bool)
    for _ in range(rounds):
        fit = fit_stripe_conic(outline, pts[keep])
        d = np.abs(sampson_distance(pts, fit.conic))
        sig = 1.4826 * np.median(d[keep])
        new = d <= max(3.0 * sig, 1.0)
        if new.sum() < 5 or np.array_equal(new, keep):
            break
        keep = new
    return pts[keep]


def calibrate(
    sphere_images,
    stripe_points=None,
    *,
    radius: float,
    edge_points=None,
    K=None,
    square_pixels: bool = False,
    zero_skew: bool = True,
    channel: str = "red",
    min_support: float = 0.9,
    refine: bool = True,
    max_nfev: int = 100,
) -> LaserCalibration:
    """Calibrate a camera and its laser light plane from images of a sphere.

    1. Outlines: given conics, or found in the images
       (:func:`calib.sphere.fit_sphere_outline`); stripes: given pixels, or
       extracted inside each outline (:func:`extract_stripe`).
    2. ``K`` from the outlines (:func:`calib.sphere.intrinsics_from_spheres`,
       with the edge points when known), unless ``K`` is given.
    3. Each sphere centre (:func:`calib.sphere.sphere_centre`); each stripe
       pixel back-projected onto its sphere (first intersection); the plane
       fitted to all those points (total least squares).
    4. Joint maximum-likelihood refinement of ``K``, the centres and the
       plane on the outline and stripe points (``refine``). The stripe conics
       constrain ``K`` here: they are images of circles in one plane and pass
       through its imaged circular points, which lie on the IAC.

    Parameters
    ----------
    sphere_images : sequence of M images (H x W x 3 BGR or H x W grey), or of
        M (3, 3) outline conics (pixels); one sphere position per entry
        (M >= 3 unless ``K`` is given)
    stripe_points : sequence of M (N_j, 2) pixel arrays (or None for an entry
        without stripe); required with conics, extracted from images if None
    radius : float, the sphere's radius (sets the units)
    edge_points : sequence of M (n_j, 2) outline points, optional (conics
        only; found automatically with images)
    K : (3, 3), optional, known intrinsics (then only the spheres and plane
        are estimated)
    square_pixels, zero_skew : intrinsics model (as in :mod:`calib.sphere`)
    channel : laser colour for extraction ("red", "green", "blue", "grey")
    min_support : float, images only: an image whose outline has edge points
        on less than this fraction of its angle (occlusion, clutter touching
        the ball) is skipped (listed in ``skipped``); an image where no stripe
        is found counts as an image without stripe
    refine : bool, run step 4
    max_nfev : int, iteration cap of the refinement

    Returns
    -------
    LaserCalibration

    Raises
    ------
    ValueError
        Too few sphere images (3, or 1 with a known ``K``); mismatched
        lengths; no stripe at all; a stripe that misses its sphere (pixels
        outside the outline); too few stripe points for a plane; no outline
        found in an image; the plane through the camera centre.
    """
    r = _check_radius(radius)
    model = _model_name(square_pixels, zero_skew)
    try:
        M = len(sphere_images)
    except TypeError:
        raise ValueError("sphere_images must be a sequence of images or of 3x3 conics") from None
    fix_K = K is not None
    if M < (1 if fix_K else 3):
        raise ValueError(
            f"too few sphere images: {M}; the intrinsics need at least 3 (or give K)"
            if not fix_K
            else "at least one sphere image is needed"
        )
    if stripe_points is not None and len(stripe_points) != M:
        raise ValueError(f"stripe_points must hold one entry per sphere image: {M} images, {len(stripe_points)} entries")
    if edge_points is not None and len(edge_points) != M:
        raise ValueError(f"edge_points must hold one entry per sphere image: {M} images, {len(edge_points)} entries")
    conic_input = all(_is_conic_like(s) for s in sphere_images)
    skipped: list[int] = []
    if conic_input:
        if stripe_points is None:
            raise ValueError("stripe_points are required when outlines are given as conics")
        conics = []
        for j, C in enumerate(sphere_images):
            C = np.asarray(C, dtype=np.float64)
            if not np.all(np.isfinite(C)) or np.linalg.norm(C) == 0:
                raise ValueError(f"sphere_images[{j}] is not a valid conic")
            C = normalize_conic(C)
            try:
                ellipse_from_conic(C)
            except ValueError:
                raise ValueError(f"sphere_images[{j}] is not a real ellipse, so not the outline of a sphere") from None
            conics.append(C)
        edges = None if edge_points is None else [_check_points(p, f"edge_points[{j}]") for j, p in enumerate(edge_points)]
        stripes = list(stripe_points)
    else:
        conics, edges, stripes = [], [], []
        for j, img in enumerate(sphere_images):
            if _is_conic_like(img):
                raise ValueError("sphere_images mixes conics and images")
            try:
                out = fit_sphere_outline(img)
            except ValueError as exc:
                raise ValueError(f"sphere_images[{j}]: {exc}") from None
            if out.support < min_support:
                skipped.append(j)
                continue
            conics.append(out.conic)
            edges.append(out.edge_points)
            if stripe_points is not None:
                stripes.append(stripe_points[j])
            else:
                mask = _inside_mask(np.asarray(img).shape[:2], out.conic, shrink=1.5)
                found = extract_stripe(img, channel=channel, mask=mask)
                stripes.append(found if len(found) >= 5 else None)
        if len(conics) < (1 if fix_K else 3):
            raise ValueError(
                f"only {len(conics)} of {M} images show a clear sphere outline (support >= {min_support:.0%}; "
                f"skipped {skipped}): too few"
            )
    # stripes: validate, drop the empty ones (None)
    str_list = []
    for j, s in enumerate(stripes):
        if s is None:
            str_list.append(None)
            continue
        s = np.asarray(s, dtype=np.float64).reshape(-1, 2) if np.size(s) else np.zeros((0, 2))
        if len(s) < 5:
            raise ValueError(
                f"stripe_points[{j}] has {len(s)} points (at least 5 needed): the laser stripe misses the "
                "sphere in that image (or give None for an image without stripe)"
            )
        s = _check_points(s, f"stripe_points[{j}]")
        try:
            s = _clean_stripe(conics[j], s)
        except ValueError as exc:
            raise ValueError(f"stripe_points[{j}]: {exc}") from None
        str_list.append(s)
    if all(s is None for s in str_list):
        raise ValueError("no laser stripe in any image: the light plane is unobservable")
    conics = np.array(conics)
    outline_pts = edges if edges is not None else [ellipse_from_conic(C).points(100) for C in conics]
    if fix_K:
        starts = [_check_K(K)]
        model_out = "fixed"
    else:
        model_out = model
        try:
            starts = [intrinsics_from_spheres(conics, edge_points=edges, square_pixels=square_pixels, zero_skew=zero_skew).K]
        except ValueError as exc:
            # noisy outlines can make the linear IAC indefinite: start the joint refinement
            # (which has the stripes' constraints too) from several focal lengths, keep the best
            starts = _focal_candidates(conics, outline_pts)
            if not starts:
                raise ValueError(f"intrinsics from the sphere outlines: {exc}") from None
    best, first_error = None, None
    for K0 in starts:
        try:
            X0, plane0, plane_rms = _initial_spheres_and_plane(K0, conics, str_list, r)
        except ValueError as exc:
            first_error = first_error or exc
            continue
        if refine:
            Kf, Xf, plane, _ = _joint_ml(K0, X0, plane0, outline_pts, str_list, r, model, fix_K, max_nfev)
        else:
            Kf, Xf, plane = K0, X0, plane0
        cost = _total_rms(Kf, Xf, plane, r, outline_pts, str_list)
        if best is None or cost < best[0]:
            best = (cost, K0, X0, plane0, plane_rms, Kf, Xf, plane)
    if best is None:
        raise first_error
    _, K0, X0, plane0, plane_rms, Kf, Xf, plane = best
    stage = "refined" if refine else "initial"
    Ki = np.linalg.inv(Kf)
    Co = _cone_conics(Ki, Xf, r)
    Cs = _stripe_conics(Ki, Xf, r, plane.normal, plane.d)
    do = np.concatenate([_rms_to(Co[j], p) for j, p in enumerate(outline_pts)])
    ds = np.concatenate([_rms_to(Cs[j], s) for j, s in enumerate(str_list) if s is not None])
    rms = lambda v: float(np.sqrt(np.mean(v * v)))  # noqa: E731
    return LaserCalibration(
        K=Kf,
        plane=plane,
        centres=Xf,
        stripe_conics=[None if s is None else normalize_conic(Cs[j]) for j, s in enumerate(str_list)],
        outline_rms=rms(do),
        stripe_rms=rms(ds),
        rms=rms(np.concatenate([do, ds])),
        plane_rms=plane_rms,
        K_spheres=K0,
        plane_init=plane0,
        stage=stage,
        model=model_out,
        n_stripe_points=int(sum(len(s) for s in str_list if s is not None)),
        skipped=tuple(skipped),
    )


def measure_sphere(K, plane, outline, pixels) -> SphereMeasurement:
    """Centre and radius of an unknown sphere from its outline and laser stripe.

    The outline gives the tangent cone (centre direction ``d``, half-angle
    ``a``, :func:`calib.sphere.centre_direction`): the centre is ``D d`` and
    the radius ``D sin(a)``. The stripe pixels, triangulated on the light
    plane, lie on the sphere: ``|P_k - D d| = D sin(a)`` fixes ``D`` (least
    squares).

    Parameters
    ----------
    K : (3, 3) intrinsics, plane : LightPlane or (4,), outline : (3, 3) conic,
    pixels : (N, 2) stripe pixels on that sphere, N >= 3

    Returns
    -------
    SphereMeasurement

    Raises
    ------
    ValueError
        Bad inputs, or the stripe rays do not meet the plane in front of the camera.
    """
    K = _check_K(K)
    pl = _as_plane(plane)
    p = _check_points(pixels, "pixels", 3)
    d, a = centre_direction(K, outline)
    P = triangulate(K, pl, p)
    P = P[np.all(np.isfinite(P), axis=1)]
    if len(P) < 3:
        raise ValueError("fewer than 3 stripe rays meet the light plane in front of the camera")
    sa, ca2 = np.sin(a), np.cos(a) ** 2
    dp = P @ d
    pp = (P * P).sum(axis=1)
    disc = np.clip(dp * dp - ca2 * pp, 0.0, None)
    D0 = float(np.median((dp + np.sqrt(disc)) / ca2))

    def fun(D):
        return np.linalg.norm(P - D[0] * d, axis=1) - D[0] * sa

    sol = scipy.optimize.least_squares(fun, [D0], method="lm", xtol=1e-14, ftol=1e-14)
    D = float(sol.x[0])
    res = fun(sol.x)
    return SphereMeasurement(centre=D * d, radius=D * sa, points=P, rms=float(np.sqrt(np.mean(res * res))))


# --------------------------------------------------------------------------
# synthetic images
# --------------------------------------------------------------------------


def render_laser_image(
    K,
    centre,
    radius,
    plane,
    image_size,
    *,
    projector=None,
    width: float | None = None,
    peak: float = 200.0,
    rng=None,
    **render_kwargs,
):
    """A rendered sphere with a red laser stripe (synthetic data for tests and benchmarks).

    The sphere is drawn by :func:`calib.synthetic.render_spheres`; the laser
    adds ``peak * exp(-s^2 / (2 w^2))`` to the red channel at sphere pixels
    whose surface point lies at distance ``s`` from the plane (and, with
    ``projector``, faces it), before blur and noise are applied by the
    renderer's settings (``blur``, ``noise``: passed through).

    Parameters
    ----------
    K : (3, 3), centre : (3,), radius : float, plane : LightPlane or (4,)
    image_size : (width, height)
    projector : (3,) optional projector centre (camera frame)
    width : float, optional, the light sheet's half-thickness ``w`` (units of
        the radius; default: about 1.2 pixels at the sphere's distance)
    peak : float, laser intensity, grey levels
    rng : numpy Generator or seed
    render_kwargs : passed to :func:`calib.synthetic.render_spheres` (default
        ``colours``: a light-grey ball, as used for laser calibration)

    Returns
    -------
    (H, W, 3) uint8 BGR image.
    """
    from calib.synthetic import render_spheres

    K = _check_K(K)
    pl = _as_plane(plane)
    X = np.asarray(centre, dtype=np.float64).reshape(3)
    g = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    noise = float(render_kwargs.pop("noise", 2.0))
    blur = float(render_kwargs.pop("blur", 0.5))
    render_kwargs.setdefault("colours", [[190.0, 190.0, 185.0]])  # a matte light-grey ball
    geo = render_spheres(K, X[None], radius, image_size, rng=g, return_geometry=True, noise=0.0, blur=0.0, **render_kwargs)
    w = width if width is not None else 1.2 * float(np.linalg.norm(X)) / K[0, 0]
    P, Nrm = geo.points, geo.normals
    s = P @ pl.normal - pl.d
    lit = np.isfinite(s)
    if projector is not None:
        pr = np.asarray(projector, dtype=np.float64).reshape(3)
        lit &= ((pr[None, None] - P) * Nrm).sum(axis=2) > 0
    add = np.where(lit, peak * np.exp(-0.5 * (np.where(lit, s, 0.0) / w) ** 2), 0.0)
    img = geo.image.astype(np.float32)
    img[:, :, 2] += add.astype(np.float32)
    img[:, :, :2] += 0.15 * add[:, :, None].astype(np.float32)
    if blur > 0:
        img = cv2.GaussianBlur(img, (0, 0), blur)
    if noise > 0:
        img = img + g.normal(0.0, noise, img.shape).astype(np.float32)
    return np.clip(np.round(img), 0, 255).astype(np.uint8)
