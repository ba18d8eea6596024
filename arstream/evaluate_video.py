"""Judging cameras against the frames themselves (no ground truth): ``arstream eval --video``.

The cameras of a run (``cameras.jsonl``, docs/formats.md) are paired with
the frames of its input by the records' ``frame`` index (a video's decode
order; a frame sequence's position). Per frame with a camera (status ``ok``
or ``tracked``) the line support is measured (:mod:`arstream.support`:
the markings projected with the camera, the share within 2 px of bright
paint); over the clip, the jitter proxy. The figures (:class:`VideoScore`):

- coverage: share of the frames with a camera;
- line support: median and mean over the frames with a camera whose support
  is defined (at least :data:`arstream.support.MIN_POINTS` marking points in
  the image; the others are counted apart, never as 0 or 1), and the share
  of those frames at >= 0.7;
- frames drawn (with a camera) at support < 0.5: their number and their share
  of the frames with a camera;
- the jitter proxy in pixels of the frame and in pixels of a 1280-wide frame.

*Pixel aspect.* Support is measured on the frames as stored, with the cameras
as they are: a camera of frames whose pixels are not square (anamorphic SD,
or resized like the shared Premier League frames: 512 x 512 from 16:9) models
them in ``K``, whose ``K[1, 1] / K[0, 0]`` is the pixel aspect A (a pixel's
width over its height). A therefore only changes what is shown and how pixels
are scaled: overlays are written at square pixels (stretched to W A x H), and
"pixels of a 1280-wide frame" are the frame's pixels scaled by 1280 / W
across and 1280 / (W A) down (the square-pixel frame 1280 wide). Without
``pixel_aspect`` A is the cameras' ``K`` aspect (1 without cameras); a
``pixel_aspect`` that the cameras' ``K`` contradicts is reported in
``warnings`` (the cameras were solved with another pixel shape).

*Overlays* (``draw_every`` N, ``draw_dir``): every Nth frame (index 0, N,
2N, ...) as ``frame_NNNNNN.png`` with the projected markings (thin magenta
polylines) and a line of text (frame, status, support), and ``contact_sheet.png``, a grid of the overlays scaled
down (at most :data:`SHEET_MAX` of them, evenly spread).
"""

from __future__ import annotations

import math
import os
from dataclasses import asdict, dataclass, field

import cv2
import numpy as np

from arstream.errors import InputError
from arstream.evaluate import record_pitches
from arstream.sink import read_jsonl
from arstream.support import MIN_POINTS, frame_mask, jitter_proxy, line_support, marking_points
from geometry.camera import Camera
from geometry.pitch import PitchModel

__all__ = ["FrameSupport", "VideoScore", "cameras_by_frame", "record_pitches", "evaluate_video", "evaluate_video_files", "draw_overlay", "contact_sheet", "format_video_table"]

#: statuses whose cameras are drawn
DRAWN = ("ok", "tracked")
#: most overlays on the contact sheet
SHEET_MAX = 48
#: width of an overlay on the contact sheet (pixels)
SHEET_THUMB = 320
#: colour of the projected markings (BGR)
MARKING_COLOUR = (255, 0, 255)


@dataclass(frozen=True)
class FrameSupport:
    """One frame: ``status`` ("ok", "tracked", "lost", or "missing" without a
    record), line support ``share`` (None without a camera or when undefined)
    and the number of marking points inside the image."""

    index: int
    status: str
    share: float | None
    n_inside: int


@dataclass(frozen=True)
class VideoScore:
    """Clip-level quality of cameras judged against their frames (no ground truth).

    Shares are in [0, 1]; a figure that cannot be computed (no camera, no
    three consecutive frames with cameras) is None. Pixels are the frame's
    own unless the name says ``_1280``.
    """

    source: str
    frames: int
    width: int
    height: int
    pixel_aspect: float
    records: int
    ok: int
    tracked: int
    lost: int
    missing: int
    coverage: float
    support_frames: int
    support_undefined: int
    support_median: float | None
    support_mean: float | None
    support_ge_0_7: float | None
    drawn_below_0_5: int
    drawn_below_0_5_share: float | None
    jitter: float | None
    jitter_1280: float | None
    jitter_triples: int
    lowest_support: tuple = ()
    overlays: tuple = ()
    contact_sheet: str | None = None
    warnings: tuple = ()
    per_frame: tuple = field(default=(), repr=False)

    @property
    def with_camera(self) -> int:
        return self.ok + self.tracked

    def to_dict(self, *, per_frame: bool = False) -> dict:
        """JSON-ready dict (no NaN: undefined figures are None); ``per_frame`` adds
        ``frames_detail``, one ``{index, status, share, n_inside}`` per frame."""
        d = asdict(self)
        d.pop("per_frame")
        d["lowest_support"] = [{"frame": i, "share": s} for i, s in self.lowest_support]
        for k in ("overlays", "warnings"):
            d[k] = list(d[k])
        if per_frame:
            d["frames_detail"] = [asdict(f) for f in self.per_frame]
        return d


def cameras_by_frame(records: list[dict], name: str = "cameras.jsonl") -> dict[int, tuple[str, Camera | None]]:
    """``frame -> (status, camera)`` of cameras.jsonl records (camera None when lost).

    Raises
    ------
    InputError
        No records; a record that is not an object, lacks an integer ``frame``,
        repeats a frame, has an unknown status, or has status ok / tracked
        without a valid camera (``K``, ``R``, ``t``).
    """
    if not records:
        raise InputError(f"{name} has no records")
    out: dict[int, tuple[str, Camera | None]] = {}
    for n, r in enumerate(records, 1):
        if not isinstance(r, dict):
            raise InputError(f"{name}: record {n} is not a JSON object")
        i = r.get("frame")
        if isinstance(i, bool) or not isinstance(i, int) or i < 0:
            raise InputError(f"{name}: record {n} has no frame index (a non-negative integer 'frame')")
        if i in out:
            raise InputError(f"{name}: two records for frame {i}")
        status = r.get("status")
        if status not in (*DRAWN, "lost"):
            raise InputError(f"{name}: frame {i} has status {status!r}, not 'ok', 'tracked' or 'lost'")
        cam = None
        if status in DRAWN:
            if r.get("K") is None:
                raise InputError(f"{name}: frame {i} has status {status!r} but no camera (K, R, t)")
            try:
                cam = Camera.from_dict(r)
            except ValueError as exc:
                raise InputError(f"{name}: frame {i}: {exc}") from None
        out[i] = (status, cam)
    return out


def _open_frames(video):
    """``(frames iterator, frame count or 0, closer, source errors list)`` of a video,
    a still, a folder or a glob of numbered frames."""
    from arstream.source import VideoSource, image_frames

    stills = image_frames(video)
    if stills is not None:
        paths, it = stills
        return it, len(paths), (lambda: None), []
    src = VideoSource(video)
    return iter(src), src.frame_count, src.close, src.errors


def _display_size(width: int, height: int, aspect: float) -> tuple[int, int]:
    """Size of the frame shown with square pixels (stretched across by ``aspect``)."""
    return max(1, int(round(width * aspect))), height


def draw_overlay(image: np.ndarray, camera: Camera | None, text: str, *, pitch: PitchModel | None = None, pixel_aspect: float = 1.0, colour=MARKING_COLOUR) -> np.ndarray:
    """A copy of ``image`` (BGR uint8, H x W x 3) with the markings projected by
    ``camera`` as thin polylines and ``text`` in a band at the top, stretched to
    square pixels when ``pixel_aspect`` is not 1 (returns (H, round(W A), 3))."""
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
        raise ValueError("image must be a BGR uint8 array (H, W, 3)")
    H, W = image.shape[:2]
    out = image.copy()
    if camera is not None:
        lim = 8.0 * max(W, H)  # keep the fixed-point coordinates far from overflow
        for poly in (pitch or PitchModel()).polylines(0.25):
            px = camera.project(np.column_stack([poly, np.zeros(len(poly))]))
            good = np.all(np.isfinite(px), axis=1) & np.all(np.abs(px) < lim, axis=1)
            # runs of consecutive good points
            edges = np.flatnonzero(np.diff(np.concatenate([[0], good.view(np.int8), [0]])))
            runs = [np.rint(px[a:b] * 16).astype(np.int32) for a, b in zip(edges[::2], edges[1::2]) if b - a >= 2]
            if runs:
                cv2.polylines(out, runs, False, colour, 1, cv2.LINE_AA, shift=4)
    if abs(pixel_aspect - 1.0) > 1e-6:
        out = cv2.resize(out, _display_size(W, H, pixel_aspect), interpolation=cv2.INTER_LINEAR if pixel_aspect > 1 else cv2.INTER_AREA)
    scale = max(0.35, min(out.shape[1], out.shape[0] * 16 / 9) / 1600)
    (tw, th), base = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
    band = out[: th + base + 8, : tw + 10]
    band[:] = (band * 0.35).astype(np.uint8)
    cv2.putText(out, text, (5, th + 4), cv2.FONT_HERSHEY_SIMPLEX, scale, (255, 255, 255), 1, cv2.LINE_AA)
    return out


def contact_sheet(images: list[np.ndarray], labels: list[str] | None = None, *, thumb_width: int = SHEET_THUMB, max_images: int = SHEET_MAX) -> np.ndarray:
    """A grid of ``images`` (BGR, all the same size) scaled to ``thumb_width``,
    each with its label (if given) written at a readable size; at most
    ``max_images`` of them, evenly spread. (h, w, 3) uint8."""
    if not images:
        raise ValueError("contact_sheet needs at least one image")
    if labels is not None and len(labels) != len(images):
        raise ValueError(f"contact_sheet: {len(labels)} labels for {len(images)} images")
    if len(images) > max_images:
        keep = [int(k) for k in np.linspace(0, len(images) - 1, max_images).round()]
        images = [images[k] for k in keep]
        labels = [labels[k] for k in keep] if labels is not None else None
    h0, w0 = images[0].shape[:2]
    tw = min(thumb_width, w0)
    th = max(1, int(round(h0 * tw / w0)))
    cols = min(len(images), max(1, math.ceil(math.sqrt(len(images) * th / tw * 1.5))), 6)
    rows = math.ceil(len(images) / cols)
    gap = 4
    sheet = np.full((rows * (th + gap) + gap, cols * (tw + gap) + gap, 3), 32, np.uint8)
    for k, img in enumerate(images):
        r, c = divmod(k, cols)
        y, x = gap + r * (th + gap), gap + c * (tw + gap)
        sheet[y : y + th, x : x + tw] = cv2.resize(img, (tw, th), interpolation=cv2.INTER_AREA)
        if labels is not None:
            (lw, lh), base = cv2.getTextSize(labels[k], cv2.FONT_HERSHEY_SIMPLEX, 0.4, 1)
            band = sheet[y : y + lh + base + 6, x : x + min(lw + 8, tw)]
            band[:] = (band * 0.3).astype(np.uint8)
            cv2.putText(sheet, labels[k], (x + 4, y + lh + 3), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1, cv2.LINE_AA)
    return sheet


class _SheetItems:
    """Thumbnails of the overlays for the contact sheet, evenly spread over the
    clip in bounded memory: at most ``2 SHEET_MAX`` are kept; when full, every
    other one is dropped and only every ``stride``-th overlay is taken after."""

    def __init__(self) -> None:
        self.thumbs: list[np.ndarray] = []
        self.labels: list[str] = []
        self.stride = 1
        self.seen = 0

    def add(self, image: np.ndarray, label: str) -> None:
        k, self.seen = self.seen, self.seen + 1
        if k % self.stride:
            return
        h, w = image.shape[:2]
        if w > SHEET_THUMB:
            image = cv2.resize(image, (SHEET_THUMB, max(1, round(h * SHEET_THUMB / w))), interpolation=cv2.INTER_AREA)
        self.thumbs.append(image)
        self.labels.append(label)
        if len(self.thumbs) > 2 * SHEET_MAX:
            self.thumbs, self.labels, self.stride = self.thumbs[::2], self.labels[::2], 2 * self.stride


def _write_png(path: str, image: np.ndarray) -> None:
    if not cv2.imwrite(path, image):
        raise InputError(f"cannot write {path}")


def _k_aspect(cams: list[Camera]) -> float | None:
    if not cams:
        return None
    return float(np.median([c.K[1, 1] / c.K[0, 0] for c in cams]))


def evaluate_video(video, records: list[dict], *, pitch: PitchModel | None = None, pixel_aspect: float | None = None, draw_every: int = 0, draw_dir=None, name: str = "cameras.jsonl") -> VideoScore:
    """Judge camera records against the frames of ``video`` (no ground truth).

    Parameters
    ----------
    video : path of a video file, a still image (PNG, JPEG: one frame, index 0),
        a folder of images or a glob of numbered frames (natural order, index =
        position)
    records : cameras.jsonl records, paired with the frames by ``frame``
    pitch : PitchModel the cameras were made at (default: a record's own
        ``pitch`` entry where it has one, as ``arstream register --json``
        writes, else 105 x 68)
    pixel_aspect : a pixel's width over its height, for overlays and the
        1280-wide scale (default: the cameras' ``K[1, 1] / K[0, 0]``); see the
        module docstring
    draw_every : draw every Nth frame (0: none)
    draw_dir : folder for the overlays and ``contact_sheet.png`` (made if missing)
    name : the records' file name, for messages

    Returns
    -------
    VideoScore

    Raises
    ------
    InputError
        Missing or unreadable video, no frame decoded, bad records
        (:func:`cameras_by_frame`, :func:`record_pitches`), a folder that
        cannot be written.
    """
    pitch_given = pitch is not None
    pitch = pitch or PitchModel()
    if pixel_aspect is not None and not (np.isfinite(pixel_aspect) and pixel_aspect > 0):
        raise InputError(f"pixel aspect must be positive, got {pixel_aspect}")
    if draw_every < 0:
        raise InputError(f"draw every N frames needs N >= 1, got {draw_every}")
    if draw_every and draw_dir is None:
        raise InputError("drawing overlays needs a folder to write them to")
    by_frame = cameras_by_frame(records, name)
    own = {} if pitch_given else record_pitches(records, name)
    cams_all = [c for _, c in by_frame.values() if c is not None]
    k_aspect = _k_aspect(cams_all)
    warnings: list[str] = []
    aspect = pixel_aspect if pixel_aspect is not None else (k_aspect or 1.0)
    if pixel_aspect is not None and k_aspect is not None and abs(k_aspect / pixel_aspect - 1) > 0.01:
        warnings.append(f"pixel aspect {pixel_aspect:.3f} given, but the cameras' K has fy/fx = {k_aspect:.3f}: they were solved with another pixel shape (support is measured with the cameras as they are)")
    if draw_every and draw_dir is not None:
        try:
            os.makedirs(draw_dir, exist_ok=True)
        except OSError as exc:
            raise InputError(f"cannot make the folder {draw_dir}: {exc.strerror or exc}") from None
    points = {(pitch.length, pitch.width): marking_points(pitch)}
    for p in own.values():
        points.setdefault((p.length, p.width), marking_points(p))
    frames_it, listed, close, src_errors = _open_frames(video)
    per_frame: list[FrameSupport] = []
    cams: list[Camera | None] = []
    overlays: list[str] = []
    sheet_items = _SheetItems()
    size = None
    try:
        for f in frames_it:
            if size is None:
                size = (f.width, f.height)
            status, cam = by_frame.get(f.index, ("missing", None))
            made_at = own.get(f.index, pitch)
            share, n_inside = None, 0
            if cam is not None:
                s = line_support(cam, frame_mask(f), points[made_at.length, made_at.width])
                share, n_inside = s.share, s.n_inside
            per_frame.append(FrameSupport(f.index, status, share, n_inside))
            cams.append(cam)
            if draw_every and f.index % draw_every == 0:
                sup = "n/a" if cam is None else (f"{share:.2f}" if share is not None else f"undefined ({n_inside} points)")
                label = f"frame {f.index}  {status}  support {sup}"
                img = draw_overlay(f.image, cam, label, pitch=made_at, pixel_aspect=aspect)
                path = os.path.join(draw_dir, f"frame_{f.index:06d}.png")
                _write_png(path, img)
                overlays.append(path)
                sheet_items.add(img, label)
    finally:
        close()
    n = len(per_frame)
    if n == 0:
        why = f": {src_errors[0]}" if src_errors else ""
        raise InputError(f"no frame could be read from {video}{why}")
    warnings.extend(src_errors)
    if listed and n != listed:
        warnings.append(f"{n} frames read, the input lists {listed}")
    past = sorted(i for i in by_frame if i >= n)
    if past:
        warnings.append(f"{len(past)} records are for frames past the last one read ({n - 1}): frames {past[0]}-{past[-1]} ignored")
    missing = sum(1 for p in per_frame if p.status == "missing")
    if missing:
        warnings.append(f"{missing} of {n} frames have no record in {name} (counted as without a camera)")
    sheet = None
    if sheet_items.thumbs:
        sheet = os.path.join(draw_dir, "contact_sheet.png")
        _write_png(sheet, contact_sheet(sheet_items.thumbs, sheet_items.labels))
    counts = {k: sum(1 for p in per_frame if p.status == k) for k in ("ok", "tracked", "lost")}
    with_cam = counts["ok"] + counts["tracked"]
    shares = np.array([p.share for p in per_frame if p.status in DRAWN and p.share is not None], dtype=np.float64)
    undefined = sum(1 for p in per_frame if p.status in DRAWN and p.share is None)
    below = int(np.count_nonzero(shares < 0.5))
    jit = jitter_proxy(cams, size)
    W, H = size
    lowest = sorted(((p.index, round(p.share, 4)) for p in per_frame if p.status in DRAWN and p.share is not None), key=lambda t: (t[1], t[0]))[:10]
    return VideoScore(
        source=os.fspath(video),
        frames=n,
        width=W,
        height=H,
        pixel_aspect=float(aspect),
        records=len(records),
        ok=counts["ok"],
        tracked=counts["tracked"],
        lost=counts["lost"],
        missing=missing,
        coverage=with_cam / n,
        support_frames=len(shares),
        support_undefined=undefined,
        support_median=float(np.median(shares)) if len(shares) else None,
        support_mean=float(np.mean(shares)) if len(shares) else None,
        support_ge_0_7=float(np.mean(shares >= 0.7)) if len(shares) else None,
        drawn_below_0_5=below,
        drawn_below_0_5_share=below / with_cam if with_cam else None,
        jitter=jit.rms,
        jitter_1280=jit.scaled(1280.0 / W, 1280.0 / (W * aspect)),
        jitter_triples=jit.n_triples,
        lowest_support=tuple(lowest),
        overlays=tuple(overlays),
        contact_sheet=sheet,
        warnings=tuple(warnings),
        per_frame=tuple(per_frame),
    )


def evaluate_video_files(video, pred_path, **kwargs) -> VideoScore:
    """:func:`evaluate_video` of a video and a cameras.jsonl file (``kwargs`` passed on)."""
    return evaluate_video(video, read_jsonl(pred_path), name=os.path.basename(os.fspath(pred_path)), **kwargs)


def format_video_table(s: VideoScore) -> str:
    """A human-readable summary of a :class:`VideoScore`."""

    def pct(v):
        return "n/a" if v is None else f"{100 * v:.1f} %"

    def num(v, fmt="{:.3f}"):
        return "n/a" if v is None else fmt.format(v)

    rows = [
        ("input", f"{s.source}: {s.frames} frames, {s.width}x{s.height}, pixel aspect {s.pixel_aspect:.3f}"),
        ("cameras", f"{s.records} records: {s.ok} ok, {s.tracked} tracked, {s.lost} lost, {s.missing} frames without a record"),
        ("coverage", pct(s.coverage)),
        ("line support median", f"{num(s.support_median)} (mean {num(s.support_mean)}; {s.support_frames} frames, {s.support_undefined} with fewer than {MIN_POINTS} marking points in view)"),
        ("support >= 0.7", pct(s.support_ge_0_7)),
        ("drawn with support < 0.5", f"{pct(s.drawn_below_0_5_share)} ({s.drawn_below_0_5} frames)"),
        ("jitter proxy", f"{num(s.jitter, '{:.2f} px')} ({num(s.jitter_1280, '{:.2f} px')} at 1280 wide; {s.jitter_triples} triples)"),
    ]
    if s.lowest_support:
        rows.append(("lowest support", ", ".join(f"{sh:.2f} (frame {i})" for i, sh in s.lowest_support[:5])))
    if s.overlays:
        rows.append(("overlays", f"{len(s.overlays)} PNG in {os.path.dirname(s.overlays[0]) or '.'}, contact sheet {s.contact_sheet}"))
    rows += [("warning", w) for w in s.warnings]
    w = max(len(r[0]) for r in rows)
    return "\n".join(f"{k:<{w}}  {v}" for k, v in rows)
