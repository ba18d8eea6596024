"""Worker processes on this machine: the cores there are, a context to start
workers from, and a pool mapped over independent jobs that a Ctrl-C stops.

Used by :mod:`arstream.batch` (a clip per worker) and by a still's scan of
pitch sizes (:func:`arstream.initialise.size_from_scan`, a size per worker).
Workers come from the ``forkserver`` context (``spawn`` where there is
none), never a plain ``fork`` of the caller, whose threads and GL state would
not survive it: a server process that has run nothing imports the modules the
jobs need once, and each worker is forked from it.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import multiprocessing
import multiprocessing.forkserver
import os
import signal
import threading
from typing import Callable, Sequence

__all__ = ["cores", "children_ignore_sigint", "worker_context", "spawning", "terminate", "init_worker", "map_in_processes"]


def cores() -> int:
    """The cores this process may run on (its CPU affinity; the machine's count
    where there is none)."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # not Linux
        return max(os.cpu_count() or 1, 1)


@contextlib.contextmanager
def children_ignore_sigint():
    """Spawned children inherit SIGINT as ignored from their first instruction
    (a pool initializer would leave a window while they import): the caller
    alone handles Ctrl-C. A no-op off the main thread (signals are the main
    thread's)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


def worker_context(preload: Sequence[str]):
    """``forkserver`` where there is one (its server imports ``preload``, module
    names, once; a worker then starts in milliseconds instead of re-importing
    for a second), else ``spawn``. The server is one per process: the
    ``preload`` of the first context that starts it stands.

    The server is started here, with SIGINT ignored (it returns at once; the
    server imports ``preload`` on its own): its workers are forked with the
    server's signal dispositions, so they ignore Ctrl-C from their first
    instruction, and the caller need not hold Ctrl-C off while a pool's
    ``submit()`` waits seconds for those imports (:func:`spawning`)."""
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(list(preload))
        with children_ignore_sigint():
            multiprocessing.forkserver.ensure_running()
        return ctx
    return multiprocessing.get_context("spawn")


@contextlib.contextmanager
def spawning(ctx):
    """Around a pool's ``submit()``, which may start workers from ``ctx``
    (:func:`worker_context`): SIGINT ignored while ``spawn`` starts them (they
    inherit it from their first instruction; starting one takes milliseconds,
    its imports are its own); nothing for a fork server's context, whose
    workers take the server's dispositions, so a Ctrl-C while ``submit()``
    waits for the server's imports reaches the caller."""
    if ctx.get_start_method() == "forkserver":
        yield
        return
    with children_ignore_sigint():
        yield


def terminate(pool: cf.ProcessPoolExecutor) -> None:
    """Stop ``pool`` now: queued jobs cancelled, running workers terminated
    (killed after 5 s), without waiting for the jobs they run."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        with contextlib.suppress(Exception):
            p.terminate()
    for p in procs:
        with contextlib.suppress(Exception):
            p.join(5.0)
            if p.is_alive():
                p.kill()
                p.join(5.0)


def init_worker(cv_threads: int) -> None:
    """Initializer of a pool's workers (:func:`map_in_processes`'s, the
    batch's): the caller alone handles Ctrl-C; OpenCV shares the cores with
    the other workers (``cv_threads`` each)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    import cv2

    cv2.setNumThreads(cv_threads)


def map_in_processes(fn: Callable, jobs: Sequence, *, workers: int | None = None, preload: Sequence[str] = ()) -> list:
    """``[fn(job) for job in jobs]``, the jobs spread over worker processes.

    Parameters
    ----------
    fn : a module-level function (pickled by name), its argument and result
        picklable
    jobs : the arguments, one call each
    workers : most processes (default :func:`cores`); with 1, one job, or
        from a daemon process (which may not have children) the jobs run
        here, one after another
    preload : modules the workers import once (:func:`worker_context`)

    Returns
    -------
    list, the results in the order of ``jobs``. A job's exception is raised
    here; on it, or on Ctrl-C (KeyboardInterrupt) while waiting, the pool is
    stopped (:func:`terminate`) before it propagates.
    """
    n = min(int(workers) if workers else cores(), len(jobs))
    if n <= 1 or multiprocessing.current_process().daemon:
        return [fn(job) for job in jobs]
    ctx = worker_context(preload)
    pool = cf.ProcessPoolExecutor(n, mp_context=ctx, initializer=init_worker, initargs=(max(1, cores() // n),))
    try:
        # (the workers ignore Ctrl-C from their first instruction; the
        # caller's KeyboardInterrupt, also while submit() waits for the fork
        # server's imports, stops them all)
        with spawning(ctx):
            futures = [pool.submit(fn, job) for job in jobs]
        out = [f.result() for f in futures]
    except BaseException:
        terminate(pool)
        raise
    pool.shutdown(wait=True)
    return out
