"""Benchmark: the camera initialiser (``arstream.initialise.initialise_camera``), warm.

    .venv/bin/python bench/initialiser_speed.py [--presets wide,zoom,hard,penalty,cut]
                                                [--frames 250] [--repeats 15]

The initialiser runs on a shot's first frame (the start of a clip, after a
cut, when tracking fails), so its time is a stall of the main thread there:
frames queue up offline, and a live stream drops them. For each preset clip
(``arstream.synth``, seed 11, generated once under ``--workdir``) the frames
go through the detector and the live tracker (640 px analysis frame, lazy
detection, the tracker's hints as of the frame before); every call the tracker makes to the
initialiser is recorded with its inputs and then timed again, warm, with the
numba kernels loaded, ``--repeats`` times (median). Reported per preset: the
calls and their median time, and the median time of the two searches inside
(``solve_from_circle``, the pole-polar solution from the centre circle and a
crossing line, summed over the pairs tried; ``cameras_from_line_hypotheses``,
the line-correspondence hypotheses) and of the refinements.
"""

from __future__ import annotations

import argparse
import collections
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import arstream.initialise as initialise  # noqa: E402
import arstream.track as track  # noqa: E402
from arstream.detect import Detector  # noqa: E402
from arstream.kernels import warm_up  # noqa: E402
from arstream.pipeline.stage import Item  # noqa: E402
from arstream.pipeline.stages import DEFAULT_ANALYSIS_WIDTH, Analysis  # noqa: E402
from arstream.source import VideoSource  # noqa: E402
from arstream.synth import generate  # noqa: E402

PARTS = ("solve_from_circle", "cameras_from_line_hypotheses", "refine_camera")


def calls_of(clip: Path) -> list[tuple[tuple, dict]]:
    """The initialiser's calls (args, kwargs) while the live tracker follows ``clip``."""
    calls = []
    real = track.initialise_camera

    def record(*a, **k):
        calls.append((a, k))
        return real(*a, **k)

    track.initialise_camera = record
    try:
        with VideoSource(clip) as src:
            an = Analysis(src.width, src.height, DEFAULT_ANALYSIS_WIDTH)
            det, tr = Detector(an.w, an.h), track.Tracker(an.w, an.h, fps=src.fps)
            for frame in src:
                hints = {"motion": tr.image_motion(frame.index - 1), "line_width": tr.line_width(frame.index - 1)}
                item = Item(frame)
                image = an.image(item)
                d = det.process(image, lazy=True, **hints)
                tr.process(frame.index, frame.pts, image, d.detach())  # (its own copy: kept for the timing)
    finally:
        track.initialise_camera = real
    return calls


def timed(calls, repeats: int) -> dict[str, float]:
    """Median milliseconds per call: the whole initialiser and its parts."""
    spent = collections.Counter()
    originals = {name: getattr(initialise, name) for name in PARTS}

    def wrap(name, fn):
        def inner(*a, **k):
            t0 = time.perf_counter()
            try:
                return fn(*a, **k)
            finally:
                spent[name] += time.perf_counter() - t0

        return inner

    rows = collections.defaultdict(list)
    for name, fn in originals.items():
        setattr(initialise, name, wrap(name, fn))
    try:
        for a, k in calls:
            for _ in range(repeats):
                spent.clear()
                t0 = time.perf_counter()
                initialise.initialise_camera(*a, **k)
                rows["total"].append((time.perf_counter() - t0) * 1e3)
                for name in PARTS:
                    rows[name].append(spent[name] * 1e3)
    finally:
        for name, fn in originals.items():
            setattr(initialise, name, fn)
    return {name: statistics.median(v) for name, v in rows.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--presets", default="wide,zoom,hard,penalty,cut")
    ap.add_argument("--frames", type=int, default=250)
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--workdir", type=Path, default=Path("/tmp/arstream-bench"), help="where the clips are generated (reused)")
    args = ap.parse_args()
    warm_up()
    print("| preset | calls | initialiser ms (median) | circle solutions | line hypotheses | refinements |")
    print("|---|---|---|---|---|---|")
    for preset in args.presets.split(","):
        out = args.workdir / f"{preset}-11-{args.frames}"
        if not (out / "clip.mp4").exists():
            generate(out, preset=preset, seed=11, frames=args.frames)
        calls = calls_of(out / "clip.mp4")
        m = timed(calls, args.repeats)
        print(f"| {preset} | {len(calls)} | {m['total']:.1f} | {m['solve_from_circle']:.1f} | {m['cameras_from_line_hypotheses']:.1f} | {m['refine_camera']:.1f} |", flush=True)


if __name__ == "__main__":
    main()
