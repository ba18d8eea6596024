"""A camera for a frame without temporal help: the initialisers, and the
registration of a single still.

* :func:`initialise_camera` — from the detector's markings: the closed-form
  pole-polar solution from the centre circle and the halfway line
  (:func:`arstream.solve.solve_from_circle`, the first choice when the
  circle is in view), else line correspondences
  (:func:`arstream.solve_lines.cameras_from_line_hypotheses`); every
  candidate refined against all markings.
* :func:`initialise_from_paint` — for real broadcast frames, where the
  ridge detector misses faint, thin lines: straight lines of the white paint
  (:mod:`arstream.detect.paint`), ordered pairs of each direction
  (:func:`arstream.solve_lines.cameras_from_line_pairs`), refined against
  the paint pixels and judged by line support (:mod:`arstream.support`).
* :func:`register_frame` — one still: both, and the line-support test that
  keeps a wrong camera from being reported.
"""

from __future__ import annotations

from dataclasses import replace

import cv2
import numpy as np

from arstream.detect.paint import PAINT_CONTRAST, paint_arcs, paint_lines, paint_mask
from arstream.estimate import CameraEstimate
from arstream.pitch_size import SCAN_BELOW, STILL_GAIN_RATIO, PitchSize, choose_still_size, estimate_view_size, size_dispute, still_scan_sizes
from arstream.solve import LineIndex, ModelSamples, Refinement, cameras_along_circle, explained_share, k1_observable, refine_camera, solve_from_circle
from arstream.solve_lines import cameras_from_line_hypotheses, cameras_from_line_pairs, plausible, same_camera
from arstream.support import ON_GRASS, ON_LINES, along_support, backed_support, backs, bright_mask, grass_region, line_support, marking_points, marking_spread, on_grass, on_lines, white_mask
from arstream.workers import map_in_processes
from geometry.camera import Camera, camera_turned
from geometry.conics import intersect_line_conic, sampson_distance
from geometry.pitch import PitchModel

__all__ = ["INIT_ACCEPT", "initialise_camera", "PaintView", "paint_view", "initialise_from_paint", "paint_score", "nudged_camera", "still_paint_camera", "paint_verdict", "paint_seen", "no_pitch_reason", "circle_view_cameras", "penalty_arc_cameras", "register_frame", "register_image"]

#: least refinement confidence (share of the model in view with a line pixel
#: near) of an initialisation from the detector's markings
INIT_ACCEPT = 0.6
#: least markings in view (each with 5 m of it inside the frame,
#: :func:`arstream.support.marking_spread`) of a camera from the paint alone: a
#: piece of one or two markings laid on a painted line fits cameras anywhere
#: (a centre-circle view shows the circle, the halfway line and a touchline)
MIN_MARKINGS = 3
#: a still's camera from the detector's lines with less line support than this
#: is compared with the paint initialiser's (real frames: a refinement on the
#: ridge detector's few lines can settle a few pixels off)
PAINT_CHECK = 0.95
#: weight of the paint a camera explains in the paint initialiser's choice:
#: of its hypotheses the one with the highest line support (the share of its
#: markings on paint: precision) plus this times the share of the paint's
#: pixels within 2.5 px of its markings (recall,
#: :func:`arstream.solve.explained_share`). A camera that lays a few markings
#: on other lines (another sport's, a single painted line, the boards) can
#: have as high a support as the right one, but leaves the frame's own
#: markings unexplained. (Every 25th frame of the shared clips re-encoded
#: five ways and of the clips themselves, at the tracker's analysis size:
#: the pick is within 5 px of the full-size run's camera on 53 of the 70
#: frames where a hypothesis is, against 45 by support alone, and no pick
#: is worse; any weight from 0.2 to 0.8 does 51-53. Tracked, over the 30
#: copies of ``bench/real_perturbed.py``, two runs each: 6.9 and 7.8 ->
#: 6.1 and 6.0 % of the frames more than 20 px from the full-size run's
#: camera, 80.1 and 77.6 -> 81.9 and 80.8 % within 5 px.)
RECALL_WEIGHT = 0.5
#: least line support of the goal and penalty areas' sides alone
#: (:func:`arstream.support.along_support`) of a camera from the penalty
#: arc's family: its members refined to the paint can slide along the lines
#: across the pitch (nearly parallel through a long lens), which stay on
#: their paint, and lay the areas' short sides off theirs (the line
#: support's own 0.7; ``israel_league_wide`` frame 275 pillarboxed: 0.38 at
#: 24.7 px from its reference; the right cameras of its reference frames
#: 0.95-1.0, Premier League frame 01's 0.94)
MIN_ALONG = 0.7
#: least line support of the goal and penalty areas' sides alone of any
#: camera of a still (:func:`register_frame`), where enough of them is in
#: view: at least half of their points on paint, as
#: :func:`arstream.support.backs` asks of the markings in view. Through a
#: long lens the lines across the pitch nearly share one direction, and a
#: camera twice as far with twice the focal length lays them on the same
#: paint (a support of 0.79 with three quarters of its markings on paint,
#: 337 px from the reference: ``israel_league_wide`` frame 375 enlarged 1.33
#: times) while the areas' sides fall off theirs. On the shared frames under
#: ``bench/real_graphics.py``'s ten variants the two wrong cameras it turns
#: away score 0.33 and 0.36; the right ones at least 0.61 (a Premier League
#: frame at 480 rows, JPEG quality 35, whose sides are faint).
MIN_SIDES = 0.5
#: splits of the paint's lines into the pitch's two directions whose line
#: pairs the paint initialiser tries (:func:`arstream.solve_lines.cameras_from_line_pairs`)
SPLITS = 2
#: further splits a still tries when the first ones give no camera with a
#: line support of at least :data:`MORE_SPLITS_BELOW` (:func:`still_paint_camera`).
#: Through a long lens looking along the pitch the lines across it are nearly
#: parallel in the picture, and the edges of a running track or of the
#: boards, and a flat penalty arc's pieces, join their family: the two splits
#: with the most line length then pair the wrong lines. Six more found
#: ``israel_league_wide`` frames 175 and 400 (goal, goal area and penalty
#: area through a lens of f ~ 4300 px), lost before; they cost a still about
#: 0.8 s more where they are tried, and a tracker never tries them. Their
#: camera must have a line support of :data:`MORE_SPLITS_CHECK`.
MORE_SPLITS = 6
#: (the line support a still's camera must have: :func:`register_frame`'s ``min_support``)
MORE_SPLITS_BELOW = 0.7
#: the least line support of the camera of the further splits
#: (:data:`MORE_SPLITS`): the wider search runs where the frame gave nothing,
#: and there a chance alignment can pass the still's tests (``world_cup_2006``
#: under a bar over its bottom third, ``bench/real_graphics.py``: its further
#: splits' cameras score 0.79-0.85; taken from 0.7 up, the still is
#: registered 13.3 px off its reference, where it is lost at 0.9; an earlier
#: version took one 888 px off at 0.82). The right cameras of the long lens's penalty
#: views it finds on a degraded picture score less than a clean one's
#: (``israel_league_wide`` frame 175 at 480 rows in a JPEG of quality 35:
#: 0.92-0.94, 1.6 px from its reference; under the bar 0.91-0.97, 2.4 px;
#: frame 400 dimmed: 0.94), and at :data:`PAINT_CHECK` they were lost
MORE_SPLITS_CHECK = 0.9
#: the paint mask's contrast (levels, :func:`arstream.detect.paint.paint_mask`)
#: of a still's second look when its paint at the usual contrast
#: (:data:`arstream.detect.paint.PAINT_CONTRAST`, 12) gives no backed camera
#: (:func:`register_frame`). The far, thin lines of a long lens's view can be
#: fainter than that, and the lines a split needs go missing
#: (``israel_league_wide`` frame 225: only the penalty area's side is found
#: along the pitch; at 8 levels the goal area's sides too, 4.0 px from the
#: reference). Its camera is held to :data:`PAINT_CHECK` (the further
#: splits' to :data:`MORE_SPLITS_CHECK`) on the paint it looked at: its line
#: support on white paint of ``FAINT_CONTRAST`` levels (:func:`faint_support`),
#: besides the still's ``min_support`` on the usual mask. A second look runs
#: where the frame gave nothing, and there it found cameras 186 and 248 px off
#: at a line support of 0.84 and 0.78 (stop 43) under ``bench/real_graphics.py``'s
#: variants; held on the usual mask, the right cameras of a soft picture
#: (0.80-0.90 there) were left out with them. Held to the same bar on the
#: paint it looked at (the faint mask holds the usual one), those score
#: 0.96-0.98 (``israel_league_wide`` 275 and 400 under a 1.2 px blur, 0.90
#: and 0.80 on the usual mask); the other cameras it finds on the 27 real
#: reference frames under the 15 variants (2026-12-07) that the usual mask
#: backs score 0.79-0.90 there and stay out as before (right ones among them:
#: the Premier League frame 00 at 384 x 384, 0.88, 2.1 px off).
FAINT_CONTRAST = 8.0


def faint_support(camera: Camera, image: np.ndarray, pitch: PitchModel) -> float:
    """The line support of ``camera`` on a BGR frame's white paint of
    :data:`FAINT_CONTRAST` levels (:func:`arstream.support.white_mask`), the
    paint a still's second look made its camera from; 0 where too few
    markings are in view for a share."""
    share, _ = backed_support(camera, white_mask(image, threshold=FAINT_CONTRAST), pitch)
    return share or 0.0


def initialise_camera(detections, index: LineIndex, size, model: ModelSamples, *, principal_point, pitch: PitchModel, centre=None, estimate_k1: bool = False, prior: Camera | None = None) -> Refinement | None:
    """A camera for a frame without temporal help (the initialiser).

    Tries, in order: the closed-form pole-polar solution from each candidate
    centre-circle ellipse with each detected line that crosses it (the
    halfway line); then homographies from line correspondences (penalty-area
    views). Every candidate is refined against all markings; the one with the
    most support wins — with a ``prior`` camera (the filter's prediction),
    candidates far from it (centre, focal length) are penalised, since with few
    markings in view (long focal lengths) several cameras explain them equally
    well. Returns None when nothing is found.
    """
    W, H = size
    cands: list[Camera] = []
    lines = list(getattr(detections, "lines", []) or [])
    for ell in list(getattr(detections, "ellipses", []) or [])[:2]:
        E = ell.conic
        crossing = []
        for dl in lines[:8]:
            try:
                intersect_line_conic(E, dl.line)
            except ValueError:
                continue
            crossing.append(dl)
        for dl in crossing[:3]:
            try:
                sols = solve_from_circle(E, dl.line, principal_point, image_width=W)
            except ValueError:
                continue
            cands.extend(s.camera for s in sols[:2])
    best: Refinement | None = None

    def merit(r: Refinement) -> float:
        m = r.confidence - 1e-3 * r.rms
        if prior is not None:
            m -= 0.15 * min(1.0, np.linalg.norm(r.camera.center - prior.center) / 10.0)
            m -= 0.15 * min(1.0, abs(np.log(r.camera.focal / prior.focal)) / 0.2)
        return m

    def consider(cam: Camera, cheap_first: bool) -> None:
        nonlocal best
        try:
            r = refine_camera(cam, index, size, model, center=centre, estimate_k1=estimate_k1)
        except ValueError:
            return
        if best is None or merit(r) > merit(best):
            best = r

    def with_k1(r: Refinement | None) -> Refinement | None:
        """Wide zoom lenses bend lines: when the best candidate explains the markings only
        partly, let one radial coefficient join the refinement."""
        if r is None or r.confidence >= 0.9:
            return r
        try:
            rk = refine_camera(r.camera, index, size, model, center=centre, estimate_k1=True, radii=(8.0, 4.0, 2.5))
        except ValueError:
            return r
        return rk if merit(rk) > merit(r) else r

    for cam in cands:
        consider(cam, False)
    best = with_k1(best)
    if best is not None and (best.confidence >= 0.75 or (best.confidence >= 0.55 and explained_share(best.camera, index, size, model) >= 0.9)):
        return best  # (the line hypotheses below cost far more)
    # line correspondences: score every hypothesis by its unrefined support, refine the best few
    hyps = cameras_from_line_hypotheses([dl.line for dl in lines[:10]], size, principal_point, pitch)
    if hyps:
        scored = []
        for cam in hyps:
            inside = _support(cam, index, size, model)
            scored.append((inside, cam))
        scored.sort(key=lambda s: -s[0])
        for _, cam in scored[:6]:
            consider(cam, True)
        best = with_k1(best)
    return best


class PaintView:
    """What the paint initialiser sees of a frame (:func:`paint_view`).

    Attributes
    ----------
    mask : (H, W) uint8, white paint (:func:`arstream.detect.paint.paint_mask`), frame pixels
    points : (M, 2) float64, the paint pixels (frame pixels; every other row and
        column above 1000 px wide)
    bright : (H, W) bool, the white-paint support mask of the frame (:func:`arstream.support.white_mask`)
    grass : (h, w) bool or None, the grass region (:func:`arstream.support.grass_region`
        of the detector's small grass mask; None without one)
    index : LineIndex over ``points`` (made on first access)
    lines : list of DetectedLine, the paint's straight lines, most support
        first (found on first access: tracking needs only the pixels)
    arcs : list of PaintArc, penalty arcs beside those lines (first access)
    """

    def __init__(self, image: np.ndarray, mask: np.ndarray, points: np.ndarray, bright: np.ndarray, grass: np.ndarray | None = None):
        self.image, self.mask, self.points, self.bright, self.grass = image, mask, points, bright, grass
        self._lines: list | None = None
        self._arcs: list | None = None
        self._index: LineIndex | None = None

    @property
    def index(self) -> LineIndex:
        if self._index is None:
            self._index = LineIndex(self.points)
        return self._index

    @property
    def lines(self) -> list:
        if self._lines is None:
            self._lines = paint_lines(self.mask, self.image)
        return self._lines

    @property
    def arcs(self) -> list:
        """Penalty arcs beside the paint's lines (:func:`arstream.detect.paint.paint_arcs`), found on first access."""
        if self._arcs is None:
            self._arcs = paint_arcs(self.mask, self.lines)
        return self._arcs


def graphics_mask(detections, size) -> np.ndarray | None:
    """(H, W) uint8, 255 on the frame's screen graphics (a score box, a
    caption: ``detections.graphics_small``) grown by a cell of their small
    grid, at ``size`` (width, height); None where there are none.

    A band the detector takes for a graphic along the frame's top or bottom
    edge is left: there it is as often the pitch's surround, beyond a
    touchline (on ``artificial_turf_multisport`` the benches at the bottom
    right, 2-4 rows of the 90 on the frame's last row, beside the near
    touchline). One at a side edge is a graphic: a caption's bar may start at
    the picture's left edge (``real-penalty`` 104 frame 125, whose outline
    was otherwise taken for paint, and the still lost)."""
    graphics = getattr(detections, "graphics_small", None)
    if graphics is None:
        return None
    _, labels, stats, _ = cv2.connectedComponentsWithStats(graphics, connectivity=8)
    h = graphics.shape[0]
    y, bh = stats[1:, cv2.CC_STAT_TOP], stats[1:, cv2.CC_STAT_HEIGHT]
    inside = np.flatnonzero((y > 0) & (y + bh < h)) + 1
    if not len(inside):
        return None
    kept = np.isin(labels, inside).astype(np.uint8) * 255
    return cv2.resize(cv2.dilate(kept, np.ones((3, 3), np.uint8)), (int(size[0]), int(size[1])), interpolation=cv2.INTER_NEAREST)


def bare_grass(detections, size, graphics: np.ndarray | None = None) -> np.ndarray | None:
    """(H, W) bool at ``size`` (width, height): the detector's grass mask less
    its screen graphics (``graphics``, the caller's :func:`graphics_mask` at
    ``size``, else made here), where a painted marking would show; None
    without a grass mask. A still's sizes are judged on it
    (:func:`arstream.support.paint_dispute`'s ``ground``)."""
    grass = getattr(detections, "grass_mask", None)
    if grass is None:
        return None
    W, H = int(size[0]), int(size[1])
    ground = (grass if grass.shape[:2] == (H, W) else cv2.resize(grass, (W, H), interpolation=cv2.INTER_NEAREST)) > 0
    if graphics is None:
        graphics = graphics_mask(detections, size)
    if graphics is not None:
        ground &= graphics == 0
    return ground


def paint_view(image: np.ndarray, detections, *, reach: int = 2, contrast: float = PAINT_CONTRAST, bright: np.ndarray | None = None) -> PaintView:
    """The paint mask (``contrast``: :func:`arstream.detect.paint.paint_mask`)
    and its pixels, the white-paint support mask (with ``reach``,
    :func:`arstream.support.white_mask`; or ``bright``, the frame's, made
    before) and the grass region of one BGR frame (the pitch region from
    ``detections``, less its screen graphics grown by a cell of their grid:
    a caption's edge on the grass is a long straight bright step, as the
    ridge detector's region leaves it out)."""
    H, W = image.shape[:2]
    grass = getattr(detections, "grass_mask", None)
    region = cv2.dilate(grass, np.ones((3, 3), np.uint8)) if grass is not None else None
    graphics = None if region is None else graphics_mask(detections, (region.shape[1], region.shape[0]))
    if graphics is not None:
        region = cv2.subtract(region, graphics)
    mask = paint_mask(image, region, contrast=contrast)
    step = 2 if W > 1000 else 1
    ys, xs = np.nonzero(mask[::step, ::step])
    small = getattr(detections, "grass_small", None) if detections is not None else None
    return PaintView(image, mask, np.column_stack([xs, ys]).astype(np.float64) * step, white_mask(image, reach=reach) if bright is None else bright, None if small is None else grass_region(small))


class FrameViews:
    """The latest frame's paint views (:func:`paint_view`), made once for the
    trackers that are fed that frame (:class:`arstream.track.Tracker`'s
    ``views``): a pitch-size scan tracks each frame at several sizes, and a
    frame's paint does not depend on the size (its lines and arcs, found on
    first access, neither). The trackers must be fed the same image and
    detections under the same frame number; a new number drops the last
    frame's views, as does another image under the same number (a source
    started again)."""

    def __init__(self):
        self._frame: tuple | None = None
        self._views: dict[int, PaintView] = {}

    def view(self, frame: int, image: np.ndarray, detections, reach: int) -> PaintView:
        """Frame ``frame``'s :func:`paint_view` (``image``, ``detections``, ``reach``)."""
        if (frame, id(image), id(detections)) != self._frame:
            self._frame, self._views = (frame, id(image), id(detections)), {}
        if reach not in self._views:
            self._views[reach] = paint_view(image, detections, reach=reach)
        return self._views[reach]


def initialise_from_paint(view: PaintView, size, *, principal_point, pitch: PitchModel, keep: int = 8, estimate_k1: bool = True, circles=(), lines=(), min_on_grass: float | None = None, min_on_lines: float | None = None, min_sides: float | None = None, refine_family: bool = False, penalty_arcs: bool = False, more_splits: int = 0, seeds=(), explain_circles: bool = False) -> tuple[Refinement | None, float | None]:
    """A camera for a real frame from its paint alone (no temporal help).

    Line hypotheses (:func:`arstream.solve_lines.cameras_from_line_pairs`, scored on
    the paint grown by about 2.5 px at 1280 wide), and with the detector's
    ellipses (``circles``, DetectedEllipse) those of a centre-circle view
    (:func:`circle_view_cameras`), are refined against the
    paint pixels, with one radial coefficient when the view has enough
    markings; of those still plausible (:func:`arstream.solve_lines.plausible`)
    with :data:`MIN_MARKINGS` in view, the refined camera with the highest
    line support on white paint (:func:`arstream.support.line_support`) plus
    :data:`RECALL_WEIGHT` times the share of the paint it explains wins. ``lines``: the
    detector's straight lines (DetectedLine), tried as the halfway line
    before the paint's. ``min_on_grass``: with the frame's grass known
    (``view.grass``), a hypothesis with a smaller share of its markings in
    view on the grass (:func:`arstream.support.on_grass`) is left out, and
    with ``min_on_lines`` one with a smaller share of its markings on paint
    lying on painted lines rather than along bright steps
    (:func:`arstream.support.on_lines`), and with ``min_sides`` one whose
    goal and penalty areas' sides in view have a smaller line support
    (:func:`arstream.support.along_support`) (a still: :func:`register_frame`).
    ``refine_family``: the centre circle's family refined before it is
    judged (:func:`circle_view_cameras`' ``refine``, and the penalty arc's,
    :func:`penalty_arc_cameras`). ``penalty_arcs``: the penalty arc's
    hypotheses too (a still, :func:`register_frame`). A tracker leaves
    them out: it keeps its tripod centre from its first camera, and on the
    shared clips re-encoded at 480 rows (``bench/real_perturbed.py``) an
    arc's camera a few pixels off, where the lines gave none or a weaker
    one, started the centre off (``israel_league_wide`` at 854 x 480 crf 12
    from frame 120: 4.6 -> 22.5 % of the frames more than 5 px from the
    full-size run's; the same run's figures with them only where nothing
    else is kept). ``more_splits``: when no hypothesis gives a line support
    of :data:`MORE_SPLITS_BELOW`, the lines' next splits into the two
    directions (:data:`MORE_SPLITS`, a still) are tried too, and their best
    kept when its line support is at least :data:`MORE_SPLITS_CHECK` and its
    :func:`paint_score` is higher. ``seeds``: cameras from elsewhere judged
    with the hypotheses, refined and scored alike (the tracker's: the
    detector's camera of the frame where it fell short of
    :data:`INIT_ACCEPT`). ``explain_circles``: a hypothesis that leaves a
    closed-circle ellipse of ``circles`` unexplained (:func:`circle_verdict`)
    is left out (a still). Returns (refinement, its support), or (None, None) when
    no hypothesis was found.
    """
    W, H = size
    r = max(2, int(round(2.5 * W / 1280)))
    near = cv2.dilate(view.mask, np.ones((2 * r + 1, 2 * r + 1), np.uint8))
    found = view.lines[:10]
    seg_lines, seg_ends = [dl.line for dl in found], [dl.endpoints for dl in found]
    hy = cameras_from_line_pairs(seg_lines, seg_ends, size, principal_point, near, pitch, keep=keep, splits=SPLITS) if len(found) >= 4 else None
    cands = list(seeds) + (hy.cameras if hy is not None else []) + circle_view_cameras(view, size, principal_point=principal_point, pitch=pitch, circles=circles, lines=lines, refine=refine_family)
    n_lines = len(cands)
    if penalty_arcs:
        cands += penalty_arc_cameras(view, size, principal_point=principal_point, pitch=pitch, refine=refine_family)
    ring = circles if explain_circles else ()
    best, best_s = _best_from_paint(cands, view, size, pitch, estimate_k1, min_on_grass, min_on_lines, min_sides, along_from=n_lines, circles=ring)
    if more_splits > 0 and hy is not None and best_s < MORE_SPLITS_BELOW:
        # (nothing backed from the first splits: a long lens's markings across
        # the pitch are nearly parallel in the picture, and the boards' or a
        # track's edges and a flat penalty arc's pieces join their family)
        hx = cameras_from_line_pairs(seg_lines, seg_ends, size, principal_point, near, pitch, keep=keep, splits=SPLITS + more_splits, first_split=SPLITS)
        bx, sx = _best_from_paint(hx.cameras, view, size, pitch, estimate_k1, min_on_grass, min_on_lines, min_sides, circles=ring)
        model = ModelSamples.from_pitch(pitch, 0.5)
        if bx is not None and sx >= MORE_SPLITS_CHECK and (best is None or paint_score(bx.camera, sx, view, size, model) > paint_score(best.camera, best_s, view, size, model)):
            best, best_s = bx, sx
    return (best, best_s) if best is not None else (None, None)


def _best_from_paint(cands: list[Camera], view: PaintView, size, pitch: PitchModel, estimate_k1: bool, min_on_grass: float | None, min_on_lines: float | None, min_sides: float | None = None, along_from: int | None = None, circles=()) -> tuple[Refinement | None, float]:
    """:func:`initialise_from_paint`'s judgement of its hypotheses ``cands``:
    (the best refinement, its line support), or (None, -1). Each must keep
    the areas' sides in view on their paint (:func:`arstream.support.along_support`)
    at ``min_sides``, and those from ``along_from`` on (the penalty arc's)
    at :data:`MIN_ALONG`; with ``circles`` (the detector's ellipses), each
    must lay its markings on the closed ones (:func:`circle_verdict`)."""
    W, H = size
    model = ModelSamples.from_pitch(pitch, 0.5)
    points = marking_points(pitch)
    best, best_s, best_score = None, -1.0, -1.0
    for j, cam in enumerate(cands):
        try:
            rf = refine_camera(cam, view.index, size, model, radii=(20.0, 10.0, 5.0, 3.0))
            if estimate_k1 and rf.n_visible >= 150 and k1_observable(rf.camera.focal, size):
                rk = refine_camera(rf.camera, view.index, size, model, estimate_k1=True, radii=(4.0, 2.5))
                sk = line_support(rk.camera, view.bright, points).share or 0.0
            else:
                rk, sk = None, -1.0
        except ValueError:
            continue
        s0 = line_support(rf.camera, view.bright, points).share or 0.0
        if sk > s0 + 0.01:
            rf, s0 = rk, sk
        if not plausible(rf.camera.center, rf.camera.focal, W, pitch)[0]:
            continue  # the refinement left the cameras a broadcast can have (one marking along one line)
        if marking_spread(rf.camera, view.bright, pitch)[0] < MIN_MARKINGS:
            continue  # too little in view to be judged: a piece of one marking on a line fits anywhere
        if min_on_grass is not None and view.grass is not None and (on_grass(rf.camera, view.grass, size, pitch) or 1.0) < min_on_grass:
            continue  # markings off the grass: a member of a long lens's depth-zoom family too far away
        if min_on_lines is not None and (on_lines(rf.camera, view.image, view.bright, pitch) or 1.0) < min_on_lines:
            continue  # markings along bright steps (the grass's edge, a track, the boards), not painted lines
        need = MIN_ALONG if along_from is not None and j >= along_from else min_sides
        if need is not None and (a := along_support(rf.camera, view.bright, pitch)) is not None and a < need:
            continue  # slid along the lines across the pitch, the areas' sides off their paint
        if circles and circle_verdict(rf.camera, circles, size, pitch, model) is not None:
            continue  # another part of the pitch laid over the centre circle
        score = paint_score(rf.camera, s0, view, size, model)
        if score > best_score:
            best, best_s, best_score = rf, s0, score
    return best, best_s


#: how much higher a still's other camera must score by :func:`paint_score`
#: to replace the one it has (:func:`register_frame`: the paint's against the
#: detector's, a nudged one against either)
PAINT_SCORE_MARGIN = 0.02

#: the turns (degrees, each way, in pan and in tilt) and the zoom (each way,
#: a share of the focal length) of :func:`nudged_camera`'s starts: a grid of
#: 5 x 5 x 3 about the camera, the refinement's reach (20 px at the first
#: round) covering the steps between them at a broadcast's focal lengths
NUDGE_TURNS_DEG = (1.0, 2.0)
NUDGE_ZOOM = 0.1


def nudged_camera(camera: Camera, view: PaintView, size, pitch: PitchModel) -> Refinement | None:
    """The best camera (by :func:`paint_score`) refined to the frame's paint
    from starts about ``camera``: turned in pan and tilt by up to
    :data:`NUDGE_TURNS_DEG` and zoomed by :data:`NUDGE_ZOOM` about its centre
    (:func:`geometry.camera.camera_turned`), or None when no start refines
    to a plausible camera showing enough markings (:func:`_best_from_paint`
    judges the starts, without the lens term or its checks of grass and lines).

    A refinement follows the paint pixels nearest the projected markings, so
    a start a few pixels beside the right camera with part of the paint
    faint (a stand's shadow across the circle) can settle in a basin of its
    own: a realistic synthetic SD still (`real-sd` 83 frame 150) whose paint
    initialiser's best camera, 20 px off at a line support of 0.79, stays
    there under refinements with radii of 8 to 30 px, while one start turned
    by a degree and zoomed by 10 % refines to 2.7 px (0.94). Which start
    wins is judged as the hypotheses are (:func:`paint_score`); the caller
    keeps it only where the paint backs it better (:func:`register_frame`).

    Parameters
    ----------
    camera : Camera of the frame (frame pixels)
    view : PaintView of the frame
    size : (width, height) of the frame, pixels
    pitch : PitchModel

    Returns
    -------
    Refinement or None
    """
    turns = np.deg2rad(np.concatenate([-np.asarray(NUDGE_TURNS_DEG)[::-1], [0.0], NUDGE_TURNS_DEG]))
    starts = [camera_turned(camera, (tilt, pan, 0.0), np.log1p(zoom), camera.center) for tilt in turns for pan in turns for zoom in (-NUDGE_ZOOM, 0.0, NUDGE_ZOOM) if not tilt == pan == zoom == 0.0]
    # (refined, made plausible and scored as the paint's hypotheses are; the
    # caller's paint_verdict judges the winner's grass, lines and sides)
    return _best_from_paint(starts, view, size, pitch, False, None, None)[0]


def paint_score(camera: Camera, support: float, view: PaintView, size, model: ModelSamples) -> float:
    """How well a frame's paint backs a camera, to choose between hypotheses:
    its line support on white paint (``support``, precision) plus
    :data:`RECALL_WEIGHT` times the share of the paint's pixels it explains
    (:func:`arstream.solve.explained_share` within 2.5 px, recall)."""
    return support + RECALL_WEIGHT * explained_share(camera, view.index, size, model, radius=2.5)


def circle_view_cameras(view: PaintView, size, *, principal_point, pitch: PitchModel, circles=(), lines=(), keep: int = 2, max_pairs: int = 4, focals_per_width=np.geomspace(0.4, 10.0, 18), refine: bool = False) -> list[Camera]:
    """Hypotheses of a centre-circle view whose ellipse does not fix the focal
    length (a short arc, or the circle nearly edge-on from a low camera far
    away: the closed form's f is then tens of per cent off).

    For each ellipse (the first two of ``circles``) and each straight line
    through it that reaches beyond it (a chord of the arc itself does not:
    the detector's ``lines`` first, then the paint's), the cameras along the
    circle (:func:`arstream.solve.cameras_along_circle`, at ``focals_per_width``
    times the width) all lay the circle and the halfway line on their
    pixels; what tells them apart is the rest of the pitch (the far
    touchline, a penalty area). Of the plausible members
    (:func:`arstream.solve_lines.plausible`), the ``keep`` with the most
    marking points on white paint net of those off it
    (``2 n_supported - n_inside`` of :func:`arstream.support.line_support`)
    are returned: a member with a longer lens shows the same circle with
    less of the pitch around it, so its share on paint can be as high while it
    explains less of the frame. With ``refine``, also the ``keep`` best of the
    members refined against the paint pixels (the distinct ones still
    plausible): the focal grid is coarse, and a member one step from the
    right camera lays those markings a few px off their paint, where a
    longer lens showing less of the pitch scores more. Returns a list of
    Camera (empty without an ellipse and a line through it).
    """
    W, H = size
    circles = [c for c in circles if getattr(c, "points", None) is not None and len(c.points) >= 6][:2]
    if not circles:
        return []
    cands = list(lines[:4])
    for dl in view.lines[:8]:
        # (the detector's line already, found again in the paint)
        if not any(abs(dl.line[:2] @ o.line[:2]) > np.cos(np.radians(1.0)) and abs(dl.line @ np.append(o.endpoints.mean(axis=0), 1.0)) < 0.005 * W for o in cands):
            cands.append(dl)
    points = marking_points(pitch)
    model = ModelSamples.from_pitch(pitch, 0.5) if refine else None
    radius = pitch["centre_circle"].radius
    out: list[Camera] = []
    pairs = 0
    for ell in circles:
        for dl in cands:
            if pairs >= max_pairs:
                return out
            try:
                intersect_line_conic(ell.conic, dl.line)
            except ValueError:
                continue
            if np.max(sampson_distance(dl.endpoints, ell.conic)) < 0.01 * W:
                continue  # both ends on the ellipse: a chord of the arc
            pairs += 1
            try:
                fam = cameras_along_circle(ell.conic, dl.line, ell.points, dl.points, principal_point, image_width=W, focals=W * np.asarray(focals_per_width), radius=radius)
            except ValueError:
                continue
            out.extend(_family_pick(fam, view, size, pitch, points, model, keep))
    return out


def penalty_arc_cameras(view: PaintView, size, *, principal_point, pitch: PitchModel, keep: int = 2, focals_per_width=np.geomspace(0.4, 10.0, 18), refine: bool = False) -> list[Camera]:
    """Hypotheses of a penalty-area view from a penalty arc and the penalty
    area's front line (the paint's arcs, :attr:`PaintView.arcs`).

    The arc is the circle of radius 9.15 m about the penalty mark, and the
    front line is the line X = 5.5 m from the mark in the circle's frame: at
    each focal length (``focals_per_width`` times the width) the pose that
    lays both on their pixels (:func:`arstream.solve.cameras_along_circle`
    with that ``offset``, the pole-polar geometry of the circle and a line
    not through its centre), and again half a grid step either side of the
    ``keep`` best members (a member one step off, refined, can slide onto
    the neighbouring lines: ``israel_league_wide`` frame 325, 38.6 px at a
    support of 0.91 on the grid alone). Each member is placed on the pitch
    at the end that puts the camera on the main camera's side (Y < 0). As with
    :func:`circle_view_cameras`, the rest of the view (goal line, goal area,
    the penalty area's sides) tells the members apart: the ``keep`` of the
    plausible members with the most marking points on paint are returned
    (and with ``refine``, the ``keep`` best refined against the paint).
    Returns a list of Camera (empty without an arc).
    """
    W, H = size
    arcs = view.arcs
    if not arcs:
        return []
    points = marking_points(pitch)
    model = ModelSamples.from_pitch(pitch, 0.5) if refine else None
    arc_m = pitch["penalty_arc_left"]
    mark = np.array([*arc_m.center, 0.0])
    offset = float(pitch["penalty_area_left_front"].start[0] - arc_m.center[0])
    grid = W * np.asarray(focals_per_width, dtype=np.float64)
    half_step = np.sqrt(grid[1] / grid[0]) if len(grid) > 1 else 1.0
    out: list[Camera] = []
    for pa in arcs:

        def family(focals) -> list[Camera]:
            """The family's members at ``focals``, on the pitch: the circle's
            frame (+X towards the halfway line) placed at the left end (as it
            is) or the right (turned half a circle), the camera on the near side."""
            try:
                fam = cameras_along_circle(pa.arc.conic, pa.front.line, pa.arc.points, pa.front.points, principal_point, image_width=W, focals=focals, radius=arc_m.radius, offset=offset)
            except ValueError:
                return []
            placed = []
            for cam in fam:
                for M in (np.eye(3), np.diag([-1.0, -1.0, 1.0])):
                    Rp = cam.R @ M
                    c = Camera(K=cam.K, R=Rp, t=cam.t - Rp @ (M @ mark))
                    if c.center[1] < 0:
                        placed.append(c)
            return placed

        placed = family(grid)
        # the grid's steps are coarse (a member one step off, refined, can slide
        # onto the neighbouring lines): half a step either side of the best
        best = _best_members([c for c in placed if plausible(c.center, c.focal, W, pitch)[0]], view, points, keep)
        placed += family(np.array([c.focal * k for c in best for k in (1 / half_step, half_step)]))
        out.extend(_family_pick(placed, view, size, pitch, points, model, keep))
    return out


def _family_pick(fam: list[Camera], view: PaintView, size, pitch: PitchModel, points: np.ndarray, model: ModelSamples | None, keep: int) -> list[Camera]:
    """Of a one-parameter family of cameras (:func:`arstream.solve.cameras_along_circle`),
    the ``keep`` plausible members with the most marking points on paint
    (:func:`_best_members`), and with a ``model`` also the ``keep`` best of
    the members refined against the paint pixels (the distinct ones still
    plausible)."""
    W = size[0]
    members = [cam for cam in fam if plausible(cam.center, cam.focal, W, pitch)[0]]
    out = _best_members(members, view, points, keep)
    if model is not None:
        refined: list[Camera] = []
        for cam in members:
            try:
                cam = refine_camera(cam, view.index, size, model, radii=(20.0, 10.0, 5.0, 3.0)).camera
            except ValueError:
                continue
            if plausible(cam.center, cam.focal, W, pitch)[0] and not any(same_camera(cam, c) for c in refined):
                refined.append(cam)
        out += _best_members(refined, view, points, keep)
    return out


def _best_members(cams: list[Camera], view: PaintView, points: np.ndarray, keep: int) -> list[Camera]:
    """The ``keep`` cameras with the most marking points (``points``, (N, 3))
    on the white paint (``view.bright``) net of those off it."""
    scored = []
    for cam in cams:
        s = line_support(cam, view.bright, points)
        scored.append((2 * s.n_supported - s.n_inside, cam))
    scored.sort(key=lambda x: -x[0])
    return [cam for _, cam in scored[:keep]]


def _support(cam: Camera, index: LineIndex, size, model: ModelSamples, radius: float = 4.0) -> float:
    """Share of the model samples visible through ``cam`` (at most about 300 of
    them, evenly taken) with a detected line pixel within ``radius``."""
    from arstream.solve import _visible

    inside, px = _visible(cam, model, size)
    return float(view_supports(px[None], inside[None], index, radius, 300)[0])


def view_supports(px: np.ndarray, inside: np.ndarray, index: LineIndex, radius: float, max_samples: int) -> np.ndarray:
    """:func:`_support` of D views at once, from their model sample pixels (D, N, 2)
    and in-view masks (D, N): one nearest-neighbour query for all; 0 for a view with
    fewer than 20 samples in view."""
    picks = []
    for j in range(len(inside)):
        idx = np.flatnonzero(inside[j])
        picks.append(idx[:: max(len(idx) // max_samples, 1)] if len(idx) >= 20 else idx[:0])
    counts = np.array([len(q) for q in picks])
    if not counts.any():
        return np.zeros(len(inside))
    d, _ = index.nearest(np.concatenate([px[j, q] for j, q in enumerate(picks)]), radius)
    hits = np.bincount(np.repeat(np.arange(len(inside)), counts), weights=np.isfinite(d), minlength=len(inside))
    return hits / np.maximum(counts, 1)


def still_paint_camera(view: PaintView, size, *, principal_point, pitch: PitchModel, detections, penalty_arcs: bool = True, min_sides: float | None = MIN_SIDES, more_splits: int = MORE_SPLITS, explain_circles: bool = False) -> tuple[Refinement | None, float | None]:
    """The paint initialiser (:func:`initialise_from_paint`) as for a frame
    without temporal help: with the detector's ellipses and lines, the centre
    circle's family refined, and hypotheses off the grass
    (:data:`arstream.support.ON_GRASS`) or along bright steps
    (:data:`arstream.support.ON_LINES`) left out. :func:`register_frame`'s
    (with the penalty arc's hypotheses, and the areas' sides on their paint:
    ``min_sides``, :data:`MIN_SIDES`; and when the first splits of its lines
    give nothing backed, ``more_splits``, :data:`MORE_SPLITS`), and the
    tracker's against its own fresh camera (without them:
    :func:`initialise_from_paint`). ``explain_circles``: hypotheses that
    leave the detector's centre circle unexplained left out
    (:func:`circle_verdict`; a still at a size it is judged at)."""
    return initialise_from_paint(view, size, principal_point=principal_point, pitch=pitch, circles=detections.ellipses, lines=detections.lines, min_on_grass=ON_GRASS, min_on_lines=ON_LINES, min_sides=min_sides, refine_family=True, penalty_arcs=penalty_arcs, more_splits=more_splits, explain_circles=explain_circles)


#: the least share of the detector's closed-circle ellipse (the centre circle)
#: that a still's camera must lay its markings on (:func:`circle_verdict`)
CIRCLE_EXPLAINED = 0.5
#: how near a projected marking an ellipse point must be to be explained
#: (a share of the frame's width; at least 2.5 px)
CIRCLE_REACH = 0.005


def circle_verdict(camera: Camera, ellipses, size, pitch: PitchModel, model: ModelSamples | None = None) -> str | None:
    """Why a still's camera is refused for leaving the detector's centre
    circle unexplained (None: it is not).

    The detector keeps an ellipse of kind "circle" only where a closed
    ring of line pixels fits one (:class:`arstream.detect.results.DetectedEllipse`);
    on the real reference frames every one is the centre circle and the
    reference camera lays a marking on all of its points (every ellipse the
    detector finds on the 27 reference frames under the clean, 480p,
    dimmed and soft variants of ``bench/real_graphics.py``: 1.00). A
    camera made from the frame's straight lines alone can instead lay
    another part of the pitch on them and still pass the line-support test:
    ``israel_league_wide`` frame 0 at 960 x 540 was registered with a
    penalty area drawn across the centre circle (line support 0.82),
    about 64 m from the right camera. Such a camera is refused where less
    than :data:`CIRCLE_EXPLAINED` of a circle ellipse's points lie within
    :data:`CIRCLE_REACH` times the width (at least 2.5 px) of a projected
    marking (:func:`arstream.solve.explained_share`).

    Parameters
    ----------
    camera : Camera of the frame (frame pixels)
    ellipses : sequence of DetectedEllipse, the detector's (frame pixels)
    size : (width, height) of the frame, pixels
    pitch : PitchModel the camera was made at
    model : its ModelSamples at 0.5 m, where the caller has them (else made here)

    Returns
    -------
    str (the reason) or None
    """
    W = size[0]
    circles = [e for e in ellipses or () if e.kind == "circle" and len(e.points) >= 6]
    if not circles:
        return None
    model = model or ModelSamples.from_pitch(pitch, 0.5)
    for e in circles:
        share = explained_share(camera, LineIndex(e.points), size, model, radius=max(2.5, CIRCLE_REACH * W))
        if share < CIRCLE_EXPLAINED:
            return f"its markings miss the centre circle's ellipse ({share:.0%} of its points explained)"
    return None


def paint_verdict(camera: Camera, support: float | None, spread: float, view: PaintView, size, pitch: PitchModel, min_support: float = 0.7, min_sides: float | None = None) -> str | None:
    """Why a frame's paint does not back a camera (None: it does), the test a
    camera without temporal help must pass (:func:`register_frame`; the
    tracker's fresh cameras, :class:`arstream.track.Tracker`).

    ``support``, ``spread``: the camera's line support on the frame's white
    paint and the share of its markings in view on paint
    (:func:`arstream.support.backed_support`). Backed: a support of at least
    ``min_support`` with half its markings on paint (:func:`arstream.support.backs`;
    an undefined support, too few markings in view, is no backing); its
    markings in view on the grass (:data:`arstream.support.ON_GRASS`: a long
    lens's camera too far away lays the far touchline on the stands, whose
    seats back it); and on painted lines, not along bright steps
    (:data:`arstream.support.ON_LINES`: a track's or the boards' edges back
    a marking as a line does); with ``min_sides`` (a still: :data:`MIN_SIDES`),
    the goal and penalty areas' sides in view on their paint
    (:func:`arstream.support.along_support`).
    """
    if support is None or not backs(support, spread, min_support):
        return f"{spread:.0%} of its markings in view on paint"
    if view.grass is not None and (g := on_grass(camera, view.grass, size, pitch)) is not None and g < ON_GRASS:
        return f"{g:.0%} of its markings in view on the grass"
    if (ln := on_lines(camera, view.image, view.bright, pitch)) is not None and ln < ON_LINES:
        return f"{ln:.0%} of its markings on paint along painted lines, not bright edges"
    if min_sides is not None and (a := along_support(camera, view.bright, pitch)) is not None and a < min_sides:
        return f"{a:.0%} of the goal and penalty areas' sides in view on paint"
    return None


def register_frame(detections, size, *, principal_point=None, pitch: PitchModel | None = None, estimate_k1: bool = True, image: np.ndarray | None = None, min_support: float = 0.7, estimate_size: bool = False, workers: int = 1, explain_circles: bool = True) -> CameraEstimate:
    """The camera of a single still (no temporal help): initialise from the centre
    circle or from line correspondences, then refine (with k1 when the view has
    enough line support). Returns a "lost" estimate when nothing fits.

    With the frame (``image``, BGR, the detections' size) the camera must also
    have a line support of at least ``min_support`` on white paint with half
    its markings in view on paint (:func:`arstream.support.backs`, the
    tracker's test); when the detector's lines give none that does, or one
    below :data:`PAINT_CHECK`, the paint initialiser
    (:func:`initialise_from_paint`, for real broadcast frames) is tried, and
    of two backed cameras the one with the higher :func:`paint_score` (by
    more than :data:`PAINT_SCORE_MARGIN`) kept; when neither is backed, the paint is looked at
    again at :data:`FAINT_CONTRAST` (its camera backed as any still's, and
    held to :data:`PAINT_CHECK` on the usual paint or on the faint paint it
    was found on: :func:`faint_support`).
    A camera the paint backs with less than :data:`PAINT_CHECK` is refined
    again from starts about it (:func:`nudged_camera`), whose best replaces
    it where the paint backs that one and it scores more by
    :data:`PAINT_SCORE_MARGIN`.
    With the frame, the detector's camera is
    judged by its paint even below INIT_ACCEPT (the ridge detector's recall
    on a real frame). The support is in ``info["support"]``. A "lost"
    estimate whose best camera the paint did not back carries that camera in
    ``info["unbacked"]`` (frame pixels; no result, for
    :func:`size_from_unbacked`).

    With ``estimate_size`` (and the frame), ``pitch`` is a prior, not a
    fact: the size the view constrains is estimated with the camera
    (:func:`size_from_view`) and the camera made with it, after the still
    is registered at the scan's grid of sizes where its markings fit
    ``pitch``'s camera poorly (:func:`size_from_scan`); the
    size is in ``info["pitch"]`` (a :class:`arstream.pitch_size.PitchSize`).
    The scan's sizes are registered on up to ``workers`` processes
    (:func:`size_from_scan`; default 1: here, one after another). A still
    lost at ``pitch`` is registered at the size its best unbacked camera's
    view gives, where that is another (:func:`size_from_unbacked`).

    ``explain_circles`` (with the frame): a camera that leaves the detector's
    centre circle unexplained (:func:`circle_verdict`) is no hypothesis of
    the paint's and no result ("lost", the reason says so). With
    ``estimate_size`` the result is judged so at the size it was made at,
    not the camera at ``pitch`` that a scan of sizes starts from: at a
    pitch of another size that camera can miss the circle where the
    scan's camera lays it right (a realistic synthetic still of a
    109.5 x 71.5 m pitch, ``real-wide`` 81 frame 0: 31 % of the circle
    explained at 105 x 68, registered 1.2 px off at 110 x 72).
    """
    W, H = size
    pitch = pitch or PitchModel()
    pp = np.array(principal_point if principal_point is not None else ((W - 1) / 2, (H - 1) / 2), dtype=np.float64)
    if estimate_size and image is not None:
        # (the default's camera is the scan's baseline: at a pitch of another
        # size it can miss the circle, and the scan's sizes then find the camera)
        est = register_frame(detections, size, principal_point=pp, pitch=pitch, estimate_k1=estimate_k1, image=image, min_support=min_support, explain_circles=False)
        if est.camera is None:
            # (lost at the default size: the size its best unbacked camera's view gives)
            est = size_from_unbacked(est, detections, size, image, pitch, pp, estimate_k1=estimate_k1, min_support=min_support)
        else:
            est = _with_size(est, detections, size, image, pitch, pp, estimate_k1, min_support, workers, explain_circles=explain_circles)
        if est.camera is not None and explain_circles and (why := circle_verdict(est.camera, detections.ellipses, size, est.info["pitch"].model(pitch.line_width))) is not None:
            return CameraEstimate.lost(0, 0.0, reason=f"no camera the frame supports (line support {est.info.get('support') or 0.0:.2f}, {why})")
        return est
    model = ModelSamples.from_pitch(pitch, 0.5)
    if detections is None or not getattr(detections, "pitch_visible", True) or len(detections.line_points) < 30:
        return CameraEstimate.lost(0, 0.0, reason=no_pitch_reason(detections, image))
    index = LineIndex(detections.line_points)
    r = initialise_camera(detections, index, size, model, principal_point=pp, pitch=pitch)
    # (with the frame, a camera the detector's few lines on a real frame leave
    # below INIT_ACCEPT is still judged by its paint, as the paint's are)
    if r is not None and ((r.confidence < INIT_ACCEPT and image is None) or not plausible(r.camera.center, r.camera.focal, W, pitch)[0]):
        r = None
    if r is not None and estimate_k1 and r.n_visible >= 250:
        try:
            rk = refine_camera(r.camera, index, size, model, estimate_k1=True, radii=(4.0, 2.5))
            if rk.confidence >= r.confidence - 0.01:
                r = rk
        except ValueError:
            pass
    sup = None
    if image is not None:
        verdicts: dict[int, str | None] = {}

        def unbacked(cam, sup, spread) -> str | None:
            """Why the frame's paint does not back ``cam`` (None: it does); judged once a camera."""
            if id(cam) not in verdicts:
                verdicts[id(cam)] = paint_verdict(cam, sup, spread, view, size, pitch, min_support, MIN_SIDES)
            return verdicts[id(cam)]

        def backed(cam, sup, spread) -> bool:
            return unbacked(cam, sup, spread) is None

        view = paint_view(image, detections)
        sup, spread = (None, 1.0) if r is None else backed_support(r.camera, view.bright, pitch)
        if r is None or not backed(r.camera, sup, spread) or sup < PAINT_CHECK:
            # (a backed camera from the detector's lines that still leaves much of
            # the paint off its markings: the paint's own may do better)
            rp, _ = still_paint_camera(view, size, principal_point=pp, pitch=pitch, detections=detections, explain_circles=explain_circles)
            if rp is not None:
                sp, spread_p = backed_support(rp.camera, view.bright, pitch)
                # (by the paint initialiser's own measure: a camera that lays a
                # few markings on one line or on the boards can have the higher
                # support while it leaves most of the frame's paint unexplained)
                if r is None or (backed(rp.camera, sp, spread_p) and not backed(r.camera, sup, spread)) or paint_score(rp.camera, sp or 0.0, view, size, model) > paint_score(r.camera, sup or 0.0, view, size, model) + PAINT_SCORE_MARGIN:
                    r, sup, spread = rp, sp, spread_p
        if r is None or not backed(r.camera, sup, spread):
            # (nothing backed from the paint at PAINT_CONTRAST: far, thin lines can
            # be fainter than that; the paint again at FAINT_CONTRAST, its camera
            # judged on the same white-paint mask and held to PAINT_CHECK)
            faint = paint_view(image, detections, contrast=FAINT_CONTRAST, bright=view.bright)
            rp, _ = still_paint_camera(faint, size, principal_point=pp, pitch=pitch, detections=detections, explain_circles=explain_circles)
            if rp is not None:
                sp, spread_p = backed_support(rp.camera, view.bright, pitch)
                if sp is not None and backed(rp.camera, sp, spread_p) and (sp >= PAINT_CHECK or faint_support(rp.camera, image, pitch) >= PAINT_CHECK):
                    r, sup, spread = rp, sp, spread_p
        if r is not None and sup is not None and sup < PAINT_CHECK:
            # (a camera that leaves much of the paint off its markings may sit in
            # a basin beside the right one, which no hypothesis started in)
            rn = nudged_camera(r.camera, view, size, pitch)
            if rn is not None:
                sn, spread_n = backed_support(rn.camera, view.bright, pitch)
                if sn is not None and backed(rn.camera, sn, spread_n) and paint_score(rn.camera, sn, view, size, model) > paint_score(r.camera, sup, view, size, model) + PAINT_SCORE_MARGIN:
                    r, sup, spread = rn, sn, spread_n
        if r is not None and (why := unbacked(r.camera, sup, spread) or (circle_verdict(r.camera, detections.ellipses, size, pitch, model) if explain_circles else None)) is not None:
            return CameraEstimate.lost(0, 0.0, reason=f"no camera the frame supports (best line support {0.0 if sup is None else sup:.2f}, {why})", unbacked=r.camera)
    if r is None:
        seen = "" if image is None else f" (the paint shows {paint_seen(view, detections)})"
        return CameraEstimate.lost(0, 0.0, reason=f"no camera fits the detected markings{seen}")
    camera = r.camera
    info = {"rms": r.rms, "n_visible": r.n_visible}
    if sup is not None:
        info["support"] = sup
    return CameraEstimate(0, 0.0, "ok", camera, r.confidence, info)


#: a picture whose colour channels differ by at most this many levels on
#: 99 % of its pixels has no colour (a grayscale still, or a grayscale clip
#: through a codec's chroma rounding: 3 levels): its grass cannot be found
#: (grass is green by at least 4 levels more: :func:`arstream.detect.paint.grass_beside`)
COLOURLESS_LEVELS = 4


def no_pitch_reason(detections, image: np.ndarray | None = None) -> str:
    """Why a still shows no pitch to register (:func:`register_frame`'s
    reason): a picture without colour (the grass is found by its green), no
    grass in view, or too few marking pixels on it. ``image``: the frame, BGR.

    >>> no_pitch_reason(None, np.full((4, 4, 3), 90, np.uint8))
    'no pitch: the picture has no colour (the grass is found by its green)'
    """
    if image is not None:
        b, g, r = (image[::4, ::4, c].astype(np.int16) for c in range(3))
        if np.percentile(np.maximum(np.abs(b - g), np.abs(g - r)), 99) <= COLOURLESS_LEVELS:
            return "no pitch: the picture has no colour (the grass is found by its green)"
    if detections is None or not getattr(detections, "pitch_visible", True):
        return "no pitch: no grass in view"
    return f"no pitch markings: {len(detections.line_points)} line pixels on the grass"


def paint_seen(view: PaintView, detections) -> str:
    """What a frame's paint shows the initialisers, for a lost still's
    reason: its straight lines (:attr:`PaintView.lines`), the detector's
    centre-circle ellipses and the penalty arcs (:attr:`PaintView.arcs`).

    >>> class Seen: lines, arcs = [object()], []
    >>> class Found: ellipses = []
    >>> paint_seen(Seen(), Found())
    '1 straight line, no centre circle, no penalty arc'
    """

    def count(n: int, what: str) -> str:
        return f"no {what}" if n == 0 else f"{n} {what}{'s' if n > 1 else ''}"

    return ", ".join([count(len(view.lines), "straight line"), count(len(detections.ellipses), "centre circle"), count(len(view.arcs), "penalty arc")])


def size_from_view(camera: Camera, support: float, view: PaintView, size, pitch: PitchModel, min_support: float = 0.7, *, ground: np.ndarray | None = None):
    """A still's pitch size and its camera (:func:`register_frame` with
    ``estimate_size``).

    The size the view constrains is estimated with the camera from the
    frame's paint pixels (:func:`arstream.pitch_size.estimate_view_size`,
    ``pitch`` as the prior). An estimate within two of its standard
    deviations of ``pitch`` is no other size (:meth:`PitchSize.within_noise`,
    as a clip's estimate is judged). Another is kept when the frame's paint
    backs its camera (:func:`paint_verdict` at the estimated size) and
    ``camera`` does not fit the paint clearly better: of the points of the
    markings in view that the two cameras lay on different places, ``camera``
    lays fewer than :data:`arstream.pitch_size.STILL_GAIN_RATIO` times as
    many on paint as the estimate's (:func:`arstream.pitch_size.size_dispute`).
    On a real frame paint the markings do not cover (the boards, another
    sport's lines) can draw the fit off, and the paint, not the fit's own
    residuals, judges a camera (with ``ground``, also where it shows no
    paint: a marking one camera draws on bare grass, missing there, that the
    other draws wholly outside the picture). The two cameras are compared point for point,
    not by their line supports: those are shares of different points (on a
    realistic synthetic still of a 103.5 x 74 m pitch the 105 x 68 camera
    scores 0.989 and is drawn 14.9 px off; the estimate's, at 104.6 x 72.7,
    scores 0.935 and is drawn 3.9 px off. Of the 700 points the two dispute,
    the first lays 2 on paint, the second 36: bench/README.md "Stop 56").
    The estimate needs no margin over ``camera``, as a scan's size does over
    the default (:func:`arstream.pitch_size.choose_still_size`): it is the
    view's own measure, beyond the noise of the default already.

    Parameters
    ----------
    camera : Camera of the frame at ``pitch``, backed by its paint (frame pixels)
    support : its line support on ``view``'s white paint
    view : PaintView of the frame
    size : (width, height) of the frame, pixels
    pitch : PitchModel the camera was made at
    ground : (H, W) bool or None, the frame's bare grass (:func:`bare_grass`):
        a marking one camera draws there, missing, that the other draws
        wholly outside the picture, counts against it in the point-for-point
        comparison (:func:`arstream.support.paint_dispute`)

    Returns
    -------
    (Camera, PitchSize, support): the estimate's camera, size and support, or
    ``camera``, ``pitch``'s size (source "default") and ``support``.
    """
    kept = (camera, PitchSize(pitch.length, pitch.width, source="default", views=1), support)
    if support is None:
        return kept
    got = _view_estimate(camera, view, size, pitch)
    if got is None or not got.cameras or got.within_noise((pitch.length, pitch.width)):
        return kept
    other = got.model(pitch.line_width)
    sup, spread = backed_support(got.cameras[0], view.bright, other)
    if sup is None or paint_verdict(got.cameras[0], sup, spread, view, size, other, min_support, MIN_SIDES) is not None:
        return kept
    dispute = size_dispute([camera, got.cameras[0]], [pitch, other], view.bright, ground=ground)(0, 1)
    if dispute.for_first >= STILL_GAIN_RATIO * dispute.for_second:
        return kept
    # (the camera is returned on its own: the size's copy would be in the frame's pixels it was fitted in)
    return got.cameras[0], replace(got, cameras=()), sup


def _view_estimate(camera: Camera, view: PaintView, size, pitch: PitchModel) -> PitchSize | None:
    """The size ``camera``'s view of the frame's paint constrains
    (:func:`arstream.pitch_size.estimate_view_size` on ``view``'s paint
    pixels, ``pitch`` the prior); None where too few of the markings in view
    matched the paint."""
    try:
        return estimate_view_size(camera, view.points, size, pitch)
    except ValueError:
        return None


def size_from_unbacked(est: CameraEstimate, detections, size, image: np.ndarray, pitch: PitchModel, principal_point, *, estimate_k1: bool = True, min_support: float = 0.7) -> CameraEstimate:
    """A still lost at ``pitch`` (the default, 105 x 68 m) registered at the
    size its view gives, where that view fixes another size
    (:func:`register_frame` with ``estimate_size``).

    A wide view of a pitch of another size (a 105 x 74 m pitch with both
    penalty areas and both touchlines in view) can leave every camera at
    105 x 68 unbacked: fitted to the touchlines 6 m too close together, its
    penalty areas miss their paint (15-34 % of their sides on paint,
    ``real-wide`` 92 frames 75 and 125), and the scan of sizes never starts,
    since it needs a camera to compare against. The best camera the paint
    did not back (``est.info["unbacked"]``) is still near the view's: the
    size the view constrains is estimated with it
    (:func:`arstream.pitch_size.estimate_view_size`, ``pitch`` the prior),
    and where that estimate is another size than ``pitch`` (beyond two of
    its standard deviations along a dimension the view fixes,
    :meth:`arstream.pitch_size.PitchSize.within_noise`) the still is
    registered again at it, with every test a still's camera passes. Its
    camera is kept only where its markings fit the frame at that size as a
    still's must to need no scan (line support at least
    :data:`arstream.pitch_size.SCAN_BELOW`) and the size its view gives,
    measured again from it, is that size (within its noise: a camera and a
    size that agree, as a clip's probe is kept where a run at it estimates
    it back): with no camera at ``pitch`` to compare against, the size is
    the view's own measurement and its camera must fit it well (a camera
    made at a size the view does not fix stays unmade: the estimate keeps
    ``pitch`` along such a dimension). On ``real-wide`` 92 frames 75 and
    125: 105.2 x 73.4 -> 105.2 x 73.5 and 105.1 x 73.7 -> 105.3 x 74.1 m.

    Parameters
    ----------
    est : the "lost" CameraEstimate of :func:`register_frame` at ``pitch``
        (``info["unbacked"]``: its best camera the paint did not back, frame
        pixels; absent where no camera fitted the markings)
    detections, size, image, pitch, principal_point, estimate_k1, min_support :
        as :func:`register_frame`

    Returns
    -------
    CameraEstimate: the registration at the estimated size (``info["pitch"]``
    the :class:`arstream.pitch_size.PitchSize` "estimated", ``info["support"]``
    its line support on white paint), or ``est``.
    """
    camera = est.info.get("unbacked")
    if camera is None:
        return est
    view = paint_view(image, detections)
    got = _view_estimate(camera, view, size, pitch)
    if got is None or not got.cameras or got.within_noise((pitch.length, pitch.width)):
        return est
    other = got.model(pitch.line_width)
    again = register_frame(detections, size, principal_point=principal_point, pitch=other, estimate_k1=estimate_k1, image=image, min_support=min_support, explain_circles=False)
    if again.camera is None:
        return est
    fits = _line_support(again, bright_mask(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)), other)
    if fits is None or fits < SCAN_BELOW:
        return est
    # (and its view, measured again from that camera, gives that size back)
    back = _view_estimate(again.camera, view, size, other)
    if back is None or not back.within_noise((other.length, other.width)):
        return est
    return replace(again, info={**again.info, "pitch": replace(got, cameras=())})


def _with_size(est: CameraEstimate, detections, size, image: np.ndarray, pitch: PitchModel, pp, estimate_k1: bool, min_support: float, workers: int = 1, *, explain_circles: bool = True) -> CameraEstimate:
    """``est`` (:func:`register_frame` at ``pitch``) with the still's size
    estimated (``register_frame(estimate_size=True)``): from its camera
    (:func:`size_from_view`), kept where the frame's line support of that
    camera at that size (docs/evaluate.md) is at least
    :data:`arstream.pitch_size.SCAN_BELOW` (or has too few markings in view
    to be measured) and it explains the detector's centre circle, if any
    (:func:`circle_verdict`, with ``explain_circles``); else the scan's
    size whose camera fits the frame clearly better, if any
    (:func:`size_from_scan`).

    A camera that misses the detector's circle fits the frame poorly
    whatever its line support (:func:`register_frame` refuses the still
    with it). A penalty view with the circle's edge in a corner shows the
    pitch's length (the circle's distance from the penalty area), and at
    105 x 68 a camera laid on the area's lines misses the circle of a
    101 m pitch (0 % of its points explained, line support 0.98:
    ``real-penalty`` 94 frame 0); the scan's sizes, whose cameras must
    explain the circle, find it (100 x 72, then 100.7 x 69.7 estimated from
    there, 2.4 px from the truth).

    ``est`` has a camera. A still without one at ``pitch`` is never scanned:
    with no camera to compare against, another size's camera is not
    evidence of the size (an ``israel_league_wide`` frame a third hidden by
    a bar, lost at 105 x 68, gives at every 72 m wide size a camera with a
    line support of 0.97 that is 13-22 px off: tests/test_paint.py); only
    the size its own view measures is (:func:`size_from_unbacked`)."""
    luma = bright_mask(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY))
    graphics = graphics_mask(detections, size)
    if graphics is not None:
        luma = luma & (graphics == 0)
    view = paint_view(image, detections)
    ground = bare_grass(detections, size, graphics)
    camera, made_at, sup = size_from_view(est.camera, est.info.get("support"), view, size, pitch, min_support, ground=ground)
    own = replace(est, camera=camera, info={**est.info, "support": sup, "pitch": made_at})
    fits = _line_support(own, luma, made_at.model(pitch.line_width))
    # (a camera with too few markings in view for a line support is no poor
    # fit; one that misses the detector's circle is)
    misses = explain_circles and circle_verdict(camera, detections.ellipses, size, made_at.model(pitch.line_width)) is not None
    if (fits is None or fits >= SCAN_BELOW) and not misses:
        return own
    got, made_at = size_from_scan(detections, size, image, own, view, luma, pitch, pp, estimate_k1=estimate_k1, min_support=min_support, workers=workers, ground=ground)
    return replace(got, info={**got.info, "pitch": made_at})


def _line_support(est: CameraEstimate, luma: np.ndarray, pitch: PitchModel) -> float | None:
    """The line support (docs/evaluate.md) of ``est``'s camera on the frame's
    bright mask ``luma`` at ``pitch``; None without a camera or markings in view."""
    return None if est.camera is None else line_support(est.camera, luma, marking_points(pitch)).share


def _register_at(job) -> CameraEstimate:
    """:func:`register_frame` of one size of a still's scan (a worker's job of
    :func:`size_from_scan`): ``job`` is (detections, size, principal_point,
    pitch, estimate_k1, image, min_support)."""
    detections, size, pp, pitch, estimate_k1, image, min_support = job
    return register_frame(detections, size, principal_point=pp, pitch=pitch, estimate_k1=estimate_k1, image=image, min_support=min_support)


def size_from_scan(detections, size, image: np.ndarray, est: CameraEstimate, view: PaintView, luma: np.ndarray, pitch: PitchModel, principal_point, *, estimate_k1: bool = True, min_support: float = 0.7, workers: int = 1, ground: np.ndarray | None = None):
    """A still's pitch size and its camera when its camera at ``pitch`` fits
    the frame's markings poorly (line support below
    :data:`arstream.pitch_size.SCAN_BELOW`; :func:`register_frame` with
    ``estimate_size``).

    A wrong size can put the camera on the wrong paint (the far touchline on
    the boards' edge), and refining from there does not reach the right
    one. The still is registered again at
    each other size of the scan's grid (:data:`arstream.pitch_size.SCAN_LENGTHS`
    x :data:`arstream.pitch_size.SCAN_WIDTHS`, each camera held to the
    frame's paint as at ``pitch``), the size chosen by the line support of
    each size's camera (docs/evaluate.md, the clip's scan's measure:
    :func:`arstream.pitch_size.choose_still_size`), then the size that view
    constrains estimated from its camera (:func:`size_from_view`, the chosen
    size the prior).

    Parameters
    ----------
    detections : the frame's Detections
    size : (width, height) of the frame, pixels
    image : (H, W, 3) uint8 BGR, the frame
    est : CameraEstimate of the frame made at ``pitch``, with its camera and
        the size estimated from it (:func:`size_from_view`; ``info["pitch"]``).
        Its line support at that size is the default's entry of the scan:
        another size must beat the default camera as its own estimate left
        it, as a clip's scan judges the estimate from the default's views
        (:func:`arstream.pitch_size.with_size`)
    view : PaintView of the frame
    luma : (H, W) bool, :func:`arstream.support.bright_mask` of the frame's luma
    pitch : PitchModel ``est`` was made at (the grid's centre where on it)
    ground : (H, W) bool, the frame's bare grass (:func:`bare_grass`; made
        here where None): the sizes' cameras are compared on it too
    principal_point : (2,) px
    workers : most processes the sizes are registered on, one size each
        (:func:`arstream.workers.map_in_processes`; default 1: here, one
        after another). The result is the same either way. More than one
        starts worker processes, which import the caller's main module:
        a script needs the ``if __name__ == "__main__":`` guard, as with
        any multiprocessing start method but fork

    Returns
    -------
    (CameraEstimate, PitchSize): the registration at the chosen size with
    the camera and support of :func:`size_from_view`, and its size, which
    carries the scan (:class:`arstream.pitch_size.SizeScan`, one frame):
    "scanned" where the chosen grid size is kept as it is. Where the
    default is kept, ``est`` and its size.
    """
    sizes = still_scan_sizes(pitch)
    jobs = [(detections, size, principal_point, PitchModel(L, W, pitch.line_width), estimate_k1, image, min_support) for L, W in sizes[1:]]
    found = map_in_processes(_register_at, jobs, workers=workers, preload=("arstream.initialise",))
    if ground is None:
        ground = bare_grass(detections, size)
    est = _default_from_scan(est, found, detections, size, view, pitch, estimate_k1, min_support, ground)
    ests = [est, *found]
    models = [est.info["pitch"].model(pitch.line_width)] + [PitchModel(*sz, pitch.line_width) for sz in sizes[1:]]
    scan = choose_still_size(sizes, [_line_support(e, luma, m) for e, m in zip(ests, models)], size_dispute([e.camera for e in ests], models, luma, ground=ground))
    if scan.chosen == 0:
        return est, replace(est.info["pitch"], scan=scan)
    best = found[scan.chosen - 1]
    camera, got, sup = size_from_view(best.camera, best.info.get("support"), view, size, PitchModel(*scan.size, pitch.line_width), min_support, ground=ground)
    if got.source == "default":
        got = PitchSize(*scan.size, source="scanned", views=1)
    return replace(best, camera=camera, info={**best.info, "support": sup}), replace(got, scan=scan)


def _default_from_scan(est: CameraEstimate, found: list[CameraEstimate], detections, size, view: PaintView, pitch: PitchModel, estimate_k1: bool, min_support: float, ground: np.ndarray | None = None) -> CameraEstimate:
    """:func:`size_from_scan`'s default entry (``est``, made at ``pitch``)
    made again from the scan's cameras at the other sizes (``found``), where
    that gives a camera the paint backs better.

    The paint initialiser keeps the best few of its line hypotheses before
    refining them, and which pairs of the frame's lines make the right
    camera's start can depend on the pitch's size: ``israel_league_wide``
    frame 400 at 960 x 540 was registered at 105 x 68 with a camera laid
    along the running track (line support 0.70, 299 px off its reference),
    while its camera at every other size of the grid was right (0.97-0.99),
    and the size rule (point for point, :func:`arstream.pitch_size.choose_still_size`)
    kept the default's. The other sizes' cameras, refined at ``pitch`` and
    judged as the paint's hypotheses are (:func:`_best_from_paint`, with the
    still's tests of grass, lines, the areas' sides and the centre circle),
    replace ``est``'s camera when the paint backs the best of them
    (:func:`paint_verdict`) and it scores more by :data:`PAINT_SCORE_MARGIN`
    (:func:`paint_score`, the rule between a still's cameras). The size
    estimated from that view (:func:`size_from_view`) goes with it.

    ``ground``: the frame's bare grass, for :func:`size_from_view`.

    Returns ``est`` or the estimate made again (``info``: its support and
    size).
    """
    seeds = [e.camera for e in found if e.camera is not None]
    if not seeds:
        return est
    made_at = est.info["pitch"].model(pitch.line_width)
    if (made_at.length, made_at.width) != (pitch.length, pitch.width):
        return est  # (its own view's size: not the grid's default to make again)
    rb, sb = _best_from_paint(seeds, view, size, pitch, estimate_k1, ON_GRASS, ON_LINES, MIN_SIDES, circles=detections.ellipses)
    if rb is None:
        return est
    sb, spread = backed_support(rb.camera, view.bright, pitch)
    if paint_verdict(rb.camera, sb, spread, view, size, pitch, min_support, MIN_SIDES) is not None:
        return est
    model = ModelSamples.from_pitch(pitch, 0.5)
    old = est.info.get("support")
    if paint_score(rb.camera, sb, view, size, model) <= paint_score(est.camera, old or 0.0, view, size, model) + PAINT_SCORE_MARGIN:
        return est
    camera, got, sup = size_from_view(rb.camera, sb, view, size, pitch, min_support, ground=ground)
    return CameraEstimate(est.frame, est.pts, "ok", camera, rb.confidence, {**est.info, "rms": rb.rms, "n_visible": rb.n_visible, "support": sup, "pitch": got})


def register_image(image: np.ndarray, *, pixel_aspect: float = 1.0, pitch: PitchModel | None = None, workers: int = 1) -> CameraEstimate:
    """``arstream register`` on one BGR frame: the camera of the frame (frame
    pixels) or a "lost" estimate with the reason.

    ``pitch`` is the pitch's size where it is known. Without it the size is
    a per-still unknown: the camera is made at 105 x 68 m (or, where its
    markings fit that camera poorly, at the size of the scan's grid whose
    camera they fit best: :func:`size_from_scan`), then the size the
    view constrains is estimated with it (:func:`size_from_view`). The size
    the camera was made at is in ``info["pitch"]``
    (:class:`arstream.pitch_size.PitchSize`: "given", "estimated",
    "scanned" or "default").

    The picture inside black bars (:func:`arstream.imaging.active_area`) is
    analysed on its own, with the frame's principal point (its centre), at
    the analysis size (:class:`arstream.pipeline.stages.Analysis` with the
    picture as its ``area``, as ``process`` analyses a clip: square pixels
    for the solver, ``pixel_aspect`` mapped back; the detector told how much
    that enlarged the picture, :attr:`Analysis.enlarged`), then
    :func:`register_frame` with the picture; the camera is mapped back to the
    whole frame. ``workers``: the processes a scan of sizes runs on
    (:func:`size_from_scan`; ``arstream register`` uses every core).
    """
    from arstream.detect import detect
    from arstream.imaging import active_area
    from arstream.pipeline.stages import Analysis

    H, W = image.shape[:2]
    an = Analysis(W, H, None, pixel_aspect=pixel_aspect, area=active_area(image))
    x0, y0, x1, y1 = an.crop
    # (square pixels for the solver: a frame of other pixels stretched, bicubic)
    frame = cv2.resize(image, an.scaled, interpolation=cv2.INTER_CUBIC) if an.scaling else image
    work = np.ascontiguousarray(frame[y0:y1, x0:x1]) if an.cropped else frame
    est = register_frame(detect(work, enlarged=an.enlarged), (an.w, an.h), principal_point=an.principal_point, image=work, pitch=pitch, estimate_size=pitch is None, workers=workers)
    if pitch is not None and est.camera is not None:
        est.info["pitch"] = PitchSize(pitch.length, pitch.width, source="given")
    if est.camera is None:
        # (an unbacked camera is in the solver's pixels, and no result)
        return replace(est, info={k: v for k, v in est.info.items() if k != "unbacked"})
    return CameraEstimate(est.frame, est.pts, est.status, an.camera(est.camera), est.confidence, est.info)
