"""Compiled loops of the detector's work on its line points
(:mod:`arstream.detect.detector`, numba): clearing points near endpoints on a
grid, linking points into chains (also the ellipse search's,
:mod:`arstream.detect.ellipses`), keeping the points with grass beside them,
testing points against a mask, whether a line cuts an arc off, and the
final fit of the line groups.

Compiled on first use and cached next to this file (numba's ``cache=True``);
:func:`arstream.kernels.warm_up` loads them ahead of a run.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from arstream.jit import JIT as _JIT, compiled
from geometry.lines import eigh_sym2

__all__ = ["beside_grass", "chains", "cut_by_line", "fit_lines", "grid_clear", "mask_at", "settle_points", "warm_up"]

_eigh_sym2 = compiled(eigh_sym2)


@nb.njit(**_JIT)
def _cell(v, scale, rint, n):
    """Grid cell of a coordinate: ``v * scale`` rounded (``rint``) or truncated, clamped to [0, n)."""
    c = v * scale
    i = int(np.rint(c)) if rint else int(c)
    return min(max(i, 0), n - 1)


@nb.njit(**_JIT)
def grid_clear(pts, ep, sx, sy, rint, rx, ry, grid):
    """Which points ``ep`` have no point of ``pts`` near them on a grid.

    Each point (x, y) falls in the cell (x ``sx``, y ``sy``), rounded
    (``rint``) or truncated, clamped to the grid. A point of ``ep`` is clear
    when no point of ``pts`` lies within ``rx`` cells across and ``ry`` cells
    down of its own (what dilating the occupied cells by a (2 ry + 1) x
    (2 rx + 1) rectangle and testing its cell does).

    Parameters
    ----------
    pts : (N, 2) float64 points (x, y)
    ep : (M, 2) float64 points to test
    sx, sy : float, cells per unit of x and y
    rint : bool, round to the nearest cell (else truncate)
    rx, ry : int, reach in cells
    grid : (gh, gw) uint8 scratch, zero on entry and on return

    Returns
    -------
    (M,) bool
    """
    gh, gw = grid.shape
    n = pts.shape[0]
    for i in range(n):
        grid[_cell(pts[i, 1], sy, rint, gh), _cell(pts[i, 0], sx, rint, gw)] = 1
    m = ep.shape[0]
    keep = np.ones(m, np.bool_)
    for i in range(m):
        cy = _cell(ep[i, 1], sy, rint, gh)
        cx = _cell(ep[i, 0], sx, rint, gw)
        for y in range(max(cy - ry, 0), min(cy + ry + 1, gh)):
            for x in range(max(cx - rx, 0), min(cx + rx + 1, gw)):
                if grid[y, x]:
                    keep[i] = False
                    break
            if not keep[i]:
                break
    for i in range(n):
        grid[_cell(pts[i, 1], sy, rint, gh), _cell(pts[i, 0], sx, rint, gw)] = 0
    return keep


@nb.njit(**_JIT)
def _root(parent, i):
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@nb.njit(**_JIT)
def chains(xi, yi, reach, grid):
    """Connected chains of points on an integer grid.

    Two points are linked when their cells (``xi``, ``yi``) are at most
    ``reach`` cells apart along both axes; a chain is a connected set of
    links. (Reach 1 is 8-connectivity of the occupied cells; reach 3 is
    8-connectivity after dilating them by a 3 x 3 square.)

    Parameters
    ----------
    xi, yi : (N,) int64 cells, inside the grid
    reach : int
    grid : (gh, gw) int32 scratch, -1 on entry and on return

    Returns
    -------
    labels : (N,) int32 chain of each point, 1..K in the raster order of the
        chains' first cells
    ext_x, ext_y : (N,) int64 the width and height (max - min of the cells)
        of each point's chain
    """
    gh, gw = grid.shape
    n = xi.shape[0]
    parent = np.arange(n)
    # one representative point per occupied cell
    for i in range(n):
        r = grid[yi[i], xi[i]]
        if r < 0:
            grid[yi[i], xi[i]] = i
        else:
            parent[i] = r
    # links are symmetric: each cell looks back only (the rows above within
    # reach, and its own row's cells to its left). A chain's root is its lowest
    # index, whatever the order of the links
    for i in range(n):
        cy, cx = yi[i], xi[i]
        if grid[cy, cx] != i:
            continue
        a = _root(parent, i)
        for y in range(max(cy - reach, 0), cy + 1):
            x_end = min(cx + reach + 1, gw) if y < cy else cx
            for x in range(max(cx - reach, 0), x_end):
                j = grid[y, x]
                if j >= 0:
                    b = _root(parent, j)
                    if b < a:
                        parent[a] = b
                        a = b
                    elif b > a:
                        parent[b] = a
    first = np.full(n, gh * gw)
    x0 = np.full(n, gw)
    x1 = np.full(n, -1)
    y0 = np.full(n, gh)
    y1 = np.full(n, -1)
    for i in range(n):
        r = _root(parent, i)
        parent[i] = r
        first[r] = min(first[r], yi[i] * gw + xi[i])
        x0[r] = min(x0[r], xi[i])
        x1[r] = max(x1[r], xi[i])
        y0[r] = min(y0[r], yi[i])
        y1[r] = max(y1[r], yi[i])
        grid[yi[i], xi[i]] = -1
    roots = np.flatnonzero(first < gh * gw)
    rank = np.empty(n, np.int32)
    o = np.argsort(first[roots])
    for k in range(o.shape[0]):
        rank[roots[o[k]]] = k + 1
    labels = np.empty(n, np.int32)
    ext_x = np.empty(n, np.int64)
    ext_y = np.empty(n, np.int64)
    for i in range(n):
        r = parent[i]
        labels[i] = rank[r]
        ext_x[i] = x1[r] - x0[r]
        ext_y[i] = y1[r] - y0[r]
    return labels, ext_x, ext_y


@nb.njit(**_JIT)
def _on_mask(mask, x, y, fx, fy):
    """Whether point (x, y), scaled by (``fx``, ``fy``) to the cells of ``mask``
    (truncated, clamped), falls on a non-zero cell."""
    return mask[_cell(y, fy, False, mask.shape[0]), _cell(x, fx, False, mask.shape[1])] > 0


@nb.njit(**_JIT)
def beside_grass(pts, nrm, d, mask, fx, fy):
    """Which points have grass on at least one side: ``mask`` (a small image,
    non-zero on grass) at ``pts`` +- ``d`` ``nrm`` scaled by (``fx``, ``fy``) to
    its cells (truncated, clamped).

    Parameters
    ----------
    pts, nrm : (N, 2) float64 points and unit normals
    d : float, distance either side (units of pts)
    mask : (mh, mw) uint8
    fx, fy : float, mask cells per unit of x and y

    Returns
    -------
    (N,) bool
    """
    n = pts.shape[0]
    keep = np.empty(n, np.bool_)
    for i in range(n):
        ok = False
        for sgn in (1.0, -1.0):
            if _on_mask(mask, pts[i, 0] + sgn * d * nrm[i, 0], pts[i, 1] + sgn * d * nrm[i, 1], fx, fy):
                ok = True
        keep[i] = ok
    return keep


@nb.njit(**_JIT)
def settle_points(pts, nrm, d, mask, fx, fy, cell_x, cell_y, grid, min_extent, lm, sx, tx, sy, ty):
    """The detector's last pass over its line points: those with grass beside
    them (:func:`beside_grass`) that lie in connected chains (:func:`chains`,
    reach 1, on the grid of cells ``(x cell_x, y cell_y)``, truncated and
    clamped) at least ``min_extent`` cells long or high; their mask and their
    frame coordinates.

    Parameters
    ----------
    pts, nrm : (N, 2) float64 working-pixel points and unit normals
    d, mask, fx, fy : as :func:`beside_grass`
    cell_x, cell_y : float, grid cells per working pixel
    grid : (gh, gw) int32 scratch, -1 on entry and on return
    min_extent : float
    lm : (h, w) uint8, set to 255 at the kept points (rounded, clamped) and 0 elsewhere
    sx, tx, sy, ty : float, working -> frame pixels ``(sx x + tx, sy y + ty)``

    Returns
    -------
    sel : (M,) int64 indices of the kept points, in order
    labels : (M,) int32 their chains (as :func:`chains` numbers them)
    full : (M, 2) float64 their frame coordinates
    """
    keep = beside_grass(pts, nrm, d, mask, fx, fy)
    idx = np.flatnonzero(keep)
    m = idx.shape[0]
    gh, gw = grid.shape
    cxi = np.empty(m, np.int64)
    cyi = np.empty(m, np.int64)
    for k in range(m):
        i = idx[k]
        cxi[k] = min(max(int(pts[i, 0] * cell_x), 0), gw - 1)
        cyi[k] = min(max(int(pts[i, 1] * cell_y), 0), gh - 1)
    lab, ext_x, ext_y = chains(cxi, cyi, 1, grid)
    long = np.empty(m, np.bool_)
    for k in range(m):
        long[k] = max(ext_x[k], ext_y[k]) + 1 >= min_extent
    cnt = int(long.sum())
    sel = np.empty(cnt, np.int64)
    labels = np.empty(cnt, np.int32)
    full = np.empty((cnt, 2))
    lm[:, :] = 0
    h, w = lm.shape
    j = 0
    for k in range(m):
        if long[k]:
            i = idx[k]
            x = pts[i, 0]
            y = pts[i, 1]
            sel[j] = i
            labels[j] = lab[k]
            full[j, 0] = x * sx + tx
            full[j, 1] = y * sy + ty
            lm[min(max(int(np.rint(y)), 0), h - 1), min(max(int(np.rint(x)), 0), w - 1)] = 255
            j += 1
    return sel, labels, full


@nb.njit(**_JIT)
def mask_at(pts, mask, fx, fy, xmax, ymax):
    """Which points lie in ``[0, xmax] x [0, ymax]`` on a non-zero cell of
    ``mask`` (a small image), the points scaled by (``fx``, ``fy``) to its
    cells (truncated, clamped).

    Parameters
    ----------
    pts : (N, 2) float64 points
    mask : (mh, mw) uint8
    fx, fy : float, mask cells per unit of x and y
    xmax, ymax : float, the points' extent

    Returns
    -------
    (N,) bool
    """
    n = pts.shape[0]
    out = np.zeros(n, np.bool_)
    for i in range(n):
        x, y = pts[i, 0], pts[i, 1]
        if 0.0 <= x <= xmax and 0.0 <= y <= ymax:
            out[i] = _on_mask(mask, x, y, fx, fy)
    return out


@nb.njit(**_JIT)
def cut_by_line(P, L, cx, cy, a, b, angle, min_share):
    """Whether a line of ``L`` cuts an ellipse with (nearly) all of its support
    beyond the line, on the side away from the ellipse's centre.

    A line cuts the ellipse "away from its centre" when its distance from the
    centre is between 0.2 and 0.95 of the ellipse's half-width along the
    line's normal (the support function ``sqrt((a n_u)^2 + (b n_v)^2)``, with
    ``(n_u, n_v)`` the normal in the ellipse's axes).

    Parameters
    ----------
    P : (N, 2) float64 support points (pixels)
    L : (K, 3) float64 lines with unit normals ``(a, b)`` (``a x + b y + c = 0``)
    cx, cy, a, b, angle : the ellipse (centre, semi-axes, major-axis angle)
    min_share : float, the share of ``P`` that must lie on the far side

    Returns
    -------
    bool: for some cutting line, more than ``min_share`` of ``P`` lies on it
    or beyond it (not on the centre's side)
    """
    ca, sa = math.cos(angle), math.sin(angle)
    n = P.shape[0]
    for k in range(L.shape[0]):
        nx, ny, c = L[k, 0], L[k, 1], L[k, 2]
        dc = nx * cx + ny * cy + c
        nu = nx * ca + ny * sa
        nv = ny * ca - nx * sa
        reach = math.sqrt((a * nu) ** 2 + (b * nv) ** 2)
        if not (abs(dc) < 0.95 * reach and abs(dc) >= 0.2 * reach):
            continue
        sc = 1.0 if dc > 0 else (-1.0 if dc < 0 else 0.0)
        far = 0
        for i in range(n):
            sd = nx * P[i, 0] + ny * P[i, 1] + c
            ss = 1.0 if sd > 0 else (-1.0 if sd < 0 else 0.0)
            if ss != sc:
                far += 1
        if n > 0 and far / n > min_share:
            return True
    return False


@nb.njit(**_JIT)
def fit_lines(P, members, offsets):
    """Total-least-squares lines of groups of points, one pass for all
    (:func:`geometry.lines.fit_line` of each group, unweighted: the detector's
    final fit of its line groups in frame pixels).

    Parameters
    ----------
    P : (N, 2) float64 points
    members : (M,) int, the groups' point indices, one group after the other
    offsets : (K + 1,) int, group ``k`` is ``members[offsets[k]:offsets[k + 1]]``

    Returns
    -------
    line : (K, 3) ``a x + b y + c = 0`` with unit normal ``(a, b)`` (NaN for a
        group with fewer than 2 distinct points)
    rms : (K,) RMS distance of the group's points from its line
    normal_sigma, angle_sigma : (K,) offset (px) and direction (rad)
        uncertainties, as :func:`geometry.lines.fit_line`
    ends : (K, 2) int64, positions within the group (first and last along the
        direction ``(-b, a)``) of its extreme points
    length : (K,) distance between them along the line
    """
    K = offsets.shape[0] - 1
    line = np.full((K, 3), np.nan)
    rms = np.full(K, np.nan)
    sig_n = np.full(K, np.nan)
    sig_a = np.full(K, np.nan)
    ends = np.zeros((K, 2), np.int64)
    length = np.zeros(K)
    for k in range(K):
        o0, o1 = offsets[k], offsets[k + 1]
        n = o1 - o0
        if n < 2:
            continue
        cx = 0.0
        cy = 0.0
        for j in range(o0, o1):
            cx += P[members[j], 0]
            cy += P[members[j], 1]
        cx /= n
        cy /= n
        sxx = 0.0
        sxy = 0.0
        syy = 0.0
        for j in range(o0, o1):
            dx = P[members[j], 0] - cx
            dy = P[members[j], 1] - cy
            sxx += dx * dx
            sxy += dx * dy
            syy += dy * dy
        w0, w1, nx, ny = _eigh_sym2(sxx / n, sxy / n, syy / n)
        if w1 < 1e-12:  # the points coincide
            continue
        line[k, 0] = nx
        line[k, 1] = ny
        line[k, 2] = -(nx * cx + ny * cy)
        r = math.sqrt(max(w0, 0.0))
        rms[k] = r
        sig_n[k] = r / math.sqrt(n - 2) if n > 2 else math.inf
        sig_a[k] = sig_n[k] / math.sqrt(w1)
        tmin = math.inf
        tmax = -math.inf
        for j in range(o0, o1):
            t = -ny * P[members[j], 0] + nx * P[members[j], 1]
            if t < tmin:
                tmin = t
                ends[k, 0] = j - o0
            if t > tmax:
                tmax = t
                ends[k, 1] = j - o0
        length[k] = tmax - tmin
    return line, rms, sig_n, sig_a, ends, length


def warm_up() -> None:
    """Load (or compile) this module's kernels by calling them once on tiny inputs."""
    th = np.zeros((8, 8), np.uint8)
    p = np.zeros((1, 2))
    z = np.zeros(1, np.int64)
    fit_lines(p, z, np.zeros(2, np.int64))
    grid_clear(p, p, 1.0, 1.0, True, 2, 0, np.zeros((2, 2), np.uint8))
    chains(z, z, 1, np.full((2, 2), -1, np.int32))
    beside_grass(p, p, 1.0, th, 1.0, 1.0)
    settle_points(p, p, 1.0, th, 1.0, 1.0, 1.0, 1.0, np.full((2, 2), -1, np.int32), 1.0, th, 1.0, 0.0, 1.0, 0.0)
    cut_by_line(p, np.ones((1, 3)), 0.0, 0.0, 2.0, 1.0, 0.0, 0.95)
    mask_at(p, th, 1.0, 1.0, 1.0, 1.0)
