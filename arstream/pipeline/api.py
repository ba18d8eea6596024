"""The library API: :func:`process` (``arstream process``), :func:`render_clip`
(``arstream render``) and :func:`stream` (``arstream stream``), each a
:class:`arstream.pipeline.runner.Pipeline` of the stages it needs.
"""

from __future__ import annotations

import contextlib
import dataclasses
import importlib.util
import os
import sys
from typing import Callable

from arstream.errors import InputError, SourceLost
from arstream.pipeline.encode import EncodeStage
from arstream.pipeline.runner import Pipeline
from arstream.pipeline.stage import Stage, ThreadedStage
from arstream.pipeline.stages import DEFAULT_ANALYSIS_WIDTH, JUDGE_EVERY, Analysis, CamerasInStage, CamerasOutStage, DetectStage, MatteStage, RenderStage, SizeWatchStage, TrackStage
from arstream.pipeline.summary import Interrupted, Summary
from arstream.source import DEFAULT_RECONNECT, DEFAULT_TIMEOUT, VideoSource, open_live

__all__ = ["process", "render_clip", "stream", "DEFAULT_LAG", "WORKER_NICE"]

#: Default lag (frames) of the offline smoother.
DEFAULT_LAG = 10

#: Niceness added to the threads that work ahead of the main thread in
#: :func:`process` and :func:`render_clip`: the overlapped stage's worker
#: (detection, keying) and the decode thread with FFmpeg's decoder threads.
#: x264 is their bottleneck and its frame threads stall on one another; the
#: threads ahead, with frames queued, do their work in those gaps rather than
#: beside x264. At 720p, five alternating pairs each: the worker alone about
#: 54.6 fps against 51.8, with the decoder too about 56.8 against 53.7.
WORKER_NICE = 10


def _overlapped(stage: Stage, overlap: bool) -> Stage:
    """``stage`` on a worker thread one frame ahead (when it does work), else as is."""
    if overlap and getattr(stage, "available", True):
        return ThreadedStage(stage, nice=WORKER_NICE)
    return stage


def _has(module: str) -> bool:
    return importlib.util.find_spec(module) is not None


def _missing(*stages) -> list[str]:
    """Stages whose module is not in this build (they pass frames through)."""
    return [name for name, mod in (("detect", "arstream.detect"), ("track", "arstream.track")) if any(st.name == name for st in stages) and not _has(mod)]


def _open(input, *, format=None, options=None, threads: bool = True) -> VideoSource:
    return VideoSource(input, format=format, options=options, threads=threads)


#: the clip's first frames whose pictures inside black bars decide the one
#: that detection and tracking analyse (:func:`_picture_area`): every
#: :data:`PEEK_EVERY`-th of the first :data:`PEEK_FRAMES`
PEEK_FRAMES = 25
PEEK_EVERY = 6


def _picture_area(input, *, threads: bool = True) -> tuple[int, int, int, int] | None:
    """The picture inside black bars (:func:`arstream.imaging.active_area`) of
    a clip's first frames: the smallest box holding each sampled frame's
    picture (a dark frame's is the whole frame, so a clip that opens on
    black keeps every pixel), or None when the input cannot be read (the
    run itself then reports why). A URL is not read twice (None: a network
    stream would be opened again and a second of it spent)."""
    from arstream.imaging import active_area
    from arstream.source import _is_url

    if isinstance(input, str) and _is_url(input):
        return None
    box = None
    try:
        with _open(input, threads=threads) as src:
            for f in src:
                if f.index % PEEK_EVERY == 0:
                    a = active_area(f.image)
                    box = a if box is None else (min(box[0], a[0]), min(box[1], a[1]), max(box[2], a[2]), max(box[3], a[3]))
                if f.index + 1 >= PEEK_FRAMES:
                    break
    except Exception:  # (any damage: the run's own opening and decoding report it)
        return None
    return box


def _check_outputs(input, *, output=None, cameras_out=None, max_frames: int | None = None) -> None:
    """Refuse, before any work, what would fail or lose data later: an output
    that would overwrite the input, one file for both the video and the
    cameras (each is written beside its name and renamed into place: the
    second rename would fail), ``max_frames`` below 1. InputError."""
    where = {os.path.abspath(os.fspath(p)): p for p in (output, cameras_out) if p is not None}
    src = os.path.abspath(os.fspath(input))
    if src in where:
        raise InputError(f"output {where[src]} would overwrite the input")
    if output is not None and cameras_out is not None and len(where) == 1:
        raise InputError(f"output and cameras_out are the same file ({output}): give the cameras a file of their own")
    if max_frames is not None and max_frames < 1:
        raise InputError(f"max_frames must be 1 or more, got {max_frames}")


def _build(stages_fn, source: VideoSource) -> list[Stage]:
    """Create the stages; close the ones already made if a later one fails."""
    made: list[Stage] = []
    try:
        for make in stages_fn:
            st = make()
            if st is not None:
                made.append(st)
    except BaseException:
        for st in made:
            with contextlib.suppress(Exception):
                if isinstance(st, EncodeStage):
                    st.close()
                    with contextlib.suppress(OSError):
                        os.remove(st.path)  # nothing was written: leave no empty file
                else:
                    st.close()
        raise
    return made

def _boxed(box: list, stage):
    """Put ``stage`` in ``box`` (for stages built before it to reach) and return it."""
    box.append(stage)
    return stage


def _run_pitch(box: list):
    """The PitchModel the tracker of the TrackStage in ``box`` solves at now
    (given, a scan's size, 105 x 68, or what ``"auto"`` estimated), or None
    without one: the size a scene without a ``[pitch]`` table stands on
    (:class:`RenderStage`, at its start) and the rerun viewer draws."""
    return getattr(getattr(box[0], "tracker", None), "pitch", None) if box else None


def _hints_of(box: list):
    """The detector's hints from the tracker of the TrackStage in ``box`` (filled
    once it is built): a callable for :class:`DetectStage`, frame -> ``{motion,
    line_width}`` as of that frame (each None where the tracker does not know)."""

    def hints(frame: int) -> dict:
        tracker = box[0].tracker if box else None
        if tracker is None or not hasattr(tracker, "image_motion"):
            return {}
        return {"motion": tracker.image_motion(frame), "line_width": tracker.line_width(frame)}

    return hints

def _load_kernels() -> None:
    """Start loading the compiled kernels on a background thread (once per
    process; see :func:`arstream.kernels.warm_up_async`), so that numba's
    set-up overlaps opening the input and building the stages rather than
    following them (the detector would start it only once it is made)."""
    from arstream.kernels import warm_up_async

    warm_up_async()


def _pitch_model(pitch):
    """``pitch`` as the tracker takes it: None (105 x 68), "auto" (105 x 68 to
    start, estimated from the clip), a PitchModel, or (length, width) in metres."""
    if pitch is None or (isinstance(pitch, str) and pitch == "auto"):
        return pitch
    from geometry.pitch import PitchModel

    if isinstance(pitch, PitchModel):
        return pitch
    try:
        length, width = (float(v) for v in pitch)
    except (TypeError, ValueError):
        raise ValueError(f"pitch must be (length, width) in metres or a PitchModel, got {pitch!r}") from None
    return PitchModel(length, width)


def process(
    input,
    output=None,
    *,
    scene=None,
    cameras_out=None,
    lag: int = DEFAULT_LAG,
    crf: int = 20,
    preset: str = "veryfast",
    audio: bool = True,
    progress: Callable | None = None,
    max_frames: int | None = None,
    handle_signals: bool = True,
    overlap: bool = True,
    analysis_width: int | None = DEFAULT_ANALYSIS_WIDTH,
    pitch=None,
    pixel_aspect: float | None = None,
    threads: int = 0,
    keep_b_frames: bool = True,
) -> Summary:
    """Augment a clip: detect, solve, track (fixed-lag smoothing), render, composite, encode.

    Mirrors ``arstream process IN -o OUT.mp4 [--scene S] [--cameras-out C]``.

    Parameters
    ----------
    input : path of a video file
    output : path of the augmented video (H.264; the input's frame rate, time
        base and audio kept), or None to write only ``cameras_out``
    scene : path of a scene file (.toml/.json), a ``render.Scene``, or None
        for the demo scene (a logo on the grass and an offside line)
    cameras_out : path for ``cameras.jsonl`` (one record per frame), optional
    lag : frames of look-ahead of the smoother (0: causal, as live)
    crf, preset : x264 quality and speed
    audio : copy the input's first audio stream through
    keep_b_frames : code the input's B-frames as B-frames (the input's frame
        pattern kept: a smaller output, closer to the input; see
        :class:`arstream.sink.VideoSink`); False: x264 chooses every frame's type
    progress : callable(done, total), optional
    max_frames : stop after this many frames (1 or more)
    handle_signals : stop gracefully on SIGINT/SIGTERM (main thread only)
    overlap : detect frame i+1 on a worker thread while frame i is tracked and rendered
    pitch : (length, width) in metres or a ``geometry.pitch.PitchModel``, when
        the pitch's size is known. None (default): 105 x 68, and when the
        clip's markings fit it poorly or its views estimate another size
        (:func:`arstream.pitch_size.needs_scan`)
        the clip is tracked again at other sizes and, when one fits better
        (:func:`arstream.pitch_size.choose_size`), run again from it with the
        size estimated; ``summary.pitch`` says what was done (its ``scan``
        the sizes' line support). A clip longer than the scan's 750 frames
        decides the size on them and is then tracked once more in full at
        it (:func:`_decided_on_opening`). "auto": start from 105 x 68 and estimate
        the size from the clip's first views (:mod:`arstream.pitch_size`,
        experimental)
    pixel_aspect : a pixel's width over its height: the stream's sample aspect
        ratio by default (1 when it has none); give it for frames resized from
        another shape. The cameras' ``K[1][1] / K[0][0]`` is this aspect
    analysis_width : width (pixels) of the frames detection and tracking work on;
        None or 0: full resolution (see :class:`Analysis`)
    threads : 0 (default): use the machine (detection overlapped on a thread,
        decoder threads as FFmpeg chooses); 1: about one core's worth of work
        per clip (no overlap, single-threaded decode), for running as many
        clips at once as there are cores (``arstream batch``). x264 keeps its
        own threading either way: its output depends on its thread count, and
        a clip's video must not depend on how many ran beside it.

    Returns
    -------
    Summary. ``summary.errors`` lists damage found in the input (the frames
    that decoded were processed).

    Raises
    ------
    InputError : missing file, not a video, bad output path, one file for
        ``output`` and ``cameras_out``, ``max_frames`` below 1
    ArstreamError : no OpenGL context (names the fix), stage failures
    Interrupted : stopped by a signal, after the outputs were finalised
    """
    if output is None and cameras_out is None:
        raise InputError("nothing to write: give an output video, cameras_out, or both")
    _check_outputs(input, output=output, cameras_out=cameras_out, max_frames=max_frames)
    if threads < 0:
        raise ValueError(f"threads must be 0 (auto) or positive, got {threads}")
    pitch = _pitch_model(pitch)
    _load_kernels()
    # (the picture inside black bars, once: a second run, after the pitch scan, analyses the same)
    area = _picture_area(input, threads=threads != 1)
    run = dict(scene=scene, lag=lag, crf=crf, preset=preset, audio=audio, progress=progress, max_frames=max_frames, handle_signals=handle_signals, overlap=overlap, analysis_width=analysis_width, pixel_aspect=pixel_aspect, threads=threads, keep_b_frames=keep_b_frames, area=area)
    from arstream.pitch_size import SCAN_ASK_SD, SCAN_MIN_FRAMES, needs_scan

    first, supports, an, seen = _process_once(input, output, cameras_out, pitch=pitch, watch_pitch=pitch is None, seen_max_sd=SCAN_ASK_SD, **run)
    if pitch is not None or not _has("arstream.track"):
        return first

    if not needs_scan(supports, min_frames=max(5, SCAN_MIN_FRAMES // JUDGE_EVERY), seen=seen):
        return first
    window = _decision_frames(max_frames)
    if first.frames <= window:
        return _rescan(input, output, cameras_out, first, an, run)
    return _decided_on_opening(input, output, cameras_out, first, an, run, window)


#: frames of a clip the size's decision runs track (:func:`_decided_on_opening`):
#: the scan's (:data:`arstream.pipeline.pitch_scan.SCAN_MAX_FRAMES`)
DECISION_FRAMES = None


def _decision_frames(max_frames: int | None) -> int:
    """The frames a run that only decides the pitch's size tracks: the scan's
    (:data:`DECISION_FRAMES`, default the scan's ``SCAN_MAX_FRAMES``), at
    most ``max_frames``."""
    from arstream.pipeline.pitch_scan import SCAN_MAX_FRAMES

    window = SCAN_MAX_FRAMES if DECISION_FRAMES is None else int(DECISION_FRAMES)
    return window if max_frames is None else min(int(max_frames), window)


def _decided_on_opening(input, output, cameras_out, first: Summary, an: Analysis, run: dict, window: int) -> Summary:
    """A clip longer than the scan's window that needs its size found
    (:func:`process`): every run that decides the size (the scan's, and
    those at the sizes it leads to, :func:`_rescan`) tracks the clip's first
    ``window`` frames and writes nothing; then one run tracks the whole clip
    at the size decided and replaces the first run's outputs. The scan
    judges those frames anyway, and the runs after it decide by the size
    their views estimate (views of the clip's first seconds) and by their
    median line support, so each would otherwise cost a whole match: the
    decisions take at most a few times the window, and the clip is tracked
    twice in full (the default's run, then the size's) rather than up to
    seven times. Stopped by a signal or failing in the last run, the first
    run's outputs stay, as when a later run of :func:`_rescan` is."""
    from geometry.pitch import PitchModel

    try:
        decided = _rescan(input, None, None, first, an, dict(run, max_frames=window))
    except Interrupted as e:  # (the first run's outputs are the ones written)
        if e.summary is not first:
            first.seconds, first.cpu_seconds = e.summary.seconds, e.summary.cpu_seconds
        first.interrupted = e.signum
        raise Interrupted(e.signum, first) from None
    if decided is not first:  # (the decision runs' time, the first run's included)
        first.seconds, first.cpu_seconds = decided.seconds, decided.cpu_seconds
    size = decided.pitch or {}
    if size.get("source") in (None, "default", "given"):
        first.pitch, first.pitch_text = decided.pitch, decided.pitch_text
        return first
    last, _, _ = _run_beside(input, output, cameras_out, first, run, pitch=PitchModel(size["length"], size["width"]))
    last.pitch, last.pitch_text = decided.pitch, decided.pitch_text
    return last


def _process_once(input, output, cameras_out, *, scene, lag, crf, preset, audio, progress, max_frames, handle_signals, overlap, analysis_width, pitch, pixel_aspect, threads, keep_b_frames, area=None, estimate_pitch: bool = False, watch_pitch: bool = False, seen_max_sd: float | None = None) -> tuple[Summary, list, Analysis, object]:
    """One run of :func:`process`: (its summary, the line support of every
    :data:`JUDGE_EVERY`-th frame (None: no camera), the Analysis it worked
    at, the tracker's PitchSize or None). ``estimate_pitch``: estimate the
    size starting from ``pitch``; ``watch_pitch``: track at ``pitch``, and
    the PitchSize returned is the size its views estimate
    (:meth:`arstream.track.Tracker.pitch_seen`, with ``max_sd``
    ``seen_max_sd`` when given; None with too few views);
    ``area``: the picture inside black bars (:func:`_picture_area`)."""
    single = threads == 1
    with _open(input, threads=not single) as src:
        W, H = src.width, src.height
        an = Analysis(W, H, analysis_width, pixel_aspect=pixel_aspect or getattr(src, "pixel_aspect", 1.0), area=area)
        track_box: list = []
        stages = _build(
            [
                lambda: _overlapped(DetectStage(W, H, analysis=an, hints=_hints_of(track_box)), overlap and not single),
                lambda: _boxed(track_box, TrackStage(W, H, fps=src.fps, lag=lag, enabled=_has("arstream.detect"), analysis=an, pitch=pitch, estimate_pitch=estimate_pitch, watch_pitch=watch_pitch)),
                (lambda: RenderStage(W, H, scene, pitch=_run_pitch(track_box))) if output is not None else (lambda: None),
                (lambda: EncodeStage(output, src, crf=crf, preset=preset, audio=audio, keep_b_frames=keep_b_frames)) if output is not None else (lambda: None),
                (lambda: CamerasOutStage(cameras_out)) if cameras_out is not None else (lambda: None),
            ],
            src,
        )
        # (the analysis frame on the decode thread, from the planes it just copied)
        prepare = an.prepare if _has("arstream.detect") else None
        pipe = Pipeline(src, stages, progress=progress, max_frames=max_frames, decode_nice=WORKER_NICE, prepare=prepare)
        pipe.summary.output = os.fspath(output) if output is not None else None
        pipe.summary.cameras = os.fspath(cameras_out) if cameras_out is not None else None
        pipe.summary.missing = _missing(*stages)
        pipe.summary.picture = an.picture
        try:
            summary = pipe.run(handle_signals=handle_signals)
        finally:
            _note_pitch(pipe.summary, track_box)
    tracker = getattr(track_box[0], "tracker", None) if track_box else None
    size = None if tracker is None else (tracker.pitch_seen() if seen_max_sd is None else tracker.pitch_seen(seen_max_sd)) if watch_pitch else tracker.pitch_size
    return summary, (track_box[0].supports if track_box else []), an, size


def _aside(path):
    """A name beside ``path`` for a later run's output (hidden, same extension)."""
    if path is None:
        return None
    path = os.fspath(path)
    head, tail = os.path.split(path)
    stem, ext = os.path.splitext(tail)
    return os.path.join(head, f".{stem}.rescan{ext}")


def _rescan(input, output, cameras_out, first: Summary, an: Analysis, run: dict) -> Summary:
    """The default size fitted the clip poorly: track it at other sizes
    (:func:`arstream.pipeline.pitch_scan.scan_sizes`) and, when one wins, run
    the clip again from it, estimating the size within the scan's grid step
    from the views that size's cameras lay on their paint
    (:func:`arstream.pitch_size.estimate_pitch_size`: the views are right
    now, as at 105 x 68 they were not). That run adopts the estimate once it
    has its views, and its frames before were drawn at the grid's size (metres
    off: 110 x 64 for a 103.5 x 65 m pitch; tens of pixels where the markings
    are near the camera); so when the estimate is another size, a last run tracks the
    whole clip at the estimate, as if it had been given, and estimates it
    again from its own views (:func:`_at_estimate`). When no grid size
    wins, the size estimated from the default's own views may
    (:func:`_estimate_from_default`). Each run after the
    first writes beside the outputs and replaces them only when it completes:
    stopped by a signal, the last complete run's outputs stay (and
    :class:`Interrupted` carries its summary). The summary's seconds and CPU
    seconds are all the runs'."""
    from arstream.pipeline.pitch_scan import scan_sizes

    try:
        scan, scan_s, scan_cpu = scan_sizes(analysis=an, **_scan_options(input, run))
    except Interrupted as e:
        first.interrupted = e.signum
        raise Interrupted(e.signum, first) from None
    first.seconds += scan_s
    first.cpu_seconds += scan_cpu
    if scan.chosen == 0:
        return _estimate_from_default(input, output, cameras_out, first, an, run, scan)
    return _at_scanned(input, output, cameras_out, first, run, scan)


def _at_scanned(input, output, cameras_out, first: Summary, run: dict, scan) -> Summary:
    """The clip run again at the grid size ``scan`` chose (written beside the
    outputs, :func:`_run_beside`), estimating the size from the views its
    cameras lay on their paint; at the estimate, when it is another size,
    :func:`_at_estimate`. (:func:`_rescan`'s tail.)"""
    from arstream.pitch_size import PitchSize
    from geometry.pitch import PitchModel

    second, est, _ = _run_beside(input, output, cameras_out, first, run, pitch=PitchModel(*scan.size), estimate_pitch=True)
    estimated = est is not None and est.source == "estimated"
    size = dataclasses.replace(est, scan=scan) if estimated else PitchSize(*scan.size, source="scanned", views=scan.frames, scan=scan)
    second.pitch, second.pitch_text = size.to_dict(), size.describe()
    if not estimated or (est.length, est.width) == tuple(scan.size):
        return second
    return _at_estimate(input, output, cameras_out, second, run, size)


def _scan_options(input, run: dict) -> dict:
    """The keyword arguments of the scan's passes over ``input``
    (:func:`arstream.pipeline.pitch_scan.scan_sizes`, ``check_size``) for a
    run of :func:`process` with options ``run``."""
    single = run["threads"] == 1
    return dict(
        open_source=lambda: _open(input, threads=not single),
        detect_stage=lambda st: _overlapped(st, run["overlap"] and not single),
        max_frames=run["max_frames"],
        progress=run["progress"],
        handle_signals=run["handle_signals"],
        decode_nice=WORKER_NICE,
    )


def _estimate_from_default(input, output, cameras_out, first: Summary, an: Analysis, run: dict, scan) -> Summary:
    """No size of the scan's grid won (:func:`_rescan`): a pitch between its
    points (106.5 x 66 m: one step along either axis fixes one dimension and
    spoils the other) may still fit better. The clip is tracked once more
    from the default with the size estimated from its own views (as
    ``pitch="auto"``; no outputs), and that estimate is judged against the
    grid's sizes on the scan's frames by the scan's own rule
    (:func:`arstream.pipeline.pitch_scan.check_size`; an estimate within two
    standard deviations of the default is no other size): on real views the
    estimate can be metres off (``docs/real-footage.md``), and only a size
    the paint backs better than the default is kept. Kept, a last run tracks
    the whole clip at it (written beside the outputs as in :func:`_rescan`,
    refined as there: :func:`_at_estimate`). Where the estimate tells a
    dimension the grid left open (higher than the grid's sizes on the other
    side of the default, :func:`arstream.pitch_size.choose_size`) and a grid
    size on its side wins, the clip runs from that size as after a scan that
    chose it (:func:`_at_scanned`).

    Views made at a size metres off pull their estimate towards it (as
    :func:`_at_estimate` says), and a run at an estimate that is not yet
    the size its own views give can fit worse than the default: a synthetic
    105.5 x 70.5 m pitch seen from 33 m up, its default's views estimating
    105.7 x 69.7, a run at that size freezing its tripod's centre 1.7 m
    short and scoring 0.86 on the scan's frames against the default's 0.91,
    while its own views give 105.5 +- 0.3 x 70.5 +- 0.2 (bench/README.md
    "Stop 90"). So the check's tracker keeps its views too, and where the
    check turns the estimate down and the size those views estimate is
    another than the estimate and than the default (beyond their noise),
    that size is tracked on the scan's frames too, and kept only where its
    median line support is higher than the default's by
    :data:`arstream.pitch_size.SCAN_MARGIN` (0.97 against 0.91 there): a
    second size tried on the same frames after one turned down needs a
    clear win, not the paired tests that settle sizes within the margin,
    whose blocks flip with the encoding on a long lens's views (an 854 x
    480 copy of ``israel_league_wide`` at crf 12: the views' 103.6 x 71.1
    at 0.966 against 105 x 68's 0.969, chosen by them, drawn 16-29 px off
    all 13 reference frames).
    Otherwise the first run's outputs stay, and the summary says the
    default was kept, with the estimates' line supports among the sizes
    tried."""
    from arstream.pipeline.pitch_scan import check_size
    from arstream.pitch_size import SCAN_MARGIN, PitchSize
    from geometry.pitch import PitchModel

    def kept(s) -> Summary:
        size = PitchSize(*s.sizes[0], source="default", views=s.frames, scan=s)
        first.pitch, first.pitch_text = size.to_dict(), size.describe()
        return first

    def checked(against, size):
        """``check_size`` of ``size`` against the SizeScan ``against``: (the SizeScan, the size
        its views give); its seconds added to ``first``'s, and on a signal ``first`` carried."""
        try:
            got, secs, cpu, seen = check_size(scan=against, size=(size.length, size.width), analysis=an, **_scan_options(input, run))
        except Interrupted as e:
            first.interrupted = e.signum
            raise Interrupted(e.signum, first) from None
        first.seconds += secs
        first.cpu_seconds += cpu
        return got, seen

    if scan.median[0] is None:  # (the scan's trackers could not follow the clip: nothing to judge by)
        return kept(scan)
    try:
        auto, _, _, est = _process_once(input, None, None, pitch=PitchModel(), estimate_pitch=True, **run)
    except Interrupted as e:
        first.interrupted = e.signum
        raise Interrupted(e.signum, first) from None
    first.seconds += auto.seconds
    first.cpu_seconds += auto.cpu_seconds
    if est is None or est.source != "estimated" or est.within_noise(scan.sizes[0]):
        return kept(scan)
    check, seen = checked(scan, est)
    if check.chosen == 0:
        # (the size the views tracked at the estimate give: another, beyond their noise, and
        # the estimate was no fixed point; that size is tracked on the scan's frames too)
        if seen is None or seen.source != "estimated" or seen.within_noise((est.length, est.width)) or seen.within_noise(scan.sizes[0]):
            return kept(check)
        # (judged against the grid's sizes and the estimate turned down: the summary lists both)
        check, _ = checked(check, seen)
        # (a second size on the same frames, after one turned down: only a clear win by the
        # median, not the paired tests that settle sizes within the margin, whose blocks flip
        # with the encoding on a long lens's views; the size is the one judged, not a grid's)
        last = len(check.sizes) - 1
        if check.chosen != last or check.median[last] is None or check.median[0] is None or check.median[last] < check.median[0] + SCAN_MARGIN:
            return kept(dataclasses.replace(check, chosen=0))
        est = seen
    if check.chosen != len(check.sizes) - 1:
        # (the estimate, higher than the grid's sizes on the other side of the default, told a
        # dimension the grid left open; a grid size on its side is nearer the default, and won)
        return _at_scanned(input, output, cameras_out, first, run, check)
    size = dataclasses.replace(est, scan=check)
    return _at_estimate(input, output, cameras_out, first, run, size)


def _run_beside(input, output, cameras_out, before: Summary, run: dict, *, pitch, estimate_pitch: bool = False, watch_pitch: bool = False, keep: Callable | None = None) -> tuple[Summary, object, list]:
    """One more run of :func:`process` (:func:`_process_once` at ``pitch``)
    written beside the outputs (:func:`_aside`), which replace them only when
    it completes: (its summary, the seconds and CPU seconds of ``before``
    added; the tracker's PitchSize, with ``watch_pitch`` the size its views
    estimate; its line supports, as :func:`_process_once`'s). ``keep``:
    callable(those line supports, that PitchSize) -> bool, asked when it completes: False
    leaves ``before``'s outputs and returns ``before`` (the run's seconds
    added). Stopped by a signal or failing, it leaves ``before``'s outputs
    in place and removes its own; on a signal :class:`Interrupted` carries
    ``before``."""
    aside = [(_aside(p), p) for p in (output, cameras_out) if p is not None]

    def drop():
        for tmp, _ in aside:
            with contextlib.suppress(OSError):
                os.remove(tmp)

    try:
        after, supports, _, est = _process_once(input, _aside(output), _aside(cameras_out), pitch=pitch, estimate_pitch=estimate_pitch, watch_pitch=watch_pitch, **run)
    except BaseException as e:
        drop()
        if isinstance(e, Interrupted):
            before.interrupted = e.signum
            raise Interrupted(e.signum, before) from None
        raise
    if keep is not None and not keep(supports, est):
        drop()
        before.seconds += after.seconds
        before.cpu_seconds += after.cpu_seconds
        return before, est, supports
    for tmp, final in aside:
        os.replace(tmp, final)
    after.output = os.fspath(output) if output is not None else None
    after.cameras = os.fspath(cameras_out) if cameras_out is not None else None
    after.seconds += before.seconds
    after.cpu_seconds += before.cpu_seconds
    return after, est, supports


def _no_lower(supports, by: float = 0.0) -> Callable:
    """A ``keep`` for :func:`_run_beside`: a run whose median line support is
    no lower than that of ``supports`` (the run before's, as
    :func:`_process_once` gives them; no floor where it had none), or,
    with ``by`` > 0, higher by at least ``by``."""
    from arstream.pitch_size import _median

    floor = _median(supports, 1)
    return lambda s, _: (m := _median(s, 1)) is not None and (floor is None or m >= floor + by)


#: most runs after the last one at an estimated size (:func:`_at_estimate`),
#: each at the size the run before's own views estimate
REFINE_RUNS = 2
#: metres: a run's views that estimate a size this far or further from the
#: size tracked, along a dimension they fix, move the last run
#: (:func:`_at_estimate`) even within two of their standard deviations,
#: where the paint then backs it more (by :data:`arstream.pitch_size.SCAN_TIE`
#: on the median). The views' spread is not their pull: made at a size
#: metres off, they estimate a size between it and the truth (a synthetic
#: 108 x 64.5 m pitch: 106.3 +- 0.5 from the run at 105.8, then 107.9 +- 0.3
#: from the run at 106.3). A length 0.3 m off moves a goal line 60 m away
#: about 5 px in a 1280-wide picture through a long lens (f 1900 px)
REFINE_STEP = 0.3


def _at_estimate(input, output, cameras_out, before: Summary, run: dict, size) -> Summary:
    """The last run: the whole clip tracked at ``size`` (a PitchSize estimated
    from views made at another size), as a run given that size would, written
    beside the outputs as :func:`_run_beside`.

    Views made at a size metres off are themselves off, and so can be the
    size estimated from them (a synthetic 107.5 x 65.5 m pitch: 107.3 x 64.8
    from its views at 110 x 64, 4 of its standard deviations off in width,
    drawn 6.3 px off at the median). So the run keeps its own views, made at
    ``size``, and estimates the size again from them after the run
    (:meth:`arstream.track.Tracker.pitch_seen`, as the first run does); while
    that lies beyond two of its standard deviations of the size tracked
    (:meth:`arstream.pitch_size.PitchSize.within_noise`), the clip is tracked
    once more at it, at most :data:`REFINE_RUNS` times, and that run replaces
    the outputs only where the paint backs its cameras no worse (a median
    line support no lower). The views of a run at the right size estimate it
    again (107.5 x 65.5 from the run at 107.3 x 64.8). An estimate within
    that noise but :data:`REFINE_STEP` or more away is tracked too, and
    replaces the outputs only where the paint backs it more (a median higher
    by :data:`arstream.pitch_size.SCAN_TIE`): views made at a wrong size
    pull their estimate towards it, so an estimate near the size tracked is
    no sign that size is right.
    """
    from arstream.pitch_size import SCAN_TIE

    last, seen, supports = _run_beside(input, output, cameras_out, before, run, pitch=size.model(), watch_pitch=True)
    last.pitch, last.pitch_text = size.to_dict(), size.describe()
    for _ in range(REFINE_RUNS):
        if seen is None or seen.source != "estimated":
            break
        noisy = seen.within_noise((size.length, size.width))
        if noisy and max(abs(seen.length - size.length), abs(seen.width - size.width)) < REFINE_STEP:
            break
        new = dataclasses.replace(seen, scan=size.scan)
        after, own, own_supports = _run_beside(input, output, cameras_out, last, run, pitch=new.model(), watch_pitch=True, keep=_no_lower(supports, SCAN_TIE if noisy else 0.0))
        if after is last:
            break
        last, size, seen, supports = after, new, own, own_supports
        last.pitch, last.pitch_text = size.to_dict(), size.describe()
    return _probe_open(input, output, cameras_out, last, run, size, seen, supports)


#: metres either side of the size tracked at which :func:`_probe_open` tracks
#: a clip whose views leave a dimension open
PROBE_STEP = 3.0


def _probe_open(input, output, cameras_out, last: Summary, run: dict, size, seen, supports) -> Summary:
    """A dimension the views of the run at ``size`` leave open (``seen``, the
    size they estimate: no standard deviation), probed.

    A penalty-area view pins the pitch's markings near its goal and says
    nothing of the length until the halfway line comes into view; tracked
    at a length metres off, the frames that show it lay it beside its paint,
    and those views do not fix the length either (a synthetic 100.5 x 72.5 m
    pitch at 105 x 72.5: length open; at 102 or 100: 100.5 +- 0.1). So the
    clip is tracked (no outputs) at ``PROBE_STEP`` metres either side along
    that dimension, shorter first; where the probe's views fix it, the clip
    is tracked at the value they estimate, and that run replaces the outputs
    only when it is a fixed point (its own views fix the dimension at that
    value, within two standard deviations) and the paint backs its cameras
    no worse (a median line support no lower). Returns the summary of the
    outputs kept, the probes' seconds added; stopped by a signal, the
    outputs stay the run before's and :class:`Interrupted` carries its
    summary."""
    from arstream.pitch_size import _metres
    from geometry.pitch import PitchModel

    if seen is None or seen.source != "estimated":
        return last
    no_lower = _no_lower(supports)

    def dim(p, d: int) -> tuple[float, float | None]:
        return (p.length, p.width)[d], (p.length_sd, p.width_sd)[d]

    for d in (0, 1):
        if seen.constrained[d]:
            continue
        for sign in (-1.0, 1.0):
            probe = [size.length, size.width]
            probe[d] += sign * PROBE_STEP
            try:
                tried, _, _, est = _process_once(input, None, None, pitch=PitchModel(*probe), watch_pitch=True, **run)
            except Interrupted as e:  # (the outputs are the run before's, complete)
                last.interrupted = e.signum
                raise Interrupted(e.signum, last) from None
            last.seconds += tried.seconds
            last.cpu_seconds += tried.cpu_seconds
            if est is None or est.source != "estimated" or not est.constrained[d]:
                continue
            value = dim(est, d)[0]
            (L, Lsd), (W, Wsd) = (dim(est if k == d else size, k) for k in (0, 1))
            new = dataclasses.replace(est, length=L, width=W, length_sd=Lsd, width_sd=Wsd, scan=size.scan)

            def fixed(s, own, d=d, value=value):
                return no_lower(s, own) and own is not None and own.source == "estimated" and own.constrained[d] and abs(dim(own, d)[0] - value) <= 2.0 * dim(own, d)[1]

            after, _, _ = _run_beside(input, output, cameras_out, last, run, pitch=new.model(), watch_pitch=True, keep=fixed)
            if after is not last:
                after.pitch = new.to_dict()
                after.pitch_text = f"{new.describe()} ({('length', 'width')[d]} left open by the views at {_metres(size.length)} x {_metres(size.width)}: probed at {_metres(probe[d])})"
                return after
    return last


def _note_pitch(summary: Summary, track_box: list) -> None:
    """The pitch's size the tracker solved with (given, default or estimated) into ``summary``."""
    tracker = getattr(track_box[0], "tracker", None) if track_box else None
    size = getattr(tracker, "pitch_size", None)
    if size is not None:
        summary.pitch = size.to_dict()
        summary.pitch_text = size.describe()


def _note_fit(summary: Summary, watch_box: list) -> None:
    """A live run's poor fit of the size tracked with (:class:`SizeWatchStage`),
    if it found one, into ``summary``: ``pitch["fits_poorly"]`` (the median
    line support it was found at) and the operator's message after
    ``pitch_text``."""
    watch = watch_box[0] if watch_box else None
    if watch is None or watch.median is None or summary.pitch is None:
        return
    summary.pitch = {**summary.pitch, "fits_poorly": round(watch.median, 3)}
    summary.pitch_text = f"{summary.pitch_text}; {watch.message()}"


def render_clip(
    input,
    cameras,
    output,
    *,
    scene=None,
    key: bool | str | Callable = True,
    crf: int = 20,
    preset: str = "veryfast",
    audio: bool = True,
    progress: Callable | None = None,
    handle_signals: bool = True,
    overlap: bool = True,
    keep_b_frames: bool = True,
) -> Summary:
    """Draw a scene on a clip with cameras read from a ``cameras.jsonl`` (no solving).

    The decode -> composite -> encode loop of :func:`process`, for
    ``arstream render``. ``key`` chooses the grass matte that keys on-grass
    graphics (players pass in front of them): True or "detector" runs the
    detector (no keying when this build has none); "green" a chroma key on the
    grass hue; a callable(image_bgr) -> (H, W) uint8 matte your own; False or
    None no keying. ``overlap`` computes the matte of frame i+1 on a worker
    thread while frame i is rendered. ``keep_b_frames`` as for :func:`process`.
    """
    _check_outputs(input, output=output)
    if key is True:
        key = "detector"
    if not (key in (None, False, "detector", "green") or callable(key)):
        raise InputError(f"key must be 'detector', 'green', a function or None, got {key!r}")
    with _open(input) as src:
        W, H = src.width, src.height
        if key == "detector":
            make_key = lambda: _overlapped(DetectStage(W, H, analysis=Analysis(W, H, DEFAULT_ANALYSIS_WIDTH)), overlap)  # noqa: E731
        elif key == "green":
            make_key = lambda: _overlapped(MatteStage.green(W, H), overlap)  # noqa: E731
        elif callable(key):
            make_key = lambda: _overlapped(MatteStage(key), overlap)  # noqa: E731
        else:
            make_key = lambda: None  # noqa: E731
        cameras_box: list = []
        stages = _build(
            [
                make_key,
                lambda: _boxed(cameras_box, CamerasInStage(cameras)),
                # (a scene without a [pitch] table stands on the size the cameras were made at)
                lambda: RenderStage(W, H, scene, pitch=cameras_box[0].pitch),
                lambda: EncodeStage(output, src, crf=crf, preset=preset, audio=audio, keep_b_frames=keep_b_frames),
            ],
            src,
        )
        pipe = Pipeline(src, stages, progress=progress, decode_nice=WORKER_NICE)
        pipe.summary.output = os.fspath(output)
        pipe.summary.cameras_in = os.fspath(cameras)
        pipe.summary.missing = _missing(*stages)
        return pipe.run(handle_signals=handle_signals)


def stream(
    source,
    *,
    rerun: tuple | list | str | None = None,
    realtime: bool | None = None,
    scene=None,
    output=None,
    cameras_out=None,
    format: str | None = None,
    options: dict | None = None,
    bind: str = "127.0.0.1",
    port: int = 9876,
    jpeg_quality: int = 75,
    max_frames: int | None = None,
    progress: Callable | None = None,
    handle_signals: bool = True,
    warn: Callable[[str], None] | None = None,
    analysis_width: int | None = DEFAULT_ANALYSIS_WIDTH,
    pitch=None,
    pixel_aspect: float | None = None,
    reconnect: float = DEFAULT_RECONNECT,
    timeout: float = DEFAULT_TIMEOUT,
) -> Summary:
    """Live mode: causal tracking (no look-ahead) of a file, URL or capture device,
    logged to rerun. Mirrors ``arstream stream --source SRC [--rerun ...] [--realtime]``.
    A file inside black bars is analysed on its picture, as :func:`process`
    does (``Summary.picture``); a URL or a device, whole.

    Parameters
    ----------
    source : file path, URL (rtsp://, http://, udp://, ...) or device (with ``format``,
        e.g. ``format="v4l2"``, ``source="/dev/video0"``)
    rerun : None (no logging), "spawn", ("save", path), ("connect", url or None), "serve"
    realtime : pace to the source clock and drop frames rather than fall behind;
        None: on for URLs and devices, off for files
    scene, output, cameras_out : as :func:`process` (output and cameras optional)
    bind, port : address of the rerun gRPC server for ``serve``
    jpeg_quality : quality of the JPEG frames sent to rerun
    warn : callable(str) for non-fatal problems (unreachable viewer, a network
        source lost and reconnected); default stderr
    analysis_width, pitch, pixel_aspect : as :func:`process`
    reconnect, timeout : a URL source that sends nothing for ``timeout`` seconds
        or whose connection fails is opened again for up to ``reconnect``
        seconds (0: not at all); its frames go on with consecutive numbers
        and timestamps (see :class:`arstream.source.ReconnectingSource`)

    Raises
    ------
    SourceLost
        The URL source was lost and did not come back in time; raised after
        the outputs were finalised with every frame read, with the run's
        :class:`Summary` as ``summary``.
    Interrupted
        Stopped by a signal, after the outputs were finalised.
    """
    from arstream.live import RerunLogger, parse_rerun
    from arstream.pipeline.pitch_scan import SCAN_MAX_FRAMES

    warn = warn or (lambda msg: print(f"arstream: warning: {msg}", file=sys.stderr))
    mode = parse_rerun(rerun)
    _check_outputs(source, output=output, cameras_out=cameras_out, max_frames=max_frames)
    pitch = _pitch_model(pitch)
    _load_kernels()
    # (a file's picture inside black bars, as process finds it; a URL or a
    # device is not read twice, and is analysed whole)
    area = _picture_area(source) if format is None and os.path.isfile(os.fspath(source)) else None
    with open_live(source, format=format, options=options, reconnect=reconnect, timeout=timeout, report=warn) as src:
        W, H = src.width, src.height
        rt = src.is_live if realtime is None else bool(realtime)
        an = Analysis(W, H, analysis_width, pixel_aspect=pixel_aspect or getattr(src, "pixel_aspect", 1.0), area=area)
        logger_box: list = []
        track_box: list = []
        watch_box: list = []

        def tell(text: str) -> None:
            """A warning for the operator: on stderr, and in the rerun viewer."""
            warn(text)
            if logger_box:
                logger_box[0].note(text)

        def make_logger():
            if mode is None:
                return None
            # (the model is drawn at the size the tracker solves at: given, or estimated with "auto")
            lg = RerunLogger(mode, W, H, bind=bind, port=port, jpeg_quality=jpeg_quality, warn=warn, name=os.path.basename(src.path), analysis=an, pitch=lambda: _run_pitch(track_box))
            logger_box.append(lg)
            return lg.input_stage

        stages = _build(
            [
                lambda: DetectStage(W, H, analysis=an, hints=_hints_of(track_box)),
                lambda: _boxed(track_box, TrackStage(W, H, fps=src.fps, lag=0, enabled=_has("arstream.detect"), analysis=an, pitch=pitch)),
                # (no size given: say so when the paint backs the default poorly, as process would scan)
                lambda: _boxed(watch_box, SizeWatchStage(track_box[0], tell, window=SCAN_MAX_FRAMES // JUDGE_EVERY)) if pitch is None and track_box[0].available else None,
                make_logger,
                lambda: RenderStage(W, H, scene, pitch=_run_pitch(track_box)),
                (lambda: logger_box[0].output_stage) if mode is not None else (lambda: None),
                (lambda: EncodeStage(output, src, audio=not src.is_live, rebase=src.is_live)) if output is not None else (lambda: None),
                (lambda: CamerasOutStage(cameras_out)) if cameras_out is not None else (lambda: None),
            ],
            src,
        )
        pipe = Pipeline(src, stages, realtime=rt, queue_size=1 if rt else 2, progress=progress, max_frames=max_frames)
        pipe.summary.output = os.fspath(output) if output is not None else None
        pipe.summary.cameras = os.fspath(cameras_out) if cameras_out is not None else None
        pipe.summary.missing = _missing(*stages)
        pipe.summary.picture = an.picture
        try:
            return pipe.run(handle_signals=handle_signals)
        except SourceLost as exc:  # the outputs are finalised: say what they hold
            exc.summary = pipe.summary
            raise
        finally:
            _note_pitch(pipe.summary, track_box)
            _note_fit(pipe.summary, watch_box)
