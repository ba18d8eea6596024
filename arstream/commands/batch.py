"""``arstream batch``: process a clip archive on a local process pool or a Ray cluster."""

from __future__ import annotations

import argparse
import json
import sys

from arstream.commands._clip import add_encoder_arguments

ORDER = 35

DESCRIPTION = """\
Process many clips: each input clip goes through the whole pipeline (as
'arstream process') and becomes DIR/<name>.mp4 and DIR/<name>.cameras.jsonl;
DIR/summary.jsonl records every clip (status, frames, share tracked, fps,
error). INPUTS are files, folders (searched recursively for videos) or glob
patterns (quote them; ** spans folders).

Resumable: a clip whose outputs are complete is skipped when the batch is run
again (--force redoes it); outputs appear under their final names only when
complete, so a killed batch leaves nothing that looks done. One failing clip
does not stop the others. Clips with the same name in different folders get
their folders as a prefix (a/clip.mp4 -> a__clip.mp4).

Engines: 'local' (default) runs a process pool with one worker per core;
'ray' runs one Ray task per clip, on a local Ray or on the cluster at
--address (needs pip install "arstream[cluster]"; every node must see the
inputs and DIR at the same paths).
"""

EPILOG = """\
examples:
  arstream batch archive/ --out out/
  arstream batch 'archive/**/*.mp4' extra.mkv --out out/ --scene scene.toml --workers 2
  arstream batch archive/ --out out/ --engine ray                        # a local Ray
  arstream batch archive/ --out /nfs/out --engine ray --address auto     # the cluster this node is in

exit status:
  0 every clip ok; 1 a clip failed or its input is damaged (see summary.jsonl);
  2 bad input or usage; 130/143 stopped by Ctrl-C/SIGTERM (running clips are
  finished, a second Ctrl-C abandons them; summary.jsonl says what finished)
"""


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "batch",
        help="process a clip archive (process pool or Ray cluster), resumable",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("inputs", nargs="+", metavar="INPUTS", help="clips, folders or glob patterns")
    p.add_argument("-o", "--out", required=True, metavar="DIR", help="output folder (made if missing)")
    p.add_argument("--scene", metavar="FILE", help="scene of graphics, .toml or .json (default: the demo scene)")
    p.add_argument("--engine", choices=("local", "ray"), default="local", help="local process pool (default) or Ray")
    p.add_argument("--address", metavar="ADDR", help="Ray cluster to join: auto (the cluster this machine is a node of) or HOST:PORT of its head (default: start a local Ray)")
    p.add_argument("--workers", type=int, metavar="N", help="clips at once (default: the cores, or the Ray cluster's CPUs)")
    p.add_argument("--force", action="store_true", help="redo clips whose outputs are already complete")
    p.add_argument("--lag", type=int, default=10, metavar="N", help="frames of look-ahead for the smoother; 0 is causal (default: 10; on real footage weakly backed frames may wait up to 2 s more for a later camera carried back)")
    add_encoder_arguments(p)
    p.add_argument("--frames", type=int, default=None, metavar="N", help="stop each clip after N frames")
    p.add_argument("--json", action="store_true", help="print the batch summary as JSON on stdout")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar and no line per clip")
    p.set_defaults(func=run)


class _Bar:
    """The batch's progress on stderr (a terminal only): clips, frames, fps, ETA."""

    def __init__(self, stream, enabled: bool):
        self.stream = stream
        self.enabled = enabled and hasattr(stream, "isatty") and stream.isatty()
        self.shown = False

    def __call__(self, p) -> None:
        if not self.enabled:
            return
        frac = p.fraction
        bar = "#" * int(frac * 30)
        todo = p.clips_total - p.clips_skipped
        done = p.clips_done - p.clips_skipped
        eta = ""
        if 0 < frac < 1 and p.seconds > 2 and todo:
            share = (frac * p.clips_total - p.clips_skipped) / todo  # of the work this run does
            if share > 0:
                left = int(p.seconds * (1 - share) / share)
                eta = f" ETA {left // 3600}:{left // 60 % 60:02d}:{left % 60:02d}"
        self.stream.write(f"\r\033[Kbatch [{bar:<30s}] {done}/{todo} clips, {len(p.running)} running, {p.frames} frames {p.fps:6.1f} fps{eta}")
        self.stream.flush()
        self.shown = True

    def clear(self) -> None:
        if self.shown:
            self.stream.write("\r\033[K")
            self.stream.flush()
            self.shown = False


def _clip_line(rec: dict) -> str:
    how = "skipped (complete)" if rec.get("skipped") else rec["status"]
    s = f"{how:<18s} {rec['name']}"
    if rec["status"] in ("ok", "damaged"):
        s += f": {rec['frames']} frames, tracked {rec['share_tracked']:.1%}"
        if not rec.get("skipped"):
            s += f", {rec['fps']:.1f} fps"
    if rec.get("error"):
        s += f": {rec['error']}"
    return s


def check_args(args) -> None:
    """The options the library would refuse under its own parameter names
    (``max_frames``, ``workers``, ``lag``), refused under the options' names;
    a warning for a scene file with no objects."""
    from arstream.commands._clip import check_frames, load_scene
    from arstream.errors import InputError

    check_frames(args.frames)
    if args.workers is not None and args.workers < 1:
        raise InputError(f"--workers must be 1 or more, got {args.workers}")
    if args.lag < 0:
        raise InputError(f"--lag must be 0 or more, got {args.lag}")
    load_scene(args.scene)  # the workers load it from the path; here for the warning (and exit 2 for a bad file)


def run(args) -> int:
    from arstream.batch import BatchInterrupted
    from arstream.batch import run as run_batch

    check_args(args)
    bar = _Bar(sys.stderr, not args.quiet)

    def on_clip(rec: dict) -> None:
        if args.quiet or args.json:
            return
        bar.clear()
        print(_clip_line(rec), flush=True)

    try:
        summary = run_batch(
            args.inputs,
            args.out,
            scene=args.scene,
            engine=args.engine,
            address=args.address,
            workers=args.workers,
            force=args.force,
            lag=args.lag,
            crf=args.crf,
            preset=args.preset,
            audio=not args.no_audio,
            keep_b_frames=not args.no_keep_b_frames,
            max_frames=args.frames,
            progress=bar if bar.enabled else None,
            on_clip=on_clip,
        )
    except BatchInterrupted as exc:
        bar.clear()
        _report(exc.summary, args)
        print(f"arstream: interrupted; {exc.summary.count('ok') + exc.summary.count('damaged')} clips complete, summary written", file=sys.stderr)
        return exc.exit_code
    finally:
        bar.clear()
    return _report(summary, args)


def _report(summary, args) -> int:
    if args.json:
        print(json.dumps(summary.to_dict(), indent=2))
    else:
        print(summary.line())
    bad = [r for r in summary.clips if r["status"] in ("failed", "damaged")]
    if bad and summary.interrupted is None:
        print(f"arstream: error: {len(bad)} of {len(summary.clips)} clips failed or are damaged (see {summary.summary_path})", file=sys.stderr)
    return summary.exit_code
