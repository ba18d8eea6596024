"""A still's scan of pitch sizes, recorded and replayed.

``arstream register`` with no size registers a still whose markings fit
105 x 68 poorly again at the grid's other sizes and keeps the one whose
camera the paint backs clearly better
(:func:`arstream.initialise.size_from_scan`, the rule
:func:`arstream.pitch_size.choose_still_size`). Registering the stills costs
10-90 s each on two cores; a rule applied to them costs milliseconds. This
bench registers each still once, as ``register`` does, and records each
scanned still's scan: every size's camera, its distance to the truth (after
the size estimated from it, as it would be drawn), and the frame's bright
mask. ``--from F`` then replays the rule of the code at hand on those
cameras, so a rule is judged on every scanned still without registering one.

Stills:

- ``--synthetic``: every 25th frame of the realistic presets' clips
  (``bench/real_synth.py --stills 25 --stills-sizes unknown``: pitches of
  100-110 x 64-74.5 m), scored against their truth marking for marking
  (:func:`arstream.pitch_size.corresponding_samples`), px @1280;
- ``--real``: the real reference frames under ``bench/real_graphics.py``'s
  variants (graphics, bars, a 480p JPEG, dim and soft looks, mirrored and
  enlarged), scored against the reference cameras
  (:func:`arstream.evaluate.distance_1280`), and the artificial-turf clip's
  frames with no size given (its pitch is 99.85 x 67.72 m).

The recorder wraps ``arstream.initialise.size_from_scan`` to see the scan's
cameras; the registration itself is the product's. Stills run on ``--jobs``
processes (each registers its scan in place).

Usage::

    python bench/still_scan.py [--synthetic] [--real] [--seeds 1-7] [--jobs N] [--record F] [--from F] [--against G]

``--against G`` lists the stills registered otherwise than in the records
``G`` (another code's, or the same code on another machine: the
registration's floating point differs between processors).
"""

from __future__ import annotations

import argparse
import json
import pickle
import sys
import time
import traceback
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from arstream.workers import cores  # noqa: E402

WORKDIR = Path("/tmp/arstream-bench")


def _synthetic_stills(presets, seeds, frames: int = 200, every: int = 25) -> list[tuple]:
    """("synthetic", clip folder, frame) of every ``every``-th frame with a pitch in view."""
    from arstream.sink import read_jsonl
    from arstream.synth import generate

    jobs = []
    for preset in presets:
        for seed in seeds:
            clip = WORKDIR / f"{preset}-{seed}-{frames}"
            if not (clip / "truth.jsonl").exists():
                generate(clip, preset=preset, seed=seed, frames=frames)
            for t in read_jsonl(clip / "truth.jsonl"):
                k = int(t["frame"])
                if k % every == 0 and t.get("K") is not None and t.get("visible_pitch", True):
                    jobs.append(("synthetic", str(clip), k))
    return jobs


_REAL = None


def _real_items() -> dict:
    global _REAL
    if _REAL is None:
        import real_graphics

        _REAL = {it[0]: it for it in real_graphics.items()}
    return _REAL


def _real_stills(prefixes=None) -> list[tuple]:
    """("real", item, variant) of every reference frame under every variant;
    the turf clip's frames only as they are (their size is the point)."""
    import real_graphics

    items = [n for n in _real_items() if not prefixes or any(n.startswith(p) for p in prefixes)]
    return [("real", n, v) for v in real_graphics.VARIANTS for n in items if v == "clean" or not n.startswith("artificial")]


def _frame(job):
    """(BGR frame, pixel aspect, scorer(camera, (L, W)) -> px @1280 or None)."""
    from arstream.evaluate import distance_1280
    from arstream.pitch_size import corresponding_samples
    from arstream.sink import read_jsonl
    from geometry.pitch import PitchModel

    if job[0] == "synthetic":
        import av
        from real_synth import _error_1280

        clip, k = Path(job[1]), job[2]
        header = json.loads((clip / "header.json").read_text())
        tp = PitchModel(header["pitch"]["length"], header["pitch"]["width"])
        aspect = header.get("pixel_aspect", [1, 1])
        size = tuple(header["size"])
        truth = next(t for t in read_jsonl(clip / "truth.jsonl") if int(t["frame"]) == k)
        with av.open(str(clip / "clip.mp4")) as c:
            image = next(f for i, f in enumerate(c.decode(video=0)) if i == k).to_ndarray(format="bgr24")

        def score(cam, made):
            return _error_1280(truth, cam, size, tp, *corresponding_samples(tp, PitchModel(*made)))

        return image, aspect[0] / aspect[1], score
    import real_graphics as rg

    _, img, aspect, ref, pitch = _real_items()[job[1]]
    H0, W0 = img.shape[:2]
    image = rg.VARIANTS[job[2]](img)
    H, W = image.shape[:2]
    truth = rg.GEOMETRIC[job[2]][1](ref, W0, H0) if job[2] in rg.GEOMETRIC else rg.scaled(ref, W / W0, H / H0)
    return image, aspect, lambda cam, made: float(distance_1280(truth, cam, (W, H), pitch, PitchModel(*made), pixel_aspect=aspect))


def record(job) -> dict:
    """One still registered as ``register`` does (no size given), its scan recorded."""
    import cv2

    import arstream.initialise as ini
    from arstream.imaging import active_area
    from arstream.pipeline.stages import Analysis
    from arstream.pitch_size import still_scan_sizes
    from geometry.pitch import PitchModel

    cv2.setNumThreads(1)
    image, aspect, score = _frame(job)
    H, W = image.shape[:2]
    an = Analysis(W, H, None, pixel_aspect=aspect, area=active_area(image))
    seen, scan, in_processes = {}, ini.size_from_scan, ini.map_in_processes

    def recorder(detections, size, img, est, view, luma, pitch, pp, **kw):
        seen.update(size=size, est=est, view=view, luma=luma, pitch=pitch, kw=kw)
        return scan(detections, size, img, est, view, luma, pitch, pp, **kw)

    def mapper(fn, jobs, **kw):
        seen["found"] = in_processes(fn, jobs, **kw)
        return seen["found"]

    ini.size_from_scan, ini.map_in_processes = recorder, mapper
    try:
        t0 = time.perf_counter()
        got = ini.register_image(image, pixel_aspect=aspect, pitch=None)
        out = {"job": list(job), "seconds": time.perf_counter() - t0, "registered": got.camera is not None, "scanned": "est" in seen}
    finally:
        ini.size_from_scan, ini.map_in_processes = scan, in_processes
    if got.camera is not None:
        made = got.info["pitch"]
        out["error"] = score(got.camera, (made.length, made.width))
        out["pitch"] = made.to_dict()
    if not out["scanned"]:
        return out
    p, est = seen["pitch"], seen["est"]
    made0 = (est.info["pitch"].length, est.info["pitch"].width)
    grid = still_scan_sizes(p)
    rows = []
    for j, e in enumerate([est, *seen["found"]]):
        made = made0 if j == 0 else grid[j]
        row = {"size": grid[j], "made": made, "camera": None if e.camera is None else e.camera.to_dict(), "support": ini._line_support(e, seen["luma"], PitchModel(*made, p.line_width))}
        row["error"] = None if e.camera is None else score(an.camera(e.camera), made)
        if j > 0 and e.camera is not None:
            cam, size_got, _ = ini.size_from_view(e.camera, e.info.get("support"), seen["view"], seen["size"], PitchModel(*made, p.line_width), seen["kw"].get("min_support", 0.7))
            row["drawn_error"] = score(an.camera(cam), (size_got.length, size_got.width))
        else:
            row["drawn_error"] = row["error"]
        rows.append(row)
    out.update(rows=rows, line_width=p.line_width, luma=np.packbits(seen["luma"]), luma_shape=seen["luma"].shape)
    return out


def _safe(job) -> dict:
    try:
        return record(job)
    except Exception:
        return {"job": list(job), "failed": traceback.format_exc()}


def replay(rec: dict) -> int:
    """The size the code at hand chooses on a recorded scan (index into its rows)."""
    from arstream.pitch_size import choose_still_size, size_dispute
    from geometry.camera import Camera
    from geometry.pitch import PitchModel

    rows = rec["rows"]
    H, W = rec["luma_shape"]
    mask = np.unpackbits(rec["luma"])[: H * W].reshape(H, W).astype(bool)
    dispute = size_dispute([None if r["camera"] is None else Camera.from_dict(r["camera"]) for r in rows], [PitchModel(*r["made"], rec["line_width"]) for r in rows], mask)
    return choose_still_size([tuple(r["size"]) for r in rows], [r["support"] for r in rows], dispute).chosen


def _name(job) -> str:
    """A still's job as a table shows it: 'real-wide-3-200 150', 'ucl_2009 bar-25'."""
    return " ".join(str(x) for x in job[1:]).replace(str(WORKDIR) + "/", "")


def _bins(errors) -> str:
    e = [x for x in errors if x is not None]
    return f"{sum(x <= 5 for x in e)} / {sum(5 < x <= 20 for x in e)} / {sum(x > 20 for x in e)} / {sum(x is None for x in errors)}"


def report(records: list[dict]) -> None:
    failed = [r for r in records if "failed" in r]
    for r in failed:
        print(f"failed: {r['job']}\n{r['failed']}")
    for kind in ("synthetic", "real"):
        recs = [r for r in records if r["job"][0] == kind and "failed" not in r]
        if not recs:
            continue
        scanned = [r for r in recs if r["scanned"]]
        chosen = [replay(r) for r in scanned]
        now = [r["rows"][k]["drawn_error"] for r, k in zip(scanned, chosen)]
        print(f"\n{kind}: {len(recs)} stills, {len(scanned)} scanned")
        print("| stills | within 5 px / 5-20 px / beyond 20 px / lost |")
        print("|---|---|")
        print(f"| all, as registered | {_bins([r.get('error') for r in recs])} |")
        print(f"| scanned, as registered | {_bins([r.get('error') for r in scanned])} |")
        print(f"| scanned, the code at hand's rule on the same scans | {_bins(now)} |")
        moved = [(r, k, e) for r, k, e in zip(scanned, chosen, now) if r.get("error") is None or e is None or abs(e - r["error"]) > 0.05]
        if moved:
            print("\n| still | as registered: px, size | now: px, size |")
            print("|---|---|---|")
            for r, k, e in moved:
                print(f"| {_name(r['job'])} | {r.get('error', float('nan')):.1f}, {tuple(r['pitch']['scan']['sizes'][r['pitch']['scan']['chosen']])} | {e:.1f}, {tuple(r['rows'][k]['size'])} |")


def _drawn(rec: dict) -> str:
    """A record's outcome as registered: 'px (source L x W)', or 'lost'."""
    if rec.get("error") is None:
        return "lost"
    p = rec["pitch"]
    return f"{rec['error']:.1f} ({p['source']} {p['length']:.1f} x {p['width']:.1f})"


def compare(before: list[dict], after: list[dict], tol: float = 0.05) -> list[tuple]:
    """The stills registered otherwise in ``after`` than in ``before`` (two
    recordings of the same stills: two codes, or one code on two machines):
    lost or registered in one only, or drawn more than ``tol`` px apart.
    Printed as a table; returned as (job, before, after) records."""
    old = {tuple(r["job"]): r for r in before if "failed" not in r}
    moved = []
    for r in after:
        o = old.get(tuple(r["job"]))
        if o is None or "failed" in r:
            continue
        e0, e1 = o.get("error"), r.get("error")
        if (e0 is None) != (e1 is None) or (e0 is not None and abs(e0 - e1) > tol):
            moved.append((r["job"], o, r))
    both = sum(tuple(r["job"]) in old for r in after)
    print(f"against the other records: {len(moved)} of {both} stills in both registered otherwise (lost in one, or more than {tol} px apart)")
    if moved:
        print("\n| still | before: px (size) | now: px (size) |")
        print("|---|---|---|")
        for job, o, r in moved:
            print(f"| {_name(job)} | {_drawn(o)} | {_drawn(r)} |")
    return moved


def main(argv=None) -> int:
    from arstream.presets import REAL_PRESETS
    from real_footage import SHARED
    from real_synth import seeds_arg

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--synthetic", action="store_true", help="the realistic presets' clips, every 25th frame as a still")
    ap.add_argument("--real", action="store_true", help="the real reference frames under bench/real_graphics.py's variants")
    ap.add_argument("--presets", nargs="+", default=list(REAL_PRESETS), choices=list(REAL_PRESETS), help="with --synthetic")
    ap.add_argument("--seeds", type=seeds_arg, default=seeds_arg("1-7"), help="with --synthetic (default 1-7)")
    ap.add_argument("--items", nargs="+", metavar="PREFIX", help="with --real: only the frames whose name starts with one of these")
    ap.add_argument("--jobs", type=int, default=None, metavar="N", help="processes, one still each (default every core)")
    ap.add_argument("--record", type=Path, help="write the records (a pickle) here")
    ap.add_argument("--from", dest="source", type=Path, help="replay the records in this file instead of registering")
    ap.add_argument("--against", type=Path, help="list the stills registered otherwise in these records (another code's or machine's)")
    a = ap.parse_args(argv)
    if a.source:
        records = pickle.loads(a.source.read_bytes())
    else:
        if a.real and not SHARED.exists():
            print(f"--real skipped: {SHARED} is absent")
            a.real = False
        jobs = (_synthetic_stills(a.presets, a.seeds) if a.synthetic else []) + (_real_stills(a.items) if a.real else [])
        if not jobs:
            ap.error("nothing to register: --synthetic, --real or --from")
        from arstream.workers import map_in_processes

        t0 = time.perf_counter()
        records = map_in_processes(_safe, jobs, workers=a.jobs or cores(), preload=("arstream.initialise",))
        print(f"{len(jobs)} stills registered in {time.perf_counter() - t0:.0f} s")
        if a.record:
            a.record.write_bytes(pickle.dumps(records))
    report(records)
    if a.against:
        print()
        compare(pickle.loads(a.against.read_bytes()), records)
    return 0


if __name__ == "__main__":
    sys.exit(main())
