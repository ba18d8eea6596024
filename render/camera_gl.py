"""OpenCV cameras as OpenGL matrices, and the readback convention.

Conventions
-----------
* ``geometry.camera.Camera`` is OpenCV's: ``x ~ K (R X + t)`` with
  ``R = R_cam_from_world``, camera looking down +z, image x right, y down,
  pixel centres at integer coordinates.
* GL eye space looks down -z with y up. :func:`view_from_Rt` is
  ``diag(1, -1, -1, 1) @ [[R, t], [0, 1]]`` (the OpenCV->GL axis flip of y and z).
* **Readback (the one place it is decided)**: GL numbers framebuffer rows
  bottom-up and ``glReadPixels`` returns the bottom row first. Instead of
  flipping the image after reading it back, :func:`projection_from_K` maps
  image row ``v`` to framebuffer row ``v`` (NDC y = -1 at the *top* of the
  image). Memory read back is then in image order, top row first, with no
  copy; ``gl_FragCoord.xy`` equals the OpenCV pixel coordinate plus 0.5 in
  both axes, so screen-space lookups (the grass matte) use the image's own
  row order. The price: triangles seen from the front wind clockwise on
  screen, so face culling must stay off (it is, everywhere in ``render``).
* Pixel centres: OpenCV pixel ``(u, v)`` is GL window coordinate
  ``(u + 0.5, v + 0.5)``; the projection includes that half-pixel shift, so
  a vertex at pixel ``(u, v)`` in ``Camera.project`` lands exactly there.

Lens distortion
---------------
``Camera.dist = (k1, k2, ...)`` is radial on normalised coordinates
(``geometry.camera.distort_normalized``). The renderer applies the same model
per vertex (:func:`distortion_scale` is the numpy twin of the shader) by
scaling eye-space x, y before the projection; flat objects are tessellated
finely (<= 0.5 m edges) so the straight edges between distorted vertices
follow the curved image of straight pitch lines. Beyond the radius where
``r (1 + k1 r^2 + ...)`` stops increasing the polynomial would fold back on
itself, so ``r^2`` is clamped there (:func:`radial_limit`); such points are
far outside any broadcast frame.

>>> import numpy as np
>>> from geometry.camera import Camera, intrinsic_matrix, rotation_from_ptr
>>> cam = Camera(intrinsic_matrix(1500.0, 655.5, 349.0), rotation_from_ptr(0.1, 0.35, 0.0), [0.0, 5.0, 60.0])
>>> X = np.array([[3.0, -2.0, 0.0], [10.0, 5.0, 2.0]])
>>> px = pixels_from_clip(clip_from_world(cam, X, 1280, 720), 1280, 720)
>>> bool(np.allclose(px, cam.project(X), atol=1e-9))
True
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "MAX_DIST_COEFFS",
    "projection_from_K",
    "view_from_Rt",
    "radial_limit",
    "distortion_scale",
    "clip_from_world",
    "pixels_from_clip",
]

#: Radial coefficients the vertex shader supports (k1..k4).
MAX_DIST_COEFFS = 4

_GL_FROM_CV = np.diag([1.0, -1.0, -1.0, 1.0])


def projection_from_K(K, width: int, height: int, near: float, far: float) -> np.ndarray:
    """GL projection (4, 4) float64 from OpenCV intrinsics, GL eye space -> clip space.

    Any principal point, skew and aspect ratio in ``K``. Rows come out
    top-down on readback (see the module docstring): image row ``v`` maps to
    framebuffer row ``v``.

    Parameters
    ----------
    K : (3, 3) intrinsics in pixels, ``K[2, 2] == 1``
    width, height : int, image size in pixels
    near, far : float, clip distances along the optical axis (metres), 0 < near < far

    Returns
    -------
    (4, 4) float64 ``P`` with ``clip = P @ eye_gl``; NDC x = -1 .. 1 spans image
    columns -0.5 .. width - 0.5, NDC y = -1 .. 1 spans rows -0.5 .. height - 0.5.
    """
    K = np.asarray(K, dtype=np.float64)
    if K.shape != (3, 3) or not np.all(np.isfinite(K)):
        raise ValueError(f"K must be a finite 3x3 matrix, got shape {K.shape}")
    if int(width) <= 0 or int(height) <= 0:
        raise ValueError(f"image size must be positive, got {width}x{height}")
    if not (0.0 < near < far and np.isfinite(far)):
        raise ValueError(f"need 0 < near < far, got near={near}, far={far}")
    W, H = float(width), float(height)
    fx, s, cx = K[0]
    fy, cy = K[1, 1], K[1, 2]
    # eye_gl = (x, y, z) = (X_cv, -Y_cv, -Z_cv); w_clip = -z = depth
    return np.array(
        [
            [2.0 * fx / W, -2.0 * s / W, 1.0 - 2.0 * (cx + 0.5) / W, 0.0],
            [0.0, -2.0 * fy / H, 1.0 - 2.0 * (cy + 0.5) / H, 0.0],
            [0.0, 0.0, -(far + near) / (far - near), -2.0 * far * near / (far - near)],
            [0.0, 0.0, -1.0, 0.0],
        ]
    )


def view_from_Rt(R_cam_from_world, t_cam_from_world) -> np.ndarray:
    """GL view matrix (4, 4) float64: world (pitch, metres) -> GL eye space.

    ``diag(1, -1, -1, 1) @ [[R, t], [0, 1]]``: OpenCV camera axes (x right, y
    down, z forward) become GL's (x right, y up, looking down -z).
    """
    R = np.asarray(R_cam_from_world, dtype=np.float64)
    t = np.asarray(t_cam_from_world, dtype=np.float64).reshape(-1)
    if R.shape != (3, 3) or t.shape != (3,):
        raise ValueError(f"R must be 3x3 and t (3,), got {R.shape} and {t.shape}")
    M = np.eye(4)
    M[:3, :3] = R
    M[:3, 3] = t
    return _GL_FROM_CV @ M


def _coeffs(dist) -> np.ndarray:
    k = np.zeros(MAX_DIST_COEFFS)
    d = np.asarray(tuple(dist), dtype=np.float64).reshape(-1)
    if len(d) > MAX_DIST_COEFFS and np.any(d[MAX_DIST_COEFFS:] != 0):
        raise ValueError(f"the renderer supports at most {MAX_DIST_COEFFS} radial coefficients, got {len(d)}")
    k[: min(len(d), MAX_DIST_COEFFS)] = d[:MAX_DIST_COEFFS]
    return k


def radial_limit(dist) -> float:
    """Largest ``r^2`` (normalised) up to which ``r (1 + k1 r^2 + k2 r^4 + ...)`` increases.

    Returns ``inf`` when it increases everywhere (no distortion, or
    pincushion). The renderer clamps ``r^2`` to this value.
    """
    k = _coeffs(dist)
    if not np.any(k):
        return float("inf")
    # d/dr [r f(r^2)] = 1 + 3 k1 s + 5 k2 s^2 + 7 k3 s^3 + 9 k4 s^4, s = r^2
    poly = np.array([9.0 * k[3], 7.0 * k[2], 5.0 * k[1], 3.0 * k[0], 1.0])
    roots = np.roots(np.trim_zeros(poly, "f"))
    real = roots[(np.abs(roots.imag) < 1e-12) & (roots.real > 0)].real
    return float(real.min()) if real.size else float("inf")


def distortion_scale(eye_gl, dist, r2_limit: float | None = None) -> np.ndarray:
    """Per-point factor ``1 + k1 r^2 + ...`` applied to eye-space x, y (numpy twin of the shader).

    Parameters
    ----------
    eye_gl : (N, 3) GL eye coordinates
    dist : radial coefficients (k1, ...)
    r2_limit : float, optional, clamp for ``r^2`` (default :func:`radial_limit`)

    Returns
    -------
    (N,) float64; 1 for points at or behind the camera plane.
    """
    k = _coeffs(dist)
    eye = np.asarray(eye_gl, dtype=np.float64)
    if not np.any(k):
        return np.ones(len(eye))
    lim = radial_limit(dist) if r2_limit is None else r2_limit
    z = -eye[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        r2 = (eye[:, 0] ** 2 + eye[:, 1] ** 2) / (z * z)
    r2 = np.minimum(np.where(z > 0, r2, 0.0), lim)
    return 1.0 + r2 * (k[0] + r2 * (k[1] + r2 * (k[2] + r2 * k[3])))


def clip_from_world(camera, X, width: int, height: int, near: float = 0.1, far: float = 1000.0) -> np.ndarray:
    """World points (N, 3) -> clip coordinates (N, 4), exactly as the vertex shader does."""
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 2 or X.shape[1] != 3:
        raise ValueError(f"X must have shape (N, 3), got {X.shape}")
    eye = X @ view_from_Rt(camera.R, camera.t)[:3, :3].T + view_from_Rt(camera.R, camera.t)[:3, 3]
    eye[:, :2] *= distortion_scale(eye, camera.dist)[:, None]
    P = projection_from_K(camera.K, width, height, near, far)
    return np.column_stack([eye, np.ones(len(eye))]) @ P.T


def pixels_from_clip(clip, width: int, height: int) -> np.ndarray:
    """Clip coordinates (N, 4) -> OpenCV pixels (N, 2) (pixel centres at integers)."""
    clip = np.asarray(clip, dtype=np.float64)
    ndc = clip[:, :2] / clip[:, 3:4]
    return np.column_stack([(ndc[:, 0] + 1.0) * (0.5 * width) - 0.5, (ndc[:, 1] + 1.0) * (0.5 * height) - 0.5])
