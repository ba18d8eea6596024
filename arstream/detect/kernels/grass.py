"""Compiled loops of the grass stage (:mod:`arstream.detect.grass`, numba): the
statistics of labelled components and the rows of a component's box that it
fills (the screen-graphics test).

Compiled on first use and cached next to this file (numba's ``cache=True``);
:func:`arstream.kernels.warm_up` loads them ahead of a run.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from arstream.jit import JIT as _JIT

__all__ = ["component_stats", "full_rows", "warm_up"]


@nb.njit(**_JIT)
def component_stats(labels, n):
    """Bounding boxes and areas of the components of a label image, in
    OpenCV's layout (``cv2.connectedComponentsWithStats``: columns
    ``CC_STAT_LEFT, TOP, WIDTH, HEIGHT, AREA``), in one pass over the pixels
    (OpenCV's own statistics, centroids included, cost twice its labelling
    on the detector's small masks).

    Parameters
    ----------
    labels : (h, w) int32 labels 0..n-1 (0: background, counted like the others)
    n : int, number of labels

    Returns
    -------
    (n, 5) int32 stats (a label without pixels, such as the background of a
    full mask: zeros, where OpenCV leaves sentinels)
    """
    h, w = labels.shape
    x0 = np.full(n, w, np.int32)
    y0 = np.full(n, h, np.int32)
    x1 = np.full(n, -1, np.int32)
    y1 = np.full(n, -1, np.int32)
    area = np.zeros(n, np.int32)
    for y in range(h):
        row = labels[y]
        x = 0
        while x < w:  # one run of a label at a time
            k = row[x]
            start = x
            x += 1
            while x < w and row[x] == k:
                x += 1
            area[k] += x - start
            if start < x0[k]:
                x0[k] = start
            if x - 1 > x1[k]:
                x1[k] = x - 1
            if y < y0[k]:
                y0[k] = y
            y1[k] = y
    stats = np.zeros((n, 5), np.int32)
    for k in range(n):
        if area[k]:
            stats[k, 0] = x0[k]
            stats[k, 1] = y0[k]
            stats[k, 2] = x1[k] - x0[k] + 1
            stats[k, 3] = y1[k] - y0[k] + 1
            stats[k, 4] = area[k]
    return stats


@nb.njit(**_JIT)
def full_rows(labels, stats, ks, share):
    """Rows of components that their label fills (the screen-graphics test of
    :func:`arstream.detect.grass.grass_masks`): for each label ``k`` of ``ks``,
    the rows of its bounding box (``stats`` as :func:`component_stats`) where
    it covers at least ``share`` of the box's width.

    Returns
    -------
    (len(ks), 3) int64: the number of such rows, the first and the last (box
    rows counted from the box's top; -1 when there are none)
    """
    out = np.full((ks.shape[0], 3), -1, np.int64)
    for i in range(ks.shape[0]):
        k = ks[i]
        x, y, bw, bh = stats[k, 0], stats[k, 1], stats[k, 2], stats[k, 3]
        cnt = 0
        for r in range(bh):
            row = labels[y + r]
            c = 0
            for xx in range(x, x + bw):
                if row[xx] == k:
                    c += 1
            if c >= share * bw:
                if cnt == 0:
                    out[i, 1] = r
                out[i, 2] = r
                cnt += 1
        out[i, 0] = cnt
    return out


def warm_up() -> None:
    """Load (or compile) this module's kernels by calling them once on tiny inputs."""
    z = np.zeros(1, np.int64)
    component_stats(np.zeros((2, 2), np.int32), 1)
    full_rows(np.zeros((2, 2), np.int32), np.zeros((1, 5), np.int32), z, 0.9)
