"""The streaming pipeline: decode -> detect -> track -> render -> encode.

Modules
-------
- :mod:`.stage`: the stage protocol (:class:`~.stage.Stage`, :class:`~.stage.Item`)
  and the stage that runs another one frame ahead on a worker thread
- :mod:`.stages`: the stages: the analysis frame and detection, tracking, the
  grass matte, cameras in and out, rendering (draw, key, composite)
- :mod:`.encode`: the encoder stage (H.264 on its own thread; writers in :mod:`arstream.sink`)
- :mod:`.runner`: :class:`~.runner.Pipeline`, the decode, main and encode
  threads, live pacing, signal handling
- :mod:`.summary`: what a run reports (:class:`Summary`) and :class:`Interrupted`
- :mod:`.api`: :func:`process`, :func:`render_clip` and :func:`stream`

Fast path (DESIGN.md section 4): frames of even size stay planar YUV 4:2:0
from decoder to encoder. BGR is made once, lazily, for the stages that ask
for ``frame.image``; the frames detection and tracking work on are scaled
from the planes on the decode thread (:meth:`.stages.Analysis.prepare`); the
overlay is composited straight into the Y, U and V planes, only inside the
renderer's rectangles (:func:`render.compositor.composite_i420`); the encoder
gets the I420 buffer as is. ``docs/architecture.md`` follows a frame through
them.
"""

from arstream.pipeline.api import DEFAULT_LAG, process, render_clip, stream
from arstream.pipeline.stages import DEFAULT_ANALYSIS_WIDTH
from arstream.pipeline.summary import Interrupted, Summary

__all__ = ["process", "render_clip", "stream", "Summary", "Interrupted", "DEFAULT_LAG", "DEFAULT_ANALYSIS_WIDTH"]
