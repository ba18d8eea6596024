"""The pitch's size chosen by line support: a clip tracked again at other
sizes (issue 29, item 4; the rule is :func:`arstream.pitch_size.choose_size`).

:func:`arstream.pipeline.process` runs a clip at the default 105 x 68 m as
always. When the frames' paint backs its cameras poorly (median line support
below :data:`arstream.pitch_size.SCAN_BELOW`), :func:`scan_sizes` decodes
and detects the clip's first frames once more (at most
:data:`SCAN_MAX_FRAMES`; twice when a first size wins) and tracks each frame
with one tracker per size, the default's included, so that the sizes are
judged on the same frames, detections and tracker; when another size wins,
``process`` runs the clip again at it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Callable


from arstream.pipeline.runner import Pipeline
from arstream.pipeline.stage import Item, Stage
from arstream.pipeline.stages import Analysis, DetectStage
from arstream.pipeline.summary import Summary
from arstream.pitch_size import PitchSize, SizeScan, choose_size, compared_point_for_point, corresponding_points, diagonal_step, grid_neighbours, on_frames, with_size
from arstream.support import frame_mask, marking_points, paint_dispute, pixel_support, within_reach

__all__ = ["SizeScanStage", "SizesTracked", "track_sizes", "scan_sizes", "scan_passes", "check_size", "SCAN_MAX_FRAMES"]

#: most frames a scan tracks (a clip's first 30 s at 25 fps: the views of
#: half a minute of play judge the size as a match's would, and each pass
#: tracks every frame at up to five sizes)
SCAN_MAX_FRAMES = 750


#: while a scan's tracker is lost, it runs the paint initialiser (0.5-4 s a
#: call) once in this many seconds of video (the tracker's own default is
#: every 4 frames), and checks a fresh camera from the detector's lines
#: against it as rarely (the tracker's own: each one): a size that loses the
#: camera is the wrong one, and the scan's cost is its initialisations
SCAN_PAINT_SECONDS = 1.0


#: a size's scan tracker that, from its first camera on, has one on fewer
#: than half of this many frames does not follow the clip
#: (:attr:`SizeScanStage.gave_up`)
SCAN_GIVE_UP_FRAMES = 50

#: a size's scan tracker that has found no camera in this many frames does
#: not follow the clip: it initialises less often than the run it judges
#: (once in :data:`SCAN_PAINT_SECONDS`), so its first camera may come a
#: second or two after the run's, but not six
SCAN_FIRST_CAMERA_FRAMES = 150


def _not_following(supports) -> bool:
    """Whether a scan's tracker of one size does not follow the clip:
    ``supports`` its frames' line supports so far (None: no camera), and it
    has found no camera in :data:`SCAN_FIRST_CAMERA_FRAMES` frames, or has
    one on fewer than half of the :data:`SCAN_GIVE_UP_FRAMES` frames from its
    first camera on."""
    start = next((i for i, x in enumerate(supports) if x is not None), None)
    if start is None:
        return len(supports) >= SCAN_FIRST_CAMERA_FRAMES
    window = supports[start : start + SCAN_GIVE_UP_FRAMES]
    return len(window) == SCAN_GIVE_UP_FRAMES and sum(x is not None for x in window) < SCAN_GIVE_UP_FRAMES / 2


class _UnlessGaveUp(Stage):
    """Passes frames on until the scan gave up (no detection after that)."""

    name = "scan"

    def __init__(self, scan: "SizeScanStage"):
        self.scan = scan

    def process(self, item: Item) -> list[Item]:
        return [] if self.scan.gave_up else [item]


@dataclass
class SizesTracked:
    """What a scan's pass found at each size, frame by frame.

    Attributes
    ----------
    supports : per size, each frame's line support (None: no camera)
    cameras : per size, each frame's camera on the frame's pixels (None: none)
    disputes : {(size_a, size_b): PaintDispute} summed over the frames both
        gave a camera, for each pair of the pass's sizes and each of its sizes
        with each earlier size (``rivals``) that the choice may weigh against
        each other (:func:`arstream.pitch_size.compared_point_for_point`),
        counting the points in view of both
        (:func:`arstream.support.paint_dispute`, ``in_both``)
    fine : per size, each frame's on-paint share: line support on the bright
        pixels themselves, undilated (``frame_mask(frame, reach=0)``; None: no
        camera), which still tells sizes apart where the 2 px support saturates
    seen : with ``watch``, per size, the size its tracker's views estimate
        (:meth:`arstream.track.Tracker.pitch_seen`; None with too few views);
        else empty
    """

    supports: list = field(default_factory=list)
    cameras: list = field(default_factory=list)
    disputes: dict = field(default_factory=dict)
    fine: list = field(default_factory=list)
    seen: list = field(default_factory=list)


class SizeScanStage(Stage):
    """Each frame tracked at several pitch sizes, its line support kept per size,
    and each size's camera compared with every other's point for point.

    One :class:`arstream.track.Tracker` per size, causal (``lag`` 0: the
    scan only judges the sizes, it draws nothing), all fed the same analysis
    frame and detections; each camera judged by its line support on the
    frame at its own size, and against each other size's camera of the frame
    that the choice may weigh it against
    (this pass's, and ``rivals``', tracked by an earlier pass over the same
    frames) by where the two lay the same markings on the frame's paint
    (:func:`arstream.support.paint_dispute`, on the points in view of both).

    Parameters
    ----------
    analysis : Analysis of the clip
    sizes : sequence of (length, width) in metres
    fps : the clip's frame rate
    rivals : optional {(length, width): cameras per frame} of earlier passes
    watch : each tracker keeps the views a size's estimate takes
        (``watch_pitch``), for :attr:`SizesTracked.seen`
    """

    name = "track"

    def __init__(self, analysis: Analysis, sizes, fps: float, rivals=None, watch: bool = False):
        from arstream.initialise import FrameViews
        from arstream.track import Tracker, TrackerConfig
        from geometry.pitch import PitchModel

        self.analysis = analysis
        every = max(1, round(fps * SCAN_PAINT_SECONDS))
        cfg = TrackerConfig(paint_every=every, rival_every=every)
        views = FrameViews()  # (a frame's paint, made once for every size)
        self.trackers = [Tracker(analysis.w, analysis.h, fps=fps, lag=0, principal_point=analysis.principal_point, support_reach=analysis.support_reach, pitch=PitchModel(L, W), config=cfg, views=views, watch_pitch=watch) for L, W in sizes]
        self.points = [marking_points(t.pitch) for t in self.trackers]
        self.sizes = [(float(L), float(W)) for L, W in sizes]
        self.rivals = {tuple(map(float, k)): v for k, v in (rivals or {}).items() if tuple(map(float, k)) not in self.sizes}
        #: each pair (earlier, later) compared: this pass's pairs and each of its
        #: sizes with each rival, of those the choice may weigh against each other
        pairs = [(a, b) for i, b in enumerate(self.sizes) for a in list(self.rivals) + self.sizes[:i] if compared_point_for_point(a, b)]
        self._samples = {(a, b): corresponding_points(PitchModel(*a), PitchModel(*b)) for a, b in pairs}
        self.tracked = SizesTracked([[] for _ in sizes], [[] for _ in sizes], {}, [[] for _ in sizes])

    @property
    def supports(self) -> list[list]:
        """Per size, each frame's line support (docs/evaluate.md, on the frame
        at its own size; None: no camera)."""
        return self.tracked.supports

    @property
    def gave_up(self) -> bool:
        """No size's tracker follows this clip (:func:`_not_following`), so
        the scan stops tracking: there is nothing to judge the sizes by
        (:func:`arstream.pitch_size.choose_size` keeps the default). Judged
        over every size, not only the default's: a wrong size loses the
        camera where the paint refutes it (a synthetic 104.5 x 74.5 m pitch:
        at 105 x 68 a camera on 8 of the first 125 frames, at 105 x 72 on 50,
        the size that wins), and judged from each tracker's first camera, not
        the clip's first frame (the scan's trackers initialise once a
        second)."""
        return bool(self.supports) and all(_not_following(s) for s in self.supports)

    def process(self, item: Item) -> list[Item]:
        if self.gave_up:
            return []
        image = self.analysis.image(item)  # (first: it may make the thumbnail)
        mask = on_paint = None
        frame = len(self.tracked.supports[0])
        cams = {}
        for tracker, points, size, supports, cameras, fine in zip(self.trackers, self.points, self.sizes, self.tracked.supports, self.tracked.cameras, self.tracked.fine):
            (est,) = tracker.process(item.index, item.pts, image, item.detections, thumbnail=item.thumbnail)
            cam = self.analysis.camera(est.camera)
            cameras.append(cam)
            if cam is None:
                supports.append(None)
                fine.append(None)
                continue
            if mask is None:
                on_paint = frame_mask(item.frame, reach=0)
                mask = within_reach(on_paint)
            px = cam.project(points)  # (one projection, judged on both masks)
            supports.append(pixel_support(px, mask).share)
            fine.append(pixel_support(px, on_paint).share)
            cams[size] = cam
        for (a, b), (pa, pb) in self._samples.items():
            ca = cams.get(a) if a in cams else (self.rivals[a][frame] if a in self.rivals and frame < len(self.rivals[a]) else None)
            cb = cams.get(b)
            if ca is None or cb is None:
                continue
            d = paint_dispute(ca, pa, cb, pb, mask, in_both=True)
            self.tracked.disputes[(a, b)] = self.tracked.disputes[(a, b)] + d if (a, b) in self.tracked.disputes else d
        return [item]


def track_sizes(source, analysis: Analysis, sizes, *, rivals=None, watch: bool = False, detect_stage: Callable[[DetectStage], Stage] = lambda st: st, max_frames: int | None = None, progress: Callable | None = None, handle_signals: bool = True, decode_nice: int = 0) -> tuple[SizesTracked, Summary]:
    """Track the clip's first frames (at most ``max_frames``) at each of ``sizes``.

    Parameters
    ----------
    source : an open :class:`arstream.source.VideoSource` at the clip's start
    analysis : Analysis of the clip (the size the first run analysed at)
    sizes : sequence of (length, width) in metres
    rivals : optional {(length, width): cameras per frame} tracked by an
        earlier pass over the same frames, to compare ``sizes``' cameras with
    watch : also estimate the size each size's views give
        (:attr:`SizesTracked.seen`)
    detect_stage : wraps the detector's stage (e.g. on a worker thread)
    max_frames, progress, handle_signals : as for :func:`arstream.pipeline.process`
    decode_nice : niceness of the decode thread

    Returns
    -------
    (SizesTracked, the Summary of the run)

    Raises
    ------
    Interrupted : stopped by a signal
    """
    W, H = source.width, source.height
    scan = SizeScanStage(analysis, sizes, source.fps, rivals=rivals, watch=watch)
    pipe = Pipeline(source, [_UnlessGaveUp(scan), detect_stage(DetectStage(W, H, analysis=analysis)), scan], progress=progress, max_frames=max_frames, decode_nice=decode_nice, prepare=analysis.prepare)
    summary = pipe.run(handle_signals=handle_signals)
    if watch:
        scan.tracked.seen = [t.pitch_seen() for t in scan.trackers]
    return scan.tracked, summary


def _frames_limit(max_frames: int | None) -> int:
    """Frames a scan's pass tracks: the run's ``max_frames`` (None: all), at most :data:`SCAN_MAX_FRAMES`."""
    return SCAN_MAX_FRAMES if max_frames is None else min(int(max_frames), SCAN_MAX_FRAMES)


def scan_sizes(open_source: Callable, analysis: Analysis, *, max_frames: int | None = None, **kwargs) -> tuple[SizeScan, float, float]:
    """Choose the pitch's size of a clip that fits 105 x 68 poorly.

    The sizes one grid step from 105 x 68 along each axis
    (:func:`arstream.pitch_size.grid_neighbours`) are tracked with it, on
    the clip's first frames (at most :data:`SCAN_MAX_FRAMES`); when one of
    them wins (:func:`arstream.pitch_size.choose_size`), that one's
    neighbours too, in a second pass (a length and a width both off); when
    none wins but one step along each axis leans above 105 x 68, the size
    two steps off that takes both (:func:`arstream.pitch_size.diagonal_step`). The
    choice is :func:`~arstream.pitch_size.choose_size` over every size
    tracked (:func:`scan_passes`): all of them on the same frames by the
    same causal tracker, so their line supports compare, frame by frame.

    Parameters
    ----------
    open_source : callable() -> a context manager giving a fresh
        :class:`arstream.source.VideoSource` at the clip's start
    analysis : Analysis of the clip
    max_frames : frames of the clip the first run processed (None: all)
    kwargs : as for :func:`track_sizes`

    Returns
    -------
    (SizeScan, wall seconds, CPU seconds) of the scan's passes

    Raises
    ------
    Interrupted : stopped by a signal
    """
    limit = _frames_limit(max_frames)
    spent = [0.0, 0.0]

    def track(sizes, rivals):
        with open_source() as src:
            got, summary = track_sizes(src, analysis, sizes, rivals=rivals, max_frames=limit, **kwargs)
        spent[0] += summary.seconds
        spent[1] += summary.cpu_seconds
        return got

    return scan_passes(track), spent[0], spent[1]


def check_size(open_source: Callable, analysis: Analysis, scan: SizeScan, size, *, max_frames: int | None = None, **kwargs) -> tuple[SizeScan, float, float, PitchSize | None]:
    """One more size judged against a scan's: ``size`` tracked on the scan's
    frames by the scan's tracker, and the choice made again over every size
    (:func:`arstream.pitch_size.with_size`), its cameras compared with the
    scan's sizes' point for point on the same frames. The tracker keeps the
    views a size's estimate takes, and the size they estimate comes back
    too: views made at a size metres off pull their estimate towards it,
    so a size that is not the one its own views give is no fixed point
    (:func:`arstream.pipeline.api._estimate_from_default`).

    Parameters
    ----------
    open_source, analysis, max_frames, kwargs : as for :func:`scan_sizes`
    scan : the SizeScan of :func:`scan_sizes` on this clip (with its cameras)
    size : (length, width) in metres, e.g. the size estimated from the
        default's views

    Returns
    -------
    (SizeScan over the scan's sizes and ``size``, wall seconds, CPU seconds,
    the PitchSize the views tracked at ``size`` estimate: None with too few
    views; a dimension they leave open at ``size``'s value)

    Raises
    ------
    Interrupted : stopped by a signal
    """
    limit = _frames_limit(max_frames)
    rivals = dict(zip(scan.sizes, scan.cameras)) if scan.cameras else None
    with open_source() as src:
        got, summary = track_sizes(src, analysis, [tuple(size)], rivals=rivals, watch=True, max_frames=limit, **kwargs)
    return with_size(scan, size, got.supports[0], got.disputes, got.cameras[0], fine=got.fine[0] if got.fine else None), summary.seconds, summary.cpu_seconds, got.seen[0]


def scan_passes(track: Callable[[list, dict], SizesTracked]) -> SizeScan:
    """The scan's passes over the grid, given a way to track sizes.

    The first pass tracks 105 x 68 and its grid neighbours
    (:func:`arstream.pitch_size.grid_neighbours`); when one of them wins
    (:func:`arstream.pitch_size.choose_size`), a second pass tracks that
    one's neighbours not yet tracked, and when none wins but one along each
    dimension leans above 105 x 68, the size that takes both steps
    (:func:`arstream.pitch_size.diagonal_step`); the choice is made again
    over every size tracked.

    Parameters
    ----------
    track : callable(list of (length, width), {size: cameras per frame} of
        the sizes tracked before) -> SizesTracked of those sizes (a line
        support per frame, None where that size gave no camera, all of the
        same frames; their disputes with each other and with the sizes
        tracked before)

    Returns
    -------
    SizeScan over every size tracked, with each size's cameras. A pass
    stops where none of its sizes' trackers follows the clip
    (:attr:`SizeScanStage.gave_up`), so a later pass may cover fewer
    frames than the first, or more: each is judged on the first pass's
    frames, a frame past its end counting as no camera
    (:func:`arstream.pitch_size.on_frames`, as
    :func:`arstream.pitch_size.with_size` counts a shorter pass).
    """
    from geometry.pitch import PitchModel

    default = PitchModel()
    tracked: dict = {}
    cameras: dict = {}
    disputes: dict = {}
    fine: dict = {}
    todo = [(default.length, default.width)] + grid_neighbours((default.length, default.width))
    pick = None
    frames = None
    for first in (True, False):
        new = [s for s in todo if s not in tracked]
        if not new:
            break
        got = track(new, dict(cameras))
        if frames is None:
            frames = len(got.supports[0]) if got.supports else 0
        tracked.update((s, on_frames(v, frames)) for s, v in zip(new, got.supports))
        cameras.update((s, on_frames(v, frames)) for s, v in zip(new, got.cameras))
        disputes.update(got.disputes)
        fine.update(zip(new, [on_frames(f, frames) for f in got.fine] if got.fine else [None] * len(new)))
        pick = choose_size(list(tracked), list(tracked.values()), disputes, fine=[fine.get(s) for s in tracked])  # (over every size tracked so far)
        if pick.chosen != 0:
            todo = grid_neighbours(pick.size)
        elif first and (both := diagonal_step(pick)) is not None:
            todo = [both]
        else:
            break
    return dataclasses.replace(pick, cameras=tuple(cameras.get(s, ()) for s in pick.sizes))
