"""Compiled CPU loops of the renderer and the compositor (numba).

The renderer's one per-frame CPU task besides driving GL is its footprint:
where the scene's triangles land in the image (:meth:`render.Renderer.footprint`).
Written as numpy expressions over the few hundred triangles of a scene it is
some thirty small array operations (about 0.4 ms a frame); here it is one
loop, and the runs of tiles the GPU resolves another. The I420 composite
(:func:`render.compositor.composite_i420`) and the fine grass key of an I420
frame (:class:`render.keying.GrassKeyI420`) are one pass each here too
(:func:`composite_i420`, :func:`key_i420`). Compiled on first use and cached
next to this file (numba's ``cache=True``); :func:`warm_up` loads them ahead
of a run (what drawing with known cameras needs, without detection's kernels).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

__all__ = ["composite_i420", "footprint_tiles", "key_i420", "tile_runs", "warm_up"]

_JIT = dict(cache=True, nogil=True, fastmath=False, boundscheck=False)


@nb.njit(**_JIT)
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


@nb.njit(**_JIT)
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


@nb.njit(**_JIT)
def composite_i420(yuv, width, height, bgra, rects, ky, ku, kv):
    """Premultiplied "over" of a BGRA overlay onto an I420 frame, in place,
    inside ``rects`` (:func:`render.compositor.composite_i420`): luma per
    pixel, chroma per 2 x 2 block from the block's mean premultiplied colour
    and mean alpha (what "over" followed by 4:2:0 subsampling gives), in
    floating point with one rounding per output sample (half up: the values
    are never negative once clamped).

    Parameters
    ----------
    yuv : (H * W * 3 / 2,) uint8 I420 samples, modified in place
    width, height : int, even frame size
    bgra : (H, W, 4) uint8 premultiplied B, G, R, A
    rects : (R, 4) int64 (x0, y0, x1, y1), even, inside the frame, half-open
    ky, ku, kv : (4,) float64 rows of the BGRA -> premultiplied Y, U, V map
        (the offsets in the alpha column)
    """
    n = width * height
    w2 = width // 2
    u0 = n
    v0 = n + n // 4
    inv255 = 1.0 / 255.0
    ky0, ky1, ky2, ky3 = ky[0], ky[1], ky[2], ky[3]
    ku0, ku1, ku2, ku3 = ku[0], ku[1], ku[2], ku[3]
    kv0, kv1, kv2, kv3 = kv[0], kv[1], kv[2], kv[3]
    for r in range(rects.shape[0]):
        x0, y0, x1, y1 = rects[r, 0], rects[r, 1], rects[r, 2], rects[r, 3]
        for y in range(y0, y1, 2):
            for x in range(x0, x1, 2):
                su = 0.0
                sv = 0.0
                sa = 0.0
                drawn = False
                for dy in range(2):
                    yy = y + dy
                    for dx in range(2):
                        xx = x + dx
                        ia = bgra[yy, xx, 3]
                        ib = bgra[yy, xx, 0]
                        ig = bgra[yy, xx, 1]
                        ir = bgra[yy, xx, 2]
                        if ia == 0 and ib == 0 and ig == 0 and ir == 0:
                            continue  # nothing drawn here
                        b = float(ib)
                        g = float(ig)
                        rr = float(ir)
                        a = float(ia)
                        k = yy * width + xx
                        val = yuv[k] * (1.0 - a * inv255) + ky0 * b + ky1 * g + ky2 * rr + ky3 * a
                        yuv[k] = min(max(int(val + 0.5), 0), 255)
                        su += ku0 * b + ku1 * g + ku2 * rr + ku3 * a
                        sv += kv0 * b + kv1 * g + kv2 * rr + kv3 * a
                        sa += a
                        drawn = True
                if not drawn:
                    continue
                c = (y // 2) * w2 + x // 2
                keep = 1.0 - 0.25 * sa * inv255
                yuv[u0 + c] = min(max(int(yuv[u0 + c] * keep + 0.25 * su + 0.5), 0), 255)
                yuv[v0 + c] = min(max(int(yuv[v0 + c] * keep + 0.25 * sv + 0.5), 0), 255)


@nb.njit(**_JIT)
def _nearest_indices(i0, i1, scale, n):
    """Indices (i1 - i0,) of the nearest samples of a length-``n`` axis for pixels
    ``i0 .. i1 - 1`` (``scale`` = n / frame size), as :func:`render.keying._sample`
    takes them."""
    out = np.empty(i1 - i0, np.int64)
    for i in range(i0, i1):
        out[i - i0] = min(int((i + 0.5) * scale), n - 1)
    return out


@nb.njit(**_JIT)
def _grass_bits(u, v, hue_lo, hue_hi, min_s, min_v, sdiv, hdiv, bits):
    """Set ``bits`` (4,) uint64: bit ``y`` where the I420 sample (y, u, v) is grass
    (OpenCV's BT.601 I420 -> BGR in fixed point, then its 8-bit HSV within
    ``[hue_lo, hue_hi] x [min_s, 255] x [min_v, 255]``)."""
    uu = np.int64(u) - 128
    vv = np.int64(v) - 128
    ruv = 524288 + 1673527 * vv
    guv = 524288 - 852492 * vv - 409993 * uu
    buv = 524288 + 2116026 * uu
    for k in range(4):
        bits[k] = 0
    for y in range(256):
        yv = max(y - 16, 0) * 1220542
        rr = min(max((yv + ruv) >> 20, 0), 255)
        gg = min(max((yv + guv) >> 20, 0), 255)
        bb = min(max((yv + buv) >> 20, 0), 255)
        vmax = max(bb, gg, rr)
        if vmax < min_v:
            continue
        diff = vmax - min(bb, gg, rr)
        if (diff * sdiv[vmax] + 2048) >> 12 < min_s:
            continue
        if vmax == rr:
            hh = gg - bb
        elif vmax == gg:
            hh = bb - rr + 2 * diff
        else:
            hh = rr - gg + 4 * diff
        hh = (hh * hdiv[diff] + 2048) >> 12
        if hh < 0:
            hh += 180
        if hue_lo <= hh <= hue_hi:
            bits[y >> 6] |= np.uint64(1) << np.uint64(y & 63)


@nb.njit(**_JIT)
def key_i420(yuv, width, height, rects, pitch, keep, se_half, lut, built, hue_lo, hue_hi, min_s, min_v, sdiv, hdiv, out):
    """Full-resolution grass key of an I420 frame inside rectangles.

    The compiled form of :func:`render.keying.refine_matte` on an I420 frame,
    pixel for pixel: a pixel is grass (255) where the pitch mask says pitch and
    either its colour is grass (OpenCV's BT.601 I420 -> BGR, then its 8-bit
    HSV within ``[hue_lo, hue_hi] x [min_s, 255] x [min_v, 255]``, as
    :func:`render.keying.green_matte`) or the keep mask, sampled at full
    resolution inside the rectangle and dilated there by the structuring
    element, is set. Whether a colour is grass comes from a table over the
    chroma pair (256 bits, one per luma), each row filled the first time
    its chroma occurs (:func:`_grass_bits`); the caller keeps the table for
    the next frames (the thresholds must stay the same).

    Parameters
    ----------
    yuv : (H * W * 3 / 2,) uint8 I420 frame, flat
    width, height : frame size (even)
    rects : (R, 4) int64 half-open (x0, y0, x1, y1), inside the frame
    pitch : (h', w') uint8 whole-frame mask at any resolution (nearest samples)
    keep : (h'', w'') uint8 whole-frame mask at any resolution, or (0, 0)
    se_half : (2 g + 1,) int64 half-widths of the structuring element's rows
        (-1: an empty row), centred
    lut : (65536, 4) uint64 grass bits by chroma (u * 256 + v), filled on demand
    built : (65536,) bool, the rows of ``lut`` filled so far
    hue_lo, hue_hi, min_s, min_v : int thresholds (OpenCV hue 0..180)
    sdiv, hdiv : (256,) int64 OpenCV's 8-bit HSV division tables
        (``round(255 * 4096 / v)``, ``round(180 * 4096 / (6 d))``, 0 at 0)
    out : (H, W) uint8, written inside the rectangles only
    """
    n = width * height
    u0 = n
    v0 = n + n // 4
    w2 = width // 2
    ph, pw = pitch.shape
    kh, kw = keep.shape
    g = (se_half.shape[0] - 1) // 2
    if rects.shape[0] == 0:
        return
    for r in range(rects.shape[0]):
        x0, y0, x1, y1 = rects[r, 0], rects[r, 1], rects[r, 2], rects[r, 3]
        if x1 <= x0 or y1 <= y0:
            continue
        w, h = x1 - x0, y1 - y0
        pcol = _nearest_indices(x0, x1, pw / width, pw)
        prow = _nearest_indices(y0, y1, ph / height, ph)
        # the keep mask's nearest samples in the rectangle, dilated within it
        kp = np.zeros((h, w), np.uint8)
        if kh > 0:
            kcol = _nearest_indices(x0, x1, kw / width, kw)
            krow = _nearest_indices(y0, y1, kh / height, kh)
            for yy in range(h):
                ks = keep[krow[yy]]
                xx = 0
                while xx < w:  # each run [a, b) of set samples: its rows of the element at once
                    if ks[kcol[xx]] == 0:
                        xx += 1
                        continue
                    a = xx
                    while xx < w and ks[kcol[xx]] != 0:
                        xx += 1
                    for dy in range(-g, g + 1):
                        hw = se_half[dy + g]
                        ty = yy + dy
                        if hw < 0 or ty < 0 or ty >= h:
                            continue
                        kp[ty, max(a - hw, 0) : min(xx + hw, w)] = 255
        for yy in range(h):
            y = y0 + yy
            orow = out[y]
            prow_ = pitch[prow[yy]]
            krow_ = kp[yy]
            luma = yuv[y * width : (y + 1) * width]
            cu = yuv[u0 + (y // 2) * w2 : u0 + (y // 2 + 1) * w2]
            cv = yuv[v0 + (y // 2) * w2 : v0 + (y // 2 + 1) * w2]
            for xx in range(w):
                x = x0 + xx
                if prow_[pcol[xx]] == 0:
                    orow[x] = 0
                elif krow_[xx] != 0:
                    orow[x] = 255
                else:
                    uc, vc = cu[x >> 1], cv[x >> 1]
                    uv = (np.int64(uc) << 8) | np.int64(vc)
                    if not built[uv]:
                        _grass_bits(uc, vc, hue_lo, hue_hi, min_s, min_v, sdiv, hdiv, lut[uv])
                        built[uv] = True
                    yl = luma[x]
                    orow[x] = np.uint8(255) if (lut[uv, yl >> 6] >> np.uint64(yl & 63)) & np.uint64(1) else np.uint8(0)


def warm_up() -> None:
    """Load (or compile) the kernels by calling them once on tiny inputs."""
    k4 = np.zeros(4)
    yuv = np.zeros(6, np.uint8)
    rect = np.zeros((1, 4), np.int64)
    composite_i420(yuv, 2, 2, np.zeros((2, 2, 4), np.uint8), rect, k4, k4, k4)
    m = np.zeros((2, 2), np.uint8)
    t = np.zeros(256, np.int64)
    key_i420(yuv, 2, 2, rect, m, m, np.zeros(1, np.int64), np.zeros((1, 4), np.uint64), np.zeros(1, np.bool_), 35, 85, 70, 40, t, t, m)
    I3 = np.eye(3)
    tiles, _, _, _, _ = footprint_tiles(np.ones((3, 3)), I3, np.zeros(3), I3, np.zeros(4), np.inf, np.zeros((1, 3), np.int64), np.zeros(1, np.int64), 1, 16, 16, 8, 2, 2, 2, 1, 1)
    tile_runs(tiles, 8, 16, 16)
