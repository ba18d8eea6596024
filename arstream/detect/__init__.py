"""Pitch detection: grass, painted-line pixels, long straight lines and the
ellipses of the circle markings, for every frame of a broadcast clip.

Pipeline (one :class:`Detector` per clip; :func:`detect` for a single image):

1. **Grass** (:mod:`.grass`). A hue-saturation histogram of the clip's own
   grass, seeded from the dominant green peak and adapted over the frames,
   back-projected on a small copy of the frame (about 160 px wide). Thin
   gaps (lines, the ball) are closed, the pitch is the large connected
   region, its convex hull fills in the players, and solid rectangles (the
   score graphic) are cut out again. Stands, boards and crowd close-ups are
   not grass; a frame with too little grass is not a pitch view.
2. **Line pixels** (:mod:`.ridges`). Steger's sub-pixel ridge detector on the
   luma plane at a working resolution (the frame shrunk by an integer
   factor: 640 px wide for 720p and 1080p), seeded by a white top-hat and
   checked for a two-sided contrast (stripes and shadow edges are one-sided
   steps) and elongation (kits and the ball are blobs). For a still
   (:func:`detect`, ``shade``) the contrast asked of a line is 12 % of its
   own grass's luma, where that grass is darker than the frame's (a stand's
   shadow across the pitch: the frame's threshold lost every line in it); a
   second pass at half
   that resolution finds the wide lines (zoomed in, or smeared by a fast pan)
   where the fine pass found nothing, and a third on the frame squashed 4x
   sideways the near-vertical lines a fast pan smears into bands. A caller
   that knows the camera (a tracker) may say how fast the image moves and how
   wide the widest line is: on a slow frame the squashed pass is skipped, and
   the coarse one too when every line is thin. Every centre has a sub-pixel
   position and the line's normal.
3. **Straight lines** (:mod:`.segments`). An orientation-aware Hough vote
   (each centre votes once, with its own normal), peaks gathered,
   cut at long gaps only (pieces split by players merge), checked for
   straightness, and fitted by :func:`geometry.lines.fit_line` in frame
   pixels (with its offset and direction uncertainty).
4. **Ellipses** (:mod:`.ellipses`). RANSAC over the direct fit with arcs as
   samples (single arcs, pairs, triples: one batched Halir-Flusser solve),
   inliers by Sampson distance and gradient direction, iteratively reweighted
   direct fits, then validation: size, shape, support along the visible
   perimeter, lying on the pitch. An arc cut off by a straight line, with
   all its support beyond it (a penalty arc), is reported as ``kind="arc"``;
   the centre circle, when in view, is ``ellipses[0]``.

Frames are BGR uint8 (H, W, 3); every output coordinate is in frame pixels
(pixel centres at integers), lines are homogeneous ``(a, b, c)`` with
``a^2 + b^2 = 1`` and conics are normalised as in :mod:`geometry.conics`.
The arrays of a :class:`Detections` may live in the detector's reused
buffers: they are valid until the next :meth:`Detector.process` call.
"""

from .detector import Detector, detect
from .draw import draw_detections
from .results import DetectedEllipse, DetectedLine, Detections

__all__ = ["Detector", "detect", "Detections", "DetectedLine", "DetectedEllipse", "draw_detections"]
