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
