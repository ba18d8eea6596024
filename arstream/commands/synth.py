"""``arstream synth``: write a synthetic broadcast clip with exact ground truth."""

from __future__ import annotations

import argparse
import sys

ORDER = 10


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size must look like 1280x720, got {text!r}") from None
    return w, h


def register(subparsers) -> None:
    from arstream.presets import PRESETS

    presets = "\n".join(f"  {name:8s} {p.description}" for name, p in PRESETS.items())
    p = subparsers.add_parser(
        "synth",
        help="generate a synthetic broadcast clip with exact per-frame cameras",
        description=(
            "Generate a synthetic broadcast clip (H.264) with the exact camera of every frame.\n"
            "Writes OUT/clip.mp4, OUT/truth.jsonl and OUT/header.json. Same seed, same clip.\n\n"
            f"presets:\n{presets}"
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--preset", default="wide", choices=sorted(PRESETS), help="camera motion and difficulty (default: wide)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    p.add_argument("--frames", type=int, default=250, help="number of frames (default: 250)")
    p.add_argument("--size", type=_size, default=(1280, 720), metavar="WxH", help="frame size (default: 1280x720)")
    p.add_argument("--fps", type=float, default=25.0, help="frame rate (default: 25)")
    p.add_argument("--crf", type=int, default=23, help="x264 quality, lower is better (default: 23)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.set_defaults(func=run)


def run(args) -> int:
    from arstream.commands._clip import check_frames
    from arstream.progress import Progress
    from arstream.synth import generate

    check_frames(args.frames)
    with Progress(args.frames, label="synth", stream=sys.stderr) as bar:
        header = generate(
            args.out, preset=args.preset, seed=args.seed, frames=args.frames, size=args.size, fps=args.fps, crf=args.crf, progress=bar.update
        )
    print(f"wrote {args.out}/clip.mp4, truth.jsonl, header.json ({header['frames']} frames, {header['generation_fps']} frames/s)")
    return 0
