"""``arstream stream``: live mode on a file, URL or capture device, logged to rerun."""

from __future__ import annotations

import argparse
import math
import sys

ORDER = 50

DESCRIPTION = """\
Run the pipeline live on a file, a network stream or a capture device, with a
causal camera filter (no look-ahead), and log everything to rerun: the input
frame with the detected lines and ellipse, the composited output, the pitch
and the camera in 3-D, and time series of focal length, pan, tilt, confidence
and per-stage timings.

SRC is a file, a URL FFmpeg opens (rtsp://, http://, udp://, srt://, ...), or a
device with --format (e.g. --format v4l2 --source /dev/video0).
"""

EPILOG = """\
rerun modes:
  spawn             start a rerun viewer and stream to it (default)
  save FILE.rrd     write a recording (open it later with: rerun FILE.rrd)
  connect [URL]     stream to a running viewer (default rerun+http://127.0.0.1:9876/proxy)
  serve             serve gRPC on --bind:--port (127.0.0.1:9876); connect a viewer
                    with: rerun rerun+http://127.0.0.1:9876/proxy (the server
                    keeps up to 1 GiB for late viewers and stops with the stream)
  none              no rerun logging
  An unreachable viewer is a warning: processing goes on without rerun.

network sources (URLs):
  A source that sends nothing for --timeout seconds (default 10) has stalled;
  one whose connection fails has dropped. Either way the URL is opened again
  after waits of 0.5, 1, 2, 4, 8, 8 ... s for up to --reconnect seconds
  (default 30; 0 = no reconnection), with a line on stderr for each event;
  frame numbers and timestamps go on from the last frame. When it does not
  come back, the outputs are finalised with every frame read and the command
  exits with status 1. A stream that ends cleanly ends the run (status 0).
  The first connection is not retried. See docs/live.md.

examples:
  arstream stream --source match.mp4 --realtime
  arstream stream --source rtsp://camera.local/live --rerun serve --bind 0.0.0.0
  arstream stream --source match.mp4 --rerun save out/match.rrd -o out/live.mp4

exit status: 0 done; 1 processing failed, the input was damaged or a network
source was lost; 2 bad input or usage; 130/143 stopped by Ctrl-C/SIGTERM
(outputs finalised).
"""


def _option(text: str) -> tuple[str, str]:
    key, sep, value = text.partition("=")
    if not sep or not key:
        raise argparse.ArgumentTypeError(f"options look like KEY=VALUE, got {text!r}")
    return key, value


def _seconds(text: str, *, zero: bool) -> float:
    """A finite number of seconds, > 0 (or >= 0 with ``zero``), for argparse."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value) or value < 0 or (value == 0 and not zero):
        what = "0 (no reconnection) or a number of seconds" if zero else "a number of seconds > 0"
        raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}")
    return value


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "stream",
        help="live mode on a file, URL or device, logged to a rerun viewer",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--source", required=True, metavar="SRC", help="file, URL or device")
    p.add_argument("--format", metavar="FMT", help="FFmpeg input format, e.g. v4l2, avfoundation, dshow (devices)")
    p.add_argument("--option", action="append", type=_option, default=[], metavar="KEY=VALUE", help="FFmpeg demuxer option, e.g. rtsp_transport=tcp (repeatable)")
    p.add_argument("--rerun", nargs="+", default=["spawn"], metavar=("MODE", "ARG"), help="spawn | save FILE.rrd | connect [URL] | serve | none (default: spawn)")
    p.add_argument("--bind", default="127.0.0.1", metavar="ADDR", help="address for --rerun serve (default: 127.0.0.1, this machine only)")
    p.add_argument("--port", type=int, default=9876, help="port for --rerun serve/spawn (default: 9876)")
    p.add_argument(
        "--realtime",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="pace to the source clock and drop frames rather than fall behind (default: on for URLs and devices, off for files)",
    )
    p.add_argument("--scene", metavar="FILE", help="scene of graphics, .toml or .json (default: the demo scene)")
    p.add_argument("-o", "--output", metavar="OUT.mp4", help="also record the augmented video")
    p.add_argument("--cameras-out", metavar="FILE", help="also write the cameras as JSON lines")
    p.add_argument("--analysis-width", type=int, default=None, metavar="PX", help="detect and solve on frames scaled to this width; 0 = full resolution (default: 640; a frame less than 1.5 times as wide, e.g. 854x480, at its own size, and one more than twice as wide at half its size, e.g. 1920x1080 at 960)")
    from arstream.commands._clip import add_view_arguments

    add_view_arguments(p)
    p.add_argument("--jpeg-quality", type=int, default=75, metavar="Q", help="quality of the JPEG frames sent to rerun (default: 75)")
    p.add_argument("--frames", type=int, default=None, metavar="N", help="stop after N frames")
    p.add_argument(
        "--reconnect",
        type=lambda t: _seconds(t, zero=True),
        default=None,
        metavar="SECONDS",
        help="network sources: after a stall or a drop, open the URL again for up to SECONDS, then give up (exit status 1); 0 = no reconnection (default: 30)",
    )
    p.add_argument(
        "--timeout",
        type=lambda t: _seconds(t, zero=False),
        default=None,
        metavar="SECONDS",
        help="network sources: SECONDS without data count as a stall; also the longest a (re)connection may take (default: 10)",
    )
    p.add_argument("--json", action="store_true", help="print the summary as JSON on stdout")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress display")
    p.set_defaults(func=run)


def run(args) -> int:
    from arstream.commands._clip import analysis_width, report, run_clip
    from arstream.commands.process import missing_stage
    from arstream.errors import SourceLost
    from arstream.pipeline import stream
    from arstream.source import DEFAULT_RECONNECT, DEFAULT_TIMEOUT

    rerun = None if args.rerun == ["none"] else args.rerun
    aw = analysis_width(args)
    try:
        return run_clip(
            lambda progress: stream(
                args.source,
                rerun=rerun,
                realtime=args.realtime,
                scene=args.scene,
                output=args.output,
                cameras_out=args.cameras_out,
                format=args.format,
                options=dict(args.option) or None,
                bind=args.bind,
                port=args.port,
                jpeg_quality=args.jpeg_quality,
                max_frames=args.frames,
                progress=progress,
                analysis_width=aw,
                pitch=args.pitch,
                pixel_aspect=args.pixel_aspect,
                reconnect=DEFAULT_RECONNECT if args.reconnect is None else args.reconnect,
                timeout=DEFAULT_TIMEOUT if args.timeout is None else args.timeout,
            ),
            args,
            label="stream",
            verb="processed",
            finalised="",
            missing=missing_stage,
        )
    except SourceLost as exc:  # the summary of what was done, then why it stopped
        if exc.summary is not None:
            report(exc.summary, args, verb="processed", missing=missing_stage)
        kept = args.output or args.cameras_out or (rerun is not None and rerun[0] == "save")
        print(f"arstream: error: {exc}{'; outputs finalised' if kept else ''}", file=sys.stderr)
        return exc.exit_code
