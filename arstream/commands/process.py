"""``arstream process``: augment a clip (detect, solve, track, render, composite, encode)."""

from __future__ import annotations

import argparse

from arstream.commands._clip import add_encoder_arguments, add_view_arguments

ORDER = 30

DESCRIPTION = """\
Augment a broadcast clip: find the pitch markings in every frame, solve and
smooth the camera, draw the scene's graphics glued to the pitch (keyed so
players pass in front), and encode the result with libx264. The output keeps
the input's frame rate and timestamps, and its audio is copied unchanged.

With no --scene, a demo scene is drawn: a logo on the grass and an offside line.
Without -o, only the cameras are solved (no OpenGL needed).
"""

EPILOG = """\
examples:
  arstream process match.mp4 -o out/match_ar.mp4
  arstream process match.mp4 -o out.mp4 --scene my_scene.toml --cameras-out out/cameras.jsonl
  arstream process match.mp4 --cameras-out cameras.jsonl     # cameras only

exit status:
  0 done; 1 processing failed or the input was damaged (what decoded was
  written); 2 bad input or usage; 130/143 stopped by Ctrl-C/SIGTERM (outputs
  are finalised and playable up to the last frame)
"""


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "process",
        help="augment a clip: detect, solve, track, render graphics, encode",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("input", metavar="IN", help="input video (any format FFmpeg reads)")
    p.add_argument("-o", "--output", metavar="OUT.mp4", help="augmented video to write")
    p.add_argument("--scene", metavar="FILE", help="scene of graphics, .toml or .json (default: the demo scene)")
    p.add_argument("--cameras-out", metavar="FILE", help="write the camera of every frame as JSON lines (cameras.jsonl)")
    p.add_argument("--lag", type=int, default=10, metavar="N", help="frames of look-ahead for the smoother; 0 is causal (default: 10; on real footage weakly backed frames may wait up to 2 s more for a later camera carried back)")
    p.add_argument("--analysis-width", type=int, default=None, metavar="PX", help="detect and solve on frames scaled to this width; 0 = full resolution (default: 640; a frame less than 1.5 times as wide, e.g. 854x480, at its own size, and one more than twice as wide at half its size, e.g. 1920x1080 at 960)")
    add_view_arguments(p)
    add_encoder_arguments(p)
    p.add_argument("--frames", type=int, default=None, metavar="N", help="stop after N frames")
    p.add_argument("--json", action="store_true", help="print the summary as JSON on stdout")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args) -> int:
    from arstream.commands._clip import analysis_width, run_clip
    from arstream.errors import InputError
    from arstream.pipeline import process

    if args.output is None and args.cameras_out is None:
        raise InputError("nothing to write: give -o OUT.mp4, --cameras-out FILE, or both")
    if args.lag < 0:
        raise InputError(f"--lag must be 0 or more, got {args.lag}")
    aw = analysis_width(args)
    return run_clip(
        lambda progress: process(
            args.input,
            args.output,
            scene=args.scene,
            cameras_out=args.cameras_out,
            lag=args.lag,
            crf=args.crf,
            preset=args.preset,
            audio=not args.no_audio,
            keep_b_frames=not args.no_keep_b_frames,
            progress=progress,
            max_frames=args.frames,
            analysis_width=aw,
            pitch=args.pitch,
            pixel_aspect=args.pixel_aspect,
        ),
        args,
        label="process",
        verb="processed",
        finalised="; outputs finalised",
        missing=missing_stage,
    )


def missing_stage(stage: str) -> str:
    return f" (arstream/{stage}.py is missing): frames pass through it unchanged"
