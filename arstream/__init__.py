"""arstream: augmented reality on broadcast soccer video.

The streaming pipeline (decode, detect, solve, track, render, composite,
encode) and its command-line interface. See DESIGN.md for the map; the
library API mirrors the CLI.
"""

__version__ = "0.1.0"
