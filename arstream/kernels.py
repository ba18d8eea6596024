"""One warm-up for every compiled (numba) loop the pipeline runs.

The loops live beside the code that calls them: detection's in
:mod:`arstream.detect.kernels` (one module per stage), the solver's in
:mod:`arstream.solve_kernels`, the renderer's footprint, the I420 composite
and the grass key in :mod:`render.kernels`; what they share (compile options,
compiled geometry helpers) is :mod:`arstream.jit`. Each module has its own
``warm_up``; this one calls them all.

Compiled on first use and cached next to each file (numba's ``cache=True``;
the first run after an install takes some seconds more). Loading the cached
code still costs about 0.5 s per process, most of it numba's one-off set-up of
its code generator on the first call: :func:`warm_up_async` (called by every
``Detector``) does that on a background thread, overlapping the caller's own
start-up (the GIL is released while LLVM loads the code).

:func:`compile_all` compiles (or loads) them all now, one module per process
in parallel: after an install, the first run compiles each kernel once into
the cache, where every later process (a test worker, a batch worker, a CLI
run) loads it instead of compiling it again (about 40 s of one core in all;
20-30 s on two cores in parallel). ``python -m arstream.kernels`` calls it.
"""

from __future__ import annotations

import threading

from arstream import solve_kernels
from arstream.detect import kernels as detect_kernels
from render import kernels as render_kernels

__all__ = ["MODULES", "compile_all", "warm_up", "warm_up_async"]

#: every module of compiled loops the pipeline calls (detection, solver, renderer
#: and compositor), each with its ``warm_up`` and its kernels in ``__all__``
MODULES = (*detect_kernels.MODULES, solve_kernels, render_kernels)


def warm_up() -> None:
    """Load (or compile) every kernel by calling it once on tiny inputs."""
    for module in MODULES:
        module.warm_up()


def _warm_module(name: str) -> None:
    """Import the kernel module ``name`` and call its ``warm_up`` (a worker's job)."""
    import importlib

    importlib.import_module(name).warm_up()


def compile_all(processes: int | None = None) -> None:
    """Compile (or load) every kernel into numba's cache, the modules spread over
    ``processes`` worker processes (default: every core; 1 = here, one after
    another). The cache makes it once per install: later calls, and every
    process that calls the kernels afterwards, only load them.
    """
    from arstream.workers import map_in_processes

    map_in_processes(_warm_module, [m.__name__ for m in MODULES], workers=processes, preload=(__name__,))


_warm_thread: threading.Thread | None = None
_warm_lock = threading.Lock()


def warm_up_async() -> None:
    """:func:`warm_up` on a daemon thread, once per process (later calls return
    at once; a kernel called meanwhile waits for numba's compiler lock)."""
    global _warm_thread
    with _warm_lock:
        if _warm_thread is None:
            _warm_thread = threading.Thread(target=warm_up, name="arstream-kernels", daemon=True)
            _warm_thread.start()


if __name__ == "__main__":  # python -m arstream.kernels: compile (or load) them all now
    import time

    t0 = time.perf_counter()
    compile_all()
    print(f"arstream kernels ready ({time.perf_counter() - t0:.1f} s)")
