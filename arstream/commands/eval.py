"""``arstream eval``: score predicted cameras against ground truth (``--truth``)
or judge them against the frames themselves (``--video``)."""

from __future__ import annotations

import argparse
import json

from arstream.commands.synth import _size

ORDER = 60


def _pitch(text: str) -> tuple[float, float]:
    """``LxW`` in metres (e.g. ``105x68``) -> (length, width)."""
    try:
        length, width = (float(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"pitch must look like 105x68 (length x width, metres), got {text!r}") from None
    from geometry.pitch import PitchModel

    try:
        PitchModel(length, width)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return length, width


def _positive(kind):
    def parse(text: str):
        try:
            v = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a positive {kind.__name__}, got {text!r}") from None
        if not v > 0 or v != v or v == float("inf"):
            raise argparse.ArgumentTypeError(f"expected a positive {kind.__name__}, got {text!r}")
        return v

    return parse


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "eval",
        help="score cameras.jsonl against truth.jsonl, or against the video's own frames",
        description=(
            "Two modes. With --truth: score predicted cameras against ground truth: coverage, "
            "reprojection error of the pitch markings (median, mean, p95), acc@5/10/20 px, focal "
            "error, jitter, and estimates given on frames without a pitch. With --video (no ground "
            "truth needed): coverage, line support (share of the projected markings within 2 px of "
            "bright paint: median, mean, share of frames >= 0.7, frames drawn below 0.5) and the "
            "jitter proxy, and overlays of the projected markings on every Nth frame."
        ),
    )
    mode = p.add_mutually_exclusive_group(required=True)
    mode.add_argument("--truth", help="truth.jsonl of a synthetic clip (header.json beside it gives the frame size and the pitch's size)")
    mode.add_argument("--video", metavar="CLIP", help="the input the cameras were made from: a video, a still image, a folder or a glob of numbered frames")
    p.add_argument("--pred", required=True, help="cameras.jsonl to score")
    p.add_argument("--size", type=_size, default=None, metavar="WxH", help="with --truth: frame size if there is no header.json")
    p.add_argument("--draw-every", type=_positive(int), default=None, metavar="N", help="with --video: draw the projected markings over every Nth frame (needs --draw-dir)")
    p.add_argument("--draw-dir", metavar="DIR", help="with --video: folder for the overlays (frame_NNNNNN.png) and contact_sheet.png (default --draw-every: 25)")
    p.add_argument(
        "--pitch",
        type=_pitch,
        default=None,
        metavar="LxW",
        help="the pitch size in metres the cameras were made at (what arstream process printed). With --video the markings drawn and judged (default: a record's own \"pitch\" entry, as register --json writes, else 105x68); with --truth, when not the clip's own size, each camera is judged on its own pitch's markings (default: a record's own \"pitch\" entry, as process writes, else the clip's)",
    )
    p.add_argument("--pixel-aspect", type=_positive(float), default=None, metavar="A", help="with --video: a pixel's width over its height, for overlays and 1280-wide pixels (default: the cameras' K[1][1]/K[0][0])")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(func=run, _parser=p)


def run(args) -> int:
    parser = args._parser
    if args.truth is not None:
        given = [o for o, v in (("--draw-every", args.draw_every), ("--draw-dir", args.draw_dir), ("--pixel-aspect", args.pixel_aspect)) if v is not None]
        if given:
            parser.error(f"{', '.join(given)}: only with --video")
        from arstream.evaluate import format_table, score_files
        from geometry.pitch import PitchModel

        s = score_files(args.truth, args.pred, args.size, pred_pitch=PitchModel(*args.pitch) if args.pitch else None)
        print(json.dumps(s.to_dict(), indent=2) if args.json else format_table(s))
        return 0
    if args.size is not None:
        parser.error("--size: only with --truth (with --video the frames give the size)")
    if args.draw_every is not None and args.draw_dir is None:
        parser.error("--draw-every needs --draw-dir")
    from arstream.evaluate_video import evaluate_video_files, format_video_table
    from geometry.pitch import PitchModel

    s = evaluate_video_files(
        args.video,
        args.pred,
        pitch=PitchModel(*args.pitch) if args.pitch else None,
        pixel_aspect=args.pixel_aspect,
        draw_every=(args.draw_every or 25) if args.draw_dir else 0,
        draw_dir=args.draw_dir,
    )
    print(json.dumps(s.to_dict(), indent=2) if args.json else format_video_table(s))
    return 0
