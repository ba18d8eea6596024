"""``arstream render``: draw a scene on a clip with cameras read from a file (no solving)."""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys

ORDER = 40

DESCRIPTION = """\
Draw a scene's graphics on a clip, with the camera of every frame read from a
cameras.jsonl file: the output of `arstream process --cameras-out`, or a
user's own tracking system (one JSON object per frame with "frame", "K",
"R", "t" and optionally "dist", DESIGN.md section 5; frames whose record is
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
    p.add_argument("--crf", type=int, default=20, help="x264 quality, lower is better (default: 20)")
    p.add_argument("--preset", default="veryfast", help="x264 speed preset (default: veryfast)")
    p.add_argument("--no-audio", action="store_true", help="drop the audio instead of copying it")
    p.add_argument("--json", action="store_true", help="print the summary as JSON on stdout")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args) -> int:
    import render
    from arstream.pipeline import Interrupted, render_clip
    from arstream.progress import Progress

    scene = render.load_scene(args.scene) if args.scene else render.default_scene()  # bad scene: exit 2 before decoding
    if args.key == "auto":
        key = "detector" if importlib.util.find_spec("arstream.detect") is not None else "green"
    else:
        key = None if args.key == "none" else args.key
    bar = Progress(None, label="render", stream=sys.stderr)
    if args.quiet:
        bar.enabled = False
    try:
        with bar:
            summary = render_clip(
                args.input,
                args.cameras,
                args.output,
                scene=scene,
                key=key,
                crf=args.crf,
                preset=args.preset,
                audio=not args.no_audio,
                progress=bar.update,
            )
    except Interrupted as exc:
        _report(exc.summary, args)
        print(f"arstream: interrupted ({exc.summary.frames} frames written; output finalised)", file=sys.stderr)
        return exc.exit_code
    return _report(summary, args)


def _report(summary, args) -> int:
    if args.json:
        print(json.dumps(summary.to_dict(), indent=2))
    else:
        print(summary.line())
    for stage in summary.missing:
        what = "graphics are not keyed (players do not pass in front)" if stage == "detect" else "frames pass through it unchanged"
        print(f"arstream: warning: no {stage} stage in this build: {what}", file=sys.stderr)
    if summary.errors:
        for e in summary.errors:
            print(f"arstream: warning: {e}", file=sys.stderr)
        print(f"arstream: error: the input is damaged; {summary.frames} frames were rendered and written", file=sys.stderr)
        return 1
    return 0
