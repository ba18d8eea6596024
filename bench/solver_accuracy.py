"""Camera solver benchmark: accuracy (arstream eval) and speed on the synthetic presets.

For each preset a clip is generated (H.264, as ``arstream synth`` writes it)
and decoded; every frame goes through the real detector and the tracker (live, causal; and offline with the fixed-lag RTS
smoother), and the estimates are scored against the exact truth. The time of
the solver stage (solve + refine + filter, detection excluded) is measured
per frame.

As in ``arstream process``, detection and tracking work on the frame scaled
to ``--analysis-width`` (default 640 px; 0: full size) and the cameras are
mapped back to frame pixels before scoring; the detector runs lazily (lines
and ellipses only when the tracker re-initialises).

With ``--truth-detections`` (full-size frames) the detector is replaced by the true projected
markings (with 0.3 px noise and occlusion gaps): that isolates the solver's
own accuracy from detection errors.

Usage::

    .venv/bin/python bench/solver_accuracy.py [--frames 250] [--presets wide,zoom,...] [--truth-detections]
                                              [--lag N] [--analysis-width 640]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from arstream.estimate import CameraEstimate  # noqa: E402
from arstream.evaluate import score  # noqa: E402
from arstream.pipeline.stage import Item  # noqa: E402
from arstream.pipeline.stages import DEFAULT_ANALYSIS_WIDTH, Analysis  # noqa: E402
from arstream.sink import read_jsonl  # noqa: E402
from arstream.source import VideoSource  # noqa: E402
from arstream.synth import PRESETS, generate  # noqa: E402
from arstream.track import Tracker  # noqa: E402
from geometry.camera import Camera  # noqa: E402


def run(preset: str, frames: int, seed: int, truth_dets: bool, lag: int, workdir: Path, analysis_width: int | None = None):
    out = workdir / f"{preset}-{seed}-{frames}"
    if not (out / "truth.jsonl").exists():
        generate(out, preset=preset, seed=seed, frames=frames)
    truth = read_jsonl(out / "truth.jsonl")
    header = json.loads((out / "header.json").read_text())
    W, H = header["size"]
    an = Analysis(W, H, None if truth_dets else analysis_width)  # as the pipeline: detect and track on a smaller frame
    if truth_dets:
        from conftest import truth_detections
    else:
        from arstream.detect import Detector

        detector = Detector(an.w, an.h)
    tr = Tracker(an.w, an.h, fps=header["fps"], lag=lag)
    ests, solve_ms, det_ms = [], [], []
    with VideoSource(out / "clip.mp4") as src:
        for frame in src:
            img = an.image(Item(frame))  # as the pipeline makes it: from the decoder's I420 planes
            t0 = time.perf_counter()
            cam = Camera.from_dict(truth[frame.index]) if truth[frame.index]["K"] else None
            det = truth_detections(cam, seed=frame.index) if truth_dets else detector.process(img, lazy=True)
            t1 = time.perf_counter()
            ests += tr.process(frame.index, frame.pts, img, det)
            t2 = time.perf_counter()
            det_ms.append(1000 * (t1 - t0))
            solve_ms.append(1000 * (t2 - t1))
    ests += tr.flush()
    ests = [CameraEstimate(e.frame, e.pts, e.status, an.camera(e.camera), e.confidence, e.info) for e in ests]  # frame pixels
    s = score(truth, [e.to_record() for e in ests], (W, H))
    return s, np.array(solve_ms), np.array(det_ms), tr.stats


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=250)
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--presets", default=",".join(PRESETS))
    ap.add_argument("--truth-detections", action="store_true")
    ap.add_argument("--lag", type=int, default=0, help="0: live (causal); N: offline fixed-lag smoother")
    ap.add_argument("--json", type=Path, help="write the results here")
    ap.add_argument("--analysis-width", type=int, default=DEFAULT_ANALYSIS_WIDTH, help="detect and track on frames this wide, as arstream process does (0: full size)")
    ap.add_argument("--workdir", type=Path, default=Path("/tmp/arstream-bench"), help="where the clips are generated (reused)")
    args = ap.parse_args()
    cv2.setNumThreads(1)
    rows = {}
    print(f"{'preset':8s} {'cov':>6s} {'median':>7s} {'p95':>7s} {'acc@5':>6s} {'acc@10':>6s} {'f err':>6s} {'jitter':>6s} {'false':>5s} {'solve ms':>8s} {'p90':>6s}")
    for p in args.presets.split(","):
        s, sm, dm, stats = run(p, args.frames, args.seed, args.truth_detections, args.lag, args.workdir, args.analysis_width or None)
        rows[p] = {**s.to_dict(), "solve_ms_median": float(np.median(sm)), "solve_ms_p90": float(np.percentile(sm, 90)), "detect_ms_median": float(np.median(dm)), "stats": stats}
        print(
            f"{p:8s} {100 * s.coverage:5.1f}% {s.median:6.2f}px {s.p95:6.2f}px {100 * s.acc[5]:5.1f}% {100 * s.acc[10]:5.1f}% "
            f"{100 * s.focal_error_median:5.2f}% {s.jitter:5.2f}px {s.false_estimates:5d} {np.median(sm):7.2f} {np.percentile(sm, 90):6.1f}",
            flush=True,
        )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
