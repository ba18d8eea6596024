"""Benchmark: how far a clip's reference cameras agree with one tripod (issue 29).

A clip's reference cameras (tests/data/real_reference) are fitted one frame
at a time. Through a long lens one frame fixes its camera's centre only
along the line of sight (the focal length and the distance trade), so the
references of one tripod camera scatter along it, and each carries that
error into the distance to reference by which a run is judged (mean over
the markings in view, px @1280). This bench fits one centre to all of a
clip's reference frames at once (:func:`arstream.tripod.fit_tripod`, each
frame's rotation and focal length its own, every frame's markings against
its own paint, as the tracker sees it: the detector's and the paint's
pixels at the analysis width) and reports:

- the references' centres: their spread, the joint centre;
- per reference frame, the jointly fitted camera's distance to the
  reference, and the line support (``arstream eval``'s) of both: how far
  right cameras that share one tripod can lie from the references;
- with ``--pred NAME=cameras.jsonl``: the run's distance to each reference
  (on the size each record was made at), and the run's camera refined about
  the joint centre on the references' size (how much of the run's distance
  its own tripod centre makes).

Usage::

    python bench/tripod_references.py [--clips NAME ...] [--pred NAME=cameras.jsonl ...]

The material is read from ``../shared/data/real-broadcast`` (skipped with a
message where it is absent).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from arstream.detect import Detector  # noqa: E402
from arstream.evaluate import distance_1280, record_pitches  # noqa: E402
from arstream.evaluate_video import cameras_by_frame  # noqa: E402
from arstream.initialise import FrameViews  # noqa: E402
from arstream.source import Frame  # noqa: E402
from arstream.pipeline.stages import DEFAULT_ANALYSIS_WIDTH, Analysis  # noqa: E402
from arstream.sink import read_jsonl  # noqa: E402
from arstream.solve import LineIndex, ModelSamples, refine_camera, seated  # noqa: E402
from arstream.support import bright_mask, line_support, marking_points  # noqa: E402
from arstream.tripod import fit_tripod  # noqa: E402
from real_footage import CLIPS, SHARED, reference_frames  # noqa: E402

def paint_index(frame: np.ndarray, index: int) -> LineIndex:
    """The frame's line pixels as the tracker sees them on real frames (the
    detector's and the paint's, found on the analysis frame ``process`` makes:
    :class:`arstream.pipeline.stages.Analysis`), in frame pixels."""
    H, W = frame.shape[:2]
    an = Analysis(W, H, DEFAULT_ANALYSIS_WIDTH)
    small = an.prepare(Frame(0, 0.0, frame)).get("analysis", frame)
    det = Detector(small.shape[1], small.shape[0]).process(small)
    view = FrameViews().view(index, small, det, an.support_reach)
    return LineIndex(an.points(np.concatenate([det.line_points, view.points])))


def clip_rows(name: str, pred: Path | None) -> tuple[dict, list[dict]]:
    """The joint fit of clip ``name``'s reference frames: (summary, one row a frame)."""
    frames = list(reference_frames(name))
    pitch = frames[0][3]
    if any((p.length, p.width) != (pitch.length, pitch.width) for *_, p in frames):
        raise SystemExit(f"{name}: the reference frames are on different pitch sizes")
    model = ModelSamples.from_pitch(pitch, 0.5)
    points = marking_points(pitch)
    size = (frames[0][1].shape[1], frames[0][1].shape[0])
    refs = [c for _, _, c, _ in frames]
    lidx = [paint_index(img, k) for k, img, _, _ in frames]
    centres = np.array([c.center for c in refs])
    start = np.median(centres, axis=0)
    fit = fit_tripod([seated(c, start, model, size) for c in refs], lidx, [size] * len(refs), model, start, pitch, radii=(8.0, 4.0, 2.5, 2.5, 2.5))
    records = read_jsonl(pred) if pred else []
    run, made_at = cameras_by_frame(records, str(pred)), record_pitches(records, str(pred))
    rows = []
    for (k, img, ref, _), cam, li in zip(frames, fit.cameras, lidx):
        bright = bright_mask(cv2.cvtColor(img, cv2.COLOR_BGR2GRAY))
        row = {
            "frame": k,
            "ref_centre": ref.center,
            "joint": distance_1280(ref, cam, size, pitch),
            "support_ref": line_support(ref, bright, points).share,
            "support_joint": line_support(cam, bright, points).share,
        }
        got = run.get(k, (None, None))[1]
        if got is not None:
            row["run"] = distance_1280(ref, got, size, pitch, made_at.get(k))
            about = refine_camera(seated(got, fit.centre, model, size), li, size, model, center=fit.centre, radii=(20.0, 10.0, 5.0, 3.0, 2.5), max_points=400)
            row["run_about_joint"] = distance_1280(ref, about.camera, size, pitch)
            row["run_centre"] = got.center
        rows.append(row)
    sight = np.mean([c.R[2] for c in refs], axis=0)
    sight /= np.linalg.norm(sight)
    along = (centres - start) @ sight
    summary = {"clip": name, "frames": len(rows), "joint_centre": fit.centre, "median_centre": start, "along_sight": (float(along.min()), float(along.max())), "spread": centres.max(axis=0) - centres.min(axis=0), "rms": fit.rms}
    return summary, rows


def f(v) -> str:
    """A vector's entries to one decimal."""
    return ", ".join(f"{x:.1f}" for x in v)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--clips", nargs="+", default=CLIPS, choices=CLIPS)
    ap.add_argument("--pred", action="append", default=[], metavar="NAME=cameras.jsonl", help="a run's cameras of a clip (repeatable)")
    a = ap.parse_args(argv)
    if not SHARED.exists():
        print(f"skipped: {SHARED} is absent")
        return 0
    preds = {}
    for p in a.pred:
        name, _, path = p.partition("=")
        if name not in CLIPS or not path:
            ap.error(f"--pred wants NAME=cameras.jsonl with NAME one of {', '.join(CLIPS)}, got {p!r}")
        preds[name] = Path(path)
    for name in a.clips:
        s, rows = clip_rows(name, preds.get(name))
        print(f"\n### {name}: {s['frames']} reference frames\n")
        print(f"- the references' centres span {f(s['spread'])} m (x, y, z), {s['along_sight'][0]:.1f} to {s['along_sight'][1]:.1f} m along the mean line of sight about their median ({f(s['median_centre'])})")
        print(f"- the joint centre: ({f(s['joint_centre'])}) m, RMS {s['rms']:.2f} px (analysis pixels' paint)")
        joint = np.array([r["joint"] for r in rows])
        print(f"- the joint cameras' distance to the references: median {np.median(joint):.1f}, max {joint.max():.1f} px @1280, {int(np.sum(joint <= 5.0))} of {len(rows)} within 5 px")
        has_run = all("run" in r for r in rows)
        head = "| frame | reference's centre (m) | support: reference / joint | joint -> reference (px) |" + (" run -> reference | run about the joint centre -> reference | run's centre (m) |" if has_run else "")
        print("\n" + head)
        print("|" + "---|" * (head.count("|") - 1))
        for r in rows:
            line = f"| {r['frame']} | {f(r['ref_centre'])} | {r['support_ref']:.3f} / {r['support_joint']:.3f} | {r['joint']:.1f} |"
            if has_run:
                line += f" {r['run']:.1f} | {r['run_about_joint']:.1f} | {f(r['run_centre'])} |"
            print(line)
        if has_run:
            for key, label in (("run", "the run"), ("run_about_joint", "the run about the joint centre")):
                d = np.array([r[key] for r in rows])
                print(f"\n{label}: {int(np.sum(d <= 5.0))} of {len(rows)} within 5 px (median {np.median(d):.1f} px)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
