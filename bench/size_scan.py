"""The pitch-size scan's choice on clips of known size, and its false choices.

``arstream process`` with no size scans a clip whose markings fit 105 x 68
poorly (:mod:`arstream.pipeline.pitch_scan`): it tracks the clip at the grid
sizes around 105 x 68 and keeps another only when the paint backs it better
(:func:`arstream.pitch_size.choose_size`). A rule that moves too easily
moves clips whose pitch *is* 105 x 68; one that moves too hardly keeps
clips metres off. This bench measures both on the realistic synthetic
presets (``arstream synth``): each seed's clip at its drawn size and, with
``--null``, the same seed's clip at 105 x 68 (the same camera, look and
graphics). Each clip is tracked once at all nine grid sizes (one causal
tracker per size, as the scan's, on the same frames and detections), and
the scan's two passes are replayed on those supports
(:func:`arstream.pipeline.pitch_scan.scan_passes`), so a rule can be judged
on every clip without running it. ``--clip PATH`` adds clips of unknown size
(a real broadcast: no verdict, the choice is shown).

Columns: the clip, its pitch, the median line support at 105 x 68, each
grid neighbour's median and (blocks for, against) of the paired test
(:func:`arstream.pitch_size.paired_blocks`; then 105 x 68's and the
neighbour's disputed points on paint, :func:`arstream.pitch_size.paint_prefers`;
then the paired test's blocks on the share of points on the paint itself, the
on-paint share of :func:`arstream.pitch_size.choose_size`), the scan's choice, and the
verdict: at 105 x 68, *false* when the scan moves it; at another size,
*nearer* / *kept* / *further* by the grid distance to the truth (metres over
the grid's step, the larger of the two dimensions). The scan runs in
``process`` only when the first run's median support is below
:data:`arstream.pitch_size.SCAN_BELOW`; here every clip is scanned. When no
grid size wins, ``process`` goes on to judge the size estimated from
105 x 68's own views (``arstream.pipeline.api._estimate_from_default``);
that needs a run per clip and is not replayed here (``bench/real_synth.py``
measures it end to end).

Usage::

    python bench/size_scan.py [--presets ...] [--seeds 1-5] [--null] [--clip PATH ...] [--json F] [--from F]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from arstream.pipeline import api  # noqa: E402
from arstream.pipeline.pitch_scan import SizesTracked, scan_passes, track_sizes  # noqa: E402
from arstream.pipeline.stages import DEFAULT_ANALYSIS_WIDTH, Analysis  # noqa: E402
from arstream.pitch_size import SCAN_LENGTHS, SCAN_WIDTHS, _median, grid_neighbours, paired_blocks  # noqa: E402
from arstream.presets import REAL_PRESETS  # noqa: E402
from arstream.support import PaintDispute  # noqa: E402
from arstream.synth import generate  # noqa: E402
from real_synth import seeds_arg  # noqa: E402

DEFAULT = (105.0, 68.0)
GRID = [DEFAULT] + [(L, W) for L in SCAN_LENGTHS for W in SCAN_WIDTHS if (L, W) != DEFAULT]


def track_grid(clip: Path, pixel_aspect: float | None = None) -> dict:
    """Every frame of ``clip`` tracked at each grid size: {"sizes", "supports",
    "fine", "disputes"} (per size a line support and an on-paint share per
    frame, None where it gave no camera; per pair of sizes [size_a, size_b, first, second, disputed,
    in_view], their cameras point for point), as the scan's trackers would,
    on the picture inside any black bars."""
    api._load_kernels()
    area = api._picture_area(clip)
    with api._open(clip) as src:
        an = Analysis(src.width, src.height, DEFAULT_ANALYSIS_WIDTH, pixel_aspect=pixel_aspect or getattr(src, "pixel_aspect", 1.0), area=area)
        got, _ = track_sizes(src, an, GRID, handle_signals=False)
    disputes = [[list(a), list(b), d.first, d.second, d.disputed, d.in_view] for (a, b), d in got.disputes.items()]
    return {"sizes": [list(s) for s in GRID], "supports": got.supports, "fine": got.fine, "disputes": disputes}


def _disputes(row: dict) -> dict:
    """A row's disputes as :attr:`arstream.pitch_size.SizeScan.disputes` (none in rows of older benches)."""
    return {(tuple(a), tuple(b)): PaintDispute(*v) for a, b, *v in row.get("disputes", [])}


def grid_steps(a, b) -> float:
    """Grid distance of two sizes: the larger of the two dimensions' differences over the grid's steps."""
    return max(abs(a[0] - b[0]) / (SCAN_LENGTHS[1] - SCAN_LENGTHS[0]), abs(a[1] - b[1]) / (SCAN_WIDTHS[1] - SCAN_WIDTHS[0]))


def judge(row: dict) -> dict:
    """The scan replayed on a row's supports, with its verdict."""
    table = {tuple(s): sup for s, sup in zip(row["sizes"], row["supports"])}
    fine = dict(zip(map(tuple, row["sizes"]), row.get("fine") or [None] * len(row["sizes"])))  # (none in rows of older benches)
    disputes = _disputes(row)
    pick = scan_passes(lambda sizes, rivals: SizesTracked([table[tuple(s)] for s in sizes], disputes=disputes, fine=[fine[tuple(s)] for s in sizes]))
    truth = tuple(row["truth"]) if row.get("truth") else None
    if truth is None:
        verdict = ""
    elif truth == DEFAULT:
        verdict = "right" if pick.chosen == 0 else "FALSE"
    else:
        before, after = grid_steps(DEFAULT, truth), grid_steps(pick.size, truth)
        verdict = "kept" if pick.chosen == 0 else ("nearer" if after < before else "further" if after > before else "as far")
    return {**row, "chosen": list(pick.size), "verdict": verdict}


def _synth(preset: str, seed: int, frames: int, workdir: Path, pitch=None) -> Path:
    clip = workdir / (f"{preset}-{seed}-{frames}" + ("-105x68" if pitch else ""))
    if not (clip / "truth.jsonl").exists():
        generate(clip, preset=preset, seed=seed, frames=frames, pitch=pitch)
    return clip


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--presets", default=",".join(REAL_PRESETS), help="comma-separated realistic presets")
    ap.add_argument("--seeds", type=seeds_arg, default=seeds_arg("1-5"), help="e.g. 1-5 or 1,4,9 (default 1-5)")
    ap.add_argument("--frames", type=int, default=200)
    ap.add_argument("--null", action="store_true", help="also each seed's clip at 105 x 68")
    ap.add_argument("--clip", action="append", default=[], help="a clip of unknown size (repeatable; PATH or PATH@PIXEL_ASPECT)")
    ap.add_argument("--workdir", type=Path, default=Path("/tmp/arstream-bench"), help="where the clips are generated (reused)")
    ap.add_argument("--json", type=Path, help="write the rows (with every frame's supports) here")
    ap.add_argument("--from", dest="from_", type=Path, help="replay the rows of an earlier --json instead of tracking")
    args = ap.parse_args(argv)
    unknown = [p for p in args.presets.split(",") if p not in REAL_PRESETS]
    if unknown:
        ap.error(f"not realistic presets: {', '.join(unknown)} (choose from {', '.join(REAL_PRESETS)})")
    if args.from_:
        rows = json.loads(args.from_.read_text())
    else:
        todo = []
        for preset in args.presets.split(","):
            for seed in args.seeds:
                todo.append((f"{preset} {seed}", _synth(preset, seed, args.frames, args.workdir), None))
                if args.null:
                    todo.append((f"{preset} {seed} at 105 x 68", _synth(preset, seed, args.frames, args.workdir, DEFAULT), None))
        for c in args.clip:
            path, _, aspect = c.partition("@")
            todo.append((Path(path).name, Path(path), float(aspect) if aspect else None))
        rows = []
        for name, clip, aspect in todo:
            head = clip / "header.json" if clip.is_dir() else None
            truth = None
            if head is not None and head.exists():
                p = json.loads(head.read_text())["pitch"]
                truth = [float(p["length"]), float(p["width"])]
            source = clip / "clip.mp4" if truth is not None else clip
            rows.append({"clip": name, "truth": truth, **track_grid(source, aspect)})
            print(f"tracked {name}", file=sys.stderr, flush=True)
    rows = [judge(r) for r in rows]
    nb = grid_neighbours(DEFAULT)
    print("| clip | pitch | 105 x 68 | " + " | ".join(f"{L:g} x {W:g}" for L, W in nb) + " | chosen | verdict |")
    print("|---|---|---|" + "---|" * len(nb) + "---|---|")
    for r in rows:
        table = {tuple(s): sup for s, sup in zip(r["sizes"], r["supports"])}
        m0 = _median(table[DEFAULT])
        fine = dict(zip(map(tuple, r["sizes"]), r.get("fine") or []))
        cells = []
        for s in nb:
            m = _median(table[s])
            pro, con = paired_blocks(table[DEFAULT], table[s])
            d = _disputes(r).get((DEFAULT, s))
            paint = "" if d is None else f"; {d.first}:{d.second}"
            if fine.get(DEFAULT) is not None and fine.get(s) is not None:
                paint += "; on paint {}, {}".format(*paired_blocks(fine[DEFAULT], fine[s]))
            cells.append(f"{'-' if m is None else f'{m:.3f}'} ({pro}, {con}{paint})")
        truth = "?" if r["truth"] is None else f"{r['truth'][0]:g} x {r['truth'][1]:g}"
        print(f"| {r['clip']} | {truth} | {'-' if m0 is None else f'{m0:.3f}'} | " + " | ".join(cells) + f" | {r['chosen'][0]:g} x {r['chosen'][1]:g} | {r['verdict']} |")
    count = lambda v: sum(r["verdict"] == v for r in rows)  # noqa: E731
    print(f"\nat 105 x 68: {count('right')} kept, {count('FALSE')} moved; at other sizes: {count('nearer')} nearer, {count('kept')} kept, {count('further')} further, {count('as far')} as far")
    if args.json and not args.from_:
        args.json.write_text(json.dumps(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
