"""``arstream render``: draw a scene on a clip with cameras read from a file (no solving)."""

from __future__ import annotations

import argparse
import importlib.util

from arstream.commands._clip import add_encoder_arguments

ORDER = 40

DESCRIPTION = """\
Draw a scene's graphics on a clip, with the camera of every frame read from a
cameras.jsonl file: the output of `arstream process --cameras-out`, or a
user's own tracking system (one JSON object per frame with "frame", "K",
"R", "t" and optionally "dist", docs/formats.md; frames whose record is
missing or "lost" are copied unchanged). Nothing is solved: rendering is
usable on its own.

Objects are described in pitch metres in a .toml or .json scene file (see
docs/render.md); with no --scene the demo scene is drawn (a logo on the
grass and an offside line). On-grass graphics are keyed by a grass matte so
players pass in front of them: --key auto (default) uses the pipeline's grass
detector when this build has one and a green chroma key otherwise; --key
green always uses the chroma key; --key none draws over everything. The
output keeps the input's frame rate and timestamps; its audio is copied.
"""

EPILOG = """\
examples:
  arstream render samples/wide/clip.mp4 --cameras samples/wide/truth.jsonl -o out/wide_ar.mp4
  arstream render match.mp4 --cameras cameras.jsonl --scene my_scene.toml -o out.mp4

exit status:
  0 done; 1 rendering failed or the input was damaged (what decoded was
  written); 2 bad input or usage; 130/143 stopped by Ctrl-C/SIGTERM
"""


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "render",
        help="draw a scene on a clip with cameras from a file (no solving)",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("input", metavar="CLIP", help="input video (any format FFmpeg reads)")
    p.add_argument("--cameras", required=True, metavar="FILE", help="cameras.jsonl: the camera of every frame")
    p.add_argument("--scene", metavar="FILE", help="scene of graphics, .toml or .json (default: the demo scene)")
    p.add_argument("-o", "--output", required=True, metavar="OUT.mp4", help="video to write")
    p.add_argument("--key", choices=("auto", "green", "none"), default="auto",
                   help="grass matte for on-grass graphics: auto (detector, else green), green (chroma key), none (default: auto)")
    add_encoder_arguments(p)
    p.add_argument("--json", action="store_true", help="print the summary as JSON on stdout")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def has_records(path: str) -> bool:
    """Whether the JSON-lines file ``path`` has a record: a line that is not
    blank (read up to the first one only; a missing file is the library's error)."""
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            return any(line.strip() for line in f)
    except OSError:
        return True


def run(args) -> int:
    from arstream.commands._clip import run_clip, warn
    from arstream.pipeline import render_clip

    if not has_records(args.cameras):
        warn(f"the cameras file {args.cameras} is empty: no frame has a camera, so the output is the input without graphics")
    if args.key == "auto":
        key = "detector" if importlib.util.find_spec("arstream.detect") is not None else "green"
    else:
        key = None if args.key == "none" else args.key
    return run_clip(
        lambda progress: render_clip(
            args.input,
            args.cameras,
            args.output,
            scene=args.scene,  # loaded by run_clip: a bad scene is exit 2 before decoding
            key=key,
            crf=args.crf,
            preset=args.preset,
            audio=not args.no_audio,
            keep_b_frames=not args.no_keep_b_frames,
            progress=progress,
        ),
        args,
        label="render",
        verb="rendered",
        finalised="; output finalised",
        missing=lambda stage: ": graphics are not keyed (players do not pass in front)" if stage == "detect" else ": frames pass through it unchanged",
    )
