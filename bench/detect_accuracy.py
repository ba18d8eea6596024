"""Detector benchmark: centre-circle detection rate, false positives, ellipse accuracy, speed.

On each preset's generated clip (decoded H.264, as in real use; the clips of
bench/solver_accuracy.py are reused when present):

* detection rate: share of frames with at least half of the centre circle in
  view where some reported ellipse lies within 1 px (median) of the true
  projected circle;
* false positives: frames where an ellipse is reported that is none of the
  pitch's circle markings (centre circle, penalty arcs) — median distance of
  its support points to every true circle marking over 2 px;
* ellipse accuracy: median over frames of the median distance between the
  true projected centre-circle samples and the detected ellipse;
* speed: median ms per frame, one thread (cv2.setNumThreads(1)).

Usage::

    .venv/bin/python bench/detect_accuracy.py [--frames 250] [--presets wide,hard]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # this checkout, not whatever is installed

from arstream.detect import Detector
from arstream.sink import read_jsonl
from arstream.source import VideoSource
from arstream.synth import PRESETS, generate
from geometry.camera import Camera
from geometry.conics import ellipse_distance
from geometry.pitch import PitchModel

PITCH = PitchModel()
CIRCLES = ("centre_circle", "penalty_arc_left", "penalty_arc_right")


def projected(cam: Camera, name: str, size) -> np.ndarray:
    px = cam.project_pitch(PITCH[name].sample(0.1))
    W, H = size
    ok = np.all(np.isfinite(px), axis=1) & (px[:, 0] >= -50) & (px[:, 0] < W + 50) & (px[:, 1] >= -50) & (px[:, 1] < H + 50)
    return px[ok]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=250)
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--presets", default=",".join(PRESETS))
    ap.add_argument("--workdir", type=Path, default=Path("/tmp/arstream-bench"))
    args = ap.parse_args()
    cv2.setNumThreads(1)
    print(f"{'preset':8s} {'in view':>7s} {'found':>7s} {'no circle':>9s} {'false +':>7s} {'ell err':>8s} {'ms med':>7s}  sub-stages (ms)")
    for p in args.presets.split(","):
        out = args.workdir / f"{p}-{args.seed}-{args.frames}"
        if not (out / "truth.jsonl").exists():
            generate(out, preset=p, seed=args.seed, frames=args.frames)
        truth = read_jsonl(out / "truth.jsonl")
        W, H = json.loads((out / "header.json").read_text())["size"]
        det = Detector(W, H)
        in_view = found = no_circle = false_pos = 0
        errs, times, stages = [], [], {}
        with VideoSource(out / "clip.mp4") as src:
            for f in src:
                img = f.image  # (the decoded frame's BGR conversion is the decoder's work, not timed)
                t0 = time.perf_counter()
                d = det.process(img)
                times.append(1000 * (time.perf_counter() - t0))
                for k, v in d.timings.items():
                    stages.setdefault(k, []).append(v)
                rec = truth[f.index]
                cam = Camera.from_dict(rec) if rec["K"] else None
                if cam is None:
                    no_circle += 1
                    false_pos += bool(d.ellipses)
                    continue
                if rec["circle_fraction"] >= 0.5:
                    in_view += 1
                    cc = projected(cam, "centre_circle", (W, H))
                    best = min((float(np.median(ellipse_distance(cc, e.ellipse))) for e in d.ellipses), default=np.inf)
                    if best < 1.0:
                        found += 1
                        errs.append(best)
                elif rec["circle_fraction"] == 0:
                    no_circle += 1
                # false positive: an ellipse that is none of the circle markings
                for e in d.ellipses:
                    dists = []
                    for n in CIRCLES:
                        px = projected(cam, n, (W, H))
                        if len(px):
                            dists.append(np.median(np.min(np.linalg.norm(e.points[::5, None] - px[None], axis=2), axis=1)))
                    if not dists or min(dists) > 2.0:
                        false_pos += 1
                        break
        n = len(truth)
        st = " ".join(f"{k} {np.median(v):.1f}" for k, v in stages.items())
        print(
            f"{p:8s} {in_view:7d} {100 * found / max(in_view, 1):6.1f}% {no_circle:9d} {100 * false_pos / n:6.1f}% "
            f"{np.median(errs) if errs else float('nan'):7.2f}px {np.median(times):7.1f}  {st}",
            flush=True,
        )


if __name__ == "__main__":
    main()
