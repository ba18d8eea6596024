"""The pitch's size as a per-clip unknown (issue 29, item 4).

Real pitches are about 100-110 x 64-75 m (Law 1 allows 90-120 x 45-90).
Calibrated with the wrong size, a camera fits the near markings and misses the
far ones by metres, or flips between fits. :func:`estimate_pitch_size`
refines the pitch's length and width jointly with the cameras of several
views of one tripod camera (the views' paint pixels against the markings of
a pitch of that size): one shared camera centre and size, a rotation and a
focal length per view, the views' lens distortion kept.

A view constrains the *width* when it shows markings whose distance across
the pitch depends on it (both touchlines, or one touchline with the penalty
area centred between them) and the *length* when it shows markings at
either end of a half together (the halfway line or the centre circle with a
goal line, the penalty or goal area or a penalty arc). Which dimensions the
views constrain is read off the estimate's uncertainty: a dimension whose
standard deviation is over ``max_sd`` metres (the views do not fix it) keeps
its prior value and is reported unconstrained.

The uncertainty is the larger of a delete-one-view jackknife over the views
and the least-squares one, which adds to the pixels' noise a systematic
error of each marking of each view as a whole (``systematic_px``): the paint
pixels of one line share its error (its centre on a compressed, blurred
picture), so the noise alone would understate it, and views alike leave
the jackknife near zero.

On real broadcast clips the tracker's own cameras at a wrong size are wrong
(they fit the near markings), so the views this estimate is made from are
too. :func:`choose_size` is the other way in, used by default on files
(:func:`arstream.pipeline.process`): a clip whose markings fit poorly at
105 x 68 (median line support below :data:`SCAN_BELOW`) is tracked again at
other sizes (the grid :data:`SCAN_LENGTHS` x :data:`SCAN_WIDTHS`, one step
from 105 x 68 along each axis, then one step from the best of those, or
both steps at once where each leans above 105 x 68: :func:`diagonal_step`), and
the size whose cameras lay the most of the markings on paint is kept when
it wins: by :data:`SCAN_MARGIN` on the medians, or frame by frame
throughout the clip (:func:`higher_throughout`).
Line support (docs/evaluate.md) needs no ground truth and judges a whole clip:
a wrong size leaves every view's far markings off their paint.

A still has one view: :func:`estimate_view_size` refines the size it
constrains from its camera at 105 x 68. Where that camera fits the
markings poorly (line support below :data:`SCAN_BELOW`), the still is
registered at the grid's sizes and :func:`choose_still_size` takes one by
comparing the sizes' cameras point for point: which lays more of the same
markings on the frame's paint (:func:`arstream.support.paint_dispute`;
:func:`arstream.initialise.size_from_scan`).

Frames: pitch frame as in ``geometry.pitch`` (metres, origin at the centre
spot); pixels of the views' frames.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from arstream.solve import LineIndex, ModelSamples
from arstream.support import SPACING, paint_dispute
from arstream.tripod import fit_tripod
from geometry.camera import Camera
from geometry.pitch import Arc, PitchModel

__all__ = ["PitchView", "PitchSize", "SizeScan", "estimate_pitch_size", "estimate_view_size", "VIEW_PRIOR_SD", "SIZE_MAX_SD", "SCAN_ASK_SD", "size_derivatives", "corresponding_samples", "needs_scan", "choose_size", "diagonal_step", "with_size", "on_frames", "paired_blocks", "higher_throughout", "SCAN_BELOW", "SCAN_MARGIN", "SCAN_BLOCK", "SCAN_TIE", "SCAN_MIN_BLOCKS", "SCAN_SIGN_LEVEL", "SCAN_LENGTHS", "SCAN_WIDTHS", "SCAN_MIN_FRAMES", "grid_neighbours", "choose_still_size", "still_scan_sizes", "size_dispute", "STILL_SUPPORTED", "STILL_GAIN_RATIO", "SCAN_GAIN_RATIO", "SCAN_DISPUTE_MARGIN", "paint_prefers", "corresponding_points", "compared_point_for_point"]

#: the sizes a broadcast pitch is searched within (Law 1's 90-120 x 45-90 m
#: narrowed to what a tracked camera can tell apart from a wrong fit)
LENGTH_RANGE = (95.0, 115.0)
WIDTH_RANGE = (58.0, 80.0)

#: a still's size (:func:`estimate_view_size`) before its view is seen: a
#: Gaussian about 105 x 68 m with these standard deviations (metres) of the
#: length and width. Top-level pitches are about 100-110 x 64-75 m (DESIGN.md
#: 5b), within 1.7 of them of 105 x 68
VIEW_PRIOR_SD = (3.0, 3.0)
#: a dimension of a still's size whose posterior standard deviation is over
#: this share of the prior's is not constrained by the view (the view gives
#: less than three quarters of what is then known of it) and keeps the
#: prior's value
VIEW_CONSTRAINS = 0.5
#: metres: the largest standard deviation of a dimension of a clip's size
#: estimated from its views for that dimension to be used
#: (:func:`estimate_pitch_size`'s ``max_sd``); a looser one keeps the prior's
SIZE_MAX_SD = 0.75
#: metres: the largest standard deviation of a dimension of the size a
#: clip's views estimate at 105 x 68 for that estimate to ask for a scan
#: (:func:`needs_scan`), the still's rule (:data:`VIEW_CONSTRAINS` of
#: :data:`VIEW_PRIOR_SD`). A size used is fixed tighter
#: (:data:`SIZE_MAX_SD`); one that only asks may be
#: looser, since the scan decides by the paint: a synthetic 106 x 74.5 m
#: pitch whose views (the centre circle with the far touchline) estimate the
#: width 72.7 +- 1.4 m was kept at 105 x 68, drawn 12.8 px off at the median,
#: and is scanned since (bench/README.md "Stop 68")
SCAN_ASK_SD = VIEW_CONSTRAINS * max(VIEW_PRIOR_SD)

#: a clip whose median line support at the default size is below this is
#: tracked again at other sizes (:func:`needs_scan`): a scan costs time, not
#: cameras (the default stays unless another size wins, :func:`choose_size`).
#: Clips of the right size score 0.98-1.00 on the shared real material at
#: 720p and 0.99-1.00 on the synthetic presets; a 99.85 m pitch tracked as
#: 105 m, 0.82; synthetic clips of other sizes 0.78-0.94. The realistic
#: presets (seeds 1-7 at their drawn sizes, 1-5 at 105 x 68; bench/README.md
#: "Stop 50") overlap: 105 x 68 0.955-0.995, other sizes 0.77-0.97 (3 of 28
#: at 0.95-0.97, 2-4 m off); 0.97 would scan 7 of the 20 at 105 x 68 too.
#: Two of those three are scanned since by their views' estimate (:func:`needs_scan`)
SCAN_BELOW = 0.95
#: how much higher another size's median line support must be to replace
#: the default (:func:`choose_size`): the same clip tracked at sizes that fit
#: it equally well differs by up to about 0.02 (israel_league_wide at 480p:
#: 0.860-0.876 at 100, 105 and 110 m), a size 5 m off by 0.15-0.18
SCAN_MARGIN = 0.05
#: the scan's paired test (:func:`higher_throughout`), the other way a size
#: wins: the clip cut into blocks of this many frames (a second at 25 fps)
#: and each size's line support compared frame by frame with the other's (a
#: frame one size's tracker gave no camera counts as none of its markings on
#: paint: :func:`paired_blocks`). The frames of a clip differ far more from
#: each other (views, paint, blur) than two sizes on one frame, so a size
#: that fits better by 0.01 on every frame can still lose to the margin on
#: the medians (``bench/README.md``, "Stop 50")
SCAN_BLOCK = 25
#: a block is for (against) a size when the median of its paired differences
#: is above (below) this; within it, a tie (the views do not tell the sizes
#: apart: a penalty view cannot see the pitch's length)
SCAN_TIE = 0.005
#: fewest blocks for a size, and the level of the one-sided sign test over
#: the blocks for and against it (ties left out), for the size to win
SCAN_MIN_BLOCKS = 5
SCAN_SIGN_LEVEL = 0.05
#: the lengths and widths a scan tries (metres): Law 1's international range
#: (100-110 x 64-75 m) on a grid of about its half-widths, 105 x 68 at the
#: centre (:func:`grid_neighbours`)
SCAN_LENGTHS = (100.0, 105.0, 110.0)
SCAN_WIDTHS = (64.0, 68.0, 72.0)
#: fewest frames with a camera for a median line support to go by
SCAN_MIN_FRAMES = 25
#: a still registered at the scan's grid (a camera at the default size with
#: a line support below :data:`SCAN_BELOW`: :func:`choose_still_size`)
#: takes another size only where that size's camera has at least this line
#: support (issue 29's target for a still): a size whose best camera leaves
#: a fifth of its markings off the paint fits the frame no better
STILL_SUPPORTED = 0.8
#: a size is higher than another on a still (:func:`choose_still_size`)
#: where, of the points of the markings in view of either size's camera that
#: the two lay on different places (:func:`arstream.support.paint_dispute`),
#: its camera lays at least this many times as many on paint as the other's,
#: and more by :data:`SCAN_MARGIN` of the points in view. The two cameras'
#: line supports are shares of different points: a wrong size can leave a
#: far marking out of the image, or share a blurred frame's misses, and score
#: higher (the realistic synthetic stills' scans: a camera 24 px off at 0.98
#: against the default's 0.93, which lays 57 of the disputed points on paint
#: to its 4; bench/README.md "Stop 55")
STILL_GAIN_RATIO = 2.0
#: the scan's third way a size wins (:func:`paint_prefers`): over the frames
#: both sizes' trackers gave a camera, of the points of the same markings in
#: view of both cameras that the two lay on different places
#: (:func:`arstream.support.paint_dispute` with ``in_both``), one size's
#: cameras lay at least this many times as many on paint as the other's, and
#: more by :data:`SCAN_DISPUTE_MARGIN` of the points in view. The medians
#: and the paired test compare shares of different points, each diluted by
#: the markings both sizes lay alike; the disputed points are the ones a
#: size changes (a 101.5 x 69 m penalty view: its estimate's cameras at
#: 0.970 against 105 x 68's 0.959, but 2460 disputed points on paint to
#: 511; ``bench/README.md``, "Stop 63")
SCAN_GAIN_RATIO = 2.0
#: see :data:`SCAN_GAIN_RATIO`. On the 20 realistic synthetic clips of a
#: 105 x 68 m pitch (seeds 1-5 of the four presets) no grid neighbour gains
#: more than 0.0002 of the points in view on the default (most lose 0.01-0.25);
#: on clips of other sizes, sizes nearer the truth than 105 x 68 gain
#: 0.006-0.10 (``bench/README.md``, "Stop 63")
SCAN_DISPUTE_MARGIN = 0.005


@dataclass(frozen=True)
class PitchView:
    """One frame for the size estimate.

    Attributes
    ----------
    camera : Camera, the frame's camera under the prior size (frame pixels)
    points : (M, 2) float64, the frame's line (paint) pixel centres
    size : (width, height) of the frame, pixels
    """

    camera: Camera
    points: np.ndarray
    size: tuple[int, int]


@dataclass(frozen=True)
class PitchSize:
    """A pitch size and where it comes from.

    Attributes
    ----------
    length, width : metres
    length_sd, width_sd : standard deviations (metres) of an estimated
        dimension; None where the size was given, or the views did not fix that
        dimension (then it is the prior's)
    source : "given", "default" (nothing estimated yet), "estimated" or
        "scanned" (chosen by :func:`choose_size`)
    views : number of views the estimate used (frames the scan judged by)
    centre : (3,) metres, the tripod centre refined with it (None unless estimated)
    cameras : the views' cameras refined with it (empty unless estimated)
    rms : px, RMS of the inlier residuals of the fit (None unless estimated)
    """

    length: float
    width: float
    length_sd: float | None = None
    width_sd: float | None = None
    source: str = "default"
    views: int = 0
    centre: np.ndarray | None = None
    cameras: tuple = ()
    rms: float | None = None
    scan: "SizeScan | None" = None

    def model(self, line_width: float | None = None) -> PitchModel:
        """The :class:`PitchModel` of this size."""
        return PitchModel(self.length, self.width) if line_width is None else PitchModel(self.length, self.width, line_width)

    def within_noise(self, size) -> bool:
        """Whether this size lies within two of its standard deviations of
        ``size`` (length, width) along each dimension (one without a standard
        deviation must equal it): no other size than ``size`` to judge."""
        for v, sd, ref in ((self.length, self.length_sd, size[0]), (self.width, self.width_sd, size[1])):
            if abs(v - ref) > (2.0 * sd if sd is not None else 1e-9):
                return False
        return True

    @property
    def constrained(self) -> tuple[bool, bool]:
        """Whether the views fixed the length, the width."""
        return self.length_sd is not None, self.width_sd is not None

    def describe(self) -> str:
        """One line for a run's summary, e.g. ``pitch 99.8 +- 0.4 x 68.0 m (estimated
        from 6 views; width not constrained: 68 kept)``."""

        def dim(v, sd):
            return f"{v:.1f}" if sd is None else f"{v:.1f} +- {sd:.1f}"

        s = f"pitch {dim(self.length, self.length_sd)} x {dim(self.width, self.width_sd)} m"
        if self.source == "given":
            return s + " (given)"
        if self.source == "default":
            return s + " (default" + (f"; {self.scan.describe()}" if self.scan is not None else "") + ")"
        if self.source == "scanned":
            return s + f" ({self.scan.describe()})"
        kept = [n for n, c in zip(("length", "width"), self.constrained) if not c]
        tail = f"; {' and '.join(kept)} not constrained by the view{'s' if self.views != 1 else ''}: default kept" if kept else ""
        if self.scan is not None:
            L, W = self.scan.size
            if L not in SCAN_LENGTHS or W not in SCAN_WIDTHS:
                # (no grid size won; the estimate from the default's views was judged against them)
                L, W = self.scan.sizes[0]
            tail += f"; from {_metres(L)} x {_metres(W)}, {self.scan.describe()}"
        return s + f" (estimated from {self.views} view{'s' if self.views != 1 else ''}{tail})"

    def to_dict(self) -> dict:
        """JSON-ready: length, width, their sd (null where not estimated), source,
        views, and the scan's figures where there was one (:meth:`SizeScan.to_dict`)."""
        r = lambda v: None if v is None else round(float(v), 3)  # noqa: E731
        out = {"length": r(self.length), "width": r(self.width), "length_sd": r(self.length_sd), "width_sd": r(self.width_sd), "source": self.source, "views": self.views}
        if self.scan is not None:
            out["scan"] = self.scan.to_dict()
        return out


@dataclass(frozen=True)
class SizeScan:
    """One clip tracked at several pitch sizes, judged by line support.

    Attributes
    ----------
    sizes : tuple of (length, width) in metres, the default's first
    median : tuple of float or None, each size's median line support over
        the frames it gave a camera (None: fewer than :data:`SCAN_MIN_FRAMES`)
    coverage : tuple of float, each size's share of the frames with a camera
    frames : frames tracked at each size
    chosen : index into ``sizes`` of the size kept
    supports : per size, the line support of each frame (None: no camera),
        what the choice was made on (:func:`with_size` adds a size to it)
    point_for_point : the sizes' cameras were compared point for point on
        the paint (a still: :func:`choose_still_size`), not by their supports
    disputes : {(size_a, size_b): PaintDispute} summed over the frames both
        sizes gave a camera (``first`` counts for ``size_a``), the scan's
        point-for-point comparison of two sizes' cameras (:func:`paint_prefers`)
    cameras : per size, the camera of each frame (None: no camera), on the
        frame's pixels, for judging another size against them later
        (:func:`arstream.pipeline.pitch_scan.check_size`)
    fine : per size, the on-paint share of each frame (None: no camera; a
        size without them: None), the line support on the bright pixels
        themselves (:func:`choose_size`'s ``fine``)
    """

    sizes: tuple
    median: tuple
    coverage: tuple
    frames: int
    chosen: int
    supports: tuple = field(default=(), repr=False, compare=False)
    point_for_point: bool = False
    disputes: dict = field(default_factory=dict, repr=False, compare=False)
    cameras: tuple = field(default=(), repr=False, compare=False)
    fine: tuple = field(default=(), repr=False, compare=False)

    @property
    def size(self) -> tuple[float, float]:
        return self.sizes[self.chosen]

    def describe(self) -> str:
        """e.g. ``chosen by line support on 176 frames: 100 x 68 0.99, 105 x 68 0.82, 110 x 68 0.93``,
        or a still's ``kept by the paint point for point on 1 frame (line support 100 x 68 0.90, ...)``."""
        parts = ", ".join(f"{_metres(L)} x {_metres(W)} {'-' if m is None else f'{m:.2f}'}" for (L, W), m in sorted(zip(self.sizes, self.median)))
        verb = "kept" if self.chosen == 0 else "chosen"
        frames = f"{self.frames} frame{'s' if self.frames != 1 else ''}"
        if self.point_for_point:
            return f"{verb} by the paint point for point on {frames} (line support {parts})"
        return f"{verb} by line support on {frames}: {parts}"

    def to_dict(self) -> dict:
        r = lambda v: None if v is None else round(float(v), 3)  # noqa: E731
        return {"sizes": [[float(L), float(W)] for L, W in self.sizes], "median_support": [r(m) for m in self.median], "coverage": [r(c) for c in self.coverage], "frames": self.frames, "chosen": self.chosen}


def _metres(v: float) -> str:
    """A size in metres to the decimetre, without a trailing ``.0`` (``105``, ``106.6``)."""
    return f"{v:.1f}".rstrip("0").rstrip(".")


def _median(supports, min_frames: int = SCAN_MIN_FRAMES) -> float | None:
    """Median of the defined values of ``supports``; None with fewer than ``min_frames``."""
    v = [float(x) for x in supports if x is not None and np.isfinite(x)]
    return float(np.median(v)) if len(v) >= max(1, int(min_frames)) else None


def needs_scan(supports, min_frames: int = SCAN_MIN_FRAMES, seen: "PitchSize | None" = None, default=None) -> bool:
    """Whether a clip tracked at the default size should be tracked at others:
    its median line support (over the frames with a camera; ``supports`` one
    value per judged frame, None for a frame without one) is below
    :data:`SCAN_BELOW`, over at least ``min_frames`` frames; or, over as
    many, the size its own views estimate (``seen``: the tracker's
    :meth:`arstream.track.Tracker.pitch_seen`, its views made at
    ``default``, with ``max_sd`` :data:`SCAN_ASK_SD`) lies beyond two of its
    standard deviations of ``default`` along a dimension the views fix
    (:meth:`PitchSize.within_noise`). A
    pitch a few metres off can keep nearly all its markings near paint (a
    101 x 68 m pitch tracked at 105 x 68 at a median of 0.95), while the
    views, fitted together about one tripod, tell its size; on clips of a
    105 x 68 m pitch they estimate it within 0.15 m, half a standard
    deviation (bench/README.md "Stop 57"). The scan then decides
    (:func:`choose_size`): the estimate only asks. ``default``: (length,
    width), None for :class:`geometry.pitch.PitchModel`'s."""
    m = _median(supports, min_frames)
    if m is None:
        return False
    if default is None:
        p = PitchModel()
        default = (p.length, p.width)
    return m < SCAN_BELOW or (seen is not None and seen.source == "estimated" and not seen.within_noise(default))


def grid_neighbours(size) -> list[tuple[float, float]]:
    """The sizes one step from ``size`` (length, width) along either axis of the
    scan's grid (:data:`SCAN_LENGTHS` x :data:`SCAN_WIDTHS`), lengths first;
    ``size`` must be on the grid."""
    L, W = (float(v) for v in size)
    if L not in SCAN_LENGTHS or W not in SCAN_WIDTHS:
        raise ValueError(f"{L:g} x {W:g} m is not on the scan's grid ({SCAN_LENGTHS} x {SCAN_WIDTHS})")
    i, j = SCAN_LENGTHS.index(L), SCAN_WIDTHS.index(W)
    out = [(SCAN_LENGTHS[k], W) for k in (i - 1, i + 1) if 0 <= k < len(SCAN_LENGTHS)]
    return out + [(L, SCAN_WIDTHS[k]) for k in (j - 1, j + 1) if 0 <= k < len(SCAN_WIDTHS)]


def paired_blocks(base, other, block: int = SCAN_BLOCK) -> tuple[int, int]:
    """How many blocks of the clip back ``other``'s cameras more than ``base``'s.

    Parameters
    ----------
    base, other : sequences of the same frames, a line support per frame
        (None where that size's tracker gave no camera)
    block : frames per block (:data:`SCAN_BLOCK`)

    Returns
    -------
    (for, against): blocks of ``block`` consecutive frames, of which at least
    two fifths have a camera at either size, whose median of ``other`` minus
    ``base`` over those frames is above :data:`SCAN_TIE` (for) or below
    minus it (against). A frame where only one size's tracker gave a camera
    counts that camera's line support against none (0): the paint backs no
    marking of a camera not given, and a size whose tracker loses the view
    where the other's follows it on paint fits those frames worse, not
    unknown (a 108 x 64.5 m pitch tracked at 105 x 68 loses two seconds of
    a pan that the size its views estimate follows at 0.9; with those
    frames left out it won 4 blocks to none, one short;
    ``bench/README.md`` "Stop 68").
    """
    if len(base) != len(other):
        raise ValueError(f"both sizes' supports must be of the same frames: {len(base)} and {len(other)}")
    pro = con = 0
    for s in range(0, len(base), block):
        d = [(0.0 if y is None else float(y)) - (0.0 if x is None else float(x)) for x, y in zip(base[s : s + block], other[s : s + block]) if x is not None or y is not None]
        if len(d) >= 0.4 * block:
            m = float(np.median(d))
            pro += m > SCAN_TIE
            con += m < -SCAN_TIE
    return pro, con


def higher_throughout(base, other, *, unanimous: bool = False) -> bool:
    """Whether the paint backs ``other``'s cameras more than ``base``'s
    throughout the clip, not only in the median: at least
    :data:`SCAN_MIN_BLOCKS` blocks for it (:func:`paired_blocks`) and a
    one-sided sign test over the blocks for and against at
    :data:`SCAN_SIGN_LEVEL` (e.g. 5 for and none against, 7 for and one
    against). The blocks are not independent (the tracker carries its
    tripod centre from one to the next), so the level is nominal: on 20
    realistic synthetic clips of a 105 x 68 m pitch no neighbour of it had
    more than 2 blocks for (``bench/README.md``, "Stop 50").

    ``unanimous``: and no block against it, how the scan reads the on-paint
    share (:func:`choose_size`). That share is not saturated, so a size
    that fits better lays more of its markings on the paint in every view
    that tells the two apart; one that trades with the view (a long lens's
    length against its distance) wins some blocks and loses others, and
    by a sign test over dependent blocks can win many: ``israel_league_wide``
    (105 x 68 m) tracked at 110 x 68 wins 13 blocks to 2, and its
    re-encoded copies 4 to 4, 6 to 4 and 6 to 10; its 480p copy from frame
    60 at 105 x 72, 10 to 3. The synthetic clips the share settles right win
    8 to 0, 7 to 0 and 5 to 0 (``bench/README.md``, "Stop 73").

    >>> base = [0.80] * 200
    >>> higher_throughout(base, [0.82] * 175 + [0.79] * 25)  # 7 blocks for, 1 against
    True
    >>> higher_throughout(base, [0.82] * 175 + [0.79] * 25, unanimous=True)
    False
    """
    from scipy.stats import binomtest

    pro, con = paired_blocks(base, other)
    if unanimous and con:
        return False
    return bool(pro >= SCAN_MIN_BLOCKS and binomtest(pro, pro + con, 0.5, alternative="greater").pvalue <= SCAN_SIGN_LEVEL)


def leans_above(base, other, dispute=None, margin: float = 0.0) -> bool:
    """Whether the clip's paint leans towards ``other``'s cameras over
    ``base``'s: more blocks for it than against (:func:`paired_blocks`), or
    more of the disputed points on paint (``dispute``, as for
    :func:`paint_prefers`; with ``margin``, more by that share of the points
    in view), the weakest signs the scan reads (a neighbour that leans the
    same way as its mirror leaves the dimension open; :func:`choose_size`,
    :func:`diagonal_step`).

    Parameters
    ----------
    base, other : sequences of the same frames, a line support per frame
        (None where that size's tracker gave no camera)
    dispute : optional PaintDispute of ``base``'s cameras against ``other``'s
    margin : share of the points in view by which ``other`` must lay more of
        the disputed points on paint (0: any more)

    >>> from arstream.support import PaintDispute
    >>> leans_above([0.9] * 50, [0.9] * 50, PaintDispute(1117, 1196, 28154, 40899))  # 79 more points on paint
    True
    >>> leans_above([0.9] * 50, [0.9] * 50, PaintDispute(1117, 1196, 28154, 40899), margin=SCAN_DISPUTE_MARGIN)  # 0.2 % of the points in view: a tie
    False
    """
    pro, con = paired_blocks(base, other)
    return pro > con or (dispute is not None and dispute.second - dispute.first > margin * max(dispute.in_view, 0))


def paint_prefers(dispute) -> bool:
    """Whether the paint backs the second of two sizes' cameras over the
    first, point for point: ``dispute`` (a PaintDispute of the first against
    the second, over the frames both gave a camera, counting the points in
    view of both) has the second lay at least :data:`SCAN_GAIN_RATIO` times
    as many of the disputed points on paint as the first, and more of them by
    :data:`SCAN_DISPUTE_MARGIN` of the points in view.

    >>> from arstream.support import PaintDispute
    >>> paint_prefers(PaintDispute(511, 2460, 48114, 180000))  # 4.8 times as many, 0.011 of the points
    True
    >>> paint_prefers(PaintDispute(220, 1419, 25983, 400000))  # 6.5 times as many, but 0.003 of the points
    False
    """
    if dispute is None or dispute.in_view <= 0:
        return False
    return dispute.second >= SCAN_GAIN_RATIO * dispute.first and dispute.second - dispute.first >= SCAN_DISPUTE_MARGIN * dispute.in_view


def _dispute(disputes, a, b):
    """The dispute of size ``a``'s cameras against ``b``'s (``first`` for ``a``) from a scan's ``disputes``; None if not compared."""
    if (a, b) in disputes:
        return disputes[(a, b)]
    if (b, a) in disputes:
        return disputes[(b, a)].swapped()
    return None


def choose_size(sizes, supports, disputes=None, fine=None) -> SizeScan:
    """The size whose cameras the clip's paint backs best.

    Parameters
    ----------
    sizes : sequence of (length, width), the default's first
    supports : one sequence per size, a line support per frame (None where
        that size's tracker gave no camera), all of the same frames
    disputes : optional {(size_a, size_b): PaintDispute} (as
        :attr:`SizeScan.disputes`), pairs of the sizes' cameras compared
        point for point on the same frames
    fine : optional, one sequence per size (or None for a size without
        them) of each frame's on-paint share: the line support on the bright
        pixels themselves, not dilated (``frame_mask(frame, reach=0)``)

    Returns
    -------
    SizeScan. A size is *higher* than another when its median line support
    is higher by :data:`SCAN_MARGIN`, or, its median not lower by the
    margin, when the paint backs it more frame by frame throughout the clip
    (:func:`higher_throughout`), on the paint itself
    (:func:`higher_throughout` of the ``fine`` shares, ``unanimous``: no
    block against it) or point for point
    (:func:`paint_prefers`, where the two were compared: a wrong size's
    cameras can lay the points they dispute on another sport's bright
    lines, a synthetic SD clip's 100 x 72 at 0.79 against 105 x 72's 0.88);
    and never, within the margin, when the other's on-paint share is higher
    throughout. The 2 px support saturates within the grid's step (a
    105.5 x 71.5 m pitch: 105 x 72 0.986 against 105 x 68's 0.978, 1
    block for, none against), the on-paint share does not (0.951 against
    0.900, higher on 98 % of the frames);
    against the default, a size higher by one of the last two alone also
    needs the size on the other side of the default along that dimension not
    to lean the same way (:func:`leans_above`: more blocks for it than
    against, or more of the disputed points on paint by
    :data:`SCAN_DISPUTE_MARGIN` of the points in view: a long lens's views
    that cannot tell 100 from 110 m favour both a little; fewer are a tie,
    and hold no win back: a 480-row copy of the artificial-turf clip's
    penalty-area view, 100 x 68 laying 4504 of the points it disputes with
    105 x 68 on paint to 1769, 110 x 68 1196 to 1117, 0.2 % of its points
    in view). Another
    size replaces the default only when it is higher than the default on a
    coverage no lower by more than 5 points (a size that finds cameras on
    fewer frames is not a better fit for scoring only its easy ones), and
    only when the default has a median itself (the scan's trackers followed
    the clip). A dimension along which a smaller and a larger size are both
    higher than the default, with medians within :data:`SCAN_MARGIN` of each
    other, is inconclusive (a pitch is not both shorter and longer: the
    clip's support does not tell its sizes apart, e.g. a low-resolution clip
    of long-lens views; each of the two on a coverage no lower than the
    default's by more than 5 points: a wrong length on a penalty view that
    pans to the halfway line scores 0.92 on the 89 % of the frames it keeps,
    the right one 0.92 on all of them, a 480-row copy of the artificial-turf
    clip from its frame 120), and no size that changes it is chosen; unless a
    size on one side (of any width, for the length: the estimate from the
    views, between the grid's points) has a median above every one of those
    on the other side by the margin, which tells the side (a 100.5 x 67 m
    pitch: 100 x 68 0.94 and 110 x 68 0.92 over 105 x 68's 0.87, its
    views' 101.2 x 67.1 0.99). Of the sizes
    left, the nearest to the default on the grid (fewest dimensions changed;
    of those, the highest median) is taken, and a farther one replaces it
    only when it is higher than that one too: a size two steps off must
    beat the one step off on the clip's evidence, not on a median within the
    noise (a penalty view's 100, 105 and 110 m lengths alike).
    """
    sizes = tuple((float(L), float(W)) for L, W in sizes)
    disputes = {} if disputes is None else {(tuple(map(float, a)), tuple(map(float, b))): v for (a, b), v in disputes.items()}
    if len(supports) != len(sizes) or not sizes:
        raise ValueError(f"one list of supports per size: {len(sizes)} sizes, {len(supports)} lists")
    frames = len(supports[0])
    if any(len(s) != frames for s in supports):
        raise ValueError("every size's supports must be of the same frames")
    med = tuple(_median(s) for s in supports)
    cov = tuple(float(np.mean([x is not None for x in s])) if frames else 0.0 for s in supports)
    d = sizes[0]
    fine = [None] * len(sizes) if fine is None else [None if f is None else list(f) for f in fine]
    if len(fine) != len(sizes) or any(f is not None and len(f) != frames for f in fine):
        raise ValueError("the on-paint shares (fine) must be one list per size (or None), of the supports' frames")

    def on_paint_throughout(j: int, k: int, unanimous: bool = False) -> bool:
        # (the share of the points on the paint itself, paired frame by frame: the
        # 2 px support saturates within the grid's step, this does not)
        return fine[j] is not None and fine[k] is not None and higher_throughout(fine[j], fine[k], unanimous=unanimous)

    def higher(j: int, k: int) -> bool:
        # (a size without a median, its tracker lost on most frames, is no
        # baseline: the scan's trackers cannot follow this clip there)
        # (the paired test and the point-for-point one settle sizes whose medians are within the
        # margin; they do not overturn a median lower by more: a wrong size's cameras can lay the
        # points they dispute on bright lines of another sport)
        if med[j] is None or med[k] is None:
            return False
        if med[k] >= med[j] + SCAN_MARGIN:
            return True
        if med[k] <= med[j] - SCAN_MARGIN:
            return False
        if on_paint_throughout(k, j):
            return False  # (the paint itself backs j's cameras throughout)
        return higher_throughout(supports[j], supports[k]) or paint_prefers(_dispute(disputes, sizes[j], sizes[k])) or on_paint_throughout(j, k, unanimous=True)

    def opposite(k: int) -> int | None:
        # (the size on the other side of the default along the one dimension k changes)
        axes = [a for a in (0, 1) if sizes[k][a] != d[a]]
        if len(axes) != 1:
            return None
        a = axes[0]
        mirror = tuple(2 * d[a] - sizes[k][a] if b == a else d[b] for b in (0, 1))
        return sizes.index(mirror) if mirror in sizes else None

    def up(k: int) -> bool:
        if not higher(0, k):
            return False
        if med[k] >= med[0] + SCAN_MARGIN:
            return True
        o = opposite(k)
        # (the mirror's disputed points count as a lean beyond the margin a win needs
        # (paint_prefers): fewer are a tie, which holds no win back)
        return o is None or med[o] is None or not leans_above(supports[0], supports[o], _dispute(disputes, d, sizes[o]), SCAN_DISPUTE_MARGIN)

    up = [k > 0 and up(k) for k in range(len(sizes))]
    open_axes = []
    for a in (0, 1):
        # (as for a choice, a size on fewer frames than the default's by more than
        # 5 points scored only its easy ones: a wrong length on a penalty view that
        # pans to the halfway line loses the frames that refute it)
        along = [k for k in range(1, len(sizes)) if up[k] and sizes[k][1 - a] == d[1 - a] and cov[k] >= cov[0] - 0.05]
        lo = [med[k] for k in along if sizes[k][a] < d[a]]
        hi = [med[k] for k in along if sizes[k][a] > d[a]]

        def beyond(side: float, top: float, a: int = a) -> bool:
            # (a size on ``side`` of the default along ``a``, of any other dimension, above ``top`` by the margin)
            return any(up[k] and np.sign(sizes[k][a] - d[a]) == side and med[k] >= top + SCAN_MARGIN for k in range(1, len(sizes)))

        if lo and hi and abs(max(lo) - max(hi)) < SCAN_MARGIN and not (beyond(-1.0, max(hi)) or beyond(1.0, max(lo))):
            open_axes.append(a)
    changed = lambda k: sum(sizes[k][a] != d[a] for a in (0, 1))  # noqa: E731
    left = [k for k in range(1, len(sizes)) if up[k] and cov[k] >= cov[0] - 0.05 and all(sizes[k][a] == d[a] for a in open_axes)]
    chosen = 0
    for k in sorted(left, key=lambda k: (changed(k), -med[k])):
        if chosen == 0 or (changed(k) > changed(chosen) and higher(chosen, k)):
            chosen = k
    return SizeScan(sizes, med, cov, frames, chosen, tuple(list(x) for x in supports), disputes=disputes, fine=tuple(fine))


def choose_still_size(sizes, supports, dispute) -> SizeScan:
    """The size whose camera a still's paint backs best (one frame registered
    at each size; :func:`choose_size` is the clip's rule).

    One frame has no medians or blocks to compare. Its sizes' cameras are
    compared point for point instead, on the same samples of the same
    markings (``dispute``): a size is *higher* than another when its camera
    lays at least :data:`STILL_GAIN_RATIO` times as many of the points the
    two dispute on paint as the other's does, and more of them by
    :data:`SCAN_MARGIN` of the points in view of either; the points the
    other's camera draws on bare grass, of a marking missing there that
    this one's draws wholly outside the picture, count for it too
    (:attr:`arstream.support.PaintDispute.for_second`, with the ``dispute``'s
    ``ground``: :func:`size_dispute`). A size may replace
    the default when its camera fits the frame (line support at least
    :data:`STILL_SUPPORTED`) and is higher than the default's (a default
    without a camera is kept: no baseline). Of those sizes, the nearest to it
    on the grid (fewest dimensions changed; of those, the highest support) is
    taken, and a farther one replaces it only when it is higher than that one
    too: sizes the view does not tell apart (a penalty view's 100, 105 and
    110 m) dispute few points, and the nearest to the default is the likelier.

    Parameters
    ----------
    sizes : sequence of (length, width) metres, the default's first
    supports : the still's line support at each size (docs/evaluate.md; None:
        no camera there); the default's is its camera's after the size
        estimated from it (:func:`arstream.initialise.size_from_scan`)
    dispute : callable ``(j, k) -> PaintDispute``, the cameras of sizes ``j``
        and ``k`` on the frame's paint (:func:`arstream.support.paint_dispute`);
        called only for sizes with a camera

    Returns
    -------
    SizeScan with ``frames`` 1 (``median`` the supports, ``coverage`` 1 or 0
    a size).

    >>> from arstream.support import PaintDispute
    >>> grid = [(105.0, 68.0), (105.0, 72.0)]
    >>> choose_still_size(grid, [0.93, 0.96], lambda j, k: PaintDispute(10, 40, 60, 500)).chosen  # the other lays 40 of the disputed points on paint, the default 10
    1
    >>> choose_still_size(grid, [0.93, 0.98], lambda j, k: PaintDispute(57, 4, 70, 900)).chosen  # higher support, but the default lays 57 of the disputed points to its 4
    0
    """
    sizes = tuple((float(L), float(W)) for L, W in sizes)
    if len(supports) != len(sizes) or not sizes:
        raise ValueError(f"one support per size: {len(sizes)} sizes, {len(supports)} supports")
    s = tuple(None if v is None or not np.isfinite(v) else float(v) for v in supports)
    d = sizes[0]

    def higher(j: int, k: int) -> bool:
        # (k lays at least twice as many of the disputed points on paint as j, and more by the margin)
        if s[j] is None or s[k] is None:
            return False
        p = dispute(j, k)
        return p.for_second >= STILL_GAIN_RATIO * p.for_first and p.for_second - p.for_first >= SCAN_MARGIN * p.in_view

    def up(k: int) -> bool:
        # (the scan's camera must itself fit the frame; a default without a
        # camera is no baseline: another size's camera is then no evidence)
        return s[k] is not None and s[k] >= STILL_SUPPORTED and higher(0, k)

    changed = lambda k: sum(sizes[k][a] != d[a] for a in (0, 1))  # noqa: E731
    chosen = 0
    for k in sorted((k for k in range(1, len(sizes)) if up(k)), key=lambda k: (changed(k), -s[k])):
        if chosen == 0 or (changed(k) > changed(chosen) and higher(chosen, k)):
            chosen = k
    return SizeScan(sizes, s, tuple(float(v is not None) for v in s), 1, chosen, tuple([v] for v in s), point_for_point=True)


def still_scan_sizes(pitch: PitchModel) -> list[tuple[float, float]]:
    """The sizes a still's scan registers it at (:func:`arstream.initialise.size_from_scan`):
    ``pitch``'s (the default) first, then the grid's others
    (:data:`SCAN_LENGTHS` x :data:`SCAN_WIDTHS`), lengths first.

    >>> still_scan_sizes(PitchModel())[:3]
    [(105.0, 68.0), (100.0, 64.0), (100.0, 68.0)]
    """
    d = (float(pitch.length), float(pitch.width))
    return [d] + [(L, W) for L in SCAN_LENGTHS for W in SCAN_WIDTHS if (L, W) != d]


def size_dispute(cameras, pitches, mask: np.ndarray, *, in_both: bool = False, ground: np.ndarray | None = None):
    """The ``dispute`` of :func:`choose_still_size` for one still: camera
    ``j`` at pitch ``j`` against camera ``k`` at pitch ``k`` on the frame's
    paint, on the same samples of the same markings
    (:func:`corresponding_samples`, :func:`arstream.support.paint_dispute`).

    Parameters
    ----------
    cameras : sequence of Camera (None where a size gave none), one per size
    pitches : sequence of PitchModel, the size each camera was made at
    mask : (H, W) bool, :func:`arstream.support.bright_mask` of the frame's luma
    in_both : only the points in view of both cameras (a clip's scan; as
        :func:`arstream.support.paint_dispute`)
    ground : (H, W) bool or None, the frame's bare grass: markings one
        camera draws there, missing, that the other draws wholly outside the
        picture count against it (:func:`arstream.support.paint_dispute`)

    Returns
    -------
    callable ``(j, k) -> PaintDispute``
    """

    def dispute(j: int, k: int):
        pj, pk = corresponding_points(pitches[j], pitches[k])
        ids = None if ground is None else ModelSamples.from_pitch(pitches[j], SPACING).marking
        return paint_dispute(cameras[j], pj, cameras[k], pk, mask, in_both=in_both, ground=ground, markings=ids)

    return dispute


def diagonal_step(scan: SizeScan) -> tuple[float, float] | None:
    """The size one grid step from the default along *each* dimension that a
    scan's first pass points to when no single step won
    (:func:`choose_size` kept the default; :func:`grid_neighbours`).

    Along each dimension, the one neighbour of the default that leans above
    it: a higher median line support and more blocks for it than against
    (:func:`paired_blocks`) or more of the disputed points on paint
    (:func:`leans_above`), while the neighbour on the other side does not
    lean so (both leaning: the dimension is open). A pitch off along both
    dimensions moves each one-step neighbour only part of the way, and
    neither may clear :func:`choose_size`'s bar on its own: a synthetic
    clip of a 110 x 64.5 m pitch (``real-wide`` seed 22) scores 0.82 at
    105 x 68, 0.86 at 110 x 68 (6 blocks for, 1 against) and 0.87 at
    105 x 64 (4 for, 3 against), and 0.94 at 110 x 64 (8 for, none
    against). The diagonal is then tracked and judged by the same rule as
    any size.

    Parameters
    ----------
    scan : SizeScan of the default (first) and its grid neighbours, with
        their supports (:func:`choose_size`)

    Returns
    -------
    (length, width) or None when a dimension has no such neighbour, the
    default has no median, or the scan chose another size
    """
    if scan.chosen != 0 or scan.median[0] is None or not scan.supports:
        return None
    d, med = scan.sizes[0], scan.median
    step = []
    for a in (0, 1):
        lean = []
        for k in range(1, len(scan.sizes)):
            s = scan.sizes[k]
            if s[1 - a] != d[1 - a] or s[a] == d[a] or med[k] is None:
                continue
            if med[k] > med[0] and leans_above(scan.supports[0], scan.supports[k], _dispute(scan.disputes, d, s)):
                lean.append(s[a])
        if len(lean) != 1:
            return None
        step.append(lean[0])
    return (step[0], step[1])


def on_frames(per_frame, frames: int) -> list:
    """A scan pass's per-frame values (line supports, on-paint shares or
    cameras) on ``frames`` frames: cut there, or padded with None (no camera)
    where the pass's trackers stopped sooner (:attr:`SizeScanStage.gave_up`
    of :mod:`arstream.pipeline.pitch_scan`).

    >>> on_frames([0.9, 0.8], 4)
    [0.9, 0.8, None, None]
    >>> on_frames([0.9, 0.8, 0.7], 2)
    [0.9, 0.8]
    """
    per_frame = list(per_frame)[:frames]
    return per_frame + [None] * (frames - len(per_frame))


def with_size(scan: SizeScan, size, supports, disputes=None, cameras=None, fine=None) -> SizeScan:
    """The choice made again with one more size (:func:`choose_size` over
    ``scan``'s sizes and ``size``): e.g. the size estimated from the
    default's own views, judged as the grid's sizes were.

    Parameters
    ----------
    scan : SizeScan with its supports
    size : (length, width) in metres
    supports : ``size``'s line support per frame of the scan's frames (a
        shorter list, whose tracker stopped, counts the rest as no camera)
    disputes : optional {(size_a, size_b): PaintDispute} of ``size``'s
        cameras against the scan's sizes' (:attr:`SizeScan.disputes`)
    cameras : optional, ``size``'s camera per frame (kept with the scan's)
    fine : optional, ``size``'s on-paint share per frame (as ``supports``;
        :attr:`SizeScan.fine`)
    """
    if len(scan.supports) != len(scan.sizes):
        raise ValueError("the scan carries no supports to judge another size against")

    old_fine = list(scan.fine) if len(scan.fine) == len(scan.sizes) else [None] * len(scan.sizes)
    got = choose_size(tuple(scan.sizes) + (tuple(float(v) for v in size),), tuple(scan.supports) + (on_frames(supports, scan.frames),), {**scan.disputes, **(disputes or {})}, fine=old_fine + [None if fine is None else on_frames(fine, scan.frames)])
    if scan.cameras and cameras is not None:
        got = dataclasses.replace(got, cameras=tuple(scan.cameras) + (tuple(cameras),))
    return got


def size_derivatives(pitch: PitchModel, model: ModelSamples) -> tuple[np.ndarray, np.ndarray]:
    """How each model sample moves with the pitch's length and width.

    Law 1 fixes the areas, arcs and circle; only where they sit depends on
    the size: the goal lines and everything drawn from them move with half
    the length, the touchlines with half the width, and a segment's sample
    at fraction ``s`` of its length moves as its ends do, linearly.

    Parameters
    ----------
    pitch : PitchModel the samples were taken from
    model : ModelSamples of ``pitch``

    Returns
    -------
    dL, dW : (N, 3) float64, d(point)/d(length) and d(point)/d(width) (Z = 0)
    """
    L, W = pitch.length, pitch.width
    dl = 1.0 if L + 1.0 <= 120.0 else -1.0
    dw = 1.0 if W + 1.0 <= 90.0 and W + 1.0 < L else -1.0
    pl, pw = PitchModel(L + dl, W, pitch.line_width), PitchModel(L, W + dw, pitch.line_width)
    dL = np.zeros_like(model.points)
    dW = np.zeros_like(model.points)
    for k, name in enumerate(model.names):
        sel = model.marking == k
        m0 = pitch[name]
        for other, step, out in ((pl, dl, dL), (pw, dw, dW)):
            m1 = other[name]
            if isinstance(m0, Arc):
                out[sel, :2] = (np.subtract(m1.center, m0.center)) / step
                continue
            a0, b0 = np.asarray(m0.start), np.asarray(m0.end)
            da = (np.asarray(m1.start) - a0) / step
            db = (np.asarray(m1.end) - b0) / step
            d = b0 - a0
            s = np.clip((model.points[sel, :2] - a0) @ d / max(d @ d, 1e-12), 0.0, 1.0)[:, None]
            out[sel, :2] = (1 - s) * da + s * db
    return dL, dW


def corresponding_samples(pitch: PitchModel, other: PitchModel, spacing: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
    """The markings of ``pitch`` sampled every ``spacing`` metres, and the same
    points of the same markings on a pitch of ``other``'s size.

    A sample at fraction ``s`` along a line goes to fraction ``s`` along the
    same line of ``other``; a sample of an arc keeps its angle about the
    arc's moved centre (Law 1 fixes the radii). The markings move linearly
    with the size (:func:`size_derivatives`), so this is exact. Used to
    judge a camera made at one size against one made at another, marking for
    marking: where each draws the same painted line.

    Parameters
    ----------
    pitch, other : PitchModel (their line widths are not used)
    spacing : metres between samples along ``pitch``'s markings

    Returns
    -------
    points, moved : (N, 2) float64, pitch frame (metres); ``points`` are
        ``pitch.sample_points(spacing)``, in its order
    """
    model = ModelSamples.from_pitch(pitch, spacing)
    points = model.points[:, :2].copy()
    if (other.length, other.width) == (pitch.length, pitch.width):
        return points, points.copy()
    dL, dW = size_derivatives(pitch, model)
    return points, points + dL[:, :2] * (other.length - pitch.length) + dW[:, :2] * (other.width - pitch.width)


def corresponding_points(pitch: PitchModel, other: PitchModel, spacing: float = SPACING) -> tuple[np.ndarray, np.ndarray]:
    """:func:`corresponding_samples` on the pitch plane: (N, 3) float64 each,
    pitch frame (metres, Z = 0), ready to project."""
    a, b = corresponding_samples(pitch, other, spacing)
    z = np.zeros((len(a), 1))
    return np.hstack([a, z]), np.hstack([b, z])


def compared_point_for_point(a, b, default=None) -> bool:
    """Whether :func:`choose_size` (and :func:`diagonal_step`) may compare
    sizes ``a`` and ``b`` (length, width) point for point: when they change
    different numbers of the default's dimensions (the default against any
    other, a size one step off against one two steps off). Two sizes that
    change as many are never weighed against each other, so a scan need not
    compare them. ``default``: (length, width), None for
    :class:`geometry.pitch.PitchModel`'s.

    >>> [compared_point_for_point(a, b) for a, b in [((105, 68), (100, 68)), ((100, 68), (110, 68)), ((100, 68), (100, 72))]]
    [True, False, True]
    """
    if default is None:
        p = PitchModel()
        default = (p.length, p.width)
    changed = lambda s: sum(float(s[i]) != float(default[i]) for i in (0, 1))  # noqa: E731
    return changed(a) != changed(b)


def estimate_pitch_size(
    views: list[PitchView],
    prior: PitchModel | None = None,
    *,
    centre: np.ndarray | None = None,
    max_sd: float = SIZE_MAX_SD,
    radii=(20.0, 8.0, 3.0),
    max_points: int = 300,
    systematic_px: float = 1.0,
) -> PitchSize:
    """The pitch's length and width from views of one tripod camera.

    Parameters
    ----------
    views : PitchView list (at least 3), cameras under the ``prior`` size
    prior : PitchModel the cameras were made with (default 105 x 68 m)
    centre : (3,) metres, the tripod centre (default the views' median centre)
    max_sd : metres; a dimension whose jackknife standard deviation is above
        this is not constrained by the views and keeps the prior's value
    radii : px, the successive association radii
    max_points : model points per view and round, evenly thinned
    systematic_px : px, how far each marking of a view may sit off its paint as a
        whole (the least-squares uncertainty adds its effect, marking by marking)

    Returns
    -------
    PitchSize (``source`` "estimated"; an unconstrained dimension has sd None)

    Raises
    ------
    ValueError
        With fewer than 3 views, or too few markings matched to their paint.
    """
    if len(views) < 3:
        raise ValueError(f"the pitch's size needs at least 3 views, got {len(views)}")
    prior = prior or PitchModel()
    model = ModelSamples.from_pitch(prior, 0.5)
    dL0, dW0 = size_derivatives(prior, model)
    L0, W0 = prior.length, prior.width
    C0 = np.median([v.camera.center for v in views], axis=0) if centre is None else np.asarray(centre, np.float64)
    all_ = list(range(len(views)))
    line_index = [LineIndex(v.points) for v in views]  # (each view's, for every fit)
    free = [True, True]
    sd = [None, None]
    for _ in range(3):  # free both; fix what the views leave open; refit
        if not any(free):
            break
        fit = fit_tripod([v.camera for v in views], line_index, [v.size for v in views], model, C0, prior, derivatives=(dL0, dW0), free=free, radii=radii, max_points=max_points, systematic_px=systematic_px)
        x, cams, rms, C, L, W, ls_sd = fit.x, fit.cameras, fit.rms, fit.centre, fit.length, fit.width, fit.size_sd
        ns = len(x) - 4 * len(views)
        # the jackknife: each view left out in turn, started from the full fit
        est = []
        for k in all_:
            keep = [i for i in all_ if i != k]
            seed = np.concatenate([x[:ns], np.delete(x[ns:].reshape(-1, 4), k, axis=0).ravel()])
            try:
                fk = fit_tripod([views[i].camera for i in keep], [line_index[i] for i in keep], [views[i].size for i in keep], model, C0, prior, derivatives=(dL0, dW0), free=free, radii=radii[-1:], max_points=max_points, seed_x=seed)
            except ValueError:
                continue
            est.append((fk.length, fk.width))
        n = len(est)
        if n < 3:
            raise ValueError("too few views fit the markings to estimate the pitch's size")
        e = np.array(est)
        jk = np.sqrt((n - 1) / n * ((e - e.mean(axis=0)) ** 2).sum(axis=0))
        jk = np.maximum(jk, ls_sd)
        now = [free[0] and jk[0] <= max_sd and LENGTH_RANGE[0] <= L <= LENGTH_RANGE[1], free[1] and jk[1] <= max_sd and WIDTH_RANGE[0] <= W <= WIDTH_RANGE[1] and W < L]
        if all(now[d] or not free[d] for d in range(2)):
            sd = [float(jk[d]) if free[d] else None for d in range(2)]
            length, width = (L if free[0] else L0), (W if free[1] else W0)
            return PitchSize(length, width, sd[0], sd[1], "estimated", len(views), np.asarray(C), tuple(cams), rms)
        free = [free[d] and now[d] for d in range(2)]
    return PitchSize(L0, W0, None, None, "estimated", len(views), None, (), None)


def estimate_view_size(
    camera: Camera,
    points: np.ndarray,
    size,
    prior: PitchModel | None = None,
    *,
    prior_sd: tuple[float, float] = VIEW_PRIOR_SD,
    radii=(8.0, 4.0, 2.5),
    max_points: int = 400,
) -> PitchSize:
    """The pitch's length and width from one view (a still), with its camera.

    One view fixes a dimension where markings whose size Law 1 fixes (the
    centre circle, the penalty and goal areas, the penalty arc) are seen
    together with markings the dimension places: the width with both
    touchlines, or a touchline and a penalty area; the length with the
    halfway line or the circle and a goal line, penalty area or arc.

    The camera (its centre, rotation, focal length and lens term) and the
    size are refined jointly to the frame's paint pixels
    (:func:`arstream.tripod.fit_tripod` with one view), under a Gaussian
    prior about ``prior``'s size with ``prior_sd`` (:data:`VIEW_PRIOR_SD`):
    a direction the view leaves open stays at the prior, where a fit without
    it drifts (on exact paint of one goal end, started a metre off, to a
    pitch 116 m long: ``tests/test_tripod.py``). A dimension whose
    posterior standard deviation is over :data:`VIEW_CONSTRAINS` of the
    prior's is not constrained by the view: it is fixed at the prior's value
    and the rest refitted.

    Parameters
    ----------
    camera : Camera of the view under ``prior`` (frame pixels)
    points : (M, 2) float64, the frame's paint pixels
    size : (width, height) of the frame, pixels
    prior : PitchModel the camera was made with (default 105 x 68 m)
    prior_sd : (length sd, width sd) metres
    radii : px, the successive association radii
    max_points : model samples in view used per round, evenly thinned

    Returns
    -------
    PitchSize, ``source`` "estimated" (``views`` 1, ``cameras`` the refined
    camera, ``length_sd``/``width_sd`` the posterior's, None where not
    constrained), or the prior's size with ``source`` "default" and no
    camera where the view constrains neither dimension.

    Raises
    ------
    ValueError
        Too few of the markings in view matched to the paint.
    """
    prior = prior or PitchModel()
    model = ModelSamples.from_pitch(prior, 0.5)
    derivatives = size_derivatives(prior, model)
    index = LineIndex(np.asarray(points, np.float64).reshape(-1, 2))
    free = [True, True]
    while any(free):
        fit = fit_tripod([camera], [index], [size], model, camera.center, prior, derivatives=derivatives, free=free, radii=radii, max_points=max_points, size_prior_sd=prior_sd)
        now = [free[d] and fit.size_sd[d] <= VIEW_CONSTRAINS * prior_sd[d] for d in range(2)]
        if now == free:
            inside = LENGTH_RANGE[0] <= fit.length <= LENGTH_RANGE[1] and WIDTH_RANGE[0] <= fit.width <= WIDTH_RANGE[1] and fit.width < fit.length
            if not inside:
                break
            sd = [fit.size_sd[d] if free[d] else None for d in range(2)]
            return PitchSize(fit.length, fit.width, sd[0], sd[1], "estimated", 1, fit.centre, fit.cameras, fit.rms)
        free = now
    return PitchSize(prior.length, prior.width, source="default", views=1)
