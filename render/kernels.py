"""Compiled CPU loops of the renderer (numba).

The renderer's one per-frame CPU task besides driving GL is its footprint:
where the scene's triangles land in the image (:meth:`render.Renderer.footprint`).
Written as numpy expressions over the few hundred triangles of a scene it is
some thirty small array operations (about 0.4 ms a frame); here it is one
loop, and the runs of tiles the GPU resolves another. Compiled on first use
and cached next to this file (numba's ``cache=True``); :func:`warm_up` loads
them ahead of a run.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

__all__ = ["footprint_tiles", "tile_runs", "warm_up"]


@nb.njit(cache=True, nogil=True, fastmath=False, boundscheck=False)
def footprint_tiles(P, R, t, K, k, r2max, tri, tri_part, n_parts, width, height, tile, block, ntx, nty, nbx, nby):
    """The tiles a camera sees triangles in, and what else the renderer needs.

    Every vertex is projected with the renderer's lens model (the vertex
    shader's: radial polynomial ``1 + k1 r^2 + ... + k4 r^8`` with ``r^2``
    clamped to ``r2max``); each triangle's pixel bounding box, grown by a
    pixel (two on the far sides: the ceiling of a half-open bound) and
    clipped to the frame, marks the tiles it touches. A triangle crossing
    the camera plane (``z <= 1e-6`` at one or two vertices) may cover
    anything: it marks the whole frame; one wholly behind marks nothing.

    Parameters
    ----------
    P : (V, 3) float64 vertices, pitch frame (metres)
    R, t : (3, 3), (3,) float64, the camera's rotation and translation (OpenCV)
    K : (3, 3) float64 intrinsics
    k : (4,) float64 radial coefficients (zeros: pinhole)
    r2max : float, the clamp of ``r^2`` (``inf`` for none)
    tri : (M, 3) int64 vertex indices of the triangles
    tri_part : (M,) int64 the part (object) of each triangle, in ``[0, n_parts)``
    width, height : int, the frame
    tile, block : int, tile size (pixels) and tiles per block side
    ntx, nty, nbx, nby : int, tiles and blocks across and down

    Returns
    -------
    tiles : (nty, ntx) bool, the tiles touched
    blocks : (nby, nbx) bool, the blocks holding a touched tile
    visible : (n_parts,) bool, parts with a triangle in view
    near, far : float, the depth range of the vertices in front of the camera
        (half the nearest, twice the farthest, at least 1 mm and 4 x near);
        0.1 and 1.0 when no triangle is in view (``tiles`` all False)
    """
    nv = P.shape[0]
    m = tri.shape[0]
    tiles = np.zeros((nty, ntx), np.bool_)
    blocks = np.zeros((nby, nbx), np.bool_)
    visible = np.zeros(n_parts, np.bool_)
    u = np.empty(nv)
    v = np.empty(nv)
    front = np.empty(nv, np.bool_)
    distorted = k[0] != 0.0 or k[1] != 0.0 or k[2] != 0.0 or k[3] != 0.0
    zmin, zmax = np.inf, -np.inf
    n_front = 0
    for i in range(nv):
        X, Y, Z = P[i, 0], P[i, 1], P[i, 2]
        xc = R[0, 0] * X + R[0, 1] * Y + R[0, 2] * Z + t[0]
        yc = R[1, 0] * X + R[1, 1] * Y + R[1, 2] * Z + t[1]
        zc = R[2, 0] * X + R[2, 1] * Y + R[2, 2] * Z + t[2]
        front[i] = zc > 1e-6
        if not front[i]:
            continue
        n_front += 1
        zmin, zmax = min(zmin, zc), max(zmax, zc)
        xn, yn = xc / zc, yc / zc
        if distorted:
            r2 = min(xn * xn + yn * yn, r2max)
            s = 1.0 + r2 * (k[0] + r2 * (k[1] + r2 * (k[2] + r2 * k[3])))
            xn, yn = xn * s, yn * s
        u[i] = K[0, 0] * xn + K[0, 1] * yn + K[0, 2]
        v[i] = K[1, 1] * yn + K[1, 2]
    if n_front == 0:
        return tiles, blocks, visible, 0.1, 1.0
    W, H = float(width), float(height)
    inv_tile = 1.0 / tile
    any_visible = False
    for j in range(m):
        a, b, c = tri[j, 0], tri[j, 1], tri[j, 2]
        nf = int(front[a]) + int(front[b]) + int(front[c])
        if nf == 0:
            continue  # wholly behind the camera
        if nf < 3:  # crosses the camera plane: may cover anything
            x0, y0, x1, y1 = 0.0, 0.0, W, H
        else:
            x0 = min(max(math.floor(min(u[a], u[b], u[c])) - 1.0, 0.0), W)
            y0 = min(max(math.floor(min(v[a], v[b], v[c])) - 1.0, 0.0), H)
            x1 = min(max(math.ceil(max(u[a], u[b], u[c])) + 2.0, 0.0), W)
            y1 = min(max(math.ceil(max(v[a], v[b], v[c])) + 2.0, 0.0), H)
        if not (x1 > x0 and y1 > y0):
            continue
        any_visible = True
        visible[tri_part[j]] = True
        tx0, ty0 = int(x0 * inv_tile), int(y0 * inv_tile)  # bounds are >= 0 and integral: exact floor / ceil
        tx1, ty1 = int(math.ceil(x1 * inv_tile)), int(math.ceil(y1 * inv_tile))
        for ty in range(ty0, ty1):
            for tx in range(tx0, tx1):
                tiles[ty, tx] = True
                blocks[ty // block, tx // block] = True
    if not any_visible:
        return tiles, blocks, visible, 0.1, 1.0
    near = max(0.5 * zmin, 1e-3)
    return tiles, blocks, visible, near, max(2.0 * zmax, 4.0 * near)


@nb.njit(cache=True, nogil=True, fastmath=False, boundscheck=False)
def tile_runs(tiles, tile, width, height):
    """Pixel rectangles of the runs of marked tiles, one per run of a tile row.

    Parameters
    ----------
    tiles : (ny, nx) bool
    tile : int, tile size (pixels)
    width, height : int, the frame (the last row and column are clipped to it)

    Returns
    -------
    (n, 4) int64 rectangles (x0, y0, x1, y1), half-open, in row-major order
    """
    ny, nx = tiles.shape
    n = 0
    for ty in range(ny):
        for tx in range(nx):
            if tiles[ty, tx] and (tx == 0 or not tiles[ty, tx - 1]):
                n += 1
    out = np.empty((n, 4), np.int64)
    j = 0
    for ty in range(ny):
        tx = 0
        while tx < nx:
            if not tiles[ty, tx]:
                tx += 1
                continue
            t0 = tx
            while tx < nx and tiles[ty, tx]:
                tx += 1
            out[j, 0], out[j, 1] = t0 * tile, ty * tile
            out[j, 2], out[j, 3] = min(tx * tile, width), min((ty + 1) * tile, height)
            j += 1
    return out


def warm_up() -> None:
    """Load (or compile) the kernels by calling them once on tiny inputs."""
    I3 = np.eye(3)
    tiles, _, _, _, _ = footprint_tiles(np.ones((3, 3)), I3, np.zeros(3), I3, np.zeros(4), np.inf, np.zeros((1, 3), np.int64), np.zeros(1, np.int64), 1, 16, 16, 8, 2, 2, 2, 1, 1)
    tile_runs(tiles, 8, 16, 16)
