"""Line support: how well a camera's projected pitch markings sit on bright paint.

A quality measure that needs no ground truth (issue 29, DESIGN.md section
5b). The tracker uses it at run time to refuse cameras the frame does not
support ("never draw with a wrong camera"), and ``arstream eval --video``
reports it per clip. The definitions are fixed so that figures compare:

*Bright pixels.* ``luma`` is the frame's BT.601 luma Y on 0..255 (full
range: what ``cv2.COLOR_BGR2GRAY`` gives and what a JPEG stores). A pixel is
bright when it exceeds the mean of its 15 x 15 box (``cv2.boxFilter``,
normalised, border replicate) by more than 12 levels. The limited-range Y
plane of decoded video (16-235) is accepted directly with
``video_range=True``: the box mean is linear, so the test is the same with
the threshold scaled by 219 / 255 (10.31 levels); no conversion pass is made.
The test is done in exact integer arithmetic (``225 Y - box sum > 225 x 12``),
so it does not depend on rounding of the mean.

*Line support* of a frame. The pitch markings (Law 1 centrelines of
:class:`geometry.pitch.PitchModel`: its segments and arcs, a point every
0.25 m, penalty and centre spots left out) are projected with the frame's
camera, lens distortion included (:meth:`geometry.camera.Camera.project`).
Of the points in front of the camera whose nearest pixel lies inside the
image, the share within 2 px (Chebyshev: a 5 x 5 neighbourhood) of a bright
pixel is the support. :func:`bright_mask` dilates the bright pixels by 5 x 5
once, so each point is one lookup. With fewer than :data:`MIN_POINTS` points
inside the image the support is undefined (``None``), not 0 or 1.

What it tells apart, on the committed sample (samples/wide, 250 frames,
exact cameras): the true camera scores 0.98-1.00; moved 2 m in X and Y,
0.07-0.10; panned 2 degrees, 0.13-0.37. An error along one direction only
keeps the markings parallel to it on their paint: tilted by 1 degree, up to
0.61; moved 3 m along Y, up to 0.56. About 16 % of that clip's pixels are in
the dilated mask, the score of points thrown at random.

*Jitter proxy* of a clip. For each three consecutive frames with cameras,
the pitch point under the middle frame's image centre (pixel
``((W - 1) / 2, (H - 1) / 2)`` back-projected to Z = 0 with the middle
camera; skipped when that ray does not meet the ground in front) is projected
with the three cameras, and the second difference ``x[i-1] - 2 x[i] + x[i+1]``
of those pixel positions is taken; the proxy is the RMS of its norm over the
clip, in pixels of the frame.

Cost per 1280 x 720 frame on this repository's 2-core test machine (fastest
of 200 calls, OpenCV on one thread): :func:`bright_mask` 1.4-1.5 ms (box sum
0.65, table lookup 0.36, compare 0.10, 5 x 5 dilation 0.12), 3-7 ms (median)
while other processes load both cores; :func:`line_support` 0.18 ms (2 886
points on a 105 x 68 pitch, of which the projection is 0.11 ms).

>>> import numpy as np
>>> luma = np.full((40, 60), 100, np.uint8)
>>> luma[20, :] = 130                     # a one-pixel bright line
>>> m = bright_mask(luma)
>>> bool(m[20, 30] and m[22, 30] and not m[23, 30])
True
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Sequence

import cv2
import numpy as np

from geometry.camera import Camera
from geometry.pitch import PitchModel

__all__ = [
    "BOX",
    "THRESHOLD",
    "REACH",
    "SPACING",
    "MIN_POINTS",
    "MISSING_SHARE",
    "frame_mask",
    "Support",
    "Jitter",
    "bright_mask",
    "white_mask",
    "marking_points",
    "marking_normals",
    "marking_spread",
    "backed_support",
    "backs",
    "pixel_support",
    "line_support",
    "PaintDispute",
    "paint_dispute",
    "ON_GRASS",
    "GRASS_REACH",
    "grass_region",
    "on_grass",
    "ON_LINES",
    "LINE_CONTRAST",
    "on_lines",
    "jitter_proxy",
]

#: side of the box whose mean a bright pixel must exceed (pixels)
BOX = 15
#: levels (0..255, full range) by which a bright pixel exceeds its box mean
THRESHOLD = 12.0
#: Chebyshev distance (pixels) within which a marking point counts as supported
REACH = 2
#: metres between marking samples
SPACING = 0.25
#: least marking points inside the image for the support to be defined
MIN_POINTS = 50
#: least share of a camera's marking points in view that lie on the pitch's
#: grass (:func:`on_grass`) for the run-time test to accept it
ON_GRASS = 0.8
#: how far the grass region reaches beyond the grass mask, as a share of the
#: frame's width (:func:`grass_region`)
GRASS_REACH = 0.01
#: least share of a camera's marking points on white paint that lie on a
#: painted *line* (:func:`on_lines`) for ``arstream register`` to accept it
ON_LINES = 0.8
#: levels (0..255) by which a line's crest must exceed the picture on both
#: of its sides (:func:`on_lines`)
LINE_CONTRAST = 6.0
#: a marking a camera draws on the grass is *missing* where at most this
#: share of its points in view lie on paint (:func:`paint_dispute`'s
#: ``ground``): its paint is nowhere along it, not faint or hidden in places
MISSING_SHARE = 0.1


@dataclass(frozen=True)
class Support:
    """Line support of one camera on one frame.

    Attributes
    ----------
    share : float in [0, 1], ``n_supported / n_inside``; None when undefined
        (fewer than ``min_points`` marking points inside the image)
    n_inside : int, marking points in front of the camera and inside the image
    n_supported : int, of those, the ones within ``REACH`` px of a bright pixel
    """

    share: float | None
    n_inside: int
    n_supported: int

    @property
    def defined(self) -> bool:
        return self.share is not None


@dataclass(frozen=True)
class Jitter:
    """Jitter proxy of a sequence of cameras (see the module docstring).

    Attributes
    ----------
    rms : float, pixels; None when no three consecutive frames gave a value
    n_triples : int, runs of three consecutive frames that contributed
    second_differences : (n_triples, 2) float64 pixels, ``x[i-1] - 2 x[i] + x[i+1]``
    """

    rms: float | None
    n_triples: int
    second_differences: np.ndarray

    def scaled(self, sx: float, sy: float) -> float | None:
        """RMS with the second differences' x and y scaled by ``sx`` and ``sy``
        (e.g. to pixels of a 1280-wide frame with square pixels), or None."""
        if self.n_triples == 0:
            return None
        d = self.second_differences * np.array([sx, sy])
        return float(np.sqrt(np.mean(np.sum(d * d, axis=1))))


@functools.lru_cache(maxsize=8)
def _level_table(threshold: float, video_range: bool, area: int) -> np.ndarray:
    """(256,) table ``max(area * v - floor(area * threshold'), 0)``: a pixel ``v`` is
    bright when the table's value exceeds its box sum (exact in integers)."""
    t = threshold * (219.0 / 255.0 if video_range else 1.0)
    lut = np.maximum(area * np.arange(256, dtype=np.int64) - math.floor(area * t), 0)
    return lut.astype(np.uint16 if area * 255 <= 65535 else np.int32)


def bright_mask(luma: np.ndarray, *, video_range: bool = False, box: int = BOX, threshold: float = THRESHOLD, reach: int = REACH) -> np.ndarray:
    """Pixels within ``reach`` px (Chebyshev) of a pixel brighter than its box mean.

    Parameters
    ----------
    luma : (H, W) uint8, BT.601 luma; full range (0..255) unless ``video_range``
    video_range : ``luma`` is limited-range Y (16-235), e.g. a decoded frame's Y
        plane: the threshold is scaled by 219 / 255 instead of converting the image
    box : odd side of the box mean (pixels, default 15)
    threshold : levels on the full-range scale (default 12)
    reach : dilation radius (default 2: a 5 x 5 neighbourhood); 0 gives the bright
        pixels themselves

    Returns
    -------
    (H, W) bool: ``True`` where a marking point would count as supported.

    Raises
    ------
    ValueError
        ``luma`` is not a 2-D uint8 array, or ``box`` / ``reach`` are out of range.
    """
    if not isinstance(luma, np.ndarray) or luma.dtype != np.uint8 or luma.ndim != 2:
        got = f"{luma.dtype} array of shape {luma.shape}" if isinstance(luma, np.ndarray) else type(luma).__name__
        raise ValueError(f"luma must be a 2-D uint8 array (H, W), got {got}")
    if not (isinstance(box, int) and box >= 3 and box % 2 == 1):
        raise ValueError(f"box must be an odd integer >= 3, got {box}")
    if not (isinstance(reach, int) and reach >= 0):
        raise ValueError(f"reach must be a non-negative integer, got {reach}")
    if not (np.isfinite(threshold) and threshold >= 0):
        raise ValueError(f"threshold must be finite and >= 0, got {threshold}")
    lut = _level_table(float(threshold), bool(video_range), box * box)
    depth = cv2.CV_16U if lut.dtype == np.uint16 else cv2.CV_32S
    box_sum = cv2.boxFilter(luma, depth, (box, box), normalize=False, borderType=cv2.BORDER_REPLICATE)
    bright = cv2.compare(cv2.LUT(luma, lut), box_sum, cv2.CMP_GT).view(bool)
    return within_reach(bright, reach)


def within_reach(mask: np.ndarray, reach: int = REACH) -> np.ndarray:
    """(H, W) bool: pixels within ``reach`` px (Chebyshev) of a ``True`` pixel
    of ``mask`` ((H, W) bool); ``mask`` itself when ``reach`` is 0. E.g. the
    line-support mask from the bright pixels themselves
    (``bright_mask(..., reach=0)``), without computing them again."""
    if not reach:
        return mask
    return cv2.dilate(mask.view(np.uint8), np.ones((2 * reach + 1, 2 * reach + 1), np.uint8)).view(bool)


def frame_mask(frame, reach: int = REACH) -> np.ndarray:
    """:func:`bright_mask` of a decoded frame (:class:`arstream.source.Frame`):
    its Y plane as it came from the decoder (limited range) on the fast path,
    else the luma of its BGR image. The mask line support is defined on
    (docs/evaluate.md), at the frame's own size; ``reach`` 0: the bright
    pixels themselves (a point *on* the paint)."""
    return bright_mask(frame.gray, video_range=frame.yuv is not None, reach=reach)


def white_mask(image: np.ndarray, *, reach: int = REACH, threshold: float = THRESHOLD) -> np.ndarray:
    """:func:`bright_mask` of the darkest channel of a BGR frame: pixels near
    paint that is bright in blue, green *and* red.

    The run-time test of a camera (the tracker's and ``arstream register``'s
    "never draw with a wrong camera") uses it instead of the luma: white paint
    raises every channel, but a yellow or orange line of another sport raises
    the luma without the blue, and a narrow view that lands its few markings on
    such lines would pass the luma test. On white markings both tests agree.
    The reported line support (``arstream eval``) keeps the luma definition.

    Parameters
    ----------
    image : (H, W, 3) uint8 BGR frame
    reach : as :func:`bright_mask`
    threshold : as :func:`bright_mask` (levels; the line support's 12 unless a
        still's second look at fainter paint asks for its own,
        :data:`arstream.initialise.FAINT_CONTRAST`)

    Returns
    -------
    (H, W) bool
    """
    return bright_mask(_darkest(image), reach=reach, threshold=threshold)


def _darkest(image: np.ndarray) -> np.ndarray:
    """The darkest colour channel of a BGR frame (H, W): white paint raises all three."""
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"image must be a BGR uint8 array (H, W, 3), got {getattr(image, 'dtype', type(image).__name__)} {getattr(image, 'shape', '')}")
    return cv2.min(cv2.min(image[:, :, 0], image[:, :, 1]), image[:, :, 2])


@functools.lru_cache(maxsize=16)
def _marking_points(length: float, width: float, line_width: float, spacing: float) -> np.ndarray:
    pitch = PitchModel(length, width, line_width)
    XY = np.concatenate([m.sample(spacing) for m in (*pitch.segments, *pitch.arcs)], axis=0)
    X = np.column_stack([XY, np.zeros(len(XY))])
    X.setflags(write=False)
    return X


def marking_points(pitch: PitchModel | None = None, spacing: float = SPACING) -> np.ndarray:
    """Points along every marking of ``pitch`` (segments and arcs, not the spots).

    Parameters
    ----------
    pitch : PitchModel (default 105 x 68)
    spacing : metres between samples along each marking (default 0.25)

    Returns
    -------
    (N, 3) float64, pitch frame (metres, Z = 0); read-only, cached per pitch size
    and spacing.
    """
    pitch = pitch or PitchModel()
    if not (np.isfinite(spacing) and spacing > 0):
        raise ValueError(f"spacing must be positive, got {spacing}")
    return _marking_points(pitch.length, pitch.width, pitch.line_width, float(spacing))


@functools.lru_cache(maxsize=16)
def _marking_ids(length: float, width: float, line_width: float, spacing: float) -> np.ndarray:
    pitch = PitchModel(length, width, line_width)
    ids = np.concatenate([np.full(len(m.sample(spacing)), k) for k, m in enumerate((*pitch.segments, *pitch.arcs))])
    ids.setflags(write=False)
    return ids


def marking_spread(camera: Camera, mask: np.ndarray, pitch: PitchModel | None = None, *, spacing: float = SPACING, min_points: int = 20, min_share: float = 0.5) -> tuple[int, int]:
    """How many of the markings in view are on paint: (in view, supported).

    A marking (a segment or an arc of :func:`marking_points`) is in view with
    at least ``min_points`` of its points inside the image, and supported when
    ``min_share`` of those are on ``mask``. The line support counts points, so
    one long marking laid along one painted line (a goal line on the halfway
    line, seen through a long lens) can carry a wrong camera; a right camera
    puts most of its markings in view on paint.
    """
    pitch = pitch or PitchModel()
    X = _marking_points(pitch.length, pitch.width, pitch.line_width, float(spacing))
    ids = _marking_ids(pitch.length, pitch.width, pitch.line_width, float(spacing))
    _, seen, backed = _on_mask(camera.project(X), ids, mask, min_points, min_share)
    return seen, backed


def _lookup(pixels: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Projected points (N, 2) on ``mask`` (H, W) bool: (inside, on), (N,)
    bool each: the point's nearest pixel lies inside the image, and it is on
    ``mask`` (False where outside). Non-finite rows (behind the camera) are
    neither."""
    H, W = mask.shape
    with np.errstate(invalid="ignore"):
        ix = np.floor(pixels + 0.5)  # nearest pixel (NaN stays NaN and fails the test below)
        inside = (ix[:, 0] >= 0) & (ix[:, 0] < W) & (ix[:, 1] >= 0) & (ix[:, 1] < H)
    on = np.zeros(len(pixels), bool)
    ij = ix[inside].astype(np.intp)
    on[inside] = mask[ij[:, 1], ij[:, 0]]
    return inside, on


def _on_mask(pixels: np.ndarray, ids: np.ndarray, mask: np.ndarray, min_points: int, min_share: float) -> tuple[Support, int, int]:
    """From projected marking points (N, 2) and their markings (N,): the
    counts on ``mask`` as a :class:`Support` (``share`` left to the caller),
    the markings with at least ``min_points`` points inside, and of those the
    ones with ``min_share`` of them on ``mask``."""
    inside, on = _lookup(pixels, mask)
    k = ids[inside]
    hit = on[inside]
    n = np.bincount(k, minlength=ids[-1] + 1)
    h = np.bincount(k, weights=hit, minlength=ids[-1] + 1)
    seen = n >= min_points
    n_in, n_hit = int(len(k)), int(np.count_nonzero(hit))
    return Support(share=None, n_inside=n_in, n_supported=n_hit), int(seen.sum()), int((h[seen] >= min_share * n[seen]).sum())


def backed_support(camera: Camera, mask: np.ndarray, pitch: PitchModel | None = None, *, spacing: float = SPACING) -> tuple[float | None, float]:
    """The run-time judgement of a camera, from one projection of the markings:
    (line support on ``mask``, the share of its markings in view that are on
    paint (:func:`marking_spread`; 1 with fewer than 3 in view)).

    With a ``spacing`` other than the definition's 0.25 m the least numbers of
    points (:data:`MIN_POINTS` for a defined support, 20 for a marking in view)
    scale with it, so that the same length of marking counts (the tracker
    samples every 0.5 m: half the cost, the same judgement)."""
    pitch = pitch or PitchModel()
    X = _marking_points(pitch.length, pitch.width, pitch.line_width, float(spacing))
    ids = _marking_ids(pitch.length, pitch.width, pitch.line_width, float(spacing))
    scale = SPACING / float(spacing)
    sup, seen, backed = _on_mask(camera.project(X), ids, mask, max(2, int(round(20 * scale))), 0.5)
    share = sup.n_supported / sup.n_inside if sup.n_inside >= max(1, MIN_POINTS * scale) else None
    return share, (backed / seen if seen >= 3 else 1.0)


def along_support(camera: Camera, mask: np.ndarray, pitch: PitchModel | None = None, *, spacing: float = SPACING, min_points: int = 20) -> float | None:
    """Line support of the goal and penalty areas' sides (the short straight
    markings along the pitch: Y constant) alone, or None with fewer than
    ``min_points`` of their points inside the image.

    A camera of a penalty-area view through a long lens can slide along the
    lines across the pitch (goal line, the areas' fronts: nearly parallel in
    the picture) and keep them on their paint; the areas' sides are what the
    slide moves off theirs. (The touchlines are left out: the far one is
    often faint or at the boards' edge in a right camera's view, the
    Premier League frame 01: 0.48 with them, 0.94 without.)"""
    pitch = pitch or PitchModel()
    XY = np.concatenate([m.sample(spacing) for m in pitch.segments if m.start[1] == m.end[1] and not m.name.startswith("touchline")], axis=0)
    return line_support(camera, mask, np.column_stack([XY, np.zeros(len(XY))]), min_points=min_points).share


def backs(support: float | None, spread: float, min_support: float) -> bool:
    """Whether a frame's paint backs a camera (:func:`backed_support`'s two
    figures): support at least ``min_support`` with at least half its markings
    in view on paint. An undefined support (too few markings in view) is not
    held against it."""
    return support is None or (support >= min_support and spread >= 0.5)


def pixel_support(pixels: np.ndarray, mask: np.ndarray, *, min_points: int = MIN_POINTS) -> Support:
    """Support of projected marking points ``pixels`` (N, 2) on ``mask`` (H, W) bool.

    A point counts when its nearest pixel is inside the image; non-finite rows
    (behind the camera) do not. For callers that project the markings themselves.
    """
    pixels = np.asarray(pixels, dtype=np.float64)
    if pixels.ndim != 2 or pixels.shape[1] != 2:
        raise ValueError(f"pixels must have shape (N, 2), got {pixels.shape}")
    if mask.ndim != 2:
        raise ValueError(f"mask must be (H, W), got shape {mask.shape}")
    inside, on = _lookup(pixels, mask)
    n = int(np.count_nonzero(inside))
    hit = int(np.count_nonzero(on))
    share = hit / n if n >= max(min_points, 1) else None
    return Support(share=share, n_inside=n, n_supported=hit)


def line_support(camera: Camera, mask: np.ndarray, points: np.ndarray | None = None, *, min_points: int = MIN_POINTS) -> Support:
    """Line support of ``camera`` on a frame.

    Parameters
    ----------
    camera : Camera (pitch frame), distortion included
    mask : (H, W) bool, :func:`bright_mask` of the frame's luma
    points : (N, 3) marking points (default: :func:`marking_points` of a 105 x 68 pitch)
    min_points : least points inside the image for a defined share

    Returns
    -------
    Support (share None when fewer than ``min_points`` points fall inside the image).
    """
    if points is None:
        points = marking_points()
    return pixel_support(camera.project(points), mask, min_points=min_points)


@dataclass(frozen=True)
class PaintDispute:
    """Two cameras' markings on one frame's paint, point for point
    (:func:`paint_dispute`).

    Attributes
    ----------
    first, second : int, disputed points only the first (second) camera lays on paint
    disputed : int, points in view of either camera that the two do not lay
        on the same place (more than ``REACH`` px apart, or one of them out of
        the image)
    in_view : int, points in view of either camera
    first_missing, second_missing : int, points the first (second) camera
        lays in the image on bare grass, of a marking missing there (at most
        :data:`MISSING_SHARE` of its points in view on paint) that the other
        lays wholly outside the image (0 unless :func:`paint_dispute` was
        given the ``ground``)
    """

    first: int
    second: int
    disputed: int
    in_view: int
    first_missing: int = 0
    second_missing: int = 0

    def __add__(self, other: "PaintDispute") -> "PaintDispute":
        """The counts of two frames' disputes (or two sets of points) together."""
        return PaintDispute(
            self.first + other.first, self.second + other.second, self.disputed + other.disputed, self.in_view + other.in_view, self.first_missing + other.first_missing, self.second_missing + other.second_missing
        )

    def swapped(self) -> "PaintDispute":
        """The same dispute with the cameras' roles exchanged."""
        return PaintDispute(self.second, self.first, self.disputed, self.in_view, self.second_missing, self.first_missing)

    @property
    def for_first(self) -> int:
        """The evidence for the first camera: the disputed points only it lays
        on paint, and the second's points on bare grass of a marking missing
        there that the first draws wholly outside the picture."""
        return self.first + self.second_missing

    @property
    def for_second(self) -> int:
        """The evidence for the second camera (:attr:`for_first`, roles exchanged)."""
        return self.second + self.first_missing


def paint_dispute(
    first: Camera, first_points: np.ndarray, second: Camera, second_points: np.ndarray, mask: np.ndarray, *, in_both: bool = False, ground: np.ndarray | None = None, markings: np.ndarray | None = None
) -> PaintDispute:
    """Which of two cameras lays more of the same markings on a frame's paint.

    The line support is a share of the points each camera has in view, so
    two cameras' supports are shares of different points: a camera that
    leaves a hard marking (a far touchline on the boards' edge) out of the
    image, or shares another's misses (a blurred frame's faint paint), scores
    as if it explained more. Compared point for point, the markings both
    cameras lay on the same place (within ``REACH`` px: the same 5 x 5
    neighbourhood of the mask) say nothing about which is right; of the
    others, the *disputed* points, each counts for the camera that lays it
    on paint where the other does not.

    Parameters
    ----------
    first, second : Camera (pitch frame), distortion included
    first_points, second_points : (N, 3) pitch frame (metres), the same
        samples of the same markings on each camera's pitch (its size:
        :func:`arstream.pitch_size.corresponding_samples`), in one order
    mask : (H, W) bool, :func:`bright_mask` of the frame's luma
    in_both : count only the points in view of both cameras. The samples of
        two pitch sizes' markings are the same fractions along each line
        (:func:`arstream.pitch_size.corresponding_samples`), so they slide
        along it with the size: at the image's edge one camera brings into
        view samples of a painted line that the other leaves outside, and in
        view of that camera alone they land on paint whichever size is right
        (a penalty view of a 105 m pitch: a 100 m pitch's camera lays 6 times
        as many such points on paint as the 105 m one's; ``bench/README.md``,
        "Stop 63"). A still's judgement keeps the default (a camera that
        leaves a marking out of the image is what it must see); a clip's scan
        of sizes uses this.
    ground : (H, W) bool or None, the bare grass where a marking would show
        (the pitch's grass mask less the screen graphics), with ``markings``:
        the points one camera draws in the image, off paint, on that grass,
        of a marking missing where it draws it (at most :data:`MISSING_SHARE`
        of that marking's points in view on paint) that the other draws
        wholly outside the image, count against the first
        (``first_missing``/``second_missing``). A camera that draws a
        touchline across the grass of a frame's corner where there is none
        says something the frame denies; one that draws it outside the
        picture says nothing the frame can deny (``real-sd`` 101 frame 150: at
        105 x 68 the near touchline drawn across 23 points of bare grass in
        the bottom corner, at 100 x 72, the right width, below the frame).
        A marking faint in places has paint along some of it and is not
        missing. Not with ``in_both``.
    markings : (N,) int, the marking of each point (:class:`arstream.solve.ModelSamples`' ``marking``)

    Returns
    -------
    PaintDispute (``in_view``: the points in view of both, with ``in_both``)
    """
    if len(first_points) != len(second_points):
        raise ValueError(f"the same samples on both pitches: {len(first_points)} and {len(second_points)} points")
    pa, pb = first.project(np.asarray(first_points, np.float64)), second.project(np.asarray(second_points, np.float64))
    ina, ona = _lookup(pa, mask)
    inb, onb = _lookup(pb, mask)
    either = (ina & inb) if in_both else (ina | inb)
    with np.errstate(invalid="ignore"):
        same = ina & inb & (np.max(np.abs(pa - pb), axis=1) <= REACH)
    disputed = either & ~same
    missing = (0, 0)
    if ground is not None and markings is not None and not in_both:
        ids = np.asarray(markings)
        if len(ids) != len(pa):
            raise ValueError(f"one marking per point: {len(pa)} points, {len(ids)} markings")
        missing = (_missing(pa, ina, ona, inb, ids, ground), _missing(pb, inb, onb, ina, ids, ground))
    return PaintDispute(int(np.count_nonzero(disputed & ona & ~onb)), int(np.count_nonzero(disputed & onb & ~ona)), int(np.count_nonzero(disputed)), int(np.count_nonzero(either)), *missing)


def _missing(pixels: np.ndarray, inside: np.ndarray, on: np.ndarray, other_inside: np.ndarray, ids: np.ndarray, ground: np.ndarray) -> int:
    """How many of one camera's points in view (``inside``, (N,) bool) lie off
    paint (``on``) on ``ground``, of a marking missing there (at most
    :data:`MISSING_SHARE` of its points in view on paint) that the other
    camera draws wholly outside the picture (none of it in ``other_inside``).
    A marking both draw in view is not counted: the samples of two sizes'
    markings slide along a line with the size, and at the picture's edge one
    camera's last samples of a line the other also draws are outside the
    other's view whichever is right. ``pixels`` (N, 2) the camera's
    projections, ``ids`` the markings."""
    m = int(ids.max()) + 1
    n = np.bincount(ids[inside], minlength=m)
    hit = np.bincount(ids[inside & on], minlength=m)
    gone = (n > 0) & (hit <= MISSING_SHARE * n) & (np.bincount(ids[other_inside], minlength=m) == 0)
    if not gone.any():
        return 0
    _, bare = _lookup(pixels, np.asarray(ground, bool))
    return int(np.count_nonzero(inside & ~on & bare & gone[ids]))


def grass_region(grass: np.ndarray, reach: float = GRASS_REACH) -> np.ndarray:
    """The pitch's grass grown by ``reach`` times its width (an ellipse's
    dilation): where a marking may be (:func:`on_grass`).

    Every marking is painted on the grass, but the grass mask
    (:mod:`arstream.detect.grass`) is coarse (made about 160 px wide) and can
    miss a strip of darker grass under floodlights along the far touchline, so
    it is grown.

    Parameters
    ----------
    grass : (h, w) uint8 or bool, non-zero on grass (any size: the frame's, or
        the detector's small copy)
    reach : share of ``w``

    Returns
    -------
    (h, w) bool
    """
    g = np.asarray(grass)
    if g.ndim != 2:
        raise ValueError(f"grass must be (h, w), got shape {g.shape}")
    r = max(1, int(round(reach * g.shape[1])))
    return cv2.dilate((g > 0).astype(np.uint8), cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))) > 0


def on_grass(camera: Camera, region: np.ndarray, size: tuple[int, int], pitch: PitchModel | None = None, *, spacing: float = 0.5) -> float | None:
    """Share of a camera's marking points in view that lie on the grass.

    A view of a distant part of the pitch through a long lens fits a family of
    cameras along its line of sight (focal length and distance together):
    each lays the markings near the middle of the view on their paint, and a
    member too far away lays the far touchline up in the stands or on the
    boards, where the bright seats and adverts back it as well as paint would
    (its line support can be higher than the right camera's). The grass
    tells them apart: every marking lies on it.

    Parameters
    ----------
    camera : Camera of a frame of ``size``
    region : (h, w) bool, :func:`grass_region` of the frame's grass mask (any
        size with the frame's aspect: the points are scaled to it)
    size : (W, H) of the frame, pixels
    pitch : PitchModel (default 105 x 68)
    spacing : metres between marking points

    Returns
    -------
    float in [0, 1], or None with fewer marking points in view than the line
    support needs (:data:`MIN_POINTS` at 0.25 m, scaled with ``spacing``)
    """
    pitch = pitch or PitchModel()
    W, H = size
    h, w = region.shape
    X = _marking_points(pitch.length, pitch.width, pitch.line_width, float(spacing))
    uv = camera.project(X)
    with np.errstate(invalid="ignore"):
        q = np.floor(uv + 0.5)  # (the frame's pixel a point lands on: NaN fails the test)
        inside = (q[:, 0] >= 0) & (q[:, 0] < W) & (q[:, 1] >= 0) & (q[:, 1] < H)
    ij = np.minimum((q[inside] * np.array([w / W, h / H])).astype(np.intp), [w - 1, h - 1])
    n = len(ij)
    if n < max(1, MIN_POINTS * SPACING / float(spacing)):
        return None
    return float(np.count_nonzero(region[ij[:, 1], ij[:, 0]])) / n


def _tangents(P: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """(N, 2) central differences of consecutive points ``P`` (N, 2) of the same
    marking (``ids``, :func:`_marking_ids`; one-sided at a marking's ends)."""
    nxt = np.r_[ids[1:] == ids[:-1], False][:, None]
    prv = np.r_[False, ids[1:] == ids[:-1]][:, None]
    return np.where(nxt, np.r_[P[1:], P[-1:]], P) - np.where(prv, np.r_[P[:1], P[:-1]], P)


@functools.lru_cache(maxsize=16)
def _marking_normals(length: float, width: float, line_width: float, spacing: float) -> np.ndarray:
    X = _marking_points(length, width, line_width, spacing)
    t = _tangents(X[:, :2], _marking_ids(length, width, line_width, spacing))
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-12)
    out = np.column_stack([-t[:, 1], t[:, 0], np.zeros(len(t))])
    out.setflags(write=False)
    return out


def marking_normals(pitch: PitchModel | None = None, spacing: float = SPACING) -> np.ndarray:
    """Unit normals (in the pitch plane) of the markings at :func:`marking_points`.

    Returns
    -------
    (N, 3) float64, pitch frame (Z = 0), the rows of ``marking_points(pitch,
    spacing)``; read-only, cached per pitch size and spacing.
    """
    pitch = pitch or PitchModel()
    return _marking_normals(pitch.length, pitch.width, pitch.line_width, float(spacing))


def on_lines(camera: Camera, image: np.ndarray, bright: np.ndarray, pitch: PitchModel | None = None, *, contrast: float = LINE_CONTRAST) -> float | None:
    """Share of a camera's marking points on white paint that lie on a painted
    *line*: a crest brighter than the picture on both of its sides.

    The line support counts a marking point as backed when a bright pixel is
    within 2 px, and a bright *step* backs it as well as a line does: the
    edge between the grass and a sand-coloured running track, between the
    track and a wall, the lower edge of the advertising boards. A wrong
    camera through a long lens can lay its touchlines and penalty-area lines
    along such edges at a line support of 0.72-0.85. A painted line is
    darker on both sides. For each marking point in view on ``bright``, the
    darkest colour channel (white paint raises all three) is read across the
    projected marking: its crest within 2 px plus half the line's projected
    width, and the picture on either side of the crest at half that width
    plus 3.5 px (4.5 px at 1280 wide). The point lies on a line when the
    crest exceeds both sides by more than ``contrast`` levels. On the shared
    real frames with a reference camera (27, each clean, under six kinds of
    broadcast graphics and at 480 rows as a JPEG of quality 35:
    ``bench/real_graphics.py``) the reference cameras and the right cameras
    ``register`` found score 0.88-0.99, the wrong ones laid along edges
    0.52-0.74 (a 3 x 3 blur or a contrast of 8 levels cost the 480-row
    JPEGs 0.07-0.1).

    Parameters
    ----------
    camera : Camera of the frame
    image : (H, W, 3) uint8 BGR frame
    bright : (H, W) bool, the frame's :func:`white_mask` (the points judged)
    pitch : PitchModel (default 105 x 68)
    contrast : levels, see :data:`LINE_CONTRAST`

    Returns
    -------
    float in [0, 1], or None with fewer than :data:`MIN_POINTS` marking points
    on ``bright`` far enough inside the image to be read across
    """
    low = _darkest(image)
    H, W = low.shape
    if bright.shape != (H, W):
        raise ValueError(f"bright must be the frame's size {(H, W)}, got {bright.shape}")
    pitch = pitch or PitchModel()
    X = _marking_points(pitch.length, pitch.width, pitch.line_width, SPACING)
    ids = _marking_ids(pitch.length, pitch.width, pitch.line_width, SPACING)
    with np.errstate(invalid="ignore", divide="ignore"):
        uv = camera.project(X)
        ti = _tangents(uv, ids)
        n = np.column_stack([-ti[:, 1], ti[:, 0]]) / np.linalg.norm(ti, axis=1, keepdims=True)
        # the line's projected width: its centreline to its edge in the pitch, across the picture's marking
        edge = X + pitch.line_width * marking_normals(pitch)
        width = np.minimum(np.abs(np.sum((camera.project(edge) - uv) * n, axis=1)), 20.0)
        side = width / 2 + max(3.5, 4.5 * W / 1280)
        reach = np.ceil(2 + width / 2)
        pad = side + reach + 1
        ok = np.isfinite(uv).all(axis=1) & np.isfinite(n).all(axis=1) & np.isfinite(width)
        ok &= (uv[:, 0] >= pad) & (uv[:, 0] < W - 1 - pad) & (uv[:, 1] >= pad) & (uv[:, 1] < H - 1 - pad)
    q = np.floor(uv[ok] + 0.5).astype(np.intp)
    on = np.zeros(len(uv), bool)
    on[np.flatnonzero(ok)] = bright[q[:, 1], q[:, 0]]
    if np.count_nonzero(on) < MIN_POINTS:
        return None
    uv, n, side, reach = uv[on], n[on], side[on], reach[on]

    def read(P):
        p = np.floor(P + 0.5).astype(np.intp)
        return low[np.clip(p[:, 1], 0, H - 1), np.clip(p[:, 0], 0, W - 1)].astype(np.int16)

    steps = np.arange(-int(reach.max()), int(reach.max()) + 1)
    prof = np.stack([read(uv + o * n) for o in steps], axis=1)
    prof[np.abs(steps)[None, :] > reach[:, None]] = -1  # (beyond this point's reach)
    k = np.argmax(prof, axis=1)
    crest = uv + steps[k][:, None] * n
    top = prof[np.arange(len(uv)), k]
    line = (top - read(crest + side[:, None] * n) > contrast) & (top - read(crest - side[:, None] * n) > contrast)
    return float(np.count_nonzero(line)) / len(line)


def jitter_proxy(cameras: Sequence[Camera | None], size: tuple[int, int]) -> Jitter:
    """Jitter proxy of the cameras of consecutive frames (None: no camera).

    Parameters
    ----------
    cameras : sequence of Camera or None, one per frame, in frame order with no gaps
    size : (width, height) of the frames, pixels

    Returns
    -------
    Jitter: RMS over the clip of ``|x[i-1] - 2 x[i] + x[i+1]|`` (pixels), where
    ``x[j]`` is camera j's projection of the pitch point under camera i's image
    centre; rms None when no triple qualifies.
    """
    W, H = size
    if not (W > 0 and H > 0):
        raise ValueError(f"size must be positive (width, height), got {size}")
    centre = np.array([[(W - 1) / 2.0, (H - 1) / 2.0]])
    diffs = []
    for i in range(1, len(cameras) - 1):
        a, b, c = cameras[i - 1], cameras[i], cameras[i + 1]
        if a is None or b is None or c is None:
            continue
        G = b.backproject_to_pitch(centre)
        if not np.all(np.isfinite(G)):
            continue
        X = np.array([[G[0, 0], G[0, 1], 0.0]])
        x = [cam.project(X)[0] for cam in (a, b, c)]
        if not all(np.all(np.isfinite(p)) for p in x):
            continue
        diffs.append(x[0] - 2 * x[1] + x[2])
    d = np.array(diffs, dtype=np.float64).reshape(-1, 2)
    rms = float(np.sqrt(np.mean(np.sum(d * d, axis=1)))) if len(d) else None
    return Jitter(rms=rms, n_triples=len(d), second_differences=d)
