"""Benchmark: the real clips inside black bars (letterbox, pillarbox), tracked
and judged against their reference cameras.

Archive matches come as 4:3 pictures pillarboxed in a 16:9 frame, films of
wider pictures letterboxed. Each shared clip with reference cameras
(``tests/data/real_reference``) gets black bars drawn over its own picture:
the bars hide part of it and move nothing, so the reference cameras stay the
truth. ``arstream process`` runs on each copy; the table gives the frames
with a camera, the median line support and jitter proxy of ``arstream eval
--video``, and of the reference frames those within 5 px of their reference
and those more than 20 px off (a wrong camera that was drawn, or none: lost).

Usage::

    python bench/real_bars.py [--clips NAME ...] [--variants KIND:SHARE ...]
                              [--pitch NAME=LxW ...] [--keep DIR]

A variant is ``letter:0.125`` (black over the top and bottom 12.5 % of the
rows: a 2.35:1 picture in 16:9) or ``pillar:0.125`` (the left and right
12.5 % of the columns: a 4:3 picture in 16:9). The copies are libx264 at crf
16 without its AVX-512 code (the same bytes on every processor,
:func:`real_perturbed.x264_options`). Distances are means over the markings in
the reference's view, in pixels of a 1280-wide frame
(:func:`arstream.evaluate.distance_1280`). The material is read from
``../shared/data/real-broadcast`` (skipped with a message where it is absent).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from arstream.evaluate_video import evaluate_video  # noqa: E402
from arstream.pipeline import process  # noqa: E402
from geometry.camera import Camera  # noqa: E402
from geometry.pitch import PitchModel  # noqa: E402
from arstream.evaluate import distance_1280  # noqa: E402
from real_footage import SHARED, _fmt, pitch_args, references  # noqa: E402
from real_graphics import barred  # noqa: E402
from real_perturbed import x264_options  # noqa: E402

CLIPS = ["israel_league_wide", "artificial_turf_multisport"]
VARIANTS = ["pillar:0.125", "pillar:0.08", "letter:0.125", "letter:0.1"]


def barred_copy(src: Path, dst: Path, variant: str, frames: int | None = None) -> Path:
    """``src`` (its first ``frames`` frames; all with None) with the bars of
    ``variant`` over every frame, libx264 crf 16 (reproducible bytes)."""
    import av

    with av.open(str(src)) as inp, av.open(str(dst), "w") as out:
        vs = inp.streams.video[0]
        st = out.add_stream("libx264", rate=vs.average_rate)
        st.width, st.height, st.pix_fmt = vs.width, vs.height, "yuv420p"
        st.options = x264_options(16)
        for k, fr in enumerate(inp.decode(video=0)):
            if frames is not None and k >= frames:
                break
            out.mux(st.encode(av.VideoFrame.from_ndarray(barred(fr.to_ndarray(format="bgr24"), variant), format="bgr24")))
        out.mux(st.encode())
    return dst


def run(clips, variants, pitches: dict, keep: Path | None = None) -> list[dict]:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        where = keep or Path(tmp)
        where.mkdir(parents=True, exist_ok=True)
        for name in clips:
            refs = references(name)
            pitch = pitches.get(name)
            for variant in variants:
                clip = where / f"{name}_{variant.replace(':', '_')}.mp4"
                if not clip.exists():
                    barred_copy(SHARED / "clips" / f"{name}.mp4", clip, variant)
                cams = clip.with_suffix(".jsonl")
                t0 = time.perf_counter()
                summary = process(str(clip), cameras_out=str(cams), pitch=pitch, handle_signals=False)
                seconds = time.perf_counter() - t0
                recs = [json.loads(x) for x in cams.read_text().splitlines()]
                used = summary.pitch or {"length": 105.0, "width": 68.0}
                score = evaluate_video(str(clip), recs, pitch=PitchModel(used["length"], used["width"]))
                dists = []
                for k, (ref, rpitch) in sorted(refs.items()):
                    cam = None if k >= len(recs) or recs[k].get("K") is None else Camera.from_dict(recs[k])
                    dists.append(float("inf") if cam is None else distance_1280(ref, cam, (score.width, score.height), rpitch))
                d = np.array(dists)
                rows.append(
                    {
                        "item": f"{name} {variant}",
                        "picture": getattr(summary, "picture", None),
                        "coverage": score.coverage,
                        "support_median": score.support_median,
                        "jitter_1280": None if score.jitter is None else score.jitter * 1280.0 / score.width,
                        "reference_frames": len(d),
                        "within_5px": int(np.sum(d <= 5.0)),
                        "wrong": int(np.sum(np.isfinite(d) & (d > 20.0))),
                        "lost": int(np.sum(~np.isfinite(d))),
                        "fps": summary.frames / seconds,
                    }
                )
                print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--clips", nargs="+", default=CLIPS)
    ap.add_argument("--variants", nargs="+", default=VARIANTS)
    ap.add_argument("--pitch", nargs="*", default=[], help="NAME=LxW: a clip's pitch size, given to the run")
    ap.add_argument("--keep", type=Path, help="keep the copies and their cameras here (reused when present)")
    a = ap.parse_args(argv)
    if not SHARED.exists():
        print(f"skipped: {SHARED} is absent")
        return 0
    rows = run(a.clips, a.variants, pitch_args(a.pitch), a.keep)
    print("| clip and bars | picture analysed | frames with a camera | median support | jitter (px) | within 5 px | more than 20 px off | lost | fps |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        pic = "whole frame" if r["picture"] is None else "{} x {} at ({}, {})".format(r["picture"][2] - r["picture"][0], r["picture"][3] - r["picture"][1], r["picture"][0], r["picture"][1])
        n = r["reference_frames"]
        print(f"| {r['item']} | {pic} | {_fmt(r['coverage'], True)} | {_fmt(r['support_median'])} | {_fmt(r['jitter_1280'])} | {r['within_5px']} of {n} | {r['wrong']} | {r['lost']} | {r['fps']:.0f} |")
    tot = {k: sum(r[k] for r in rows) for k in ("reference_frames", "within_5px", "wrong", "lost")}
    print(f"| **all** | | | | | {tot['within_5px']} of {tot['reference_frames']} | {tot['wrong']} | {tot['lost']} | |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
