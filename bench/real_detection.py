"""Benchmark: the detector's line pixels on the real reference frames (issue 29, point 1).

Every frame with a reference camera (``bench/real_graphics.py``'s frames: the
shared stills, the three Premier League frames, every 25th frame of the two
shared clips), under the variants asked for (default: as it is), goes through
:func:`arstream.detect.detect`, and its line pixels are compared with the
reference camera's markings (Law 1 centrelines, a point every 0.25 m; 0.05 m
for precision), in view and on the detector's grass:

* **recall**: the share of the markings' points with a line pixel within
  2 px (of a 1280-wide frame);
* **precision**: the share of the line pixels within 2 px of a marking (the
  others lie on players, goal frames, the boards' edges, lines of other
  sports, or markings the reference leaves out: none are left out here
  but the penalty spots);
* the straight lines found, and the milliseconds a frame (one thread).

With ``--thin-lines`` every frame goes through the detector a second time
with its rule for thin lines on (``Detector(thin_lines=True)``), its rows
marked ``+thin`` beside the default's, in the same process.

Usage::

    python bench/real_detection.py [--variants NAME ...] [--items PREFIX ...] [--thin-lines]

The material is read from ``../shared/data/real-broadcast`` (skipped with a
message where it is absent).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from arstream.detect import detect  # noqa: E402
from arstream.kernels import warm_up  # noqa: E402
from arstream.solve import LineIndex  # noqa: E402
from arstream.support import _lookup, marking_points  # noqa: E402
from real_footage import SHARED  # noqa: E402
from real_graphics import GEOMETRIC, VARIANTS, items, scaled  # noqa: E402


def _in_view(cam, points: np.ndarray, grass: np.ndarray) -> np.ndarray:
    """The pixels (M, 2) of ``points`` (N, 3) that ``cam`` puts inside the frame on ``grass`` (H, W)."""
    uv = cam.project(points)
    return uv[_lookup(uv, grass > 0)[1]]


def _share_near(queries: np.ndarray, points: np.ndarray, reach: float) -> float:
    """The share of ``queries`` (N, 2) with one of ``points`` (M, 2) within ``reach`` px (nan for none)."""
    if not len(queries):
        return float("nan")
    if not len(points):
        return 0.0
    return float(np.mean(np.isfinite(LineIndex(points).nearest(queries, reach)[0])))


def frame_row(image: np.ndarray, ref, pitch, thin_lines: bool = False) -> dict:
    """One frame's recall, precision, lines and time against its reference camera."""
    H, W = image.shape[:2]
    t0 = time.perf_counter()
    det = detect(image, thin_lines=thin_lines)
    ms = 1e3 * (time.perf_counter() - t0)
    reach = 2.0 * W / 1280
    coarse = _in_view(ref, marking_points(pitch), det.grass_mask)
    fine = _in_view(ref, marking_points(pitch, spacing=0.05), det.grass_mask)
    recall = _share_near(coarse, det.line_points, reach)
    precision = _share_near(det.line_points, fine, reach) if len(fine) else float("nan")
    return {"markings": len(coarse), "points": len(det.line_points), "recall": recall, "precision": precision, "lines": len(det.lines), "ms": ms}


def run(variants, prefixes=None, thin_lines=(False,)) -> list[dict]:
    rows = []
    frames = items(prefixes)
    for v in variants:
        for thin in thin_lines:
            for name, img, aspect, ref, pitch in frames:
                H0, W0 = img.shape[:2]
                im = VARIANTS[v](img)
                H, W = im.shape[:2]
                truth = GEOMETRIC[v][1](ref, W0, H0) if v in GEOMETRIC else scaled(ref, W / W0, H / H0)
                rows.append({"variant": v + (" +thin" if thin else ""), "item": name, **frame_row(im, truth, pitch, thin)})
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--variants", nargs="+", default=["clean"], choices=list(VARIANTS))
    ap.add_argument("--items", nargs="+", help="only the frames whose name starts with one of these")
    ap.add_argument("--frames", action="store_true", help="print every frame's row, not only each clip's and still's mean")
    ap.add_argument("--thin-lines", action="store_true", help="also with the detector's rule for thin lines on (rows marked +thin)")
    a = ap.parse_args(argv)
    if not SHARED.exists():
        print(f"skipped: {SHARED} is absent")
        return 0
    cv2.setNumThreads(1)
    warm_up()  # (the compiled kernels loaded before the first frame is timed)
    rows = run(a.variants, a.items, (False, True) if a.thin_lines else (False,))
    print("| variant | item | frames | recall | precision | line pixels | straight lines | ms a frame |")
    print("|---|---|---|---|---|---|---|---|")
    groups: dict = {}
    for r in rows:
        key = (r["variant"], r["item"] if a.frames else r["item"].split(" ")[0])
        groups.setdefault(key, []).append(r)
    for (v, item), rs in groups.items():
        mean = {k: float(np.nanmean([r[k] for r in rs])) for k in ("recall", "precision", "points", "lines", "ms")}
        print(f"| {v} | {item} | {len(rs)} | {mean['recall']:.2f} | {mean['precision']:.2f} | {mean['points']:.0f} | {mean['lines']:.1f} | {mean['ms']:.0f} |")
    for v in dict.fromkeys(r["variant"] for r in rows):
        rs = [r for r in rows if r["variant"] == v]
        print(f"| {v} | all | {len(rs)} | {np.nanmean([r['recall'] for r in rs]):.2f} | {np.nanmean([r['precision'] for r in rs]):.2f} | | | |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
