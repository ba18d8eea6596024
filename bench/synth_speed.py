"""Generation speed of ``arstream synth`` per preset (720p, 25 fps, H.264).

Prints wall-clock frames/s and CPU seconds per frame (all threads of this
process: rendering plus the x264 encoder), so that a figure taken while other
jobs share the 2 cores can still be read.

Usage::

    .venv/bin/python bench/synth_speed.py [--frames 100] [--presets wide,hard]
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # this checkout, not whatever is installed

from arstream.synth import PRESETS, generate


def cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=100)
    ap.add_argument("--presets", default=",".join(PRESETS))
    args = ap.parse_args()
    print(f"{'preset':8s} {'wall fps':>9s} {'cpu ms/frame':>13s} {'fps at 1 cpu':>13s}")
    for p in args.presets.split(","):
        with tempfile.TemporaryDirectory() as d:
            t0, c0 = time.perf_counter(), cpu()
            generate(d, preset=p, seed=5, frames=args.frames, size=(1280, 720), fps=25)
            wall, used = time.perf_counter() - t0, cpu() - c0
        print(f"{p:8s} {args.frames / wall:9.1f} {1000 * used / args.frames:13.1f} {args.frames / used:13.1f}", flush=True)


if __name__ == "__main__":
    main()
