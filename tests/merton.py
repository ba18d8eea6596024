"""The VGG "Merton College I" pair from ../shared/data (real images with
ground truth), shared by tests/test_fmatrix.py and bench/fmatrix_stability.py."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import calib.fmatrix as fm

#: where the data lies: the shared/ folder beside the checkout
DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "vgg-merton-college-1"


def load_merton(data: Path = DATA) -> dict:
    """The two views' true fundamental matrix ``F`` (3, 3), the corners seen in
    both ``x1``, ``x2`` (N, 2) pixels, their 3-D points ``X`` (N, 3), and the
    angle (degrees) between the two optical axes."""
    P = [np.loadtxt(data / "2D" / f"00{i}.P") for i in (1, 2)]
    corners = [np.loadtxt(data / "2D" / f"00{i}.corners") for i in (1, 2)]
    X = np.loadtxt(data / "3D" / "p3d")
    rows = [line.split() for line in (data / "2D" / "nview-corners").read_text().splitlines() if line.strip()]
    sel = [(k, int(r[0]), int(r[1])) for k, r in enumerate(rows) if r[0] != "*" and r[1] != "*"]
    k = np.array([s[0] for s in sel])
    axes = [p[2, :3] / np.linalg.norm(p[2, :3]) for p in P]
    return {
        "F": fm.fundamental_from_cameras(P[0], P[1]),
        "x1": corners[0][[s[1] for s in sel]],
        "x2": corners[1][[s[2] for s in sel]],
        "X": X[k],
        "angle": float(np.degrees(np.arccos(np.clip(axes[0] @ axes[1], -1, 1)))),
    }


def facade(X: np.ndarray) -> np.ndarray:
    """Mask (N,) of the points of the largest plane of the reconstruction ``X``
    (N, 3) (seeded RANSAC, 0.5 % of the scene's scale)."""
    rng = np.random.default_rng(0)
    scale = np.median(np.linalg.norm(X - np.median(X, axis=0), axis=1))
    best = np.zeros(len(X), bool)
    for _ in range(500):
        s = X[rng.choice(len(X), 3, replace=False)]
        n = np.cross(s[1] - s[0], s[2] - s[0])
        if np.linalg.norm(n) < 1e-9:
            continue
        inl = np.abs((X - s[0]) @ (n / np.linalg.norm(n))) < 0.005 * scale
        if inl.sum() > best.sum():
            best = inl
    return best
