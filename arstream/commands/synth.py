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


def _pixel_aspect(text: str) -> tuple[int, int]:
    try:
        p, q = (int(v) for v in text.split(":"))
        if p <= 0 or q <= 0:
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(f"pixel aspect must look like 64:45, got {text!r}") from None
    return p, q


def register(subparsers) -> None:
    from arstream.presets import ALL_PRESETS, PRESETS, REAL_PRESETS

    presets = "\n".join(f"  {name:8s} {p.description}" for name, p in PRESETS.items())
    real = "\n".join(f"  {name:15s} {p.description}" for name, p in REAL_PRESETS.items())
    p = subparsers.add_parser(
        "synth",
        help="generate a synthetic broadcast clip with exact per-frame cameras",
        description=(
            "Generate a synthetic broadcast clip (H.264) with the exact camera of every frame.\n"
            "Writes OUT/clip.mp4, OUT/truth.jsonl and OUT/header.json. Same seed, same clip.\n\n"
            f"presets:\n{presets}\n\n"
            "realistic presets (what real television shows: barrel distortion, faint worn lines,\n"
            "sun/roof shadow, mowing patterns, other sports' lines, graphics, pitch sizes\n"
            "100-110 x 64-75 m, lower resolutions, stronger compression; each seed draws its own\n"
            "look, recorded in header.json; see docs/synth.md):\n"
            f"{real}"
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--preset", default="wide", choices=list(ALL_PRESETS), help="camera motion and difficulty (default: wide)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    p.add_argument("--frames", type=int, default=250, help="number of frames (default: 250)")
    p.add_argument("--size", type=_size, default=None, metavar="WxH", help="frame size in stored pixels (default: the preset's, else 1280x720)")
    p.add_argument(
        "--pixel-aspect", type=_pixel_aspect, default=None, metavar="P:Q", help="stored pixels' aspect ratio, written into the stream (64:45: anamorphic 720x576; default: the preset's, else 1:1)"
    )
    p.add_argument("--fps", type=float, default=25.0, help="frame rate (default: 25)")
    p.add_argument("--crf", type=int, default=None, help="x264 quality, lower is better (default: the preset's, else 23)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.set_defaults(func=run)


def run(args) -> int:
    from arstream.commands._clip import check_frames
    from arstream.progress import Progress
    from arstream.synth import generate

    check_frames(args.frames)
    with Progress(args.frames, label="synth", stream=sys.stderr) as bar:
        header = generate(
            args.out, preset=args.preset, seed=args.seed, frames=args.frames, size=args.size, fps=args.fps, crf=args.crf, pixel_aspect=args.pixel_aspect, progress=bar.update
        )
    print(f"wrote {args.out}/clip.mp4, truth.jsonl, header.json ({header['frames']} frames, {header['generation_fps']} frames/s)")
    return 0
