"""Benchmark: throughput of ``arstream batch`` — 2 clips one after the other vs 2 at once.

    .venv/bin/python bench/batch_throughput.py [--size 1280x720] [--frames 150]
                                               [--repeats 3] [--json out.json]

Two synthetic broadcast clips (``arstream.synth``, preset wide, seeds 1 and
2) go through ``arstream.batch.run`` on the local engine, alternately

* **one after the other**: ``workers=1`` (one worker process, the clips in turn);
* **at once**: ``workers=2`` (two worker processes, one clip each);

``--repeats`` times each, in the same run (so both see the same load on this
shared machine), every time into a fresh output folder. Timed: the whole
``batch.run`` call (spawning the workers, their imports and GL set-up
included) — what a user waits for. Reported: medians of the wall times, the
ratio at once / one after the other (target <= 0.65 on 2 cores), the
frames/s of the batch, the CPU seconds of the workers per frame and the
load average, which says how much of the machine others were using.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import shutil
import statistics
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)


def children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def one_run(clips: list[str], out: str, workers: int) -> dict:
    from arstream import batch

    shutil.rmtree(out, ignore_errors=True)
    c0 = children_cpu()
    t0 = time.perf_counter()
    s = batch.run(clips, out, workers=workers, handle_signals=False)
    wall = time.perf_counter() - t0
    assert s.all_ok, [r["error"] for r in s.clips]
    return {
        "workers": workers,
        "wall_s": wall,
        "frames": s.frames,
        "fps": s.frames / wall,
        "clip_s": [r["seconds"] for r in s.clips],
        # workers are reaped when the pool shuts down, so their CPU time is counted here
        "cpu_s": children_cpu() - c0,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", default="1280x720")
    ap.add_argument("--frames", type=int, default=150)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", metavar="FILE")
    args = ap.parse_args(argv)
    w, h = (int(v) for v in args.size.lower().split("x"))

    from arstream.synth import generate

    tmp = tempfile.mkdtemp(prefix="arstream-batch-bench-")
    try:
        clips = []
        for seed in (1, 2):
            d = os.path.join(tmp, f"src{seed}")
            generate(d, preset="wide", seed=seed, frames=args.frames, size=(w, h))
            clips.append(shutil.move(os.path.join(d, "clip.mp4"), os.path.join(tmp, f"clip{seed}.mp4")))
        one_run(clips, os.path.join(tmp, "warm"), 2)  # page cache, first-import costs
        runs = {1: [], 2: []}
        loads = []
        for r in range(args.repeats):
            for workers in ((1, 2) if r % 2 == 0 else (2, 1)):
                runs[workers].append(one_run(clips, os.path.join(tmp, f"out{workers}"), workers))
                loads.append(os.getloadavg()[0])
                x = runs[workers][-1]
                print(f"  repeat {r + 1}, workers={workers}: {x['wall_s']:.2f} s, {x['fps']:.1f} fps, worker CPU {x['cpu_s']:.1f} s", flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)

    seq = statistics.median(x["wall_s"] for x in runs[1])
    par = statistics.median(x["wall_s"] for x in runs[2])
    frames = runs[1][0]["frames"]
    res = {
        "size": [w, h],
        "frames_per_clip": args.frames,
        "repeats": args.repeats,
        "cores": os.cpu_count(),
        "sequential_s": round(seq, 3),
        "at_once_s": round(par, 3),
        "ratio": round(par / seq, 3),
        "sequential_fps": round(frames / seq, 1),
        "at_once_fps": round(frames / par, 1),
        "cpu_ms_per_frame_sequential": round(1e3 * statistics.median(x["cpu_s"] for x in runs[1]) / frames, 2),
        "cpu_ms_per_frame_at_once": round(1e3 * statistics.median(x["cpu_s"] for x in runs[2]) / frames, 2),
        "load_average": round(statistics.median(loads), 2),
        "all_walls": {str(k): [round(x["wall_s"], 3) for x in v] for k, v in runs.items()},
        "python": platform.python_version(),
    }
    print(
        f"\n2 clips of {args.frames} frames at {w}x{h}, {args.repeats} repeats (medians):\n"
        f"  one after the other (workers=1): {seq:6.2f} s  ({res['sequential_fps']:.1f} fps, {res['cpu_ms_per_frame_sequential']} ms CPU/frame)\n"
        f"  at once (workers=2):             {par:6.2f} s  ({res['at_once_fps']:.1f} fps, {res['cpu_ms_per_frame_at_once']} ms CPU/frame)\n"
        f"  ratio at once / one after the other: {res['ratio']:.3f}  (target <= 0.65: {'met' if res['ratio'] <= 0.65 else 'NOT met'})\n"
        f"  load average during the runs: {res['load_average']} on {res['cores']} cores"
    )
    if args.json:
        with open(args.json, "w") as f:
            json.dump(res, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
