"""arstream.workers: jobs spread over worker processes, in order, stopped on an error."""

from __future__ import annotations

import math
import multiprocessing
import os
import time

import pytest

from arstream.workers import cores, map_in_processes, terminate, worker_context


def test_results_come_back_in_the_order_of_the_jobs():
    jobs = [float(k) for k in range(9)]
    assert map_in_processes(math.sqrt, jobs, workers=3) == [math.sqrt(j) for j in jobs]
    # (one worker, or one job: run here)
    assert map_in_processes(math.sqrt, jobs, workers=1) == [math.sqrt(j) for j in jobs]
    assert map_in_processes(math.sqrt, [4.0]) == [2.0]
    assert map_in_processes(math.sqrt, []) == []


def test_the_jobs_run_in_other_processes():
    pids = map_in_processes(_pid, list(range(4)), workers=2)
    assert os.getpid() not in pids and 1 <= len(set(pids)) <= 2


def _pid(_job) -> int:
    return os.getpid()


def test_a_job_s_error_is_raised_here_and_the_pool_stopped():
    with pytest.raises(ValueError, match="math domain error"):
        map_in_processes(math.sqrt, [1.0, -1.0, 4.0], workers=2)
    assert not multiprocessing.active_children()


def test_terminate_does_not_wait_for_running_jobs():
    import concurrent.futures as cf

    pool = cf.ProcessPoolExecutor(2, mp_context=worker_context(()))
    futures = [pool.submit(time.sleep, 60.0) for _ in range(4)]
    while not any(f.running() for f in futures):
        time.sleep(0.05)
    t0 = time.monotonic()
    terminate(pool)
    assert time.monotonic() - t0 < 10.0
    assert not multiprocessing.active_children()


def test_cores_are_those_this_process_may_run_on():
    assert cores() == len(os.sched_getaffinity(0)) >= 1


_WINDOW = r"""
import json, os, signal, sys, threading, time
import concurrent.futures as cf
from arstream.workers import spawning, worker_context

caught = []
signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
ctx = worker_context(["slow_import"])  # the fork server imports it: 2 s
pool = cf.ProcessPoolExecutor(1, mp_context=ctx)
threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT)).start()
t0 = time.monotonic()
with spawning(ctx):
    fut = pool.submit(signal.getsignal, signal.SIGINT)
waited = time.monotonic() - t0
worker = fut.result()
pool.shutdown()
print(json.dumps({"waited": waited, "caught": len(caught), "worker_ignores": worker == signal.SIG_IGN}))
"""


@pytest.mark.skipif("forkserver" not in multiprocessing.get_all_start_methods(), reason="no fork server here")
def test_a_ctrl_c_while_the_workers_start_reaches_the_caller(tmp_path):
    # submit() waits while the fork server imports its preload (seconds for
    # arstream.batch's); a Ctrl-C sent then reaches the caller's handler, and
    # the worker still ignores Ctrl-C from its first instruction (the caller
    # alone handles it)
    import json
    import subprocess
    import sys

    (tmp_path / "slow_import.py").write_text("import time\ntime.sleep(2.0)\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), os.path.dirname(os.path.dirname(os.path.abspath(__file__)))])}
    done = subprocess.run([sys.executable, "-c", _WINDOW], capture_output=True, text=True, timeout=60, env=env, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    got = json.loads(done.stdout.strip().splitlines()[-1])
    assert got["waited"] > 0.5, got  # the signal came while submit() waited
    assert got["caught"] == 1 and got["worker_ignores"], got
