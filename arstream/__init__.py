"""arstream: augmented reality on broadcast soccer video.

The streaming pipeline (decode, detect, solve, track, render, composite,
encode) and its command-line interface. See DESIGN.md for the map; the
library API mirrors the CLI::

    import arstream
    summary = arstream.process("match.mp4", "out.mp4", cameras_out="cameras.jsonl")  # arstream process
    arstream.stream("rtsp://camera/live", rerun="spawn")                            # arstream stream
    arstream.render_clip("match.mp4", "cameras.jsonl", "out.mp4", scene="s.toml")   # draw known cameras

The pipeline is imported on first use, so ``import arstream`` stays light.
"""

__version__ = "0.1.0"

__all__ = ["process", "stream", "render_clip", "Summary", "Interrupted", "__version__"]

_LAZY = {"process", "stream", "render_clip", "Summary", "Interrupted"}


def __getattr__(name):
    if name in _LAZY:
        from arstream import pipeline

        return getattr(pipeline, name)
    raise AttributeError(f"module 'arstream' has no attribute {name!r}")
