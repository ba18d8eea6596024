"""Benchmark: throughput of ``arstream batch`` — 2 clips one after the other vs 2 at once.

    .venv/bin/python bench/batch_throughput.py [--size 1280x720] [--frames 300]
                                               [--repeats 3] [--json out.json]

Two synthetic broadcast clips (``arstream.synth``, preset wide, seeds 1 and
2; 100 rendered frames, their packets repeated up to ``--frames``, which
saves rendering time and changes nothing for throughput) go through
``arstream.batch.run`` on the local engine, alternately

* **one after the other**: ``workers=1`` (one worker process, the clips in turn);
* **at once**: ``workers=2`` (two worker processes, one clip each);

``--repeats`` times each, in the same run (so both see the same load on this
shared machine), every time into a fresh output folder. Timed: the whole
``batch.run`` call (forking the workers from the already running fork
server, their GL set-up, every clip, the summary) — the steady state of a
long batch. Reported: medians of the wall times, the ratio at once / one
after the other (target <= 0.65 on 2 cores), the frames/s of the batch, the
workers' CPU per frame, how many cores one clip alone keeps busy (its CPU
time over its wall time: what bounds the gain of running two at once), and
the load average, which says how much of the machine others were using.

Then, ``--cli-repeats`` times each (default 1), the same with the command in
a fresh process, ``arstream batch CLIP1 CLIP2 --out DIR --workers N``: what a
user waits for, interpreter start, imports and fork-server start included.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)


def one_run(clips: list[str], out: str, workers: int) -> dict:
    from arstream import batch

    shutil.rmtree(out, ignore_errors=True)
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
        "clip_cores": [r["cpu_seconds"] / r["seconds"] for r in s.clips],  # cores one clip kept busy
        "cpu_s": sum(r["cpu_seconds"] for r in s.clips),  # the workers' processes while on a clip
    }


def _thread_cpu() -> dict:
    """CPU seconds of each thread of this process (Linux /proc)."""
    out = {}
    tick = os.sysconf("SC_CLK_TCK")
    for t in os.listdir("/proc/self/task"):
        try:
            with open(f"/proc/self/task/{t}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        out[int(t)] = (int(fields[11]) + int(fields[12])) / tick
    return out


def profile_one(clip: str, out: str) -> dict:
    """One clip through ``arstream.process`` in this process: its CPU time (all threads) and
    that of its busiest thread (sampled from /proc while it runs, as the pipeline's threads
    end with it). The pipeline is a chain of threads (decode, detect, stages, encode), so a
    clip alone cannot be faster than its busiest thread: on an idle machine with ``c`` cores
    it takes at least A = max(busiest, cpu / c), exactly A if its threads overlap perfectly,
    and two at once then max(A, 2 cpu / c) — a model of the ratio that does not depend on
    what else runs on this machine (less overlap gives a lower ratio)."""
    import threading

    import arstream

    before = _thread_cpu()
    seen: dict = {}
    stop = threading.Event()

    def sample():
        while not stop.wait(0.1):
            seen.update(_thread_cpu())

    sampler = threading.Thread(target=sample, daemon=True)
    sampler.start()
    try:
        s = arstream.process(clip, os.path.join(out, "o.mp4"), cameras_out=os.path.join(out, "c.jsonl"), handle_signals=False)
    finally:
        stop.set()
        sampler.join()
    seen.update(_thread_cpu())
    per_thread = sorted((cpu - before.get(tid, 0.0) for tid, cpu in seen.items() if tid != sampler.native_id), reverse=True)
    return {"frames": s.frames, "wall_s": s.seconds, "cpu_s": s.cpu_seconds, "busiest_thread_cpu_s": per_thread[0], "second_thread_cpu_s": per_thread[1]}


def cli_run(clips: list[str], out: str, workers: int) -> float:
    shutil.rmtree(out, ignore_errors=True)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "arstream.cli", "batch", *clips, "--out", out, "--workers", str(workers), "-q"], cwd=ROOT, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


def lengthen(src: str, dst: str, frames: int) -> None:
    """``src``'s video packets repeated back to back until there are ``frames`` (no re-encode)."""
    import av

    with av.open(src) as inp, av.open(dst, "w") as out:
        vin = inp.streams.video[0]
        vout = out.add_stream_from_template(vin)
        pkts = [p for p in inp.demux(vin) if p.dts is not None]
        step = pkts[-1].pts - pkts[0].pts + (pkts[1].pts - pkts[0].pts)
        for i in range(frames):
            k, p = divmod(i, len(pkts))
            q = av.Packet(bytes(pkts[p]))
            q.pts, q.dts = pkts[p].pts + k * step, pkts[p].dts + k * step
            q.is_keyframe, q.time_base, q.stream = pkts[p].is_keyframe, pkts[p].time_base, vout
            out.mux(q)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", default="1280x720")
    ap.add_argument("--frames", type=int, default=300, help="frames per clip (default: 300)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--cli-repeats", type=int, default=1)
    ap.add_argument("--json", metavar="FILE")
    args = ap.parse_args(argv)
    w, h = (int(v) for v in args.size.lower().split("x"))

    from arstream.synth import generate

    tmp = tempfile.mkdtemp(prefix="arstream-batch-bench-")
    try:
        clips = []
        for seed in (1, 2):
            d = os.path.join(tmp, f"src{seed}")
            generate(d, preset="wide", seed=seed, frames=min(args.frames, 100), size=(w, h))
            clips.append(os.path.join(tmp, f"clip{seed}.mp4"))
            lengthen(os.path.join(d, "clip.mp4"), clips[-1], args.frames)
        one_run(clips, os.path.join(tmp, "warm"), 2)  # page cache; starts the fork server
        prof = profile_one(clips[0], tmp)
        runs = {1: [], 2: []}
        loads = []
        for r in range(args.repeats):
            for workers in ((1, 2) if r % 2 == 0 else (2, 1)):
                runs[workers].append(one_run(clips, os.path.join(tmp, f"out{workers}"), workers))
                loads.append(os.getloadavg()[0])
                x = runs[workers][-1]
                print(f"  repeat {r + 1}, workers={workers}: {x['wall_s']:.2f} s, {x['fps']:.1f} fps, worker CPU {x['cpu_s']:.1f} s", flush=True)
        cli = {1: [], 2: []}
        for r in range(args.cli_repeats):
            for workers in ((1, 2) if r % 2 == 0 else (2, 1)):
                cli[workers].append(cli_run(clips, os.path.join(tmp, f"cli{workers}"), workers))
                print(f"  command, repeat {r + 1}, workers={workers}: {cli[workers][-1]:.2f} s", flush=True)
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
        "cores_one_clip_alone": round(statistics.median(c for x in runs[1] for c in x["clip_cores"]), 2),
        "cores_used_sequential": round(statistics.median(x["cpu_s"] / x["wall_s"] for x in runs[1]), 2),
        "cores_used_at_once": round(statistics.median(x["cpu_s"] / x["wall_s"] for x in runs[2]), 2),
        "load_average": round(statistics.median(loads), 2),
        "profile_one_clip": {k: round(v, 3) for k, v in prof.items()},
        "all_walls": {str(k): [round(x["wall_s"], 3) for x in v] for k, v in runs.items()},
        "command_sequential_s": round(statistics.median(cli[1]), 3) if cli[1] else None,
        "command_at_once_s": round(statistics.median(cli[2]), 3) if cli[2] else None,
        "python": platform.python_version(),
    }
    print(
        f"\n2 clips of {args.frames} frames at {w}x{h}, {args.repeats} repeats (medians):\n"
        f"  one after the other (workers=1): {seq:6.2f} s  ({res['sequential_fps']:.1f} fps, {res['cpu_ms_per_frame_sequential']} ms CPU/frame)\n"
        f"  at once (workers=2):             {par:6.2f} s  ({res['at_once_fps']:.1f} fps, {res['cpu_ms_per_frame_at_once']} ms CPU/frame)\n"
        f"  ratio at once / one after the other: {res['ratio']:.3f}  (target <= 0.65: {'met' if res['ratio'] <= 0.65 else 'NOT met'})\n"
        f"  cores kept busy: one clip alone {res['cores_one_clip_alone']}; whole run one after the other {res['cores_used_sequential']}, at once {res['cores_used_at_once']}\n"
        f"  load average during the runs: {res['load_average']} on {res['cores']} cores"
    )
    c = 2
    alone = max(prof["busiest_thread_cpu_s"], prof["cpu_s"] / c)
    model = max(alone, 2 * prof["cpu_s"] / c) / (2 * alone)
    res["model_ratio_idle_2_cores"] = round(model, 3)
    print(
        f"  one clip's profile: {1e3 * prof['cpu_s'] / prof['frames']:.1f} ms CPU/frame; its busiest thread "
        f"{1e3 * prof['busiest_thread_cpu_s'] / prof['frames']:.1f} ms, the next {1e3 * prof['second_thread_cpu_s'] / prof['frames']:.1f} ms\n"
        f"  model for an idle 2-core machine, if a clip's threads overlapped perfectly: a clip alone keeps "
        f"{prof['cpu_s'] / alone:.2f} cores busy, ratio {model:.3f} (less overlap: fewer cores, a lower ratio)"
    )
    if cli[1] and cli[2]:
        a, b = res["command_sequential_s"], res["command_at_once_s"]
        print(f"  the command in a fresh process: one after the other {a:.2f} s, at once {b:.2f} s, ratio {b / a:.3f}")
        res["command_ratio"] = round(b / a, 3)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(res, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
