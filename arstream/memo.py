"""Memos of pure functions' answers by the content of their inputs.

A still's pitch-size scan registers the one frame at up to nine sizes, and a
clip's scan tracks each frame at up to six; the work that does not depend on
the size (the paint's lines and penalty arcs, a circle view's family of
cameras) is the same each time. Its answers are kept here by the bytes of
the inputs (arrays and numbers), the most recently used first, so the same
inputs give the same (not recomputed) answer. A memo changes no result:
what it keeps are the answers of functions of their arguments alone.

>>> m = ContentMemo(2)
>>> k = content_key(np.arange(3), 1.5)
>>> m.get(k) is None
True
>>> m.put(k, "answer")
>>> m.get(content_key(np.arange(3.0), 1.5))  # the same values
'answer'
>>> m.answer(content_key(np.arange(4)), lambda: [1, 2])
[1, 2]
"""

from __future__ import annotations

import copy
import hashlib
import threading
from collections import OrderedDict

import numpy as np

__all__ = ["ContentMemo", "content_key"]


def content_key(*parts) -> bytes:
    """A key (20 bytes) of the values of ``parts``: arrays (any shape and
    numeric or boolean type; uint8 images hashed as they are, everything
    else as float64) and numbers. Equal values of equal shapes give equal
    keys."""
    h = hashlib.sha1()
    for p in parts:
        a = np.asarray(p)
        if a.dtype != np.uint8:
            a = a.astype(np.float64)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(np.ascontiguousarray(a).data)
    return h.digest()


class ContentMemo:
    """The answers to the last ``size`` keys asked for (:func:`content_key`),
    least recently used dropped first. Thread-safe (a run's detection thread
    and its trackers may share one).

    Parameters
    ----------
    size : most answers kept
    """

    def __init__(self, size: int):
        if size < 1:
            raise ValueError(f"a memo keeps at least one answer, got {size}")
        self.size = int(size)
        self._d: OrderedDict[bytes, object] = OrderedDict()
        self._lock = threading.Lock()

    def answer(self, key: bytes, compute):
        """The answer for ``key``: kept, or ``compute()`` kept now. Each caller
        gets its own copy (a deep one: the answers hold arrays and mutable
        records), so none sees another's changes."""
        got = self.get(key)
        if got is None:
            got = compute()
            self.put(key, copy.deepcopy(got))
            return got
        return copy.deepcopy(got)

    def get(self, key: bytes):
        """The answer kept for ``key``, or None."""
        with self._lock:
            if key not in self._d:
                return None
            self._d.move_to_end(key)
            return self._d[key]

    def put(self, key: bytes, value) -> None:
        """Keep ``value`` as the answer for ``key``."""
        with self._lock:
            self._d[key] = value
            self._d.move_to_end(key)
            while len(self._d) > self.size:
                self._d.popitem(last=False)
