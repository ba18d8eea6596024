"""Views of one tripod camera refined jointly (issue 29).

A broadcast main camera turns and zooms on a tripod: its centre is one point
for the whole shot. A single view fixes that point poorly along its line of
sight (a long lens's focal length and distance trade), two views turned from
each other fix it where those lines cross. :func:`fit_tripod` refines views
jointly to their frames' paint pixels: one centre, a rotation and focal
length per view, optionally the pitch's length and width
(:func:`arstream.pitch_size.estimate_pitch_size` frees them; the tracker
triangulates its tripod centre from two views with the size fixed,
:meth:`arstream.track.Tracker._check_centre`).

Frames: pitch frame as in ``geometry.pitch`` (metres, origin at the centre
spot, Z up); pixels of each view's frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.sparse import csr_matrix, lil_matrix

from arstream.solve import ModelSamples
from arstream.solve_kernels import marking_residuals, project_points
from geometry.camera import Camera, camera_turned, rotation_with_derivatives
from geometry.lines import unskew
from geometry.pitch import PitchModel

__all__ = ["TripodFit", "fit_tripod"]


@dataclass(frozen=True)
class TripodFit:
    """Result of :func:`fit_tripod`.

    Attributes
    ----------
    x : the parameter vector (centre, free size offsets, ``k1 f`` where the
        views have a lens term, then per view a rotation vector and log f): a
        ``seed_x`` for a fit of the same views
    cameras : tuple of Camera, the views' refined cameras (frame pixels)
    rms : px, RMS of the inlier residuals (|r| < 2.5 px) of the last round
    centre : (3,) metres, the shared camera centre
    length, width : metres, the pitch's (the prior's where not free)
    size_sd : (length sd, width sd) metres from the least squares with the
        systematic term; inf where not free
    """

    x: np.ndarray
    cameras: tuple
    rms: float
    centre: np.ndarray
    length: float
    width: float
    size_sd: tuple[float, float]


@dataclass
class _Matches:
    """One view's associations for a round: model points, their derivatives, the
    paint pixels they matched and the projected markings' normals there."""

    X: np.ndarray
    dL: np.ndarray
    dW: np.ndarray
    q: np.ndarray
    n: np.ndarray
    marking: np.ndarray


def _camera(view: Camera, w: np.ndarray, logf0: float, logf: float, C: np.ndarray, kappa: float | None) -> Camera:
    """``view``'s camera turned by ``w`` (rad, about the pitch frame's axes),
    its focal length ``exp(logf)`` (``view``'s is ``exp(logf0)``), centre
    ``C``; radial ``k1 = kappa / f`` (None: its own)."""
    d = logf - logf0
    return camera_turned(view, w, d, C, None if kappa is None else (float(kappa) / (view.K[0, 0] * np.exp(d)),))


def _project(cam: Camera, X: np.ndarray, size) -> np.ndarray:
    c = np.ascontiguousarray
    px, _ = project_points(c(X, np.float64), c(cam.R, np.float64), c(cam.t, np.float64), c(cam.K, np.float64), np.asarray(cam.dist, np.float64), int(size[0]), int(size[1]), -1e6, 0.1)
    return px



class _TripodProblem:
    """:func:`fit_tripod`'s residuals for one round's associations
    (``matches``, one :class:`_Matches` per view) and their Jacobian.

    The residuals: each view's matched samples' distances (px) along the
    projected markings' normals from their paint pixels (50 px where a
    sample gets no pixel), then the size prior's rows.

    The Jacobian in closed form, for views with square pixels and no skew:
    each view's rows from :func:`arstream.solve_kernels.marking_residuals`
    (a residual's derivatives by a left rotation perturbation, the centre,
    log f and k1 at the view's camera), carried to the fit's parameters: the
    rotation vector ``w`` of ``R = exp(w) R0`` through ``dR / dw_i =
    [delta_i]x R`` (:func:`geometry.camera.rotation_with_derivatives`),
    ``k1 = kappa / f`` (d/d log f loses ``k1`` times the k1 column, and
    d/d kappa is that column over f), and the size offsets as the samples'
    move (``-dr/dC`` along ``dL`` or ``dW``). A sample with no pixel has
    zero rows. Sparse (the solver's trust-region steps by LSMR, as with
    finite differences and their sparsity)."""

    def __init__(self, matches, cameras, indices, sizes, f0, unpack, size0, ns: int, free, lens: bool, prior_sd):
        self.matches, self.cameras, self.indices, self.sizes, self.f0, self.unpack, self.size0 = matches, cameras, indices, sizes, f0, unpack, size0
        self.ns, self.free, self.lens, self.prior_sd = ns, free, lens, prior_sd
        self._last: tuple | None = None  # (x, its _parts): the solver asks for both at one x

    def _parts(self, x: np.ndarray) -> tuple[list, list, list]:
        """Per view at ``x``: its camera, its matched samples (the size
        applied) and their pixels (NaN where none)."""
        key = x.tobytes()
        if self._last is None or self._last[0] != key:
            C, L, W, kappa = self.unpack(x)
            L0, W0 = self.size0
            ns = self.ns
            cams = [_camera(self.cameras[i], x[ns + 4 * j : ns + 4 * j + 3], self.f0[j], x[ns + 4 * j + 3], C, kappa) for j, i in enumerate(self.indices)]
            pts = [np.ascontiguousarray(m.X + m.dL * (L - L0) + m.dW * (W - W0)) for m in self.matches]
            px = [_project(c, P, self.sizes[i]) for c, P, i in zip(cams, pts, self.indices)]
            self._last = (key, (cams, pts, px))
        return self._last[1]

    def residuals(self, x: np.ndarray) -> np.ndarray:
        _, _, px = self._parts(x)
        out = []
        for m, p in zip(self.matches, px):
            r = np.einsum("ij,ij->i", m.n, p - m.q)
            out.append(np.where(np.isfinite(r), r, 50.0))
        _, L, W, _ = self.unpack(x)
        L0, W0 = self.size0
        off = [v for d, v in enumerate((L - L0, W - W0)) if self.free[d]]
        out.append(np.array([o / sd for o, sd in zip(off, self.prior_sd)], np.float64))
        return np.concatenate(out)

    def jacobian(self, x: np.ndarray) -> csr_matrix:
        ns = self.ns
        C = np.ascontiguousarray(self.unpack(x)[0], np.float64)
        cams, pts, px = self._parts(x)
        data, rows, cols = [], [], []
        row = 0
        for j, (m, cam, P, p) in enumerate(zip(self.matches, cams, pts, px)):
            w = x[ns + 4 * j : ns + 4 * j + 3]
            Rc, K = np.ascontiguousarray(cam.R), cam.K
            f, k1 = float(K[0, 0]), (float(cam.dist[0]) if cam.dist else 0.0)
            _, G = marking_residuals(P, np.ascontiguousarray(m.q, np.float64), np.ascontiguousarray(m.n, np.float64), Rc, C, f, float(K[0, 2]), float(K[1, 2]), k1)
            R, dR = rotation_with_derivatives(w)
            D = unskew(dR @ R.T).T  # (column i: the left perturbation d/dw_i makes, [delta_i]x = dR_i R^T)
            B = np.zeros((len(P), ns + 4))
            B[:, :3] = G[:, 3:6]
            k = 3
            for d, dX in ((0, m.dL), (1, m.dW)):
                if self.free[d]:
                    B[:, k] = -np.einsum("ij,ij->i", G[:, 3:6], dX)
                    k += 1
            if self.lens:
                B[:, ns - 1] = G[:, 7] / f
            B[:, ns : ns + 3] = G[:, :3] @ D
            B[:, ns + 3] = G[:, 6] - (k1 * G[:, 7] if self.lens else 0.0)
            B[~np.isfinite(p[:, 0])] = 0.0  # (a point with no pixel has the constant residual)
            c = np.r_[np.arange(ns), ns + 4 * j + np.arange(4)]
            data.append(B.ravel())
            rows.append(np.repeat(row + np.arange(len(P)), ns + 4))
            cols.append(np.tile(c, len(P)))
            row += len(P)
        for k, sd in enumerate(self.prior_sd):
            data.append(np.array([1.0 / sd]))
            rows.append(np.array([row + k]))
            cols.append(np.array([3 + k]))
        shape = (row + len(self.prior_sd), ns + 4 * len(self.matches))
        return csr_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))), shape=shape)


def fit_tripod(
    cameras,
    line_index,
    sizes,
    model: ModelSamples,
    centre,
    pitch: PitchModel,
    *,
    derivatives: tuple[np.ndarray, np.ndarray] | None = None,
    free=(False, False),
    radii=(8.0, 4.0, 2.5),
    max_points: int = 400,
    seed_x: np.ndarray | None = None,
    systematic_px: float = 1.0,
    size_prior_sd: tuple[float, float] | None = None,
) -> TripodFit:
    """Views of one tripod camera refined jointly to their frames' paint.

    One camera centre for all views and, where ``free``, the pitch's length
    and width; a rotation and a focal length per view; one ``k1 f`` for all
    views when any has a lens term (a zoom lens's k1 goes as 1 / f). Each
    round associates every view's model samples in view (at most
    ``max_points``, evenly thinned) with their nearest paint pixel within
    the round's radius, and minimises the distances along the projected
    markings' normals (soft L1, 1 px scale).

    Parameters
    ----------
    cameras : sequence of Camera, the views' starting cameras (their
        centres are replaced by ``centre``)
    line_index : sequence of LineIndex, each view's paint (line) pixels
    sizes : sequence of (width, height), each view's frame size in pixels
    model : ModelSamples of ``pitch`` (metres, pitch frame)
    centre : (3,) metres, the starting tripod centre
    pitch : PitchModel the samples were taken from
    derivatives : (dL, dW), (N, 3) each, how the samples move with the length
        and width (:func:`arstream.pitch_size.size_derivatives`); needed
        where ``free``
    free : (length free, width free)
    radii : px, the successive association radii (one round each)
    max_points : model samples per view and round
    seed_x : a parameter vector to start from (as :attr:`TripodFit.x`)
    systematic_px : px, how far each marking of each view may sit off its
        paint as a whole (added to the size's standard deviation)
    size_prior_sd : (length sd, width sd) metres, a Gaussian prior on the free
        dimensions about ``pitch``'s, each as one residual of ``(L - L0) /
        sd`` (px in the fit, at the loss's 1 px scale): a direction the views
        leave open stays at the prior instead of drifting, and the size's
        standard deviation is the posterior's (the pixels' information at
        their noise and the prior's, then the systematic term). None: no
        prior

    Returns
    -------
    TripodFit

    Raises
    ------
    ValueError
        No views, a line index or frame size missing for a view, a free size
        without its derivatives, or too few model samples matched to the
        views' paint.
    """
    if not cameras or len(line_index) != len(cameras) or len(sizes) != len(cameras):
        raise ValueError(f"one line index and one frame size per view: {len(cameras)} views, {len(line_index)} line indices, {len(sizes)} sizes")
    if any(free) and derivatives is None:
        raise ValueError("a free length or width needs the samples' size derivatives")
    dL0, dW0 = derivatives if derivatives is not None else (np.zeros_like(model.points), np.zeros_like(model.points))
    L0, W0 = pitch.length, pitch.width
    C0 = np.asarray(centre, np.float64)
    indices = list(range(len(cameras)))
    nv = len(indices)
    f0 = [np.log(cameras[i].focal) for i in indices]
    nfree = int(free[0]) + int(free[1])
    # square pixels with no skew (the tracker's and the size estimate's frames):
    # the Jacobian in closed form (solve_kernels.marking_residuals); else by
    # finite differences
    square = all(cameras[i].K[0, 0] == cameras[i].K[1, 1] and cameras[i].K[0, 1] == 0.0 for i in indices)
    # a zoom lens's k1 goes as 1 / f: one k1 f for all views, when they have a lens term
    lens = any(cameras[i].dist for i in indices)
    ns = 3 + nfree + int(lens)
    x = np.zeros(ns + 4 * nv)
    x[:3] = C0
    if lens:
        x[ns - 1] = np.median([(cameras[i].dist[0] if cameras[i].dist else 0.0) * cameras[i].focal for i in indices])
    for j in range(nv):
        x[ns + 4 * j + 3] = f0[j]
    if seed_x is not None:
        x[:] = seed_x

    def unpack(x):
        C = x[:3]
        k = 3
        L, W = L0, W0
        if free[0]:
            L = L0 + x[k]
            k += 1
        if free[1]:
            W = W0 + x[k]
        return C, L, W, (x[ns - 1] if lens else None)

    def cams(x):
        C, _, _, kappa = unpack(x)
        return [_camera(cameras[i], x[ns + 4 * j : ns + 4 * j + 3], f0[j], x[ns + 4 * j + 3], C, kappa) for j, i in enumerate(indices)]

    prior_sd = [sd for d, sd in enumerate(size_prior_sd) if free[d]] if size_prior_sd is not None else []

    matches = None
    res = None
    for radius in radii:
        C, L, W, _ = unpack(x)
        cs = cams(x)
        matches = []
        for j, i in enumerate(indices):
            P = model.points + dL0 * (L - L0) + dW0 * (W - W0)
            px, inside = project_points(P, np.ascontiguousarray(cs[j].R), np.ascontiguousarray(cs[j].t), np.ascontiguousarray(cs[j].K), np.asarray(cs[j].dist, np.float64), int(sizes[i][0]), int(sizes[i][1]), 2.0, 0.5)
            idx = np.flatnonzero(inside)
            if len(idx) > max_points:
                idx = idx[np.linspace(0, len(idx) - 1, max_points).astype(int)]
            d, q = line_index[i].nearest(px[idx], radius)
            ok = np.isfinite(d)
            idx, q = idx[ok], q[ok]
            X = P[idx]
            p_ab = _project(cs[j], np.concatenate([X, X + 0.05 * model.tangents[idx]]), sizes[i])
            tg = p_ab[len(X) :] - p_ab[: len(X)]
            nrm = np.column_stack([-tg[:, 1], tg[:, 0]])
            nrm /= np.linalg.norm(nrm, axis=1, keepdims=True) + 1e-12
            matches.append(_Matches(model.points[idx], dL0[idx], dW0[idx], q, nrm, model.marking[idx]))
        counts = [len(m.q) for m in matches]
        if sum(counts) < ns + 4 * nv + 8 or min(counts) < 8:
            raise ValueError("too few marking points matched to the views' paint")
        n_data = sum(counts)

        problem = _TripodProblem(matches, cameras, indices, sizes, f0, unpack, (L0, W0), ns, free, lens, prior_sd)
        fun = problem.residuals
        if square:
            res = least_squares(fun, x, jac=problem.jacobian, tr_solver="lsmr", loss="soft_l1", f_scale=1.0, x_scale="jac", max_nfev=60)
        else:
            S = lil_matrix((n_data + len(prior_sd), len(x)), dtype=np.int8)
            S[n_data:, 3 : 3 + nfree] = 1
            row = 0
            for j, n in enumerate(counts):
                S[row : row + n, :ns] = 1
                S[row : row + n, ns + 4 * j : ns + 4 * j + 4] = 1
                row += n
            res = least_squares(fun, x, jac_sparsity=S, loss="soft_l1", f_scale=1.0, x_scale="jac", max_nfev=60)
        x = res.x
    r = res.fun[:n_data]
    inl = np.abs(r) < 2.5
    rms = float(np.sqrt(np.mean(r[inl] ** 2))) if inl.any() else float("inf")
    # the least-squares standard deviations of the size (a floor for the jackknife's:
    # views alike leave a direction the data do not fix with a jackknife near zero)
    J = res.jac.toarray() if hasattr(res.jac, "toarray") else np.asarray(res.jac)
    J, J_prior = J[:n_data][inl], J[n_data:]
    # (a direction the views leave open keeps its huge variance: eigenvalues are
    # floored, not dropped as a pseudo-inverse would)
    # Besides the noise, each marking of each view may sit ``systematic_px`` off its
    # paint as a whole (a line's centre on a compressed, blurred picture; lens
    # distortion beyond one term): its effect on the size, from the normal
    # equations, adds up over those (view, marking) groups independently.
    groups = np.concatenate([j * 10_000 + m.marking for j, m in enumerate(matches)])[inl]
    try:
        # (the information: the pixels' at their noise, the prior's rows already
        # in units of its standard deviation)
        noise = max(rms, 0.3) ** 2
        lam, V = np.linalg.eigh(J.T @ J / noise + J_prior.T @ J_prior)
        lam = np.maximum(lam, 1e-12 * max(lam.max(), 1e-300))
        cov = (V / lam) @ V.T
        rows = slice(3, 3 + nfree)
        G = cov[rows] @ J.T / noise  # (nfree, N): d(size) / d(residual)
        _, g = np.unique(groups, return_inverse=True)
        per_group = np.stack([np.bincount(g, weights=G[k]) for k in range(nfree)]) if nfree else np.zeros((0, 0))
        sys_var = systematic_px**2 * (per_group**2).sum(axis=1) if nfree else np.zeros(0)
        ls_sd = np.sqrt(np.maximum(np.diag(cov)[rows], 0.0) + sys_var)
    except np.linalg.LinAlgError:
        ls_sd = np.full(nfree, np.inf)
    sd = [np.inf, np.inf]
    k = 0
    for d in range(2):
        if free[d]:
            sd[d] = float(ls_sd[k])
            k += 1
    C, L, W, _ = unpack(x)
    return TripodFit(x, tuple(cams(x)), rms, np.asarray(C, np.float64).copy(), float(L), float(W), (sd[0], sd[1]))
