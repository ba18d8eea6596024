"""Shared fixtures and helpers for the test suite."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

from geometry.camera import Camera
from geometry.conics import ellipse_from_conic
from geometry.homography import transfer_conic
from geometry.pitch import Arc, PitchModel

ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = ROOT.parent / "shared" / "data"


def pytest_configure(config) -> None:
    """Compile every numba kernel into its cache once, in parallel, before the
    tests start (on a fresh install each test worker, batch worker and CLI
    subprocess would otherwise compile the same kernels again, about 40 s of
    a core each). Skipped in xdist's workers: the controller did it. In a
    process of its own (``python -m arstream.kernels``): the fork server its
    pool starts stays out of this one, whose tests (``-n0``) start their own."""
    if hasattr(config, "workerinput"):
        return
    import subprocess
    import sys

    subprocess.run([sys.executable, "-m", "arstream.kernels"], check=True, stdout=subprocess.DEVNULL)


def pytest_collection_modifyitems(config, items) -> None:
    """The tests marked ``long`` first (stable otherwise): started early, the
    slowest tests do not leave one worker busy alone at the end of the run."""
    items.sort(key=lambda item: item.get_closest_marker("long") is None)


@pytest.fixture
def shared_data() -> Path:
    if not SHARED_DATA.exists():
        pytest.skip(f"shared data not found at {SHARED_DATA}")
    return SHARED_DATA


@dataclass
class TruthLine:
    line: np.ndarray
    length: float
    endpoints: np.ndarray
    points: np.ndarray = field(default=None)


@dataclass
class TruthEllipse:
    conic: np.ndarray
    ellipse: object
    score: float = 1.0


@dataclass
class TruthDetections:
    """What a perfect detector would report for a camera: the projected markings.

    Used to test the solver and tracker in isolation from the detector (the
    end-to-end tests use the real detector)."""

    width: int
    height: int
    pitch_visible: bool
    line_points: np.ndarray
    lines: list
    ellipses: list


def truth_detections(cam: Camera | None, size=(1280, 720), noise=0.3, seed=0, drop=0.15) -> TruthDetections:
    W, H = size
    if cam is None:
        return TruthDetections(W, H, False, np.zeros((0, 2)), [], [])
    rng = np.random.default_rng(seed)
    pitch = PitchModel()
    pts, lines, ellipses = [], [], []
    for name, m in pitch.markings.items():
        s = m.sample(0.05)
        X = np.column_stack([s, np.zeros(len(s))])
        keep = cam.in_front(X)
        px = cam.project(X[keep])
        inside = (px[:, 0] >= 0) & (px[:, 0] < W) & (px[:, 1] >= 0) & (px[:, 1] < H)
        px = px[inside]
        if len(px) < 2:
            continue
        # occlusions: drop random runs
        keep = np.ones(len(px), bool)
        for _ in range(int(drop * 10)):
            a = rng.integers(0, len(px))
            keep[a : a + len(px) // 20] = False
        pts.append(px[keep] + rng.normal(0, noise, (keep.sum(), 2)))
        if not isinstance(m, Arc):
            from geometry.lines import fit_line

            fit = fit_line(px)
            length = float(np.linalg.norm(px[-1] - px[0]))
            if length > 40:
                lines.append(TruthLine(fit.line, length, px[[0, -1]], px))
        elif name == "centre_circle" and len(px) > 0.5 * len(s):
            E = transfer_conic(cam.H_img_from_pitch, m.conic)
            ellipses.append(TruthEllipse(E, ellipse_from_conic(E)))
    lines.sort(key=lambda l: -l.length)
    lp = np.concatenate(pts) if pts else np.zeros((0, 2))
    return TruthDetections(W, H, len(lp) > 100, lp, lines, ellipses)
