"""Scoring predicted cameras against ground truth (``truth.jsonl`` vs ``cameras.jsonl``).

Per frame with a visible pitch, the pitch markings are sampled every 0.25 m;
points whose *true* projection lies inside the image are projected with the
predicted camera too, and the pixel distances between the two projections
are the frame's errors. The pitch looks the same under its four symmetries
(mirror in X, in Y, half turn), so a prediction is scored against the
symmetry that fits it best. Per frame we keep the mean and the worst point.

Clip-level figures (see :class:`Score`): coverage, median / mean / p95 of the
per-frame mean error, acc@5/10/20 px (share of pitch frames whose worst point
is within the threshold; frames without an estimate count as misses), the
median relative focal error, jitter (RMS of the second temporal difference of
the projected ground point under the image centre), and estimates given on
frames without a pitch.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from arstream.errors import InputError
from arstream.sink import read_jsonl
from geometry.camera import Camera
from geometry.pitch import PitchModel

__all__ = ["Score", "FrameError", "frame_error", "distance_1280", "record_pitches", "score", "score_files", "format_table"]

THRESHOLDS = (5, 10, 20)


@dataclass(frozen=True)
class FrameError:
    """Errors of one frame (pixels)."""

    mean: float
    worst: float
    n_points: int
    symmetry: int


@dataclass(frozen=True)
class Score:
    """Clip-level accuracy of predicted cameras (pixels unless said otherwise)."""

    frames: int
    pitch_frames: int
    coverage: float
    median: float
    mean: float
    p95: float
    acc: dict
    focal_error_median: float
    jitter: float
    false_estimates: int
    no_pitch_frames: int

    def to_dict(self) -> dict:
        d = asdict(self)
        d["acc"] = {f"@{k}": v for k, v in self.acc.items()}
        return {k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in d.items()}


def _camera(rec: dict | None) -> Camera | None:
    if rec is None or rec.get("status") == "lost" or rec.get("K") is None:
        return None
    return Camera.from_dict(rec)


def frame_error(truth: Camera, pred: Camera, size: tuple[int, int], pitch_points: np.ndarray, symmetries: np.ndarray, pred_points: np.ndarray | None = None) -> FrameError | None:
    """Reprojection error of ``pred`` against ``truth`` on one frame.

    Parameters
    ----------
    truth, pred : Camera
    size : (width, height) pixels
    pitch_points : (N, 2) marking samples on the pitch, metres
    symmetries : (S, 3, 3) pitch symmetries (``PitchModel.symmetries``)
    pred_points : (N, 2), optional, the same samples of the same markings on
        the pitch ``pred`` was made at, when its size differs from the
        truth's (:func:`arstream.pitch_size.corresponding_samples`): each
        camera then projects its own pitch's marking. Default: ``pitch_points``

    Returns
    -------
    FrameError, or None when no marking point is in view.
    """
    W, H = size
    X = np.column_stack([pitch_points, np.zeros(len(pitch_points))])
    front = truth.in_front(X)
    pt = truth.project(X[front])
    inside = (pt[:, 0] >= 0) & (pt[:, 0] <= W - 1) & (pt[:, 1] >= 0) & (pt[:, 1] <= H - 1)
    if not inside.any():
        return None
    pt = pt[inside]
    Xv = X[front][inside]
    if pred_points is not None:
        P = np.asarray(pred_points, np.float64)[front][inside]
        Xv = np.column_stack([P, np.zeros(len(P))])
    best = None
    for k, S in enumerate(symmetries):
        Xs = Xv.copy()
        Xs[:, :2] = Xv[:, :2] @ S[:2, :2].T
        ok = pred.in_front(Xs)
        pp = pred.project(Xs)
        d = np.linalg.norm(pp - pt, axis=1)
        d[~ok | ~np.isfinite(d)] = 1e6
        m = float(d.mean())
        if best is None or m < best.mean:
            best = FrameError(mean=m, worst=float(d.max()), n_points=len(d), symmetry=k)
    return best


def distance_1280(ref: Camera, got: Camera, size, pitch: PitchModel, got_pitch: PitchModel | None = None, *, pixel_aspect: float = 1.0) -> float:
    """Mean distance between two cameras of one frame over the markings in the
    reference's view, in pixels of the frame shown 1280 wide (square pixels):
    how the real material's cameras are judged against its reference cameras.

    Parameters
    ----------
    ref : Camera, the reference (frame pixels), on ``pitch``'s markings
    got : Camera of the same frame, on ``got_pitch``'s markings where it was
        made at another size (the same points of the same markings,
        :func:`arstream.pitch_size.corresponding_samples`)
    size : (width, height) of the frame, pixels
    pitch : PitchModel of the reference
    got_pitch : PitchModel ``got`` was made at (default ``pitch``)
    pixel_aspect : a pixel's width over its height (the frame shown with
        square pixels)

    Returns
    -------
    float, NaN when no marking is in the reference's view. No symmetry is
    applied: the pitch's side is part of the answer.
    """
    from arstream.pitch_size import corresponding_samples

    if pixel_aspect != 1.0:
        ref, got = (Camera(K=np.diag([pixel_aspect, 1.0, 1.0]) @ c.K, R=c.R, t=c.t, dist=c.dist) for c in (ref, got))
        size = (round(size[0] * pixel_aspect), size[1])
    pts, moved = corresponding_samples(pitch, got_pitch or pitch)
    err = frame_error(ref, got, size, pts, pitch.symmetries[:1], moved)
    return float("nan") if err is None else err.mean * 1280.0 / size[0]


def _ground_under_centre(truth: Camera, pred: Camera, size) -> np.ndarray | None:
    """Predicted pixel of the pitch point that the true camera sees at the image centre."""
    c = np.array([[(size[0] - 1) / 2, (size[1] - 1) / 2]])
    G = truth.backproject_to_pitch(c)
    if not np.all(np.isfinite(G)):
        return None
    p = pred.project_pitch(G)[0]
    return p if np.all(np.isfinite(p)) else None


def record_pitches(records: list[dict], name: str = "cameras.jsonl") -> dict[int, PitchModel]:
    """``frame -> PitchModel`` of the records that carry the size their camera
    was made at (a ``pitch`` entry with ``length`` and ``width`` in metres, as
    ``arstream register --json``, ``process`` and ``stream`` write; docs/formats.md).

    (:func:`arstream.evaluate_video.evaluate_video` checks the records' frames first.)

    Raises
    ------
    InputError
        A ``pitch`` entry that is not an object with a legal length and width.
    """
    out: dict[int, PitchModel] = {}
    for r in records:
        p = r.get("pitch") if isinstance(r, dict) else None
        if p is None:
            continue
        try:
            out[r["frame"]] = PitchModel(float(p["length"]), float(p["width"]))
        except (TypeError, KeyError, ValueError) as exc:
            raise InputError(f"{name}: frame {r.get('frame')}: a pitch entry needs a length and a width in metres ({exc})") from None
    return out


def score(truth: list[dict], pred: list[dict], size: tuple[int, int], pitch: PitchModel | None = None, spacing: float = 0.25, pred_pitch: PitchModel | None = None) -> Score:
    """Score predicted camera records against truth records (matched by ``frame``).

    Parameters
    ----------
    truth : list of truth.jsonl records
    pred : list of cameras.jsonl records (frames missing from it count as lost)
    size : (width, height) of the frames, pixels
    pitch : PitchModel, the pitch the truth's markings are painted on (default 105 x 68)
    spacing : metres between marking samples
    pred_pitch : PitchModel the predictions were made at, when not ``pitch``
        (a size given or estimated otherwise): each marking is then scored
        where each camera draws its own pitch's version of it
        (:func:`arstream.pitch_size.corresponding_samples`), as a viewer sees
        the drawn markings against the painted ones. None: each record's own
        ``pitch`` entry where it has one (:func:`record_pitches`; ``arstream
        process`` writes it), else ``pitch``
    """
    pitch = pitch or PitchModel()
    pts = pitch.sample_points(spacing)
    samples: dict = {}

    def pred_points(made_at: PitchModel | None):
        """The samples where a camera made at ``made_at`` draws the painted ones (None: the same)."""
        if made_at is None or (made_at.length, made_at.width) == (pitch.length, pitch.width):
            return None
        key = (made_at.length, made_at.width)
        if key not in samples:
            from arstream.pitch_size import corresponding_samples

            samples[key] = corresponding_samples(pitch, made_at, spacing)[1]
        return samples[key]

    sym = pitch.symmetries
    by_frame = {}
    for r in pred:
        if "frame" not in r:
            raise InputError("prediction record without a 'frame' key")
        by_frame[int(r["frame"])] = r
    own = {} if pred_pitch is not None else record_pitches(pred)
    means, worsts, focal = [], [], []
    covered = pitch_frames = false_est = no_pitch = 0
    centre_err: dict[int, np.ndarray] = {}
    for t in truth:
        i = int(t["frame"])
        tc = _camera(t)
        pc = _camera(by_frame.get(i))
        if not t.get("visible_pitch", tc is not None) or tc is None:
            no_pitch += 1
            if pc is not None:
                false_est += 1
            continue
        pitch_frames += 1
        if pc is None:
            worsts.append(np.inf)
            continue
        covered += 1
        fe = frame_error(tc, pc, size, pts, sym, pred_points(own.get(i, pred_pitch)))
        if fe is None:
            worsts.append(np.inf)
            continue
        means.append(fe.mean)
        worsts.append(fe.worst)
        focal.append(abs(pc.focal - tc.focal) / tc.focal)
        g = _ground_under_centre(tc, pc, size)
        if g is not None:
            centre_err[i] = g - np.array([(size[0] - 1) / 2, (size[1] - 1) / 2])
    second = [centre_err[i + 1] - 2 * centre_err[i] + centre_err[i - 1] for i in centre_err if i - 1 in centre_err and i + 1 in centre_err]
    jitter = float(np.sqrt(np.mean([np.dot(s, s) for s in second]))) if second else float("nan")
    means_a = np.array(means) if means else np.array([np.nan])
    worsts_a = np.array(worsts) if worsts else np.array([np.inf])
    acc = {k: (float(np.mean(worsts_a <= k)) if pitch_frames else float("nan")) for k in THRESHOLDS}
    return Score(
        frames=len(truth),
        pitch_frames=pitch_frames,
        coverage=covered / pitch_frames if pitch_frames else float("nan"),
        median=float(np.median(means_a)) if means else float("nan"),
        mean=float(np.mean(means_a)) if means else float("nan"),
        p95=float(np.percentile(means_a, 95)) if means else float("nan"),
        acc=acc,
        focal_error_median=float(np.median(focal)) if focal else float("nan"),
        jitter=jitter,
        false_estimates=false_est,
        no_pitch_frames=no_pitch,
    )


def score_files(truth_path, pred_path, size: tuple[int, int] | None = None, pred_pitch: PitchModel | None = None) -> Score:
    """Score two JSON-lines files. The frame size comes from ``header.json`` beside the
    truth file unless ``size`` is given (or, failing both, from the truth's principal point);
    the pitch the truth's markings are painted on from the header's ``pitch``
    (105 x 68 without one). ``pred_pitch``: the size the predictions were made
    at, when not the truth's (:func:`score`)."""
    import json
    import os

    truth = read_jsonl(truth_path)
    pred = read_jsonl(pred_path)
    if not truth:
        raise InputError(f"{truth_path} has no records")
    header = os.path.join(os.path.dirname(os.path.abspath(truth_path)), "header.json")
    meta = {}
    if os.path.exists(header):
        with open(header) as f:
            meta = json.load(f)
    p = meta.get("pitch")
    pitch = PitchModel(float(p["length"]), float(p["width"])) if p else None
    if size is None:
        if "size" in meta:
            size = tuple(meta["size"])
        else:
            k = next((r["K"] for r in truth if r.get("K")), None)
            if k is None:
                raise InputError("cannot tell the frame size: give --size")
            size = (int(round(2 * k[0][2] + 1)), int(round(2 * k[1][2] + 1)))
    return score(truth, pred, size, pitch, pred_pitch=pred_pitch)


def format_table(s: Score) -> str:
    """A human-readable summary of a :class:`Score`."""

    def f(v, unit="px", pct=False):
        if v is None or (isinstance(v, float) and not np.isfinite(v)):
            return "n/a"
        return f"{100 * v:.1f} %" if pct else f"{v:.2f} {unit}"

    rows = [
        ("frames", f"{s.frames} ({s.pitch_frames} with a pitch, {s.no_pitch_frames} without)"),
        ("coverage", f(s.coverage, pct=True)),
        ("error median", f(s.median)),
        ("error mean", f(s.mean)),
        ("error p95", f(s.p95)),
        *[(f"acc@{k}", f(v, pct=True)) for k, v in s.acc.items()],
        ("focal error (median)", f(s.focal_error_median, pct=True)),
        ("jitter", f(s.jitter)),
        ("estimates without pitch", str(s.false_estimates)),
    ]
    w = max(len(r[0]) for r in rows)
    return "\n".join(f"{k:<{w}}  {v}" for k, v in rows)
