"""Camera calibration from one-dimensional objects (thesis contribution 2).

Two tools, one result type (:class:`OneDCalibration`):

* :func:`zhang_1d` — the classic baseline (Z. Zhang, "Camera calibration with
  one-dimensional objects", PAMI 26(7), 2004): a rod of known length ``L``
  turns about a fixed end ``A``; its free end ``B`` and a marker
  ``C = (1 - ratio) A + ratio B`` are imaged in N >= 6 views (fewer with a
  stricter camera model). Closed form, then maximum-likelihood refinement.
* :func:`from_two_spheres` — the 1-D object is made of *sphere centres*: one
  sphere (radius ``r``) is imaged at a fixed position ``A`` and at other
  positions ``B_i`` (or two equal spheres, one of them left in place). Each
  pair ``(A, B_i)`` with its midpoint ``M_i`` is a 1-D object of unknown,
  varying length; the sphere images give its image points and its depth
  ratio without knowing ``K``.

Geometry used by :func:`from_two_spheres` (note)
-------------------------------------------------
Let ``C_A``, ``C_B`` be the outlines of two spheres. ``x ~ K X`` for a point
``X`` in the camera frame; ``omega = K^-T K^-1``.

1. *Line of centres* (pole-polar). The outline of a sphere with imaged centre
   ``a`` is ``C_A ~ omega - mu (omega a)(omega a)^T`` (Ying & Zha, PAMI 2006;
   Zhang, Wong & Zhang, PAMI 2007), so the polar of ``a`` is the same line
   w.r.t. ``C_A`` and ``omega``. The two outlines have a common self-polar
   triangle (the generalised eigenvectors of ``(C_A, C_B)``); its vertex
   ``x0`` that lies *outside both outlines* is the vanishing point of the
   normal of the plane (O, A, B), and its polar ``l = C_A x0 ~ C_B x0`` is the
   image of the line ``AB``: it passes through both imaged centres. This
   needs no ``K``.
2. *Imaged centres*. Every pair of sphere positions gives such a line through
   both of its imaged centres, so each imaged centre is the common point of
   the lines of all pairs it belongs to (least squares; >= 2 pairs, not all
   centres coplanar with the camera centre). No ``K``; any radii.
3. *Midpoint and vanishing point* (centres of similitude). For two spheres
   the planes through the camera centre ``O`` tangent to both pass through
   one of the two centres of similitude of the spheres: the common external
   tangents of the outlines meet at the image of the external centre, the
   common internal tangents at the image of the internal centre. For *equal
   radii* the internal centre is the midpoint ``M`` and the external one is
   the point at infinity of ``AB``. In the dual pencil ``C_A^-1 - nu C_B^-1``
   the degenerate member with ``nu = 1 / lambda_0`` (``lambda_0`` the
   eigenvalue of ``x0``) is the point pair ``{m, v}`` on ``l``: the imaged
   midpoint ``m`` and the vanishing point ``v`` of ``AB``. ``m`` is the one
   between the imaged centres. No ``K``; equal radii.
4. *Depth ratio*. With ``a~ = (a, 1)``, ``b~ = (b, 1)`` and depths ``z_A``,
   ``z_B``: ``z_A a~ + z_B b~ ~ m`` (``M`` is the midpoint) and
   ``z_B b~ - z_A a~ ~ v`` (``B - A`` is parallel to ``K^-1 v``). Solving both
   in least squares gives ``k = z_B / z_A`` (the harmonic relation
   ``(a, b; m, v) = -1`` makes them consistent). This is Zhang's 1-D depth
   equation with ratio 1/2. No ``K``.
5. *What needs K*: the lengths ``|B_i - A|`` (and so their ratios), the
   metric depth. A single image pair constrains ``K`` no more than the two
   outlines do: in one camera a sphere of radius ``r`` at ``X`` and one of
   radius ``s r`` at ``s X`` look the same, so equal radii add no constraint
   on ``K`` beyond the sphere images themselves. The closed form therefore
   uses, for every sphere ``j`` with K-free imaged centre ``p_j``,
   ``omega in span{C_j, (C_j p_j)(C_j p_j)^T}`` — four linear equations in
   ``omega`` per sphere (``omega p_j ~ C_j p_j``, and ``omega`` restricted to
   the polar line of ``p_j`` equals ``C_j`` restricted to it: the double
   contact points lie there) — solved by SVD in Hartley-normalised
   coordinates. The metric 1-D object then follows: ``|OA| = r / sin(a_A)``
   from the cone of the fixed sphere, ``B_i = z_A k_i K^-1 b~_i``.
6. *Refinement*: the maximum-likelihood estimate of ``K``, ``A`` and the
   ``B_i`` from the outline points (Sampson distances to the outlines of the
   forward model :func:`calib.sphere.outline_conic`), started from the better
   (by outline residual) of the closed form above and the rank-1 estimate of
   :func:`calib.sphere.intrinsics_from_spheres` (an alternation in the sense
   that ``K`` from the outlines seeds the 1-D reconstruction). The fixed
   sphere is shared by all views, so repeated images of it are pooled.

Honest summary: the imaged centres, midpoints, vanishing points and depth
ratios are K-free; the lengths are not, and no K-free 1-D calibration with
unknown lengths exists for a single camera, so ``K`` comes from the sphere
constraints with the K-free centres (closed form) and the ML refinement.

Conventions (docs/formats.md): OpenCV camera ``x ~ K X`` with ``X`` in the
camera frame (looking down +z), pixels with integer pixel centres; ``K``
upper triangular, ``K[2, 2] = 1``; conics normalised as in
:mod:`geometry.conics` (negative inside). Lengths are in the units of
``length`` (Zhang) or of ``radius`` (spheres).

Round trip of Zhang's method on exact data:

>>> K = np.array([[1000.0, 0.0, 320.0], [0.0, 1000.0, 240.0], [0.0, 0.0, 1.0]])
>>> rng = np.random.default_rng(0)
>>> d = rng.normal(size=(8, 3)); d[:, 2] = -np.abs(d[:, 2])
>>> a, b, c = project_rod(K, [0.0, 35.0, 150.0], d, length=70.0, ratio=0.5)
>>> res = zhang_1d(a, b, c, length=70.0, ratio=0.5)
>>> bool(np.allclose(res.K, K, atol=1e-6))
True
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
import scipy.optimize

from calib._fit import conic_to_vec6, sampson_with_jacobian
from calib.sphere import _K_from_params as _K_of
from calib.sphere import _check_conic, _check_radius
from calib.sphere import _model_name
from calib.sphere import _params_from_K as _params_of
from calib.sphere import centre_direction, intrinsics_from_spheres
from geometry.camera import K_from_iac
from geometry.conics import ellipse_distance, ellipse_from_conic, normalize_conic, split_degenerate_conic
from geometry.lines import hartley_normalization

__all__ = [
    "OneDCalibration",
    "TwoSphereGeometry",
    "project_rod",
    "zhang_1d",
    "two_sphere_geometry",
    "from_two_spheres",
]


# --------------------------------------------------------------------------
# result types
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class TwoSphereGeometry:
    """K-free projective geometry of a sphere at a fixed position ``A`` and at
    positions ``B_i`` (:func:`two_sphere_geometry`). All points in pixels.

    Attributes
    ----------
    fixed_centre : (2,) float64, image of the fixed sphere's centre ``A``
        (not the ellipse centre)
    free_centres : (N, 2) float64, images of the centres ``B_i``
    midpoints : (N, 2) float64, images of the midpoints ``(A + B_i) / 2``
        (internal centres of similitude; equal radii)
    vanishing_points : (N, 3) float64, homogeneous (unit norm), vanishing
        points of the directions ``B_i - A`` (external centres of similitude)
    lines : (N, 3) float64, the image lines ``AB_i`` (``a^2 + b^2 = 1``)
    depth_ratios : (N,) float64, ``z(B_i) / z(A)``, ratio of the depths along
        the optical axis
    """

    fixed_centre: np.ndarray
    free_centres: np.ndarray
    midpoints: np.ndarray
    vanishing_points: np.ndarray
    lines: np.ndarray
    depth_ratios: np.ndarray


@dataclass(frozen=True)
class OneDCalibration:
    """Intrinsics and the 1-D object from :func:`zhang_1d` or :func:`from_two_spheres`.

    All 3-D points are in the camera frame, in the units of the rod length
    (Zhang) or of the sphere radius (spheres).

    Attributes
    ----------
    K : (3, 3) float64, intrinsics (pixels), upper triangular, ``K[2, 2] = 1``
    fixed_point : (3,) float64, the fixed end ``A``
    free_points : (N, 3) float64, the free ends ``B_i``, one per view
    markers : (N, 3) float64, the third points ``C_i`` (the marker; the
        midpoints for spheres)
    lengths : (N,) float64, ``|B_i - A|``
    residual_rms : float, RMS image residual (pixels) at the answer: point
        reprojection errors (Zhang) or distances of the outline points to the
        predicted outlines (spheres)
    per_view_rms : (N,) float64, the same per view
    K_linear : (3, 3) float64, the closed-form estimate (None when it failed —
        no positive-definite IAC — and the refinement started from
        :func:`calib.sphere.intrinsics_from_spheres` instead)
    stage : str, ``"linear"`` or ``"refined"``
    model : str, ``"square_pixels"``, ``"zero_skew"`` or ``"general"``
    method : str, ``"zhang"`` or ``"two_spheres"``
    geometry : TwoSphereGeometry or None, the K-free sphere geometry (spheres only)
    init : str, what seeded the refinement (``"linear"`` or ``"sphere_rank1"``)
    """

    K: np.ndarray
    fixed_point: np.ndarray
    free_points: np.ndarray
    markers: np.ndarray
    lengths: np.ndarray
    residual_rms: float
    per_view_rms: np.ndarray
    K_linear: np.ndarray | None
    stage: str
    model: str
    method: str
    geometry: TwoSphereGeometry | None = field(default=None, repr=False)
    init: str = "linear"

    @property
    def focal(self) -> float:
        """Mean focal length ``(fx + fy) / 2``, pixels."""
        return float(0.5 * (self.K[0, 0] + self.K[1, 1]))

    @property
    def directions(self) -> np.ndarray:
        """(N, 3) float64 unit directions ``(B_i - A) / |B_i - A|``."""
        d = self.free_points - self.fixed_point
        return d / np.linalg.norm(d, axis=1, keepdims=True)


# --------------------------------------------------------------------------
# intrinsics models (shared with calib.structured_light)
# --------------------------------------------------------------------------

_N_PARAMS = {"square_pixels": 3, "zero_skew": 4, "general": 5}


def _iac_basis(model: str) -> np.ndarray:
    """(k, 3, 3) symmetric matrices spanning the IACs of the model. A similarity
    without rotation (Hartley normalisation) keeps an IAC in the span."""

    def e(i, j):
        M = np.zeros((3, 3))
        M[i, j] = M[j, i] = 1.0
        return M

    if model == "square_pixels":
        return np.array([e(0, 0) + e(1, 1), e(0, 2), e(1, 2), e(2, 2)])
    if model == "zero_skew":
        return np.array([e(0, 0), e(1, 1), e(0, 2), e(1, 2), e(2, 2)])
    return np.array([e(0, 0), e(0, 1), e(1, 1), e(0, 2), e(1, 2), e(2, 2)])


def _K_from_omega(omega: np.ndarray, T: np.ndarray, model: str) -> np.ndarray:
    """``K`` in pixels from an IAC in the frame conditioned by ``T`` (pixels -> conditioned)."""
    Kc = K_from_iac(omega)
    K = np.linalg.solve(T, Kc)
    K = K / K[2, 2]
    K[1, 0] = K[2, 0] = K[2, 1] = 0.0
    return _K_of(_params_of(K, model), model)




def _project(K: np.ndarray, X: np.ndarray) -> np.ndarray:
    """Pixels (N, 2) of camera-frame points (N, 3)."""
    x = X @ K.T
    return x[:, :2] / x[:, 2:3]


def _cone_conics(Kinv: np.ndarray, X: np.ndarray, r: float) -> np.ndarray:
    """Outline conics (M, 3, 3) of spheres of radius ``r`` at ``X`` (M, 3): the
    tangent cone ``X X^T - (|X|^2 - r^2) I`` mapped by ``Kinv^T . Kinv`` (the
    forward model of :func:`calib.sphere.outline_conic`, vectorised, unit norm)."""
    q = (X * X).sum(axis=1) - r * r
    Q = X[:, :, None] * X[:, None, :] - q[:, None, None] * np.eye(3)
    C = np.einsum("ki,mkl,lj->mij", Kinv, Q, Kinv)
    return C / np.linalg.norm(C, axis=(1, 2))[:, None, None]


# --------------------------------------------------------------------------
# Zhang's 1-D calibration
# --------------------------------------------------------------------------


def project_rod(K, fixed_point, directions, *, length, ratio):
    """Image points of a rod turning about a fixed end (forward model of :func:`zhang_1d`).

    Parameters
    ----------
    K : (3, 3) float64, intrinsics (pixels)
    fixed_point : (3,) float64, the fixed end ``A``, camera frame
    directions : (N, 3) float64, rod directions (normalised here); ``B = A + length * d``
    length : float, ``|B - A|``
    ratio : float, ``C = (1 - ratio) A + ratio B``

    Returns
    -------
    a, b, c : three (N, 2) float64 arrays, pixels (``a`` repeats ``A``'s image)

    Raises
    ------
    ValueError
        Bad shapes, or a point not in front of the camera.
    """
    K = np.asarray(K, dtype=np.float64)
    A = np.asarray(fixed_point, dtype=np.float64).reshape(-1)
    d = np.atleast_2d(np.asarray(directions, dtype=np.float64))
    if K.shape != (3, 3) or A.shape != (3,) or d.shape[1] != 3:
        raise ValueError("project_rod needs K (3, 3), fixed_point (3,) and directions (N, 3)")
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    B = A + float(length) * d
    C = A + float(ratio) * float(length) * d
    if A[2] <= 0 or np.any(B[:, 2] <= 0) or np.any(C[:, 2] <= 0):
        raise ValueError("every rod point must lie in front of the camera (z > 0)")
    a = np.repeat(_project(K, A[None]), len(d), axis=0)
    return a, _project(K, B), _project(K, C)


def _check_views(a, b, c) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    arrs = []
    for name, p in (("a", a), ("b", b), ("c", c)):
        p = np.asarray(p, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 2:
            raise ValueError(f"{name} must have shape (N, 2) (one image point per view), got {p.shape}")
        if not np.all(np.isfinite(p)):
            raise ValueError(f"{name} has non-finite coordinates")
        arrs.append(p)
    if not (arrs[0].shape == arrs[1].shape == arrs[2].shape):
        raise ValueError(f"a, b and c must have the same number of views, got {len(arrs[0])}, {len(arrs[1])} and {len(arrs[2])}")
    return arrs[0], arrs[1], arrs[2]


def _rank_diagnosis(H: np.ndarray, n_unknowns: int) -> None:
    """Raise the ValueError naming a degenerate set of rod directions ``H`` (N, 3)
    (vanishing points of the rods, conditioned frame)."""
    Hn = H / np.linalg.norm(H, axis=1, keepdims=True)
    s = np.linalg.svd(Hn, compute_uv=False)
    if s[1] < 1e-6 * s[0]:
        raise ValueError("all views have the same rod orientation: the rod must be turned to different directions")
    if s[2] < 1e-6 * s[0]:
        raise ValueError(
            "all rod directions lie in one plane: the 1-D constraints fix only the IAC restricted to that "
            "plane; tilt the rod out of it"
        )


def _zhang_linear(a, b, c, length, ratio, model):
    """Zhang's closed form in Hartley-normalised coordinates.

    Returns (K, z_A, h) with ``h`` (N, 3) the pixel-frame vectors with
    ``B_i - A = -z_A K^-1 h_i``."""
    T = hartley_normalization(np.concatenate([a, b, c]))
    hom = lambda p: np.column_stack([p, np.ones(len(p))]) @ T.T  # noqa: E731
    at, bt, ct = hom(a), hom(b), hom(c)
    lam_a, lam_b = 1.0 - ratio, ratio
    axc = np.cross(at, ct)
    bxc = np.cross(bt, ct)
    den = (bxc * bxc).sum(axis=1)
    bad = np.flatnonzero(den < 1e-18 * (bt * bt).sum(axis=1) * (ct * ct).sum(axis=1))
    if len(bad):
        raise ValueError(f"view {int(bad[0])}: the images of B and C coincide, the rod is seen end-on")
    k = lam_a * (axc * bxc).sum(axis=1) / (lam_b * den)
    wrong = np.flatnonzero(k >= 0)
    if len(wrong):
        raise ValueError(
            f"view {int(wrong[0])}: the points are not in the order the ratio implies "
            f"(C must divide AB with ratio {ratio}); check the a, b, c correspondence"
        )
    h = at + k[:, None] * bt
    basis = _iac_basis(model)
    _rank_diagnosis(h, len(basis))
    M = np.einsum("ni,kij,nj->nk", h, basis, h)
    # h^T x h = L^2 with x = z_A^2 omega; unknown x / L^2
    sol, *_ = np.linalg.lstsq(M, np.ones(len(h)), rcond=None)
    s = np.linalg.svd(M, compute_uv=False)
    if len(s) < len(basis) or s[-1] < 1e-10 * s[0]:
        raise ValueError("the views do not determine K (degenerate rod directions)")
    x = np.einsum("k,kij->ij", sol, basis) * length**2
    if not np.all(np.linalg.eigvalsh(x) > 0):
        raise ValueError(
            "the closed form gives no positive-definite image of the absolute conic: the data are too "
            "noisy or inconsistent with a rod of this length and ratio"
        )
    Kc = K_from_iac(x)
    Kci = np.linalg.inv(Kc)
    omega = Kci.T @ Kci
    zA = float(np.sqrt((x * omega).sum() / (omega * omega).sum()))
    K = _K_from_omega(x, T, model)
    h_px = h @ np.linalg.inv(T).T
    return K, zA, h_px


def _tangent_basis(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (N, 3) orthogonal to the unit vectors ``u`` (N, 3) and to each other."""
    ref = np.where(np.abs(u[:, [0]]) < 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    e1 = np.cross(u, ref)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, np.cross(u, e1)


def _proj_jac(K: np.ndarray, X: np.ndarray, model: str):
    """Pixels (N, 2), d pixels / d K-params (N, 2, k) and d pixels / d X (N, 2, 3)."""
    fx, s, fy = K[0, 0], K[0, 1], K[1, 1]
    Z = X[:, 2]
    xn, yn = X[:, 0] / Z, X[:, 1] / Z
    uv = np.stack([fx * xn + s * yn + K[0, 2], fy * yn + K[1, 2]], axis=1)
    N = len(X)
    one, zero = np.ones(N), np.zeros(N)
    if model == "square_pixels":
        dK = np.stack([np.stack([xn, one, zero], 1), np.stack([yn, zero, one], 1)], 1)
    elif model == "zero_skew":
        dK = np.stack([np.stack([xn, zero, one, zero], 1), np.stack([zero, yn, zero, one], 1)], 1)
    else:
        dK = np.stack([np.stack([xn, zero, yn, one, zero], 1), np.stack([zero, yn, zero, zero, one], 1)], 1)
    dX = np.zeros((N, 2, 3))
    dX[:, 0, 0] = fx / Z
    dX[:, 0, 1] = s / Z
    dX[:, 0, 2] = -(fx * X[:, 0] + s * X[:, 1]) / Z**2
    dX[:, 1, 1] = fy / Z
    dX[:, 1, 2] = -fy * X[:, 1] / Z**2
    return uv, dK, dX


def _zhang_refine(K0, A0, u0, a, b, c, length, ratio, model, max_nfev):
    """Maximum-likelihood refinement over K, A and the rod directions."""
    N = len(a)
    nK = _N_PARAMS[model]
    e1, e2 = _tangent_basis(u0)
    obs = np.concatenate([a, b, c], axis=1).reshape(-1)  # per view: a, b, c

    def unpack(x):
        K = _K_of(x[:nK], model)
        A = x[nK : nK + 3]
        w = x[nK + 3 :].reshape(N, 2)
        g = u0 + w[:, :1] * e1 + w[:, 1:] * e2
        gn = np.linalg.norm(g, axis=1, keepdims=True)
        return K, A, g / gn, gn

    def points(K, A, u):
        return A[None], A + length * u, A + ratio * length * u

    def fun(x):
        K, A, u, _ = unpack(x)
        PA, PB, PC = points(K, A, u)
        pa = np.repeat(_project(K, PA), N, axis=0)
        pred = np.concatenate([pa, _project(K, PB), _project(K, PC)], axis=1).reshape(-1)
        return pred - obs

    def jac(x):
        K, A, u, gn = unpack(x)
        PA, PB, PC = points(K, A, u)
        J = np.zeros((6 * N, len(x)))
        rows = np.arange(N) * 6
        _, dKa, dXa = _proj_jac(K, PA, model)
        # du/dw: (I - u u^T) / |g| [e1 e2]
        P = (np.eye(3)[None] - u[:, :, None] * u[:, None, :]) / gn[:, :, None]
        dudw = np.stack([np.einsum("nij,nj->ni", P, e1), np.einsum("nij,nj->ni", P, e2)], axis=2)  # (N, 3, 2)
        for off, X, scale in ((2, PB, length), (4, PC, ratio * length)):
            _, dK, dX = _proj_jac(K, X, model)
            for q in range(2):
                J[rows + off + q, :nK] = dK[:, q]
                J[rows + off + q, nK : nK + 3] = dX[:, q]
                dw = scale * np.einsum("nj,njk->nk", dX[:, q], dudw)
                J[rows + off + q, nK + 3 + 2 * np.arange(N)] = dw[:, 0]
                J[rows + off + q, nK + 4 + 2 * np.arange(N)] = dw[:, 1]
        for q in range(2):
            J[rows + q, :nK] = dKa[0, q]
            J[rows + q, nK : nK + 3] = dXa[0, q]
        return J

    x0 = np.concatenate([_params_of(K0, model), A0, np.zeros(2 * N)])
    sol = scipy.optimize.least_squares(fun, x0, jac=jac, method="lm", x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=max_nfev)
    K, A, u, _ = unpack(sol.x)
    return K, A, u, sol.fun


def _min_views(model: str) -> int:
    # unknowns of the closed form: the IAC entries with the scale z_A^2 (inhomogeneous)
    return len(_iac_basis(model))


def zhang_1d(
    a,
    b,
    c,
    *,
    length: float,
    ratio: float,
    square_pixels: bool = False,
    zero_skew: bool = True,
    refine: bool = True,
    max_nfev: int = 200,
) -> OneDCalibration:
    """1-D calibration with a rod turning about a fixed point (Zhang, PAMI 2004).

    The rod's fixed end ``A`` (unknown, camera frame), its free end ``B_i``
    with ``|B_i - A| = length`` and the marker ``C_i = (1 - ratio) A + ratio
    B_i`` are imaged in N views. With ``lambda_A = 1 - ratio``,
    ``lambda_B = ratio`` and homogeneous image points ``a~, b~, c~``
    (w = 1), the depths satisfy ``z_C c~ = lambda_A z_A a~ + lambda_B z_B b~``,
    hence ``z_B = -z_A k`` with ``k = lambda_A (a~ x c~).(b~ x c~) /
    (lambda_B |b~ x c~|^2)``, and ``B - A = -z_A K^-1 h`` with
    ``h = a~ + k b~``. The known length gives one linear equation per view in
    the entries of ``x = z_A^2 omega`` (``omega = K^-T K^-1``):
    ``h^T x h = length^2``. Solved in Hartley-normalised coordinates, ``K``
    follows by Cholesky and ``z_A`` from the scale. Then Levenberg-Marquardt
    over ``K``, ``A`` and each view's rod direction minimises the
    reprojection error of all ``a``, ``b``, ``c`` (analytic Jacobian).

    Parameters
    ----------
    a, b, c : (N, 2) float64, pixels: images of ``A`` (one per view: it is
        re-measured in every view), ``B_i`` and ``C_i``
    length : float, ``|B - A|`` (sets the units of the 3-D answer)
    ratio : float, ``|A C| / |A B|`` (0.5: the marker is the midpoint);
        ``C`` may lie outside the segment, but not at ``A`` or ``B``
    square_pixels : bool, model ``fx = fy``, zero skew (3 unknowns; N >= 4)
    zero_skew : bool, model zero skew (4 unknowns; N >= 5; the default).
        False: the paper's general model with skew (5 unknowns; N >= 6)
    refine : bool, run the nonlinear refinement
    max_nfev : int, iteration cap of the refinement

    Returns
    -------
    OneDCalibration (``method == "zhang"``)

    Raises
    ------
    ValueError
        Bad shapes or values; too few views for the model; all views with
        the same rod orientation, or all rods in one plane; points in the
        wrong order for ``ratio``; no positive-definite IAC.
    """
    model = _model_name(square_pixels, zero_skew)
    a, b, c = _check_views(a, b, c)
    try:
        length = float(length)
        ratio = float(ratio)
    except (TypeError, ValueError):
        raise ValueError("length and ratio must be numbers") from None
    if not (np.isfinite(length) and length > 0):
        raise ValueError(f"length must be positive and finite, got {length}")
    if not np.isfinite(ratio) or abs(ratio) < 1e-6 or abs(ratio - 1.0) < 1e-6:
        raise ValueError(f"ratio must be finite and the marker must differ from A and B (ratio not 0 or 1), got {ratio}")
    n_min = _min_views(model)
    if len(a) < n_min:
        raise ValueError(f"too few views: the {model} model needs at least {n_min}, got {len(a)}")
    K_lin, zA, h = _zhang_linear(a, b, c, length, ratio, model)
    Ki = np.linalg.inv(K_lin)
    a_mean = np.append(a.mean(axis=0), 1.0)
    A0 = zA * (Ki @ a_mean)
    u0 = -(h @ Ki.T)
    u0 /= np.linalg.norm(u0, axis=1, keepdims=True)
    if refine:
        K, A, u, res = _zhang_refine(K_lin, A0, u0, a, b, c, length, ratio, model, max_nfev)
        stage = "refined"
    else:
        K, A, u = K_lin, A0, u0
        stage = "linear"
    B = A + length * u
    C = A + ratio * length * u
    pa = np.repeat(_project(K, A[None]), len(a), axis=0)
    r2 = ((pa - a) ** 2).sum(1) + ((_project(K, B) - b) ** 2).sum(1) + ((_project(K, C) - c) ** 2).sum(1)
    return OneDCalibration(
        K=K,
        fixed_point=A,
        free_points=B,
        markers=C,
        lengths=np.full(len(a), length),
        residual_rms=float(np.sqrt(r2.sum() / (3 * len(a)))),
        per_view_rms=np.sqrt(r2 / 3.0),
        K_linear=K_lin,
        stage=stage,
        model=model,
        method="zhang",
    )


# --------------------------------------------------------------------------
# K-free geometry of sphere pairs
# --------------------------------------------------------------------------




def _pair_line(C1: np.ndarray, C2: np.ndarray):
    """Vertex ``x0`` of the common self-polar triangle of two outlines (conditioned
    frame) lying outside both, its eigenvalue ``lam`` (``C1 x0 = lam C2 x0``)
    and its polar line ``l`` (unit norm). None when no vertex lies clearly
    outside both (nested outlines: one sphere hides the other)."""
    try:
        w, V = scipy.linalg.eig(C1, C2)
    except (np.linalg.LinAlgError, ValueError):
        return None
    best = None
    for k in range(3):
        lam = w[k]
        if not np.isfinite(lam) or abs(lam.imag) > 1e-7 * max(1.0, abs(lam)):
            continue
        x = np.real(V[:, k])
        x = x / np.linalg.norm(x)
        q = min(x @ C1 @ x, x @ C2 @ x)
        if best is None or q > best[0]:
            best = (q, float(lam.real), x)
    if best is None or best[0] <= 1e-9 or best[1] <= 0:
        return None
    _, lam, x0 = best
    l = C1 @ x0
    return x0, lam, l / np.linalg.norm(l)


def _nested(C1: np.ndarray, C2: np.ndarray) -> bool:
    """Whether one outline lies entirely inside the other (a hidden sphere)."""
    for A, B in ((C1, C2), (C2, C1)):
        p = ellipse_from_conic(A).points(64)
        X = np.column_stack([p, np.ones(len(p))])
        if np.all(np.einsum("ni,ij,nj->n", X, B, X) < 0):
            return True
    return False


def _similitude_points(C1: np.ndarray, C2: np.ndarray, lam: float):
    """The real point pair of the degenerate dual conic ``C1^-1 - C2^-1 / lam``:
    the images of the two centres of similitude, (2, 3) unit vectors; None when
    the pair is not real."""
    D = np.linalg.inv(C1) - np.linalg.inv(C2) / lam
    D = 0.5 * (D + D.T)
    ev = np.linalg.eigvalsh(D)
    big = ev[np.argsort(np.abs(ev))[1:]]
    if big[0] * big[1] >= 0:
        return None
    g, h = split_degenerate_conic(D)
    out = []
    for p in (g, h):
        k = np.argmax(np.abs(p))
        p = p * (np.conj(p[k]) / abs(p[k]))
        q = np.real(p)
        out.append(q / np.linalg.norm(q))
    return np.array(out)


def _concurrent_point(lines: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares common point (3,) of lines (L, 3) and the ratio of the two
    smallest singular values' second to the largest (0 when undetermined)."""
    Ln = lines / np.linalg.norm(lines, axis=1, keepdims=True)
    _, s, Vt = np.linalg.svd(Ln)
    if len(s) < 2:
        return Vt[-1], 0.0
    return Vt[-1], float(s[1] / s[0])


def _conditioning(Cs: np.ndarray) -> np.ndarray:
    pts = np.concatenate([ellipse_from_conic(C).points(8) for C in Cs])
    return hartley_normalization(pts)


def _to_frame(T: np.ndarray, Cs: np.ndarray) -> np.ndarray:
    Ti = np.linalg.inv(T)
    return np.array([normalize_conic(Ti.T @ C @ Ti) for C in Cs])


def _centres_from_pairs(Cn: np.ndarray, required_pairs_with: int | None = None):
    """Imaged centres (M, 3), w = 1, of spheres with outlines ``Cn`` (conditioned
    frame, M >= 3): each is the common point of the lines of centres of all
    pairs it belongs to. Also returns the pairs' ``(x0, lam, line)`` by pair.
    Pairs with sphere ``required_pairs_with`` must all be usable."""
    M = len(Cn)
    lines = {}
    for i, j in itertools.combinations(range(M), 2):
        pl = _pair_line(Cn[i], Cn[j])
        if pl is None:
            if i == required_pairs_with:
                raise ValueError(
                    f"view {j - 1}: one sphere image lies (almost) inside the other (one sphere hides the "
                    "other): the pair gives no line of centres"
                )
            continue
        lines[(i, j)] = pl
    centres = np.empty((M, 3))
    for i in range(M):
        L = np.array([lines[k][2] for k in lines if i in k])
        if len(L) < 2:
            raise ValueError("too few usable sphere pairs to locate the imaged sphere centres")
        p, cond = _concurrent_point(L)
        if cond < 1e-6 or abs(p[2]) < 1e-12:
            raise ValueError(
                "the sphere positions and the camera centre are coplanar (e.g. all moves along one line "
                "or all views with the same orientation): the imaged centres are undetermined"
            )
        centres[i] = p / p[2]
    return centres, lines


def _closed_form_K(conics: np.ndarray, model: str) -> np.ndarray:
    """Closed-form ``K`` (pixels) from three or more sphere outlines (pixels) via
    their K-free imaged centres (module note, items 2 and 5). Raises ValueError."""
    T = _conditioning(conics)
    Cn = _to_frame(T, conics)
    centres, _ = _centres_from_pairs(Cn)
    omega = _linear_iac_from_centres(Cn, centres, model)
    if not np.all(np.linalg.eigvalsh(omega) > 0):
        raise ValueError("the closed form gives no positive-definite image of the absolute conic")
    return _K_from_omega(omega, T, model)


def _kfree_geometry(Cn: np.ndarray):
    """K-free geometry in the conditioned frame; sphere 0 is the fixed one.

    Returns (centres (M, 3) homogeneous with w = 1, midpoints (N, 3),
    vanishing points (N, 3), lines (N, 3), depth ratios (N,))."""
    M = len(Cn)
    for j in range(1, M):
        if _nested(Cn[0], Cn[j]):
            raise ValueError(
                f"view {j - 1}: one sphere image lies (almost) inside the other (one sphere hides the "
                "other): the pair gives no line of centres"
            )
    centres, lines = _centres_from_pairs(Cn, required_pairs_with=0)
    a = centres[0]
    N = M - 1
    mids = np.empty((N, 3))
    vps = np.empty((N, 3))
    lns = np.empty((N, 3))
    ks = np.empty(N)
    for i in range(N):
        _, lam, l = lines[(0, i + 1)]
        pts = _similitude_points(Cn[0], Cn[i + 1], lam)
        if pts is None:
            raise ValueError(f"view {i}: the centres of similitude of the two sphere images are not real (inconsistent outlines)")
        b = centres[i + 1]
        # m lies between the imaged centres, v outside the segment
        d = b[:2] - a[:2]
        ts = []
        for p in pts:
            if abs(p[2]) < 1e-12:
                ts.append(np.inf)
            else:
                ts.append(float((p[:2] / p[2] - a[:2]) @ d / (d @ d)))
        inside = [0.0 < t < 1.0 for t in ts]
        if inside[0] == inside[1]:
            raise ValueError(
                f"view {i}: cannot tell the imaged midpoint from the vanishing point (the spheres nearly "
                "line up with the camera)"
            )
        m, v = (pts[0], pts[1]) if inside[0] else (pts[1], pts[0])
        m = m / m[2]
        # z_A a + z_B b ~ m and z_B b - z_A a ~ v, with z_A = 1: unknowns (k, mu, nu)
        Mx = np.zeros((6, 3))
        Mx[:3, 0], Mx[:3, 1] = b, -m
        Mx[3:, 0], Mx[3:, 2] = b, -v
        rhs = np.concatenate([-a, a])
        sol, *_ = np.linalg.lstsq(Mx, rhs, rcond=None)
        if not sol[0] > 0:
            raise ValueError(f"view {i}: negative depth ratio: the sphere images are inconsistent")
        mids[i], vps[i], lns[i], ks[i] = m, v, l, sol[0]
    return centres, mids, vps, lns, ks


def _as_conic_list(conics, name: str, min_count: int = 1) -> np.ndarray:
    try:
        n = len(conics)
    except TypeError:
        raise ValueError(f"{name} must be a sequence of 3x3 conic matrices") from None
    arr = np.asarray(conics, dtype=np.float64) if n else np.zeros((0, 3, 3))
    if arr.ndim == 2 and arr.shape == (3, 3):
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[1:] != (3, 3):
        raise ValueError(f"{name} must hold 3x3 conic matrices, got shape {arr.shape}")
    if len(arr) < min_count:
        raise ValueError(f"{name} needs at least {min_count} conics, got {len(arr)}")
    return np.array([_check_conic(C, f"{name}[{i}]") for i, C in enumerate(arr)])


def _mean_conic(Cs: np.ndarray) -> np.ndarray:
    return normalize_conic(np.mean([normalize_conic(C) for C in Cs], axis=0))


def two_sphere_geometry(fixed, moving) -> TwoSphereGeometry:
    """K-free image geometry of a sphere at a fixed position and at other positions.

    See the module note: imaged centres from the lines of centres of all
    pairs (pole-polar), imaged midpoints and vanishing points from the
    centres of similitude (dual pencil), depth ratios from the 1-D relation.

    Parameters
    ----------
    fixed : (3, 3) conic, or (N, 3, 3) outlines of the sphere at the fixed
        position (one per view; they are averaged), pixels
    moving : (N, 3, 3) outlines of the sphere (same radius) at the other
        positions, N >= 2, pixels

    Returns
    -------
    TwoSphereGeometry (pixels)

    Raises
    ------
    ValueError
        Fewer than 2 moved positions; a conic that is not an ellipse; one
        sphere hiding the other; all positions coplanar with the camera
        centre (e.g. all moves along one line).
    """
    Cf = _as_conic_list(fixed, "fixed")
    Cm = _as_conic_list(moving, "moving")
    if len(Cm) < 2:
        raise ValueError(f"too few views: the 1-D object from two spheres needs at least 2 moved positions, got {len(Cm)}")
    Cs = np.concatenate([_mean_conic(Cf)[None], Cm])
    for i in range(len(Cm)):
        if min(np.linalg.norm(Cs[0] - Cm[i]), np.linalg.norm(Cs[0] + Cm[i])) < 1e-9:
            raise ValueError(f"moving[{i}] is the fixed sphere's outline: the sphere was not moved")
    T = _conditioning(Cs)
    Cn = _to_frame(T, Cs)
    centres, mids, vps, lns, ks = _kfree_geometry(Cn)
    return _geometry_in_pixels(T, centres, mids, vps, lns, ks)


def _geometry_in_pixels(T, centres, mids, vps, lns, ks) -> TwoSphereGeometry:
    Ti = np.linalg.inv(T)
    c = centres @ Ti.T
    m = mids @ Ti.T
    v = vps @ Ti.T
    l = lns @ T
    l = l / np.hypot(l[:, 0], l[:, 1])[:, None]
    return TwoSphereGeometry(
        fixed_centre=c[0, :2] / c[0, 2],
        free_centres=c[1:, :2] / c[1:, 2:3],
        midpoints=m[:, :2] / m[:, 2:3],
        vanishing_points=v / np.linalg.norm(v, axis=1, keepdims=True),
        lines=l,
        depth_ratios=ks.copy(),
    )


# --------------------------------------------------------------------------
# from two spheres: closed form and refinement
# --------------------------------------------------------------------------


def _linear_iac_from_centres(Cn: np.ndarray, P: np.ndarray, model: str) -> np.ndarray:
    """IAC (conditioned frame) from outlines ``Cn`` (M, 3, 3) and imaged centres
    ``P`` (M, 3): ``omega in span{C, (C p)(C p)^T}``, four equations per sphere."""
    basis = _iac_basis(model)
    rows = []
    for C, p in zip(Cn, P):
        p = p / np.linalg.norm(p)
        n = C @ p
        n = n / np.linalg.norm(n)
        U = np.linalg.svd(n[None])[2][1:].T  # (3, 2): points on the polar line of p
        e, W = np.linalg.eigh(U.T @ C @ U)
        U = U @ W
        F = np.column_stack([U, p])
        Bf = np.einsum("ia,kij,jb->kab", F, basis, F)  # basis in the frame (u1, u2, p)
        sc = np.hypot(e[0], e[1])
        rows.extend([Bf[:, 0, 2], Bf[:, 1, 2], Bf[:, 0, 1], (e[1] * Bf[:, 0, 0] - e[0] * Bf[:, 1, 1]) / sc])
    A = np.array(rows)
    _, s, Vt = np.linalg.svd(A)
    if len(s) < len(basis) or s[len(basis) - 2] < 1e-9 * s[0]:
        raise ValueError("the sphere images do not determine K (degenerate configuration)")
    omega = np.einsum("k,kij->ij", Vt[-1], basis)
    return omega if np.trace(omega) > 0 else -omega


def _outline_points(Cs: np.ndarray, pts, n: int = 100) -> list[np.ndarray]:
    if pts is not None:
        return pts
    return [ellipse_from_conic(C).points(n) for C in Cs]


def _check_points_list(pts, n: int, name: str):
    if pts is None:
        return None
    if len(pts) != n:
        raise ValueError(f"{name} must hold one (n, 2) array per conic: {n} conics, {len(pts)} arrays")
    out = []
    for i, p in enumerate(pts):
        p = np.asarray(p, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 2 or len(p) < 5:
            raise ValueError(f"{name}[{i}] must have shape (n, 2) with n >= 5, got {p.shape}")
        if not np.all(np.isfinite(p)):
            raise ValueError(f"{name}[{i}] has non-finite coordinates")
        out.append(p)
    return out


def _sphere_ml(K0, X0, obs_pts, obs_sphere, r, model, max_nfev):
    """ML refinement of K and sphere centres ``X0`` (M, 3) from outline points.

    ``obs_pts`` is a list of (n, 2) arrays, ``obs_sphere`` the sphere index of
    each. Returns (K, X, per-observation RMS orthogonal distance, total RMS)."""
    nK = _N_PARAMS[model]
    M = len(X0)
    pts = np.concatenate(obs_pts)
    sph = np.concatenate([np.full(len(p), s) for p, s in zip(obs_pts, obs_sphere)])

    def conics(x):
        K = _K_of(x[:nK], model)
        X = x[nK:].reshape(M, 3)
        return _cone_conics(np.linalg.inv(K), X, r)

    def fun(x):
        return sampson_with_jacobian(pts, sph, conics(x), jac=False)

    def jac(x):
        C = conics(x)
        _, J6 = sampson_with_jacobian(pts, sph, C)
        J = np.zeros((len(pts), len(x)))
        for k in range(nK):
            h = 1e-6 * max(1.0, abs(x[k]))
            xp, xm = x.copy(), x.copy()
            xp[k] += h
            xm[k] -= h
            dC = (conic_to_vec6(conics(xp)) - conic_to_vec6(conics(xm))) / (2 * h)
            J[:, k] = np.einsum("nc,nc->n", J6, dC[sph])
        K = _K_of(x[:nK], model)
        Ki = np.linalg.inv(K)
        X = x[nK:].reshape(M, 3)
        h = 1e-7 * max(1.0, float(np.abs(X).max()))
        for q in range(3):
            E = np.zeros_like(X)
            E[:, q] = h
            dC = (conic_to_vec6(_cone_conics(Ki, X + E, r)) - conic_to_vec6(_cone_conics(Ki, X - E, r))) / (2 * h)
            J[np.arange(len(pts)), nK + 3 * sph + q] = np.einsum("nc,nc->n", J6, dC[sph])
        return J

    x0 = np.concatenate([_params_of(K0, model), X0.ravel()])
    sol = scipy.optimize.least_squares(fun, x0, jac=jac, method="lm", x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=max_nfev)
    K = _K_of(sol.x[:nK], model)
    X = sol.x[nK:].reshape(M, 3)
    return K, X


def _outline_rms(K, X, r, obs_pts, obs_sphere) -> tuple[np.ndarray, float]:
    """Per-observation RMS orthogonal distance (pixels) of outline points to the
    outlines of spheres ``X`` under ``K``, and the overall RMS."""
    C = _cone_conics(np.linalg.inv(K), X, r)
    per = np.empty(len(obs_pts))
    sq, n = 0.0, 0
    for o, (p, s) in enumerate(zip(obs_pts, obs_sphere)):
        try:
            d = ellipse_distance(p, ellipse_from_conic(C[s]))
        except ValueError:
            per[o] = np.inf
            sq, n = np.inf, n + len(p)
            continue
        per[o] = np.sqrt(np.mean(d * d))
        sq += float(d @ d)
        n += len(p)
    return per, float(np.sqrt(sq / n))


def _metric_1d(K, Cf, a, b, ks, r):
    """The 1-D object in metric units from K and the K-free geometry: ``|OA|``
    from the fixed sphere's cone, ``B_i = z_A k_i K^-1 b~_i``."""
    Ki = np.linalg.inv(K)
    _, half = centre_direction(K, Cf)
    dA = Ki @ np.append(a, 1.0)
    A = dA / np.linalg.norm(dA) * (r / np.sin(half))
    B = (A[2] * ks)[:, None] * (np.column_stack([b, np.ones(len(b))]) @ Ki.T)
    return A, B


def from_two_spheres(
    fixed,
    moving,
    *,
    radius: float,
    fixed_points=None,
    moving_points=None,
    square_pixels: bool = False,
    zero_skew: bool = True,
    refine: bool = True,
    max_nfev: int = 100,
) -> OneDCalibration:
    """Calibrate from a sphere imaged at a fixed position and moved to others.

    The centres ``A`` (fixed) and ``B_i`` (moved) with the midpoints ``M_i``
    form 1-D objects of unknown, varying length. Steps (details and
    references in the module note):

    1. K-free: imaged centres ``a``, ``b_i`` (common points of the lines of
       centres of all pairs, each the polar of the outside vertex of the
       pair's common self-polar triangle), imaged midpoints ``m_i`` and
       vanishing points ``v_i`` (images of the centres of similitude: the
       real point pair of a degenerate member of the dual pencil), depth
       ratios ``k_i = z(B_i) / z(A)`` from ``z_A a~ + z_B b~ ~ m`` and
       ``z_B b~ - z_A a~ ~ v`` (:func:`two_sphere_geometry`).
    2. Closed form: ``omega`` from ``omega in span{C_j, (C_j p_j)(C_j
       p_j)^T}`` for every sphere with its K-free imaged centre ``p_j``
       (linear, Hartley-normalised); then the metric 1-D objects: ``|OA| = r /
       sin(half-angle)`` of the fixed sphere's cone, ``B_i = z_A k_i K^-1
       b~_i`` — the lengths and their ratios follow.
    3. Refinement (``refine``): maximum likelihood over ``K``, ``A`` and every
       ``B_i`` on the outline points (the given edge points, or 100 points
       sampled on each measured outline), started from the closed form or
       from :func:`calib.sphere.intrinsics_from_spheres` (rank-1 stage),
       whichever fits the outlines better after step 2's reconstruction.

    Assumptions: both positions show the *same* sphere (or two spheres of
    equal radius ``radius``); one camera with fixed intrinsics; outlines
    not nested (neither sphere hides the other); the moves not all in one
    plane through the camera centre.

    Parameters
    ----------
    fixed : (3, 3) conic (pixels) of the sphere at the fixed position, or
        (N, 3, 3): one outline per view (two spheres per image; the fixed
        one is re-measured in every view and the measurements are pooled)
    moving : (N, 3, 3) conics (pixels) of the sphere at the N >= 2 other positions
    radius : float, the sphere radius (sets the units of the 3-D answer)
    fixed_points : (n, 2) array, or a list of them (one per fixed conic),
        optional: edge points the fixed outline(s) were fitted to
    moving_points : list of N (n_i, 2) arrays, optional: edge points of the
        moved outlines
    square_pixels, zero_skew : the intrinsics model (as in :mod:`calib.sphere`)
    refine : bool, run step 3
    max_nfev : int, iteration cap of the refinement

    Returns
    -------
    OneDCalibration (``method == "two_spheres"``; ``markers`` are the
    midpoints; ``geometry`` holds the K-free quantities of step 1;
    ``residual_rms`` is the RMS distance of the outline points to the
    predicted outlines, pixels)

    Raises
    ------
    ValueError
        Fewer than 2 moved positions; a conic that is not an ellipse; the
        sphere not moved; one sphere hiding the other; all positions coplanar
        with the camera centre (e.g. every move along the same direction);
        mismatched edge points; no positive-definite IAC.
    """
    model = _model_name(square_pixels, zero_skew)
    r = _check_radius(radius)
    Cf = _as_conic_list(fixed, "fixed")
    Cm = _as_conic_list(moving, "moving")
    if fixed_points is not None and not isinstance(fixed_points, (list, tuple)):
        fp = np.asarray(fixed_points, dtype=np.float64)
        fixed_points = [fp] if fp.ndim == 2 else list(fp)
    fixed_points = _check_points_list(fixed_points, len(Cf), "fixed_points")
    moving_points = _check_points_list(moving_points, len(Cm), "moving_points")
    geom = two_sphere_geometry(Cf, Cm)
    N = len(Cm)
    Cfm = _mean_conic(Cf)
    Cs = np.concatenate([Cfm[None], Cm])
    T = _conditioning(Cs)
    Cn = _to_frame(T, Cs)
    P = np.column_stack([np.vstack([geom.fixed_centre, geom.free_centres]), np.ones(N + 1)]) @ T.T
    # observations for residuals / refinement: fixed outline(s) -> sphere 0
    obs_pts = _outline_points(Cf, fixed_points) + _outline_points(Cm, moving_points)
    obs_sph = [0] * len(Cf) + list(range(1, N + 1))

    def seed(K):
        A, B = _metric_1d(K, Cfm, geom.fixed_centre, geom.free_centres, geom.depth_ratios, r)
        X = np.vstack([A[None], B])
        return X, _outline_rms(K, X, r, obs_pts, obs_sph)[1]

    K_lin, X_lin, rms_lin, closed_error = None, None, np.inf, None
    try:
        omega = _linear_iac_from_centres(Cn, P, model)
        if not np.all(np.linalg.eigvalsh(omega) > 0):
            raise ValueError(
                "the closed form gives no positive-definite image of the absolute conic: the sphere images "
                "constrain K too weakly or are inconsistent"
            )
        K_lin = _K_from_omega(omega, T, model)
        X_lin, rms_lin = seed(K_lin)
    except ValueError as exc:
        if not refine:
            raise
        closed_error = exc
    K0, X0, init = K_lin, X_lin, "linear"
    if refine:
        try:
            # one outline per sphere position (repeated images of the fixed sphere pooled)
            alt = intrinsics_from_spheres(Cs, square_pixels=square_pixels, zero_skew=zero_skew).K
            X_alt, rms_alt = seed(alt)
            if rms_alt < rms_lin:
                K0, X0, init = alt, X_alt, "sphere_rank1"
        except ValueError:
            if closed_error is not None:
                raise closed_error from None
        K, X = _sphere_ml(K0, X0, obs_pts, obs_sph, r, model, max_nfev)
        stage = "refined"
    else:
        K, X = K_lin, X_lin
        stage = "linear"
    per_obs, rms = _outline_rms(K, X, r, obs_pts, obs_sph)
    # per view: the moved outline, plus the fixed one when it was re-measured in that view
    per_view = per_obs[len(Cf) :].copy()
    if len(Cf) == N:
        per_view = np.sqrt(0.5 * (per_view**2 + per_obs[:N] ** 2))
    A, B = X[0], X[1:]
    return OneDCalibration(
        K=K,
        fixed_point=A,
        free_points=B,
        markers=0.5 * (A + B),
        lengths=np.linalg.norm(B - A, axis=1),
        residual_rms=rms,
        per_view_rms=per_view,
        K_linear=K_lin,
        stage=stage,
        model=model,
        method="two_spheres",
        geometry=geom,
        init=init,
    )
