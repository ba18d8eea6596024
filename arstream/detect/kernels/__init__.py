"""Compiled per-pixel and per-point loops of detection (numba), one module per
stage that calls them: :mod:`.ridges` (line pixels), :mod:`.segments` (the
Hough lines), :mod:`.points` (the detector's chains, grass test and line
fits), :mod:`.ellipses` (conic fits and their validation), :mod:`.grass`
(component statistics).

The detector's stages are whole-image OpenCV operations followed by work on
the few thousand line pixels they leave. Written as numpy expressions, that
work is dozens of passes over small arrays, each paying numpy's per-call
overhead, and it holds the GIL between them; here each is one compiled loop
that releases the GIL (the pipeline runs detection on its own thread).
Compiled on first use and cached next to each file (numba's ``cache=True``);
:func:`arstream.kernels.warm_up` loads them, with the solver's and the
renderer's, ahead of a run.
"""

from arstream.detect.kernels import ellipses, grass, points, ridges, segments

__all__ = ["MODULES", "warm_up"]

#: the modules of detection's compiled loops, each with its own ``warm_up``
MODULES = (ridges, segments, points, ellipses, grass)


def warm_up() -> None:
    """Load (or compile) every detection kernel by calling it once on tiny inputs."""
    for module in MODULES:
        module.warm_up()
