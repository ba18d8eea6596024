"""Benchmark: the product on the shared real broadcast material (issue 29).

For each shared still, ``arstream register`` (the Premier League frames with
their pixel aspect 16/9), and on each clip's reference frames one by one; for each shared clip, ``arstream process`` then the
ground-truth-free figures of ``arstream eval --video`` (coverage, line support,
share of frames at >= 0.7, frames drawn below 0.5, jitter proxy); for every
item, the mean distance to the reference cameras (tests/data/real_reference,
made independently by bench/reference_cameras.py) over the markings in view,
in pixels of a 1280-wide frame, and the speed; and each clip's run against
every N-th frame of the clip registered as a still (``--still-every N``,
:func:`still_agreement`: the frames without a reference camera). Prints
Markdown tables and writes contact sheets of overlays (``--sheets DIR``).

Usage::

    python bench/real_footage.py [--sheets DIR] [--clips NAME ...] [--pitch NAME=LxW ...] [--still-every N]

The material is read from ``../shared/data/real-broadcast`` (skipped with a
message where it is absent).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from arstream.evaluate import distance_1280  # noqa: E402
from arstream.evaluate_video import draw_overlay, evaluate_video  # noqa: E402
from arstream.initialise import register_image  # noqa: E402
from arstream.pipeline import process  # noqa: E402
from arstream.support import bright_mask, line_support, marking_points  # noqa: E402
from geometry.camera import Camera  # noqa: E402
from geometry.pitch import PitchModel  # noqa: E402

SHARED = ROOT.parent / "shared" / "data" / "real-broadcast"
REFERENCE = ROOT / "tests" / "data" / "real_reference"
STILLS = ["ucl_2009", "world_cup_2006", "world_cup_2018"]
CLIPS = ["israel_league_wide", "artificial_turf_multisport"]
EPL_ASPECT = 16 / 9
#: the least line support (the issue's, on the frame at its own size) of a
#: still's camera that a clip's run is checked against (:func:`still_agreement`)
STILL_BACKED = 0.95


def references(item: str) -> dict[int, tuple[Camera, PitchModel]]:
    path = REFERENCE / f"{item}.json"
    if not path.exists():
        return {}
    out = {}
    for e in json.loads(path.read_text())["frames"]:
        p = e["pitch"]
        out[e["frame"]] = (Camera.from_dict(e["camera"]), PitchModel(p["length"], p["width"]))
    return out


def still_rows(sheets: Path | None) -> list[dict]:
    rows, overlays = [], []
    items = [(s, SHARED / "stills" / f"{s}.png", 1.0, 0) for s in STILLS]
    items += [(f"sequence_epl frame {k:02d}", SHARED / "sequence-epl" / f"frame_{k:02d}.jpg", EPL_ASPECT, k) for k in (0, 25, 50)]
    for name, path, aspect, frame in items:
        img = cv2.imread(str(path))
        H, W = img.shape[:2]
        t0 = time.perf_counter()
        est, cam = _register(img, aspect)
        seconds = time.perf_counter() - t0
        # (no size given: the camera is made at the size the still's view gives)
        made_at = est.info["pitch"] if cam is not None else None
        pitch = None if made_at is None else made_at.model()
        sup = None if cam is None else frame_support(img, cam, pitch)
        refs = references("sequence_epl" if name.startswith("sequence") else name)
        d = distance_1280(*refs[frame][:1], cam, (W, H), refs[frame][1], pitch, pixel_aspect=aspect) if cam is not None and frame in refs else float("nan")
        rows.append({"item": name, "status": est.status, "support": sup, "distance_1280": d, "seconds": seconds, "pitch": None if made_at is None else made_at.describe()})
        overlays.append(draw_overlay(img, cam, f"{name}: {est.status}" + (f"  support {sup:.2f}" if sup is not None else ""), pitch=pitch, pixel_aspect=aspect))
    if sheets is not None:
        sheet(overlays, sheets / "real_registration_stills.jpg")
    return rows


def frame_support(img: np.ndarray, cam: Camera, pitch: PitchModel | None = None) -> float | None:
    """The issue's line support (DESIGN.md 5b) of ``cam`` on the BGR frame ``img``
    at its own size; None with too few markings in view."""
    return line_support(cam, bright_mask(cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)), marking_points(pitch)).share


def _register(img: np.ndarray, aspect: float = 1.0, pitch: PitchModel | None = None):
    """``arstream register`` on one BGR frame: (estimate, camera of the frame or None)."""
    est = register_image(img, pixel_aspect=aspect, pitch=pitch)
    return est, est.camera


def reference_frames(name: str):
    """(frame index, BGR frame, reference Camera, PitchModel) of each frame of
    the shared clip ``name`` that has a reference camera, in order."""
    import av

    refs = references(name)
    with av.open(str(SHARED / "clips" / f"{name}.mp4")) as c:
        for k, frame in enumerate(c.decode(video=0)):
            if k > max(refs):
                break
            if k in refs:
                yield k, frame.to_ndarray(format="bgr24"), *refs[k]


def clip_frame_rows(clips, pitches: dict) -> list[dict]:
    """Every reference frame of each clip registered on its own, as a still:
    how many get a camera, and how many of those are within 5 px of the
    reference (a camera further off is a wrong one)."""
    rows = []
    for name in clips:
        refs = references(name)
        pitch = PitchModel(*pitches[name]) if name in pitches else None
        got, near, dists, t0 = 0, 0, [], time.perf_counter()
        for k, img, ref, ref_pitch in reference_frames(name):
            est, cam = _register(img, pitch=pitch)
            if cam is not None:
                got += 1
                d = distance_1280(ref, cam, (img.shape[1], img.shape[0]), ref_pitch, got_pitch=est.info["pitch"].model())
                dists.append(d)
                near += d <= 5.0
        rows.append({"item": name + (f" (--pitch {pitches[name][0]:g}x{pitches[name][1]:g})" if name in pitches else ""), "frames": len(refs), "registered": got, "within_5px": near, "distances": dists, "seconds": (time.perf_counter() - t0) / len(refs)})
    return rows


def still_agreement(path: Path, recs: list[dict], every: int, pitch: PitchModel) -> dict:
    """The clip's run against its own frames registered as stills.

    The reference cameras sit on every 25th frame from frame 100 of
    ``israel_league_wide`` (none on its opening long-lens view). ``arstream
    register`` works on the frame at its own resolution, where a far line
    one or two pixels wide is still a line; the tracker works on the frame
    scaled down. Every ``every``-th frame is registered as a still (at the
    run's ``pitch``), and where the frame's paint backs the still's camera
    clearly (line support, DESIGN.md 5b, at least :data:`STILL_BACKED`)
    the run's camera (``recs``, cameras.jsonl records) is compared with it:
    two cameras more than 5 px apart (mean over the markings in view, px of
    a 1280-wide frame) cannot both be right, and the still's is the one the
    paint backs more. A ground-truth-free check for the frames that have no
    reference; it costs a still's registration (1-3 s) a frame checked.

    Returns
    -------
    dict: ``checked`` (frames whose still camera is backed), ``agree``
    (of those, the run's camera within 5 px), ``off`` (frame, px) of the
    others (inf: the run has no camera there)
    """
    import av

    checked, agree, off = 0, 0, []
    with av.open(str(path)) as c:
        for k, frame in enumerate(c.decode(video=0)):
            if k % every or k >= len(recs):
                continue
            img = frame.to_ndarray(format="bgr24")
            _, cam = _register(img, pitch=pitch)
            if cam is None:
                continue
            size = (img.shape[1], img.shape[0])
            sup = frame_support(img, cam, pitch)
            if sup is None or sup < STILL_BACKED:
                continue
            checked += 1
            run = None if recs[k].get("K") is None else Camera.from_dict(recs[k])
            d = float("inf") if run is None else distance_1280(cam, run, size, pitch)
            if d <= 5.0:
                agree += 1
            else:
                off.append((k, d))
    return {"checked": checked, "agree": agree, "off": off}


def clip_rows(clips, pitches: dict, sheets: Path | None, still_every: int = 0) -> list[dict]:
    rows = []
    for name in clips:
        path = SHARED / "clips" / f"{name}.mp4"
        pitch = pitches.get(name)
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            cams = tmp / "cameras.jsonl"
            t0 = time.perf_counter()
            summary = process(str(path), cameras_out=str(cams), pitch=pitch, handle_signals=False)
            seconds = time.perf_counter() - t0
            draw = tmp / "draw"
            recs = [json.loads(x) for x in cams.read_text().splitlines()]
            # (judged at the size the run drew with: given, or found by its scan)
            used = summary.pitch or {"length": 105.0, "width": 68.0}
            score = evaluate_video(str(path), recs, pitch=PitchModel(used["length"], used["width"]), draw_every=25, draw_dir=str(draw))
            shares = [f.share for f in score.per_frame if f.share is not None]
            drawn = [f.share for f in score.per_frame if f.status in ("ok", "tracked") and f.share is not None]
            refs = references(name)
            dists = []
            for k, (ref, rpitch) in sorted(refs.items()):
                rec = recs[k] if k < len(recs) else None
                cam = None if rec is None or rec.get("K") is None else Camera.from_dict(rec)
                dists.append(float("inf") if cam is None else distance_1280(ref, cam, (score.width, score.height), rpitch))
            rows.append(
                {
                    "item": name + (f" (--pitch {pitch[0]:g}x{pitch[1]:g})" if pitch else (f" ({summary.pitch_text})" if "scan" in used else "")),
                    "frames": summary.frames,
                    "coverage": score.coverage,
                    "support_median": score.support_median,
                    "share_at_0_7": (sum(v >= 0.7 for v in shares) / len(shares)) if shares else None,
                    "drawn_below_0_5": (sum(v < 0.5 for v in drawn) / len(drawn)) if drawn else None,
                    "jitter_1280": None if score.jitter is None else score.jitter * 1280.0 / score.width,
                    "reference_frames": len(dists),
                    "within_5px": (sum(d <= 5.0 for d in dists) / len(dists)) if dists else None,
                    "run": name + (f" --pitch {pitch[0]:g}x{pitch[1]:g}" if pitch else ""),
                    "distances": dists,
                    "fps": summary.frames / seconds,
                    "stills": still_agreement(path, recs, still_every, PitchModel(used["length"], used["width"])) if still_every else None,
                }
            )
            if sheets is not None and (draw / "contact_sheet.png").exists():
                img = cv2.imread(str(draw / "contact_sheet.png"))
                cv2.imwrite(str(sheets / f"real_process_{name}{'_pitch' if pitch else ''}.jpg"), img, [cv2.IMWRITE_JPEG_QUALITY, 80])
    return rows


def sheet(images, out: Path, cols: int = 3, width: int = 640) -> None:
    tiles = [cv2.resize(im, (width, round(im.shape[0] * width / im.shape[1]))) for im in images]
    h = max(t.shape[0] for t in tiles)
    tiles = [cv2.copyMakeBorder(t, 0, h - t.shape[0], 0, 0, cv2.BORDER_CONSTANT) for t in tiles]
    while len(tiles) % cols:
        tiles.append(np.zeros_like(tiles[0]))
    grid = np.vstack([np.hstack(tiles[i : i + cols]) for i in range(0, len(tiles), cols)])
    cv2.imwrite(str(out), grid, [cv2.IMWRITE_JPEG_QUALITY, 80])


def _fmt(v, pct=False, nd=2):
    if v is None or (isinstance(v, float) and not np.isfinite(v)):
        return "n/a"
    return f"{100 * v:.1f} %" if pct else f"{v:.{nd}f}"


def pitch_args(items) -> dict:
    """``--pitch NAME=LxW`` arguments as ``{name: (length, width)}`` (metres)."""
    out = {}
    for p in items:
        name, size = p.split("=")
        out[name] = tuple(float(v) for v in size.lower().split("x"))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sheets", type=Path, help="write contact sheets of overlays into this folder")
    ap.add_argument("--clips", nargs="*", default=CLIPS, help="clips to process (default: both)")
    ap.add_argument("--pitch", action="append", default=[], metavar="NAME=LxW", help="a clip's pitch size (repeatable)")
    ap.add_argument("--no-stills", action="store_true")
    ap.add_argument("--still-every", type=int, default=10, metavar="N", help="check each clip's run against every N-th frame registered as a still (0: not; default 10)")
    args = ap.parse_args(argv)
    if args.still_every < 0:
        ap.error(f"--still-every must be 0 or more, got {args.still_every}")
    if not SHARED.is_dir():
        print(f"skipped: {SHARED} is absent")
        return 0
    pitches = pitch_args(args.pitch)
    if args.sheets:
        args.sheets.mkdir(parents=True, exist_ok=True)
    if not args.no_stills:
        print("| still | status | line support | distance to reference (px @1280) | pitch | seconds |")
        print("|---|---|---|---|---|---|")
        for r in still_rows(args.sheets):
            print(f"| {r['item']} | {r['status']} | {_fmt(r['support'])} | {_fmt(r['distance_1280'])} | {r['pitch'] or '-'} | {r['seconds']:.1f} |", flush=True)
    if not args.no_stills:
        print()
        print("| clip's reference frames, each registered on its own | frames | registered | within 5 px of the reference | distances (px @1280) | seconds a frame |")
        print("|---|---|---|---|---|---|")
        for r in clip_frame_rows(args.clips, pitches):
            print(f"| {r['item']} | {r['frames']} | {r['registered']} | {r['within_5px']} | {', '.join(f'{d:.1f}' for d in r['distances'])} | {r['seconds']:.1f} |", flush=True)
    runs = [(c, None) for c in args.clips] + [(c, pitches[c]) for c in pitches]
    print()
    print("| clip | frames | coverage | support median | >= 0.7 | drawn < 0.5 | jitter (px @1280) | reference frames within 5 px | fps |")
    print("|---|---|---|---|---|---|---|---|---|")
    stills = []
    for name, pitch in runs:
        for r in clip_rows([name], {name: pitch} if pitch else {}, args.sheets, args.still_every):
            print(
                f"| {r['item']} | {r['frames']} | {_fmt(r['coverage'], True)} | {_fmt(r['support_median'])} | {_fmt(r['share_at_0_7'], True)} | "
                f"{_fmt(r['drawn_below_0_5'], True)} | {_fmt(r['jitter_1280'])} | {_fmt(r['within_5px'], True)} of {r['reference_frames']} | {r['fps']:.1f} |",
                flush=True,
            )
            stills.append(r)
    print()
    print("| clip | the run's distance to each reference frame (px @1280, frames 0, 25, 50, ...) |")
    print("|---|---|")
    for r in stills:
        print(f"| {r['run']} | {', '.join(f'{d:.1f}' for d in r['distances'])} |")
    if args.still_every:
        print()
        print(f"| clip | every {args.still_every}th frame as a still: backed (line support >= {STILL_BACKED}) | the run within 5 px of it | the run further (frame: px @1280) |")
        print("|---|---|---|---|")
        for r in stills:
            a = r["stills"]
            print(f"| {r['item']} | {a['checked']} | {a['agree']} | {', '.join(f'{k}: {d:.1f}' for k, d in a['off']) or 'none'} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
