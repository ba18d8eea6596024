"""Benchmark: the real clips broadcast otherwise (lower resolution, stronger
compression), judged frame by frame against the clip's own full-size run.

The shared clips have reference cameras on every 25th frame only. Their
full-size run is itself within 5 px of those references (12 of 13 on
``israel_league_wide``, 8 of 8 on ``artificial_turf_multisport`` with its
pitch size: ``bench/real_footage.py``), so its cameras serve as a
pseudo-truth for *every* frame of a re-encoded copy of the same clip: the
copy is the same match through another broadcast chain (scaled with area
averaging, then libx264 at a given crf; :func:`reencode`). A frame whose camera lies far from
the full-size run's, where that run is right, is wrong; the table counts
them, beside the ground-truth-free figures of ``arstream eval --video``.
The pseudo-truth moves with the code under test; the reference frames the
copy holds are also judged against the reference cameras themselves
(:func:`reference_distances`, the issue's "within 5 px"), which do not.

Two variants make *another real clip* rather than another broadcast of the
same one, with cameras that follow from the original's exactly
(``WxHxCRF:mirror``, ``:reverse``, ``:mirror+reverse``): flipped left to
right, the view of the other half of the pitch, which its markings map onto
themselves (the reference and full-size cameras mirrored:
``real_graphics.mirrored``); played backwards, a pan the other way that
opens on the view the clip ends on. The tracker meets them as it would a
clip it has never seen: the check of generality the shared material
allows (bench/README.md, "Stop 76").

Usage::

    python bench/real_perturbed.py [--clips NAME ...] [--variants WxHxCRF[:LOOK][+mirror][+reverse] ...]
                                   [--frames N] [--pitch NAME=LxW ...] [--own-size] [--keep DIR]

Distances are means over the markings in the full-size camera's view, in
pixels of a 1280-wide frame (:func:`arstream.evaluate.distance_1280`). The
material is read from ``../shared/data/real-broadcast`` (skipped with a
message where it is absent).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from fractions import Fraction
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from arstream.evaluate_video import evaluate_video  # noqa: E402
from arstream.pipeline import process  # noqa: E402
from arstream.sink import x264_reproducible_params  # noqa: E402
from arstream.source import i420_planes  # noqa: E402
from geometry.camera import Camera  # noqa: E402
from geometry.pitch import PitchModel  # noqa: E402
from arstream.evaluate import distance_1280  # noqa: E402
from real_footage import SHARED, _fmt, pitch_args, references  # noqa: E402
from real_graphics import dim, mirrored, soft  # noqa: E402

#: the frame rates MPEG-2 can code
MPEG2_RATES = (Fraction(24000, 1001), Fraction(24), Fraction(25), Fraction(30000, 1001), Fraction(30), Fraction(50), Fraction(60000, 1001), Fraction(60))
VARIANTS = ["1280x720x28", "1024x576x20", "854x480x12", "854x480x20", "848x478x26"]
#: looks of the picture a variant can add (``WxHxCRF:LOOK``): an evening match, a soft picture
LOOKS = {"dim": dim, "soft-1.2": soft}
#: changes of the clip's geometry or time a variant can add (``WxHxCRF:mirror``,
#: ``:reverse``, ``:mirror+reverse``): another real clip whose cameras follow from the
#: original's exactly. Flipped left to right, the view of the other half (or end) of a
#: pitch its markings map onto themselves (``real_graphics.mirrored``); played
#: backwards, a pan the other way that opens on the view the clip ends on.
ORDERS = ("mirror", "reverse")


def _area_weights(n_in: int, n_out: int) -> tuple[np.ndarray, np.ndarray, int]:
    """Integer weights of area averaging from ``n_in`` to ``n_out`` samples
    (``n_out <= n_in``): input index (K, n_out) and weight (K, n_out) of the
    at most K input samples each output sample covers, and their sum."""
    g = math.gcd(n_in, n_out)
    a, b = n_out // g, n_in // g  # an input sample spans a units, an output sample b
    K = b // a + 2
    j = np.arange(n_out)
    first = (b * j) // a
    idx = first[None, :] + np.arange(K)[:, None]
    lo = np.maximum(a * idx, b * j[None, :])
    hi = np.minimum(a * (idx + 1), b * (j[None, :] + 1))
    w = np.clip(hi - lo, 0, None)
    return np.minimum(idx, n_in - 1), w, b


def area_scale(plane: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """(H, W) uint8 plane scaled down to ``size`` (w, h) by area averaging,
    rounded half up: exact integer arithmetic, the same on every processor."""
    h_in, w_in = plane.shape
    w, h = size
    if w > w_in or h > h_in:
        raise ValueError(f"area_scale only scales down: {w_in} x {h_in} -> {w} x {h}")
    ix, wx, bx = _area_weights(w_in, w)
    iy, wy, by = _area_weights(h_in, h)
    x = plane.astype(np.int64)
    cols = sum(x[:, ix[k]] * wx[k] for k in range(len(ix)))  # (h_in, w)
    both = sum(cols[iy[k], :] * wy[k][:, None] for k in range(len(iy)))  # (h, w)
    d = bx * by
    return ((both + d // 2) // d).astype(np.uint8)


def _linear_weights(n_in: int, n_out: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Integer weights of linear interpolation from ``n_in`` to ``n_out >= n_in``
    samples (pixel centres aligned, edges clamped): the two input indices of
    each output sample, their weights, and the weights' sum."""
    j = np.arange(n_out, dtype=np.int64)
    d = 2 * n_out  # an output sample's source position (2 j + 1) n_in / d - 1 / 2, in units of 1 / d
    num = (2 * j + 1) * n_in - n_out
    i0 = np.floor_divide(num, d)
    frac = num - i0 * d
    return np.clip(i0, 0, n_in - 1), np.clip(i0 + 1, 0, n_in - 1), np.stack([d - frac, frac]), d


def linear_scale(plane: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """(H, W) uint8 plane scaled up to ``size`` (w, h) by bilinear
    interpolation, rounded half up: exact integer arithmetic, the same on
    every processor (a 720p programme up-converted to a 1080 channel)."""
    h_in, w_in = plane.shape
    w, h = size
    if w < w_in or h < h_in:
        raise ValueError(f"linear_scale only scales up: {w_in} x {h_in} -> {w} x {h}")
    x0, x1, wx, dx = _linear_weights(w_in, w)
    y0, y1, wy, dy = _linear_weights(h_in, h)
    x = plane.astype(np.int64)
    cols = x[:, x0] * wx[0] + x[:, x1] * wx[1]  # (h_in, w)
    both = cols[y0, :] * wy[0][:, None] + cols[y1, :] * wy[1][:, None]  # (h, w)
    d = dx * dy
    return ((both + d // 2) // d).astype(np.uint8)


def scale_plane(plane: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """A plane scaled down by area averaging (:func:`area_scale`) or up
    bilinearly (:func:`linear_scale`); the same size is a copy."""
    h_in, w_in = plane.shape
    w, h = size
    if w <= w_in and h <= h_in:
        return area_scale(plane, size)
    if w >= w_in and h >= h_in:
        return linear_scale(plane, size)
    raise ValueError(f"a plane is scaled up or down in both directions, not {w_in} x {h_in} -> {w} x {h}")


def x264_options(crf: int) -> dict:
    """libx264's options for the same bytes on every processor: ``crf``, preset
    fast, without its AVX-512 code, which at some frame sizes reads memory it
    never wrote (bench/README.md, "Reproducible encodes")."""
    params = x264_reproducible_params()
    return {"crf": str(crf), "preset": "fast", **({"x264-params": params} if params else {})}


def reencode(src: Path, dst: Path, size: tuple[int, int], quality: int, frames: int | None = None, start: int = 0, *, codec: str = "libx264", look=None, mirror: bool = False, reverse: bool = False) -> Path:
    """``frames`` frames of ``src`` (all with None) from frame ``start`` on,
    scaled to ``size`` (area averaging down, bilinear up: :func:`scale_plane`) and encoded with
    ``codec`` at ``quality`` (libx264's crf, or with ``"mpeg2video"``, the
    codec of SD broadcasts, its bit rate in kbit/s): another broadcast of
    the same match. ``look``: a function of a BGR frame applied to each
    decoded frame first (``real_graphics.dim``, ``real_graphics.soft``: an
    evening match, a soft picture); its colour conversions are FFmpeg's, so
    such a copy is not the same bytes on every processor. ``mirror``: every
    frame flipped left to right (its planes' columns reversed: exact);
    ``reverse``: the clip played backwards, ``start`` and ``frames`` counted
    on the reversed clip (its frames are held in memory: about 1.4 MB each
    at 720p). Returns ``dst``.

    The same bytes on every run: the scaling is exact integer arithmetic on
    the decoded planes, the same on every processor (FFmpeg's swscale,
    PyAV's ``reformat``, and OpenCV's ``INTER_AREA`` round differently with
    their AVX-512, AVX2 and SSE kernels); libx264 runs without its AVX-512
    code, which at some frame sizes (848 x 478 and 854 x 480 among them)
    reads memory it never wrote (bench/README.md, "Reproducible encodes");
    FFmpeg's MPEG-2 encoder runs on one thread with ``bitexact``. The
    tracker answers a copy a level off here and there with other cameras
    (docs/real-footage.md).

    Raises
    ------
    ValueError
        ``src`` is not 4:2:0 8-bit, ``size`` is not even, or ``codec`` is
        neither.
    """
    import av

    w, h = size
    if w % 2 or h % 2:
        raise ValueError(f"size must be even, got {w} x {h}")
    if codec == "libx264":
        options = x264_options(quality)
    elif codec == "mpeg2video":
        options = {"b": f"{int(quality)}k", "threads": "1", "flags": "+bitexact"}
    else:
        raise ValueError(f"codec must be libx264 or mpeg2video, got {codec!r}")
    with av.open(str(src)) as inp, av.open(str(dst), "w") as out:
        vs = inp.streams.video[0]
        rate = vs.average_rate
        if codec == "mpeg2video":  # (its frame rates are the broadcast ones)
            rate = min(MPEG2_RATES, key=lambda r: abs(float(r) - float(rate)))
        st = out.add_stream(codec, rate=rate)
        st.width, st.height, st.pix_fmt = w, h, "yuv420p"
        st.options = options

        def copies():
            """The copy's frames: (Y, U, V) planes scaled (and flipped), in the source's order."""
            for k, frame in enumerate(inp.decode(vs)):
                if not reverse and k < start:
                    continue
                if not reverse and frames is not None and k >= start + frames:
                    break
                if frame.format.name not in ("yuv420p", "yuvj420p"):
                    raise ValueError(f"{src}: frames are {frame.format.name}, not 4:2:0 8-bit")
                if look is not None:
                    frame = av.VideoFrame.from_ndarray(look(frame.to_ndarray(format="bgr24")), format="bgr24").reformat(format="yuv420p")
                planes = i420_planes(frame.to_ndarray(), frame.width, frame.height)
                scaled = [scale_plane(p, (w, h) if i == 0 else (w // 2, h // 2)) for i, p in enumerate(planes)]
                yield [q[:, ::-1] for q in scaled] if mirror else scaled

        order = copies()
        if reverse:
            held = list(order)[::-1]
            order = held[start : None if frames is None else start + frames]
        for scaled in order:
            g = av.VideoFrame.from_ndarray(np.concatenate([q.ravel() for q in scaled]).reshape(-1, w), format="yuv420p")
            for packet in st.encode(g):
                out.mux(packet)
        for packet in st.encode():
            out.mux(packet)
    return dst


def _cameras(records: list[dict]) -> list[Camera | None]:
    """The camera of each cameras.jsonl record (None where lost)."""
    return [None if r.get("K") is None else Camera.from_dict(r) for r in records]


def _at_1280(cam: Camera, size: tuple[int, int]) -> Camera:
    """``cam`` (a camera of a ``size`` copy) as a camera of the 1280 x 720 frame."""
    return Camera(K=np.diag([1280.0 / size[0], 720.0 / size[1], 1.0]) @ cam.K, R=cam.R, t=cam.t, dist=cam.dist)


def copy_frame(k: int, start: int = 0, *, reverse: bool = False, total: int | None = None) -> int:
    """The frame of a copy (:func:`reencode` from frame ``start``) that shows
    frame ``k`` of the source; with ``reverse``, of a source of ``total`` frames."""
    return (total - 1 - k if reverse else k) - start


def as_copy(cam: Camera | None, *, mirror: bool = False) -> Camera | None:
    """A camera of the 1280 x 720 source as the same frame's camera in a copy
    (at 1280 x 720): flipped with ``mirror`` (:func:`real_graphics.mirrored`)."""
    return mirrored(cam, 1280) if mirror and cam is not None else cam


def reference_distances(name: str, got: list[Camera | None], size: tuple[int, int], start: int = 0, *, mirror: bool = False, reverse: bool = False, total: int | None = None) -> np.ndarray:
    """(R,) distance (px @1280) of each reference camera of the shared clip
    ``name`` (tests/data/real_reference, made independently of the product)
    to ``got``'s camera of the same frame (cameras of a ``size`` copy of the
    clip from frame ``start``, flipped and played backwards as
    :func:`reencode` made it; ``total``: the source's frame count, for
    ``reverse``): inf where the copy has none. Only the
    reference frames the copy holds count. Both cameras project the
    reference's markings, whatever size ``got`` was made at (as
    ``bench/real_footage.py`` and ``tests/test_real_clips.py`` judge a run)."""
    out = []
    for k, (ref, pitch) in sorted(references(name).items()):
        j = copy_frame(k, start, reverse=reverse, total=total)
        if 0 <= j < len(got):
            out.append(np.inf if got[j] is None else distance_1280(as_copy(ref, mirror=mirror), _at_1280(got[j], size), (1280, 720), pitch))
    return np.array(out)


def distances(truth: list[Camera | None], got: list[Camera | None], size: tuple[int, int], pitch: PitchModel) -> np.ndarray:
    """(N,) per-frame distance (px @1280) of ``got`` (cameras of a ``size``
    frame) to ``truth`` (cameras of the 1280 x 720 full-size frame), both
    projecting ``pitch``'s markings; NaN where either has none."""
    d = np.full(min(len(truth), len(got)), np.nan)
    for k in range(len(d)):
        a, b = truth[k], got[k]
        if a is not None and b is not None:
            d[k] = distance_1280(a, _at_1280(b, size), (1280, 720), pitch)
    return d


def _size(summary) -> PitchModel:
    """The pitch size a run of :func:`process` ended at (its summary's)."""
    return PitchModel(summary.pitch["length"], summary.pitch["width"]) if summary.pitch else PitchModel()


def run(clips, variants, starts, frames, pitches, keep: Path | None, own_size: bool = False) -> list[dict]:
    """Each clip's full-size run, then each copy's (given the full run's
    size, or with ``own_size`` none: the copy's own scan and estimate, as a
    user with no ``--pitch`` would run it; its line support measured at the
    size it found, its distances on the full run's and the references'
    markings as for any copy)."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        work = keep or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        for name in clips:
            src = SHARED / "clips" / f"{name}.mp4"
            pitch = pitches.get(name)
            full = work / f"{name}_full.jsonl"
            t0 = time.perf_counter()
            s = process(src, cameras_out=full, handle_signals=False, pitch=pitch)
            used = _size(s)
            records = [json.loads(x) for x in full.read_text().splitlines()]
            truth = _cameras(records)
            rows.append(dict(clip=name, variant="full size (the pseudo-truth)", start=0, seconds=time.perf_counter() - t0, score=evaluate_video(src, records, pitch=used), refs=reference_distances(name, truth, (1280, 720)), pitch=used))
            for v in variants:
                shape, _, extra = v.partition(":")
                w, h, crf = (int(x) for x in shape.split("x"))
                changes = [x for x in extra.split("+") if x]
                unknown = [x for x in changes if x not in LOOKS and x not in ORDERS]
                if unknown or sum(x in LOOKS for x in changes) > 1:
                    raise SystemExit(f"variant {v!r}: after ':' one look of {sorted(LOOKS)} and any of {list(ORDERS)}, joined by '+'")
                look = next((x for x in changes if x in LOOKS), "")
                mirror, reverse = "mirror" in changes, "reverse" in changes
                # the source's cameras as the copy's frames (flipped, in its order)
                seen = [as_copy(truth[len(truth) - 1 - j] if reverse else truth[j], mirror=mirror) for j in range(len(truth))]
                for start in starts:
                    if start >= len(truth) - 25:
                        continue
                    stem = f"{name}_{w}x{h}_crf{crf}{'_' + '_'.join(changes) if changes else ''}_from{start}"
                    clip = reencode(src, work / f"{stem}.mp4", (w, h), crf, frames, start, look=LOOKS[look] if look else None, mirror=mirror, reverse=reverse)
                    out = work / f"{stem}.jsonl"
                    t0 = time.perf_counter()
                    sc = process(clip, cameras_out=out, handle_signals=False, pitch=None if own_size else (used.length, used.width))
                    dt = time.perf_counter() - t0
                    at = _size(sc) if own_size else used
                    recs = [json.loads(x) for x in out.read_text().splitlines()]
                    d = distances(seen[start:], _cameras(recs), (w, h), used)
                    refs = reference_distances(name, _cameras(recs), (w, h), start, mirror=mirror, reverse=reverse, total=len(truth))
                    rows.append(dict(clip=name, variant=f"{w} x {h}, crf {crf}" + "".join(f", {x}" for x in changes), start=start, seconds=dt, score=evaluate_video(clip, recs, pitch=at), dist=d[np.isfinite(d)], frames=len(d), refs=refs, pitch=at))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clips", nargs="+", default=["israel_league_wide"])
    ap.add_argument("--variants", nargs="+", default=VARIANTS, help="WxHxCRF, or WxHxCRF:X with a look of the picture (dim, soft-1.2) and/or mirror, reverse, joined by '+' (e.g. 1280x720x18:mirror+reverse)")
    ap.add_argument("--starts", nargs="+", type=int, default=[0, 60, 120], help="each variant from these frames of the clip on (other starting conditions)")
    ap.add_argument("--frames", type=int, default=None, help="at most N frames from each start")
    ap.add_argument("--pitch", action="append", default=[], help="NAME=LxW: the pitch size of a clip (given to every run of it)")
    ap.add_argument("--own-size", action="store_true", help="give the copies no size: each scans and estimates its own (as a user with no --pitch; its line support measured at that size, its distances on the full run's and the references' markings); by default every copy is given its full-size run's size")
    ap.add_argument("--keep", type=Path, default=None, help="keep the re-encoded clips and cameras here")
    args = ap.parse_args(argv)
    if not SHARED.exists():
        print(f"skipped: {SHARED} is absent")
        return 0
    rows = run(args.clips, args.variants, args.starts, args.frames, pitch_args(args.pitch), args.keep, args.own_size)
    print("| clip | broadcast | from frame | pitch (m) | frames with a camera | support median | >= 0.7 | drawn < 0.5 | jitter (px @1280) | distance to full size: median | p90 | frames > 5 px | frames > 20 px | reference frames within 5 px | fps |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        s, d, rd = r["score"], r.get("dist"), r["refs"]
        far = ("n/a",) * 4 if d is None or not len(d) else (_fmt(float(np.median(d))), _fmt(float(np.percentile(d, 90))), _fmt(float(np.mean(d > 5)), pct=True), _fmt(float(np.mean(d > 20)), pct=True))
        print(f"| {r['clip']} | {r['variant']} | {r['start']} | {r['pitch'].length:.1f} x {r['pitch'].width:.1f} | {_fmt(s.coverage, pct=True)} | {_fmt(s.support_median)} | {_fmt(s.support_ge_0_7, pct=True)} | {s.drawn_below_0_5} | {_fmt(s.jitter_1280)} | {' | '.join(far)} | {int(np.sum(rd <= 5))} of {len(rd)} | {s.frames / r['seconds']:.1f} |")
    runs = [r for r in rows if r.get("dist") is not None]
    if runs:
        # over every re-encoded run: the share of its frames with a camera within / beyond the bounds
        within5 = np.mean([np.sum(r["dist"] <= 5) / r["frames"] for r in runs])
        beyond20 = np.mean([np.sum(r["dist"] > 20) / r["frames"] for r in runs])
        cover = np.mean([r["score"].coverage for r in runs])
        print(f"\n{len(runs)} re-encoded runs: on average {100 * cover:.1f} % of their frames with a camera, {100 * within5:.1f} % with one within 5 px of the full-size run's, {100 * beyond20:.1f} % with one beyond 20 px")
        rd = np.concatenate([r["refs"] for r in runs])
        if len(rd):
            print(f"their reference frames (every 25th of the clip, tests/data/real_reference): {int(np.sum(rd <= 5))} of {len(rd)} within 5 px ({100 * np.mean(rd <= 5):.1f} %), {int(np.sum(rd > 20))} beyond 20 px (no camera counts as beyond)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
