"""Synthetic spheres with exact ground truth: outline conics, noisy outline
points, rendered images (shaded balls over background clutter) and
multi-camera rigs.

Everything here is deterministic given a ``numpy.random.Generator`` and is
meant for tests and benchmarks of :mod:`calib.sphere` and the tools built on
it (1-D calibration from sphere centres, structured light on a sphere).

Conventions as in :mod:`calib.sphere`: OpenCV camera ``x ~ K (R X + t)``,
camera frame looks down +z, integer pixel centres (pixel ``(u, v)`` covers
``[u - 0.5, u + 0.5] x [v - 0.5, v + 0.5]``), images are uint8 H x W x 3 BGR.
``image_size`` is always ``(width, height)``.

>>> K = np.array([[800.0, 0.0, 320.0], [0.0, 800.0, 240.0], [0.0, 0.0, 1.0]])
>>> rng = np.random.default_rng(0)
>>> X = random_sphere_centres(K, (640, 480), 3, radius=0.1, rng=rng)
>>> pts = sphere_outline_points(K, X[0], 0.1, 50)
>>> from geometry.conics import sampson_distance
>>> bool(np.abs(sampson_distance(pts, outline_conic(K, X[0], 0.1))).max() < 1e-9)
True
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from calib.sphere import outline_conic
from geometry.camera import Camera
from geometry.conics import ellipse_from_conic

__all__ = [
    "SphereRender",
    "outline_conic",
    "sphere_outline_points",
    "random_sphere_centres",
    "look_at",
    "rig_cameras",
    "random_rig_centres",
    "render_spheres",
    "clutter_background",
]


def _rng(rng) -> np.random.Generator:
    return rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)


def _size(image_size) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in image_size)
    except (TypeError, ValueError):
        raise ValueError(f"image_size must be (width, height), got {image_size!r}") from None
    if w < 8 or h < 8:
        raise ValueError(f"image_size must be at least 8 x 8 pixels, got {w} x {h}")
    return w, h


def sphere_outline_points(K, centre, radius, n: int = 200, *, noise: float = 0.0, rng=None, arc=None) -> np.ndarray:
    """Points on a sphere's outline, optionally with Gaussian noise.

    Parameters
    ----------
    K : (3, 3) float64, intrinsics (pixels)
    centre : (3,) float64, sphere centre, camera frame
    radius : float, > 0
    n : int, number of points (uniform in the ellipse's parametric angle)
    noise : float, standard deviation (pixels) of isotropic Gaussian noise
        added to each coordinate
    rng : numpy Generator or seed
    arc : (2,) float, optional, parametric-angle interval (radians) to sample
        instead of the full outline (an occluded sphere)

    Returns
    -------
    (n, 2) float64, pixels.
    """
    if int(n) < 1:
        raise ValueError(f"n must be positive, got {n}")
    if not noise >= 0:
        raise ValueError(f"noise must be non-negative, got {noise}")
    e = ellipse_from_conic(outline_conic(K, centre, radius))
    if arc is None:
        pts = e.points(int(n))
    else:
        a0, a1 = (float(a) for a in arc)
        pts = e.points_at(np.linspace(a0, a1, int(n)))
    if noise > 0:
        pts = pts + _rng(rng).normal(0.0, noise, pts.shape)
    return pts


def random_sphere_centres(
    K,
    image_size,
    n: int,
    *,
    radius: float = 1.0,
    image_radius=(30.0, 60.0),
    margin: float = 5.0,
    min_separation: float | None = None,
    rng=None,
    max_tries: int = 10000,
) -> np.ndarray:
    """Random sphere centres whose outlines lie inside the image.

    The apparent radius (pixels) is drawn uniformly in ``image_radius``; the
    imaged centres are spread by drawing each in a different cell of a
    coarse grid over the image (so the set is never nearly collinear for
    ``n >= 3``), then the whole outline is checked to lie at least
    ``margin`` pixels inside the image.

    Parameters
    ----------
    K : (3, 3) float64, intrinsics (pixels)
    image_size : (width, height), pixels
    n : int, number of spheres
    radius : float, sphere radius (units of the returned centres)
    image_radius : (2,) float, range of the apparent radius, pixels
    margin : float, pixels
    min_separation : float, optional, minimum distance (pixels) between
        outlines (default: outlines may overlap; set 0 for non-overlapping)
    rng : numpy Generator or seed

    Returns
    -------
    (n, 3) float64, centres in the camera frame.
    """
    rng = _rng(rng)
    K = np.asarray(K, dtype=np.float64)
    w, h = _size(image_size)
    lo, hi = (float(v) for v in image_radius)
    if not 0 < lo <= hi:
        raise ValueError(f"image_radius must be 0 < lo <= hi, got {image_radius}")
    f = 0.5 * (K[0, 0] + K[1, 1])
    Ki = np.linalg.inv(K)
    g = int(np.ceil(np.sqrt(max(n, 1) * 1.5)))
    cells = rng.permutation(g * g)
    out: list[np.ndarray] = []
    ells = []
    tries = 0
    ci = 0
    while len(out) < n:
        tries += 1
        if tries > max_tries:
            raise ValueError(f"could not place {n} spheres of apparent radius {image_radius} px inside a {w}x{h} image")
        cell = cells[ci % len(cells)]
        gx, gy = cell % g, cell // g
        rho = rng.uniform(lo, hi)
        u = rng.uniform(gx / g, (gx + 1) / g) * w
        v = rng.uniform(gy / g, (gy + 1) / g) * h
        d = Ki @ np.array([u, v, 1.0])
        d /= np.linalg.norm(d)
        dist = radius / np.sin(np.arctan(rho / f))
        X = d * dist
        if X[2] <= radius * 1.01:
            continue
        e = ellipse_from_conic(outline_conic(K, X, radius))
        pts = e.points(64)
        if pts[:, 0].min() < margin - 0.5 or pts[:, 1].min() < margin - 0.5:
            continue
        if pts[:, 0].max() > w - 0.5 - margin or pts[:, 1].max() > h - 0.5 - margin:
            continue
        if min_separation is not None and any(
            np.hypot(*(np.subtract(e.center, o.center))) < e.axes[0] + o.axes[0] + min_separation for o in ells
        ):
            ci += 1
            continue
        out.append(X)
        ells.append(e)
        ci += 1
    return np.array(out)


def look_at(centre, target, up=(0.0, -1.0, 0.0)) -> np.ndarray:
    """``R_cam_from_world`` (3, 3) of a camera at ``centre`` (3,) looking at
    ``target`` (3,), with image y as close as possible to ``-up`` (world frame)."""
    c = np.asarray(centre, dtype=np.float64)
    z = np.asarray(target, dtype=np.float64) - c
    if np.linalg.norm(z) == 0:
        raise ValueError("camera centre and target coincide")
    z /= np.linalg.norm(z)
    upv = np.asarray(up, dtype=np.float64)
    x = np.cross(-upv, z)
    if np.linalg.norm(x) < 1e-9:
        raise ValueError("viewing direction is parallel to 'up'")
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.stack([x, y, z])


def rig_cameras(
    n_cameras: int,
    *,
    f: float = 1000.0,
    image_size=(640, 480),
    distance: float = 3.0,
    spread_deg: float = 60.0,
    rng=None,
    jitter: float = 0.0,
) -> list[Camera]:
    """Cameras on an arc around the origin of a world frame, all looking at it.

    Camera 0 is at ``(0, 0, -distance)`` looking down +z with identity
    rotation, so the world frame is camera 0's frame; the others are spread
    over ``spread_deg`` degrees on both sides (about the world y axis),
    slightly above or below (``jitter`` radians of random elevation).

    Returns
    -------
    list of geometry.camera.Camera (world = camera 0's frame shifted by
    ``distance`` along its axis; square pixels, principal point at the image
    centre, no distortion).
    """
    rng = _rng(rng)
    w, h = _size(image_size)
    K = np.array([[f, 0.0, (w - 1) / 2.0], [0.0, f, (h - 1) / 2.0], [0.0, 0.0, 1.0]])
    cams = []
    angles = np.zeros(1) if n_cameras == 1 else np.linspace(-0.5, 0.5, n_cameras) * np.radians(spread_deg)
    order = np.argsort(np.abs(angles), kind="stable")
    for k in order:
        a = angles[k]
        el = rng.normal(0.0, jitter) if jitter > 0 and len(cams) > 0 else 0.0
        c = distance * np.array([np.sin(a) * np.cos(el), np.sin(el), -np.cos(a) * np.cos(el)])
        R = look_at(c, np.zeros(3))
        cams.append(Camera(K=K, R=R, t=-R @ c))
    return cams


def random_rig_centres(cameras, n: int, *, radius: float, box: float = 0.6, margin: float = 5.0, image_size=(640, 480), rng=None, max_tries: int = 100000) -> np.ndarray:
    """Sphere centres (n, 3), world frame, uniform in a cube of side ``box``
    about the origin, each with its whole outline inside every camera's image."""
    rng = _rng(rng)
    w, h = _size(image_size)
    out = []
    tries = 0
    while len(out) < n:
        tries += 1
        if tries > max_tries:
            raise ValueError("could not place the spheres inside every camera's view")
        X = rng.uniform(-box / 2, box / 2, 3)
        ok = True
        for cam in cameras:
            Xc = cam.R @ X + cam.t
            try:
                e = ellipse_from_conic(outline_conic(cam.K, Xc, radius))
            except ValueError:
                ok = False
                break
            p = e.points(64)
            if p.min(axis=0).min() < margin or p[:, 0].max() > w - 1 - margin or p[:, 1].max() > h - 1 - margin:
                ok = False
                break
        if ok:
            out.append(X)
    return np.array(out)


# --------------------------------------------------------------------------
# rendering
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class SphereRender:
    """A rendered image and its per-pixel geometry (at pixel centres).

    Attributes
    ----------
    image : (H, W, 3) uint8, BGR
    index : (H, W) int32, which sphere the pixel centre's ray hits first, -1 for background
    points : (H, W, 3) float64, the hit point (camera frame), NaN for background
    normals : (H, W, 3) float64, unit surface normal at the hit point, NaN for background
    """

    image: np.ndarray
    index: np.ndarray
    points: np.ndarray
    normals: np.ndarray


def clutter_background(image_size, *, rng=None, n_shapes: int = 40, base=None) -> np.ndarray:
    """A cluttered background: a smooth gradient, random polygons, bars,
    lines, small discs and texture. (H, W, 3) float32 BGR in [0, 255]."""
    rng = _rng(rng)
    w, h = _size(image_size)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    b0 = rng.uniform(60, 190, 3) if base is None else np.asarray(base, dtype=np.float32)
    grad = rng.uniform(-60, 60, 3)
    img = b0[None, None, :] + grad[None, None, :] * (xx / w - 0.5)[..., None] + 0.5 * grad[None, None, ::-1] * (yy / h - 0.5)[..., None]
    img = np.ascontiguousarray(img, dtype=np.float32)
    for _ in range(n_shapes):
        col = tuple(float(c) for c in rng.uniform(0, 255, 3))
        kind = rng.integers(0, 5)
        if kind == 0:  # polygon
            c = rng.uniform([0, 0], [w, h])
            k = rng.integers(3, 7)
            ang = np.sort(rng.uniform(0, 2 * np.pi, k))
            rr = rng.uniform(10, 0.25 * min(w, h), k)
            poly = np.stack([c[0] + rr * np.cos(ang), c[1] + rr * np.sin(ang)], axis=1)
            cv2.fillPoly(img, [np.round(poly * 16).astype(np.int32)], col, lineType=cv2.LINE_AA, shift=4)
        elif kind == 1:  # bar (thick line)
            p, q = rng.uniform([0, 0], [w, h], (2, 2))
            cv2.line(img, tuple(int(v) for v in p), tuple(int(v) for v in q), col, int(rng.integers(2, 12)), cv2.LINE_AA)
        elif kind == 2:  # thin line
            p, q = rng.uniform([0, 0], [w, h], (2, 2))
            cv2.line(img, tuple(int(v) for v in p), tuple(int(v) for v in q), col, 1, cv2.LINE_AA)
        elif kind == 3:  # small disc
            c = rng.uniform([0, 0], [w, h])
            cv2.circle(img, tuple(int(v) for v in c), int(rng.integers(3, 12)), col, -1, cv2.LINE_AA)
        else:  # rectangle outline
            p = rng.uniform([0, 0], [w, h])
            s = rng.uniform(10, 0.3 * min(w, h), 2)
            cv2.rectangle(img, tuple(int(v) for v in p), tuple(int(v) for v in p + s), col, int(rng.integers(1, 4)), cv2.LINE_AA)
    tex = cv2.GaussianBlur(rng.normal(0, 12, (h, w)).astype(np.float32), (0, 0), 2.0)
    img += tex[..., None]
    return np.clip(img, 0, 255)


def _hit(rays: np.ndarray, X: np.ndarray, r: float) -> np.ndarray:
    """Ray parameter of the first hit of rays (P, 3) with a sphere; inf for a miss."""
    b = rays @ X
    a = (rays * rays).sum(axis=1)
    c = X @ X - r * r
    disc = b * b - a * c
    t = np.full(len(rays), np.inf)
    ok = disc >= 0
    t[ok] = (b[ok] - np.sqrt(disc[ok])) / a[ok]
    t[t <= 0] = np.inf
    return t


def render_spheres(
    K,
    centres,
    radii,
    image_size,
    *,
    colours=None,
    light=(-0.5, -0.6, -0.6),
    ambient: float = 0.2,
    specular: float = 0.7,
    shininess: float = 40.0,
    background="clutter",
    noise: float = 2.0,
    blur: float = 0.5,
    supersample: int = 6,
    rng=None,
    return_geometry: bool = False,
):
    """Render shaded spheres (Lambert + Phong highlight) over a background.

    Pixels on the outlines are anti-aliased by ``supersample^2`` rays per
    pixel, so the silhouette is exact to a small fraction of a pixel; a mild
    Gaussian blur (``blur`` px, the optics) and sensor noise (``noise`` grey
    levels) follow.

    Parameters
    ----------
    K : (3, 3) float64, intrinsics (pixels)
    centres : (S, 3) float64, sphere centres, camera frame (one sphere: (3,))
    radii : float or (S,) float64
    image_size : (width, height)
    colours : (S, 3) BGR albedo in [0, 255]; default: random saturated colours
    light : (3,) direction from the scene toward the light, camera frame
    ambient, specular, shininess : shading parameters
    background : "clutter", "plain", or an (H, W, 3) array (BGR)
    noise : float, standard deviation of additive Gaussian noise, grey levels
    blur : float, Gaussian blur sigma, pixels (0 for none)
    supersample : int, rays per pixel side on outline pixels
    rng : numpy Generator or seed
    return_geometry : bool, return a :class:`SphereRender` instead of the image

    Returns
    -------
    (H, W, 3) uint8 BGR image, or SphereRender.
    """
    rng = _rng(rng)
    K = np.asarray(K, dtype=np.float64)
    w, h = _size(image_size)
    X = np.atleast_2d(np.asarray(centres, dtype=np.float64))
    if X.shape[1] != 3:
        raise ValueError(f"centres must have shape (S, 3), got {X.shape}")
    r = np.broadcast_to(np.asarray(radii, dtype=np.float64), (len(X),)).copy()
    if np.any(r <= 0):
        raise ValueError("radii must be positive")
    if colours is None:
        hue = rng.uniform(0, 180, len(X))
        hsv = np.stack([hue, np.full(len(X), 200.0), np.full(len(X), 230.0)], axis=1).astype(np.uint8)[None]
        colours = cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)[0].astype(np.float64)
    colours = np.atleast_2d(np.asarray(colours, dtype=np.float64))
    if isinstance(background, str):
        if background == "clutter":
            bg = clutter_background((w, h), rng=rng)
        elif background == "plain":
            bg = np.full((h, w, 3), 128.0, dtype=np.float32)
        else:
            raise ValueError(f"background must be 'clutter', 'plain' or an image, got {background!r}")
    else:
        bg = np.asarray(background, dtype=np.float32)
        if bg.shape != (h, w, 3):
            raise ValueError(f"background image must be ({h}, {w}, 3), got {bg.shape}")
    L = np.asarray(light, dtype=np.float64)
    L = L / np.linalg.norm(L)
    Ki = np.linalg.inv(K)

    def shade(rays):
        T = np.stack([_hit(rays, X[s], r[s]) for s in range(len(X))], axis=1)
        idx = np.argmin(T, axis=1)
        t = T[np.arange(len(rays)), idx]
        hit = np.isfinite(t)
        P = rays * np.where(hit, t, 0.0)[:, None]
        N = (P - X[idx]) / r[idx][:, None]
        ndl = np.clip(N @ L, 0.0, None)
        V = -P / np.maximum(np.linalg.norm(P, axis=1, keepdims=True), 1e-300)
        Rf = 2 * ndl[:, None] * N - L
        spec = specular * np.clip((Rf * V).sum(axis=1), 0.0, None) ** shininess * (ndl > 0)
        col = colours[idx] * (ambient + (1 - ambient) * ndl)[:, None] + 255.0 * spec[:, None]
        return col, hit, idx, P, N

    vv, uu = np.mgrid[0:h, 0:w].astype(np.float64)
    pix = np.stack([uu.ravel(), vv.ravel(), np.ones(h * w)], axis=1)
    rays = pix @ Ki.T
    col, hit, idx, P, N = shade(rays)
    out = bg.reshape(-1, 3).astype(np.float64).copy()
    out[hit] = col[hit]
    # outline pixels: within 1.5 px of any outline (Sampson distance)
    near = np.zeros(h * w, dtype=bool)
    for s in range(len(X)):
        C = outline_conic(K, X[s], r[s])
        Cx = pix @ C
        num = (Cx * pix).sum(axis=1)
        den = 2 * np.hypot(Cx[:, 0], Cx[:, 1])
        near |= np.abs(num) < 1.5 * den
    ss = max(int(supersample), 1)
    if np.any(near):
        off = (np.arange(ss) + 0.5) / ss - 0.5
        ou, ov = np.meshgrid(off, off)
        sub = np.stack([ou.ravel(), ov.ravel(), np.zeros(ss * ss)], axis=1)
        pn = pix[near]
        sp = (pn[:, None, :] + sub[None, :, :]).reshape(-1, 3)
        c2, h2, _, _, _ = shade(sp @ Ki.T)
        bgn = bg.reshape(-1, 3).astype(np.float64)[near]
        c2 = np.where(h2[:, None], c2, np.repeat(bgn, ss * ss, axis=0))
        out[near] = c2.reshape(-1, ss * ss, 3).mean(axis=1)
    img = out.reshape(h, w, 3).astype(np.float32)
    if blur > 0:
        img = cv2.GaussianBlur(img, (0, 0), blur)
    if noise > 0:
        img = img + rng.normal(0.0, noise, img.shape).astype(np.float32)
    img8 = np.clip(np.round(img), 0, 255).astype(np.uint8)
    if not return_geometry:
        return img8
    index = np.where(hit, idx, -1).reshape(h, w).astype(np.int32)
    pts = np.where(hit[:, None], P, np.nan).reshape(h, w, 3)
    nrm = np.where(hit[:, None], N, np.nan).reshape(h, w, 3)
    return SphereRender(image=img8, index=index, points=pts, normals=nrm)
