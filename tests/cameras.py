"""Test cameras built from a place and a target, and the grass a camera sees,
shared by the geometry, pitch-size, support and circle-view tests."""

from __future__ import annotations

import numpy as np

from geometry.camera import Camera, intrinsic_matrix
from geometry.pitch import PitchModel


def looking_at(centre, target, f: float, size=(1280, 720)) -> Camera:
    """A level camera (no roll) at ``centre`` (3,) metres looking at ``target``
    (3,), focal length ``f`` px, principal point at the centre of ``size`` (w, h)."""
    c, z = np.asarray(centre, float), np.asarray(target, float) - np.asarray(centre, float)
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    R = np.array([x, np.cross(z, x), z])
    return Camera(K=intrinsic_matrix(f, (size[0] - 1) / 2, (size[1] - 1) / 2), R=R, t=-R @ c)


def grass_seen(cam: Camera, size, small=(160, 90), margin: float = 3.0, pitch: PitchModel | None = None) -> np.ndarray:
    """The pitch grown by ``margin`` metres as ``cam`` sees it, on a small copy
    of a frame of ``size`` (w, h) (the detector's grass mask is made about 160
    px wide): (h, w) of ``small``, uint8, 255 on the grass."""
    p = pitch or PitchModel()
    W, H = size
    w, h = small
    v, u = np.mgrid[0:h, 0:w]
    px = np.column_stack([(u.ravel() + 0.5) * W / w - 0.5, (v.ravel() + 0.5) * H / h - 0.5])
    XY = cam.backproject_to_pitch(px)
    with np.errstate(invalid="ignore"):
        inside = (np.abs(XY[:, 0]) <= p.length / 2 + margin) & (np.abs(XY[:, 1]) <= p.width / 2 + margin)
    return (inside.reshape(h, w) * 255).astype(np.uint8)
