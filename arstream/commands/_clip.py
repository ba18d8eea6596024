"""What the clip commands (process, render, stream, batch) share: the encoder
and analysis-width options, checking the options they share, running under a
progress bar, and reporting the summary."""

from __future__ import annotations

import json
import os
import sys
from typing import Callable


def add_encoder_arguments(p) -> None:
    """The output video's options: ``--crf``, ``--preset``, ``--no-audio``, ``--no-keep-b-frames``."""
    p.add_argument("--crf", type=int, default=20, help="x264 quality, lower is better (default: 20)")
    p.add_argument("--preset", default="veryfast", help="x264 speed preset (default: veryfast)")
    p.add_argument("--no-audio", action="store_true", help="drop the audio instead of copying it")
    p.add_argument(
        "--no-keep-b-frames",
        action="store_true",
        help="let x264 choose every frame's type (default: the input's B-frames stay B-frames, which keeps its frame pattern: a smaller output, closer to the input)",
    )


def add_view_arguments(p) -> None:
    """What the solver may be told about the pictures: ``--pitch`` and ``--pixel-aspect``."""
    from arstream.commands.eval import _pitch, _positive

    def pitch(text: str):
        return "auto" if text.strip().lower() == "auto" else _pitch(text)

    p.add_argument("--pitch", type=pitch, default=None, metavar="LxW|auto", help="the pitch's size in metres when known, e.g. 100x64 (default 105x68; with process, a clip whose markings fit it poorly is tracked again at other sizes and the best one estimated, which takes several times as long: give the size to skip it; with stream, a warning once the first 30 s fit it poorly: docs/live.md); 'auto': start from 105x68 and estimate the size from the clip's first views (experimental, see docs/real-footage.md)")
    p.add_argument(
        "--pixel-aspect", type=_positive(float), default=None, metavar="A",
        help="a pixel's width over its height, for frames resized from another shape (default: the stream's sample aspect ratio, else 1); the cameras' K[1][1]/K[0][0] is A",
    )  # fmt: skip


def analysis_width(args) -> int | None:
    """``--analysis-width`` as the library takes it: the default when not given,
    None for 0 (full resolution); InputError below 64 px."""
    from arstream.errors import InputError
    from arstream.pipeline import DEFAULT_ANALYSIS_WIDTH

    w = args.analysis_width
    if w is not None and 0 < w < 64:
        raise InputError(f"--analysis-width must be 0 (full resolution) or at least 64, got {w}")
    return DEFAULT_ANALYSIS_WIDTH if w is None else (w or None)


def check_frames(frames: int | None) -> None:
    """``--frames``: None (the whole input) or 1 or more; InputError naming the option."""
    from arstream.errors import InputError

    if frames is not None and frames < 1:
        raise InputError(f"--frames must be 1 or more, got {frames}")


def warn(message: str) -> None:
    """A non-fatal problem, one line on stderr (``arstream: warning: ...``)."""
    print(f"arstream: warning: {message}", file=sys.stderr)


def load_scene(path):
    """The scene file ``--scene`` names, loaded (ValueError naming the file when
    it is bad), with a warning when it has no objects (an empty file, or tables
    of settings only): the output would carry no graphics. None: no ``--scene``
    (the library draws its demo scene)."""
    if path is None:
        return None
    from render.scene import load_scene as load

    scene = load(path)
    if not scene.objects:
        warn(f"the scene {path} has no objects: nothing will be drawn (see docs/render.md for the format)")
    return scene


def check_clip_args(args) -> None:
    """Check the options the clip commands share, before any work: ``--frames``
    (1 or more), ``-o`` and ``--cameras-out`` (not the same file), and
    ``--scene`` (loaded once here, so a bad file is exit 2 before decoding and
    an empty one is a warning; ``args.scene`` stays the path, which each run
    loads again so that a scene without a ``[pitch]`` table stands on the
    size that run solves at). Options a command does not have are skipped."""
    from arstream.errors import InputError

    check_frames(getattr(args, "frames", None))
    output, cameras = getattr(args, "output", None), getattr(args, "cameras_out", None)
    if output is not None and cameras is not None and os.path.abspath(output) == os.path.abspath(cameras):
        raise InputError(f"-o and --cameras-out are the same file ({output}): give the cameras a file of their own, e.g. cameras.jsonl")
    if isinstance(getattr(args, "scene", None), (str, os.PathLike)):
        load_scene(args.scene)


def run_clip(call: Callable, args, *, label: str, verb: str, finalised: str, missing: Callable[[str], str]) -> int:
    """Check the shared options (:func:`check_clip_args`), run ``call(progress)``
    (a library function over one clip) under a progress bar (silent with
    ``--quiet`` or off a terminal), print its summary and return the exit code;
    on Ctrl-C, report what was done and say ``finalised``.

    ``verb``: what was done to the frames (for the damaged-input error);
    ``missing(stage)``: what a stage missing from this build means."""
    from arstream.pipeline import Interrupted
    from arstream.progress import Progress

    check_clip_args(args)
    bar = Progress(None, label=label, stream=sys.stderr)
    if args.quiet:
        bar.enabled = False
    try:
        with bar:
            summary = call(bar.update)
            bar.finish(summary.frames, summary.seconds)  # the final bar's fps is the summary line's
    except Interrupted as exc:
        report(exc.summary, args, verb=verb, missing=missing)
        print(f"arstream: interrupted ({exc.summary.frames} frames{finalised})", file=sys.stderr)
        return exc.exit_code
    return report(summary, args, verb=verb, missing=missing)


def report(summary, args, *, verb: str, missing: Callable[[str], str]) -> int:
    """Print a pipeline summary (one line, or JSON with ``--json``), warn about
    missing stages and input damage; the exit code (1 for a damaged input)."""
    print(json.dumps(summary.to_dict(), indent=2) if args.json else summary.line())
    pitch = summary.pitch or {}
    if not args.json and summary.pitch_text and (pitch.get("source") in ("estimated", "scanned") or "scan" in pitch or "fits_poorly" in pitch):
        print(summary.pitch_text)
        if pitch.get("source") != "default":
            print(f"(judge these cameras at this size: arstream eval --pitch {pitch['length']:.1f}x{pitch['width']:.1f}; eval --video reads it from the cameras' records)")
    for stage in summary.missing:
        warn(f"no {stage} stage in this build{missing(stage)}")
    if summary.cameras_in is None and summary.frames > 0 and summary.tracked == 0 and "track" not in summary.missing:
        warn(f"no frame got a camera, so nothing was drawn: the frames show no pitch whose markings give one (`arstream register {summary.input} --frame N` says why for frame N)")
    if summary.errors:
        for e in summary.errors:
            warn(e)
        print(f"arstream: error: the input is damaged; {summary.frames} frames were {verb} and written", file=sys.stderr)
        return 1
    return 0
