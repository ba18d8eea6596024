"""Compiled loops of the solver (:mod:`arstream.solve`, numba): the tracker's
nearest-line-pixel lookups (:class:`arstream.solve.LineIndex`: a grid of the
points and a compiled search over it; building a k-d tree cost more per
frame than all its queries), the projection of the pitch model
(:func:`project_points`) and the fit of the camera to the line pixels
(:func:`refine_pose`, a robust Levenberg-Marquardt over
:func:`marking_residuals`).

Compiled on first use and cached next to this file (numba's ``cache=True``);
:func:`arstream.kernels.warm_up` loads them ahead of a run.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from arstream.jit import JIT as _JIT, counting_sort

__all__ = ["grid_nearest", "marking_residuals", "point_grid", "pose_from_params", "project_points", "refine_pose", "warm_up"]


@nb.njit(**_JIT)
def point_grid(pts, cell, max_side):
    """Points bucketed by the cells of a grid over their bounding box (a
    counting sort), for :func:`grid_nearest`.

    The cell of (x, y) is (floor((x - x0) / cell), floor((y - y0) / cell)),
    (x0, y0) the least coordinates; the cell grows where the box would be
    more than ``max_side`` cells a side.

    Parameters
    ----------
    pts : (N, 2) float64 finite points, N >= 1
    cell : float, cell size (units of pts)
    max_side : int

    Returns
    -------
    order : (N,) int64 point indices, cell after cell (raster order of the cells)
    starts : (gw gh + 1,) int64, cell c holds order[starts[c]:starts[c + 1]]
    grid : (x0, y0, cell, gw, gh)
    """
    n = pts.shape[0]
    x0 = np.inf
    y0 = np.inf
    x1 = -np.inf
    y1 = -np.inf
    for i in range(n):
        x0 = min(x0, pts[i, 0])
        x1 = max(x1, pts[i, 0])
        y0 = min(y0, pts[i, 1])
        y1 = max(y1, pts[i, 1])
    cell = max(cell, max(x1 - x0, y1 - y0) / max_side)
    gw = int((x1 - x0) / cell) + 1
    gh = int((y1 - y0) / cell) + 1
    cid = np.empty(n, np.int64)
    for i in range(n):
        cx = int(min((pts[i, 0] - x0) / cell, gw - 1.0))
        cy = int(min((pts[i, 1] - y0) / cell, gh - 1.0))
        cid[i] = cy * gw + cx
    order, starts = counting_sort(cid, gw * gh)
    return order, starts, (x0, y0, cell, gw, gh)


@nb.njit(**_JIT)
def grid_nearest(pts, order, starts, x0, y0, cell, gw, gh, q, radius):
    """The nearest point of ``pts`` to each query, searched on its
    :func:`point_grid` ring by ring over the cells within ``radius`` (exact;
    ties go to the lower index).

    Parameters
    ----------
    pts : (N, 2) float64 points; order, starts, x0, y0, cell, gw, gh : their grid
    q : (M, 2) float64 queries (a non-finite query finds nothing)
    radius : float, only points closer than this (strictly) count

    Returns
    -------
    d : (M,) float64 distances (inf where none is closer than ``radius``)
    idx : (M,) int64 indices into ``pts`` (-1 where none)
    """
    m = q.shape[0]
    d = np.full(m, np.inf)
    idx = np.full(m, -1, np.int64)
    k = int(min(np.ceil(radius / cell), max(gw, gh)))
    r2 = radius * radius
    for i in range(m):
        qx = q[i, 0]
        qy = q[i, 1]
        if not (np.isfinite(qx) and np.isfinite(qy)):
            continue
        cx = int(min(max((qx - x0) / cell, 0.0), gw - 1.0))
        cy = int(min(max((qy - y0) / cell, 0.0), gh - 1.0))
        best = r2
        bj = -1
        # rings of cells outwards; the points of ring rr are at least (rr - 1) cells away
        for rr in range(k + 1):
            lim = (rr - 1) * cell
            if rr > 1 and best < lim * lim:
                break
            for y in range(max(cy - rr, 0), min(cy + rr + 1, gh)):
                edge = y == cy - rr or y == cy + rr
                step = 1 if edge else 2 * rr
                for x in range(cx - rr, cx + rr + 1, max(step, 1)):
                    if x < 0 or x >= gw:
                        continue
                    c = y * gw + x
                    for t in range(starts[c], starts[c + 1]):
                        j = order[t]
                        dx = pts[j, 0] - qx
                        dy = pts[j, 1] - qy
                        dd = dx * dx + dy * dy
                        if dd < best or (dd == best and bj >= 0 and j < bj):
                            best = dd
                            bj = j
        if bj >= 0:
            d[i] = np.sqrt(best)
            idx[i] = bj
    return d, idx


@nb.njit(**_JIT)
def project_points(P, R, t, K, dist, width, height, margin, min_depth):
    """Pinhole projection with a radial lens, and which points land in view.

    The same model as :meth:`geometry.camera.Camera.project`: camera
    coordinates ``Xc = R X + t``, normalised ``x = Xc[:2] / Xc[2]`` bent by
    ``(1 + k1 r^2 + k2 r^4 + ...)``, then ``K``. A point past the radius
    where the lens polynomial stops growing (``d r_d / d r <= 0``) gets no
    pixel, as one at depth ``<= min_depth``.

    Parameters
    ----------
    P : (N, 3) float64 world points (metres)
    R : (3, 3), t : (3,) world -> camera
    K : (3, 3) intrinsic matrix
    dist : (k,) float64 radial coefficients (may be empty)
    width, height : frame size (pixels)
    margin : float, pixels inside the frame's edge pixels (negative: beyond them)
    min_depth : float, least camera-frame depth (metres)

    Returns
    -------
    px : (N, 2) float64 pixels, NaN where none
    inside : (N,) bool, a pixel within ``[margin, size - 1 - margin]`` on both axes
    """
    n = P.shape[0]
    px = np.empty((n, 2))
    inside = np.zeros(n, np.bool_)
    nd = dist.shape[0]
    xmax = width - 1 - margin
    ymax = height - 1 - margin
    for i in range(n):
        X0, X1, X2 = P[i, 0], P[i, 1], P[i, 2]
        z = R[2, 0] * X0 + R[2, 1] * X1 + R[2, 2] * X2 + t[2]
        if not z > min_depth:
            px[i, 0] = np.nan
            px[i, 1] = np.nan
            continue
        x = (R[0, 0] * X0 + R[0, 1] * X1 + R[0, 2] * X2 + t[0]) / z
        y = (R[1, 0] * X0 + R[1, 1] * X1 + R[1, 2] * X2 + t[1]) / z
        if nd:
            r2 = x * x + y * y
            factor = 1.0
            slope = 1.0
            rp = 1.0
            for k in range(nd):
                rp *= r2
                factor += dist[k] * rp
                slope += (2 * k + 3) * dist[k] * rp
            if not slope > 0:
                px[i, 0] = np.nan
                px[i, 1] = np.nan
                continue
            x *= factor
            y *= factor
        u = K[0, 0] * x + K[0, 1] * y + K[0, 2]
        v = K[1, 0] * x + K[1, 1] * y + K[1, 2]
        px[i, 0] = u
        px[i, 1] = v
        inside[i] = u >= margin and u <= xmax and v >= margin and v <= ymax
    return px, inside


@nb.njit(**_JIT)
def marking_residuals(X, Q, nrm, R, C, f, cx, cy, k1):
    """Residuals and Jacobian of a camera against matched line pixels.

    The residual of model point ``X_i`` is the signed distance along the
    image normal ``nrm_i`` of its projection from its matched line pixel
    ``Q_i``: ``r_i = n_i . (f x_d + c - Q_i)``, with ``x_d`` the normalised
    point ``(Xc_x, Xc_y) / Xc_z`` of ``Xc = R (X - C)`` bent by
    ``(1 + k1 r^2)``; a point behind the camera has the constant residual
    50 px (and no derivative).

    Parameters
    ----------
    X : (N, 3) model points (metres); Q : (N, 2) matched pixels;
    nrm : (N, 2) unit image normals of the projected markings
    R : (3, 3) rotation, C : (3,) centre (world -> camera ``R (X - C)``)
    f : focal length (px); cx, cy : principal point; k1 : radial coefficient

    Returns
    -------
    r : (N,) residuals (px)
    G : (N, 8) their derivatives by (w_x, w_y, w_z: a left rotation
        perturbation ``R <- exp([w]x) R``, C_x, C_y, C_z, log f, k1)
    """
    n = X.shape[0]
    r = np.empty(n)
    G = np.empty((n, 8))
    for i in range(n):
        d0, d1, d2 = X[i, 0] - C[0], X[i, 1] - C[1], X[i, 2] - C[2]
        x = R[0, 0] * d0 + R[0, 1] * d1 + R[0, 2] * d2
        y = R[1, 0] * d0 + R[1, 1] * d1 + R[1, 2] * d2
        z = R[2, 0] * d0 + R[2, 1] * d1 + R[2, 2] * d2
        if not z > 0:
            r[i] = 50.0
            for j in range(8):
                G[i, j] = 0.0
            continue
        iz = 1.0 / z
        u, v = x * iz, y * iz
        r2 = u * u + v * v
        s = 1.0 + k1 * r2
        n0, n1 = nrm[i, 0], nrm[i, 1]
        r[i] = n0 * (f * u * s + cx - Q[i, 0]) + n1 * (f * v * s + cy - Q[i, 1])
        # d(pixel)/d(u, v) through the lens, contracted with the normal
        a = f * (s + 2 * k1 * u * u)
        b = f * (2 * k1 * u * v)
        c = f * (s + 2 * k1 * v * v)
        gu = n0 * a + n1 * b
        gv = n0 * b + n1 * c
        # dr/dXc
        e0, e1, e2 = gu * iz, gv * iz, -(gu * u + gv * v) * iz
        # left rotation perturbation: dXc/dw = -[Xc]x
        G[i, 0] = e2 * y - e1 * z
        G[i, 1] = e0 * z - e2 * x
        G[i, 2] = e1 * x - e0 * y
        # dXc/dC = -R
        G[i, 3] = -(e0 * R[0, 0] + e1 * R[1, 0] + e2 * R[2, 0])
        G[i, 4] = -(e0 * R[0, 1] + e1 * R[1, 1] + e2 * R[2, 1])
        G[i, 5] = -(e0 * R[0, 2] + e1 * R[1, 2] + e2 * R[2, 2])
        G[i, 6] = f * s * (n0 * u + n1 * v)
        G[i, 7] = f * r2 * (n0 * u + n1 * v)
    return r, G


@nb.njit(**_JIT)
def _rotation_exp(w):
    """``exp([w]x)`` (3, 3) of a rotation vector (3,), as ``cv2.Rodrigues``."""
    th = math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    R = np.eye(3)
    if th < 2.220446049250313e-16:
        return R
    c, s = math.cos(th), math.sin(th)
    c1 = 1.0 - c
    x, y, z = w[0] / th, w[1] / th, w[2] / th
    R[0, 0], R[0, 1], R[0, 2] = c + c1 * x * x, c1 * x * y - s * z, c1 * x * z + s * y
    R[1, 0], R[1, 1], R[1, 2] = c1 * x * y + s * z, c + c1 * y * y, c1 * y * z - s * x
    R[2, 0], R[2, 1], R[2, 2] = c1 * x * z - s * y, c1 * y * z + s * x, c + c1 * z * z
    return R


@nb.njit(**_JIT)
def pose_from_params(th, R_ref, M, C_fixed, k1_fixed):
    """The camera of a parameter vector of :func:`refine_pose`.

    Parameters
    ----------
    th : (k,) parameters
    R_ref : (3, 3) rotation they perturb
    M : (8, k) map from ``th`` to (w (3): a left rotation perturbation
        ``R = exp([w]x) R_ref``, C (3), log f, k1); the centre rows all zero
        for a fixed centre, the k1 row zero for a fixed k1
    C_fixed : (3,) the centre when it is fixed; k1_fixed : k1 when it is fixed

    Returns
    -------
    R (3, 3), C (3,), f, k1
    """
    k = th.shape[0]
    v = np.zeros(8)
    free_c = False
    free_k = False
    for i in range(8):
        for j in range(k):
            v[i] += M[i, j] * th[j]
            if M[i, j] != 0.0:
                if 3 <= i < 6:
                    free_c = True
                elif i == 7:
                    free_k = True
    E = _rotation_exp(v[:3])
    R = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            R[i, j] = E[i, 0] * R_ref[0, j] + E[i, 1] * R_ref[1, j] + E[i, 2] * R_ref[2, j]
    C = v[3:6].copy() if free_c else C_fixed.copy()
    return R, C, math.exp(v[6]), (v[7] if free_k else k1_fixed)


@nb.njit(**_JIT)
def _pose_residuals(th, X, Q, nrm, R_ref, M, C_fixed, k1_fixed, cx, cy):
    R, C, f, k1 = pose_from_params(th, R_ref, M, C_fixed, k1_fixed)
    r, G = marking_residuals(X, Q, nrm, R, C, f, cx, cy, k1)
    n, k = G.shape[0], M.shape[1]
    J = np.zeros((n, k))
    for i in range(n):
        for a in range(8):
            g = G[i, a]
            if g != 0.0:
                for j in range(k):
                    J[i, j] += g * M[a, j]
    return r, J


@nb.njit(**_JIT)
def _soft_l1(r, s2):
    c = 0.0
    for i in range(r.shape[0]):
        c += 2.0 * (math.sqrt(1.0 + r[i] * r[i] / s2) - 1.0)
    return c


@nb.njit(**_JIT)
def _solve_spd(A, b):
    """Solve ``A x = b`` for a symmetric positive definite (k, k) ``A`` (Cholesky);
    (x, False) when a pivot is not positive."""
    k = A.shape[0]
    L = np.zeros((k, k))
    x = np.zeros(k)
    for j in range(k):
        d = A[j, j]
        for m in range(j):
            d -= L[j, m] * L[j, m]
        if not d > 0.0:
            return x, False
        L[j, j] = math.sqrt(d)
        for i in range(j + 1, k):
            v = A[i, j]
            for m in range(j):
                v -= L[i, m] * L[j, m]
            L[i, j] = v / L[j, j]
    y = np.zeros(k)
    for i in range(k):
        v = b[i]
        for m in range(i):
            v -= L[i, m] * y[m]
        y[i] = v / L[i, i]
    for i in range(k - 1, -1, -1):
        v = y[i]
        for m in range(i + 1, k):
            v -= L[m, i] * x[m]
        x[i] = v / L[i, i]
    return x, True


@nb.njit(**_JIT)
def refine_pose(X, Q, nrm, R_ref, M, th0, C_fixed, k1_fixed, cx, cy, f_scale, max_iter, tol):
    """Levenberg-Marquardt with the soft-L1 loss (iteratively reweighted least
    squares) of a camera against matched line pixels.

    Minimises ``sum 2 (sqrt(1 + (r_i / s)^2) - 1)`` over the residuals of
    :func:`marking_residuals` (``s`` = ``f_scale``) for the camera
    :func:`pose_from_params` makes of the parameters: the problem of scipy's
    ``least_squares(loss="soft_l1")``, compiled, because for the few
    parameters of a camera (4-8) and a few hundred residuals the per-call
    overhead of any Python loop is most of the per-frame cost of tracking.
    Damping starts at 1e-3 of the diagonal, shrinks 5x after a step that
    lowers the cost and grows 10x after one that does not; it stops after
    ``max_iter`` steps, when no step lowers the cost, when a step is below
    ``tol`` relative to the parameters, or when the cost fell by less than
    1e-4 of itself.

    Parameters
    ----------
    X, Q, nrm : as :func:`marking_residuals`
    R_ref, M, C_fixed, k1_fixed : as :func:`pose_from_params`
    th0 : (k,) initial parameters
    cx, cy : principal point; f_scale : soft-L1 scale (px)
    max_iter : int; tol : float

    Returns
    -------
    x (k,), residuals (N,) and Jacobian (N, k) at ``x``, cost, steps taken
    """
    s2 = f_scale * f_scale
    k = th0.shape[0]
    x = th0.copy()
    r, J = _pose_residuals(x, X, Q, nrm, R_ref, M, C_fixed, k1_fixed, cx, cy)
    cost = _soft_l1(r, s2)
    lam = 1e-3
    steps = 0
    n = r.shape[0]
    A = np.zeros((k, k))
    g = np.zeros(k)
    B = np.zeros((k, k))
    for it in range(1, max_iter + 1):
        steps = it
        cost_prev = cost
        A[:] = 0.0
        g[:] = 0.0
        for i in range(n):
            w = 1.0 / math.sqrt(1.0 + r[i] * r[i] / s2)
            for a in range(k):
                wa = w * J[i, a]
                g[a] += wa * r[i]
                for b in range(a + 1):
                    A[a, b] += wa * J[i, b]
        for a in range(k):
            for b in range(a):
                A[b, a] = A[a, b]
        improved = False
        dx = np.zeros(k)
        while lam < 1e8:
            for a in range(k):
                for b in range(k):
                    B[a, b] = A[a, b]
                B[a, a] += lam * max(A[a, a], 1e-12)
            dx, ok = _solve_spd(B, -g)
            if not ok:
                lam *= 10.0
                continue
            xn = x + dx
            rn, Jn = _pose_residuals(xn, X, Q, nrm, R_ref, M, C_fixed, k1_fixed, cx, cy)
            cn = _soft_l1(rn, s2)
            if cn < cost:
                x, r, J, cost = xn, rn, Jn, cn
                lam = max(lam * 0.2, 1e-9)
                improved = True
                break
            lam *= 10.0
        if not improved:
            break
        if math.sqrt(np.sum(dx * dx)) < tol * (math.sqrt(np.sum(x * x)) + tol) or cost_prev - cost < 1e-4 * cost_prev:
            break
    return x, r, J, cost, steps


def warm_up() -> None:
    """Load (or compile) this module's kernels by calling them once on tiny inputs."""
    p = np.zeros((1, 2))
    order, starts, grid = point_grid(p, 8.0, 1024)
    grid_nearest(p, order, starts, *grid, p, 2.5)
    P3, I3 = np.zeros((1, 3)), np.eye(3)
    project_points(P3, I3, np.zeros(3), I3, np.zeros(0), 2, 2, 0.0, 0.5)
    marking_residuals(P3, p, p, I3, np.zeros(3), 1.0, 0.0, 0.0, 0.0)
    refine_pose(P3 + [0.0, 0.0, 1.0], p, p + [1.0, 0.0], I3, np.eye(8, 4), np.zeros(4), np.zeros(3), 0.0, 0.0, 0.0, 1.0, 12, 1e-10)
    pose_from_params(np.zeros(4), I3, np.eye(8, 4), np.zeros(3), 0.0)  # (also called on its own, not only inside refine_pose)
