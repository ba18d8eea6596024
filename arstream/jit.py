"""What arstream's compiled (numba) loops share: the compile options, plain-float
helpers of :mod:`geometry` compiled for them to call, and a counting sort.

The loops themselves live beside the code that calls them: detection's in
:mod:`arstream.detect.kernels`, the solver's in :mod:`arstream.solve_kernels`
(``render`` keeps its own, :mod:`render.kernels`). :mod:`arstream.kernels`
loads them all at once.
"""

from __future__ import annotations

import types

import numba as nb
import numpy as np

__all__ = ["JIT", "compiled", "counting_sort"]

#: numba options of every compiled loop: cached next to its file (``cache=True``;
#: compiled on the first run after an install), the GIL released (detection
#: runs on its own thread), IEEE arithmetic, no bounds checks.
JIT = dict(cache=True, nogil=True, fastmath=False, boundscheck=False)


def compiled(fn, **deps):
    """A plain-float helper of :mod:`geometry` compiled for the kernels to call
    (the same arithmetic as in Python), with the helpers it calls in turn
    (``deps``: name -> compiled version) in place of its module's Python ones.
    numba's cache keys on the calling kernel's file only: after editing such a
    helper, touch the files of the kernels that call it (or clear their
    ``__pycache__``) to recompile them."""
    scope = dict(fn.__globals__, **deps)
    return nb.njit(nogil=True)(types.FunctionType(fn.__code__, scope, fn.__name__, fn.__defaults__, fn.__closure__))


@nb.njit(**JIT)
def counting_sort(keys, n_keys):
    """Indices 0..N-1 sorted by ``keys`` (N,) int64 in [0, n_keys), stable:
    (order (N,), starts (n_keys + 1,)); key k's indices are order[starts[k]:starts[k + 1]]."""
    n = keys.shape[0]
    starts = np.zeros(n_keys + 1, np.int64)
    for i in range(n):
        starts[keys[i] + 1] += 1
    for k in range(n_keys):
        starts[k + 1] += starts[k]
    fill = starts[:-1].copy()
    order = np.empty(n, np.int64)
    for i in range(n):
        order[fill[keys[i]]] = i
        fill[keys[i]] += 1
    return order, starts


