"""Test cameras built from a place and a target, shared by the geometry and
pitch-size tests."""

from __future__ import annotations

import numpy as np

from geometry.camera import Camera, intrinsic_matrix


def looking_at(centre, target, f: float, size=(1280, 720)) -> Camera:
    """A level camera (no roll) at ``centre`` (3,) metres looking at ``target``
    (3,), focal length ``f`` px, principal point at the centre of ``size`` (w, h)."""
    c, z = np.asarray(centre, float), np.asarray(target, float) - np.asarray(centre, float)
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    R = np.array([x, np.cross(z, x), z])
    return Camera(K=intrinsic_matrix(f, (size[0] - 1) / 2, (size[1] - 1) / 2), R=R, t=-R @ c)
