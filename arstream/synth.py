"""Synthetic broadcast clips with the exact camera of every frame.

A clip is a deterministic function of ``(preset, seed, frames, size, fps)``:
a stadium (grass with mowing stripes and lighting variation, worn white
lines 0.12 m wide, goals, advertising boards and stands with a crowd, all in
3-D in the pitch frame), 22 players and referees with shadows, a ball, a TV
score graphic, and a broadcast camera on a fixed tripod behind the near
touchline that follows the play with pan, tilt and zoom. Post-processing adds
motion blur on fast pans, optional radial distortion, sensor noise, and the
H.264 encoder's own artefacts.

Rendering is exact where it matters for scoring: the lines are filled as
polygons whose vertices are the projected edges of each 0.12 m marking
(sub-pixel, anti-aliased), so they sit where ``truth.jsonl`` projects them.
Lens distortion is applied as a final remap of an undistorted render over a
slightly larger canvas, so every element (lines, grass, stands) is distorted
consistently with ``dist``.

Frames: the pitch frame of docs/formats.md; images are BGR uint8.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import asdict, dataclass, field
from fractions import Fraction
from statistics import NormalDist

import cv2
import numpy as np

from arstream.presets import ALL_PRESETS, PRESETS, REAL_PRESETS, Preset, RealPreset
from geometry.camera import PTZ, Camera, camera_from_ptz, undistort_normalized
from geometry.pitch import GOAL_HEIGHT, GOAL_WIDTH, Arc, PitchModel

__all__ = ["Preset", "PRESETS", "REAL_PRESETS", "ALL_PRESETS", "Look", "SynthClip", "generate", "TruthFrame"]

GENERATOR_VERSION = 1


@dataclass
class TruthFrame:
    """Ground truth of one frame (a ``truth.jsonl`` record, docs/formats.md)."""

    frame: int
    pts: float
    camera: Camera | None
    visible_pitch: bool
    circle_visible: bool
    circle_fraction: float

    def to_record(self) -> dict:
        rec = {"frame": self.frame, "pts": round(self.pts, 6)}
        if self.camera is None:
            rec.update(status="lost", K=None, R=None, t=None, dist=None, H=None, confidence=0.0)
        else:
            rec.update(status="ok", **self.camera.to_dict(), confidence=1.0)
        rec.update(visible_pitch=self.visible_pitch, circle_visible=self.circle_visible, circle_fraction=round(self.circle_fraction, 4))
        return rec


# ---------------------------------------------------------------------------
# the realistic family's look
#: Paint colours (BGR) of other sports' lines: not soccer markings.
OTHER_SPORT_COLOURS = {"yellow": (30, 200, 235), "orange": (20, 120, 240), "blue": (205, 120, 25)}


@dataclass(frozen=True)
class Look:
    """What one clip of the realistic family (:data:`REAL_PRESETS`) shows, drawn
    once from its seed within its :class:`~arstream.presets.RealPreset`'s ranges.
    JSON-ready (``header.json`` keeps it under ``"look"``).

    Attributes
    ----------
    pitch : [length, width] metres (the pitch the markings are painted on)
    k1_wide : float, radial distortion at the preset's widest zoom (fades as 1/f)
    grass_bgr : [b, g, r] the grass colour
    stripes : "bands", "checks", "diagonal" or "none"; stripe_count bands along
        the length, brightness 1 +- stripe_contrast
    paint : float, grey level that fresh white paint is blended toward
    wear : float in [0, 1], how worn the paint is (gaps, uneven brightness)
    softness : float, the lens' blur (Gaussian sigma, display pixels)
    shadow : None or {"point": [x, y], "normal": [nx, ny], "velocity": [vx, vy],
        "strength": s}: the pitch (+4 m) where ``n . (p - point - velocity t) >= 0``
        is darkened by the share ``s`` (hard edge; t in seconds)
    other_lines : list of {"colour", "bgr", "width" (metres), "points" [[x, y], [x, y]]}:
        straight painted lines of other sports, in the pitch frame
    graphics : list of {"kind", "box" [x0, y0, x1, y1] stored pixels (x1, y1
        exclusive), "display_box" (the same before the anamorphic squeeze),
        "frames" [first, last] (inclusive), "opacity", "bgr"}: the on-screen
        graphics (score, logo, caption, black box, watermark)
    """

    pitch: list
    k1_wide: float
    grass_bgr: list
    stripes: str
    stripe_count: int
    stripe_contrast: float
    paint: float
    wear: float
    softness: float
    shadow: dict | None
    other_lines: list = field(default_factory=list)
    graphics: list = field(default_factory=list)

    def shadow_polygon(self, t: float) -> np.ndarray | None:
        """(N, 2) pitch polygon (metres) of the shadow at time ``t`` (s), or None."""
        if self.shadow is None:
            return None
        L, W = self.pitch[0] / 2 + 4.0, self.pitch[1] / 2 + 4.0
        rect = np.array([[-L, -W], [L, -W], [L, W], [-L, W]])
        n = np.asarray(self.shadow["normal"], float)
        p = np.asarray(self.shadow["point"], float) + t * np.asarray(self.shadow["velocity"], float)
        poly = _clip_halfplane(rect, np.array([n[0], n[1], -n @ p]), 0.0)
        return poly if len(poly) >= 3 else None


def draw_look(rng, preset: RealPreset, display_size: tuple[int, int], stored_width: int, frames: int, pitch: PitchModel | None = None) -> Look:
    """Draw a clip's :class:`Look` from ``rng`` within ``preset``'s ranges.

    ``display_size`` (W, H) are the square pixels the frame is drawn in;
    ``stored_width`` the width it is stored at (anamorphic squeeze);
    ``pitch`` replaces the drawn pitch size (the draws are made all the same)."""
    length = round(float(rng.uniform(*preset.pitch_length)) * 2) / 2
    width = round(float(rng.uniform(*preset.pitch_width)) * 2) / 2
    if pitch is not None:
        length, width = float(pitch.length), float(pitch.width)
    L, Wp = length / 2, width / 2
    k1 = float(rng.uniform(*preset.k1_wide))
    if preset.turf == "artificial":
        grass = np.array([45.0, 165.0, 70.0]) * rng.uniform(0.9, 1.1, 3)
        stripes, count, contrast = "none", 0, 0.0
        paint, wear = float(rng.uniform(215, 240)), float(rng.uniform(0.05, 0.3))
    else:
        grass = np.array([52.0, 135.0, 78.0]) * rng.uniform(0.85, 1.12, 3)
        stripes = str(rng.choice(["bands", "bands", "checks", "diagonal"]))
        count = int(rng.integers(7, 12)) * 2
        contrast = float(rng.uniform(0.03, 0.09))
        paint, wear = float(rng.uniform(200, 240)), float(rng.uniform(0.1, 0.5))
    softness = float(rng.uniform(0.5, 0.9))
    shadow = None
    if rng.random() < preset.shadow:
        if rng.random() < 0.75:  # a roof edge along the touchlines
            ang = rng.uniform(-0.4, 0.4)
        else:  # a stand behind a goal
            ang = np.pi / 2 + rng.uniform(-0.4, 0.4)
        d = np.array([np.cos(ang), np.sin(ang)])
        n = np.array([-d[1], d[0]]) * rng.choice([-1.0, 1.0])
        point = np.array([rng.uniform(-0.3, 0.3) * L, rng.uniform(-0.5, 0.5) * Wp])
        v = n * (rng.uniform(0.05, 0.4) if rng.random() < 0.5 else 0.0)
        shadow = {"point": (np.round(point, 3) + 0.0).tolist(), "normal": (np.round(n, 6) + 0.0).tolist(), "velocity": (np.round(v, 4) + 0.0).tolist(), "strength": round(float(rng.uniform(0.3, 0.55)), 3)}
    other = _other_sport_lines(rng, L, Wp) if rng.random() < preset.other_lines else []
    graphics = _draw_graphics_layout(rng, preset.graphics, display_size, stored_width, frames)
    return Look(
        pitch=[length, width],
        k1_wide=round(k1, 5),
        grass_bgr=np.round(grass, 1).tolist(),
        stripes=stripes,
        stripe_count=count,
        stripe_contrast=round(contrast, 4),
        paint=round(paint, 1),
        wear=round(wear, 3),
        softness=round(softness, 3),
        shadow=shadow,
        other_lines=other,
        graphics=graphics,
    )


def _other_sport_lines(rng, L: float, W: float) -> list[dict]:
    """Yellow lines across the pitch (parallel to the goal lines) with orange
    dashes across them, and sometimes a blue court: at least 1.5 m from the
    soccer markings' lines that run the same way."""
    soccer_x = np.array([0.0, L - 16.5, L - 5.5, L, -(L - 16.5), -(L - 5.5), -L])
    xs = []
    for x in np.sort(rng.uniform(-L + 3, L - 3, int(rng.integers(3, 7)))):
        if np.min(np.abs(soccer_x - x)) > 1.5 and all(abs(x - x0) > 4.0 for x0 in xs):
            xs.append(float(x))
    out = []
    w = float(rng.uniform(0.08, 0.12))
    for x in xs:
        out.append({"colour": "yellow", "bgr": list(OTHER_SPORT_COLOURS["yellow"]), "width": w, "points": [[round(x, 3), -W], [round(x, 3), W]]})
        for y in (-W + 5.0, -W / 3, W / 3, W - 5.0):
            out.append({"colour": "orange", "bgr": list(OTHER_SPORT_COLOURS["orange"]), "width": w, "points": [[round(x - 2.5, 3), round(y, 3)], [round(x + 2.5, 3), round(y, 3)]]})
    if rng.random() < 0.5:  # a court: two sides along X, two across
        cx, hl, hw = rng.uniform(-L / 3, L / 3), rng.uniform(12, 20), rng.uniform(7, 10)
        c = [[cx - hl, -hw], [cx + hl, -hw], [cx + hl, hw], [cx - hl, hw]]
        for a, b in zip(c, c[1:] + c[:1]):
            out.append({"colour": "blue", "bgr": list(OTHER_SPORT_COLOURS["blue"]), "width": w, "points": np.round([a, b], 3).tolist()})
    return out


def _draw_graphics_layout(rng, kind: str, display_size: tuple[int, int], stored_width: int, frames: int) -> list[dict]:
    """Where and when the on-screen graphics sit (see :attr:`Look.graphics`).

    Boxes are laid out in display pixels and recorded in stored pixels."""
    Wd, H = display_size
    sx = stored_width / Wd
    s = H / 720.0
    out = []

    def word(n):
        return "".join(chr(65 + int(c)) for c in rng.integers(0, 26, n))

    def add(kind_, x0, y0, w, h, first, last, opacity, bgr, text):
        x0, y0, w, h = int(round(x0)), int(round(y0)), int(round(w)), int(round(h))
        # every stored pixel the graphic touches (the squeeze's filter reaches one pixel further)
        pad = 0 if sx == 1 else 1
        box = [int(math.floor((x0 + 0.5) * sx - 0.5)) - pad, y0, int(math.ceil((x0 + w + 0.5) * sx - 0.5)) + pad, y0 + h]
        out.append({"kind": kind_, "box": [max(box[0], 0), max(box[1], 0), min(box[2], stored_width), min(box[3], H)], "display_box": [x0, y0, x0 + w, y0 + h], "frames": [int(first), int(last)], "opacity": round(float(opacity), 3), "bgr": [int(v) for v in bgr], "text": text})

    m = 28 * s
    if kind == "tv":
        bgr = rng.integers(20, 140, 3)
        w = rng.uniform(240, 330) * s * (Wd / H) / (16 / 9)
        x0 = m if rng.random() < 0.7 else (Wd - w) / 2
        add("score", x0, m, w, 34 * s, 0, frames - 1, rng.uniform(0.85, 1.0), bgr, f"{word(3)}  {rng.integers(0, 4)}-{rng.integers(0, 4)}  {word(3)}")
        add("logo", Wd - m - 120 * s, m, 120 * s, 30 * s, 0, frames - 1, rng.uniform(0.45, 0.8), (255, 255, 255), f"{word(3)} TV")
        a = int(rng.integers(0, max(frames // 3, 1)))
        add("caption", m * 2, H - m * 2 - 56 * s, rng.uniform(260, 380) * s, 56 * s, a, min(a + max(frames // 2, 1), frames - 1), 1.0, rng.integers(20, 200, 3), f"{rng.integers(2, 40)} {word(1)}. {word(6)}|{rng.integers(2, 40)} {word(1)}. {word(5)}")
        if rng.random() < 0.4:
            add("black box", Wd - m - 150 * s, H - m - 44 * s, 150 * s, 44 * s, 0, frames - 1, 1.0, (0, 0, 0), "LIVE")
    else:
        add("logo", m, m, 150 * s, 30 * s, 0, frames - 1, rng.uniform(0.5, 0.8), (255, 255, 255), f"{word(5)}.TV")
        add("black box", Wd - m - rng.uniform(140, 220) * s, m, 180 * s, 40 * s, 0, frames - 1, 1.0, (0, 0, 0), f"{word(3)} 0:{rng.integers(0, 3)} {word(3)}")
        add("watermark", Wd / 2 - 150 * s, H - m - 80 * s, 300 * s, 26 * s, 0, frames - 1, rng.uniform(0.25, 0.45), (255, 255, 255), f"WWW.{word(6)}.COM")
    return out


# ---------------------------------------------------------------------------
# smooth random signals
def _smooth_signal(rng, n: int, fps: float, lo: float, hi: float, freqs=(0.03, 0.12), k: int = 3) -> np.ndarray:
    """A smooth random signal in [lo, hi] over n frames (sum of k sinusoids)."""
    t = np.arange(n) / fps
    s = np.zeros(n)
    for _ in range(k):
        f = rng.uniform(*freqs)
        s += rng.uniform(0.5, 1.0) * np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi))
    s = s / (np.abs(s).max() + 1e-9)
    return lo + (hi - lo) * 0.5 * (s + 1)


def _smoothstep(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


# ---------------------------------------------------------------------------
# textures
def _grass_texture(rng, pitch: PitchModel, ppm: float, extent: tuple[float, float], white_kit: bool, look: "Look | None" = None) -> tuple[np.ndarray, np.ndarray]:
    """Top-down grass BGR texture and a line-wear map over X in [-ex, ex], Y in [-ey, ey].

    ``look`` (the realistic family) sets the grass colour, the mowing pattern
    and the paint's wear (gaps and uneven brightness along the lines)."""
    ex, ey = extent
    w, h = int(2 * ex * ppm) + 1, int(2 * ey * ppm) + 1
    X = (np.arange(w) / ppm - ex)[None, :]
    Y = (np.arange(h) / ppm - ey)[:, None]
    base = np.array([38.0, 128.0, 62.0]) * rng.uniform(0.85, 1.1, 3)
    if look is None:
        n_stripes = 18 if pitch.length >= 100 else 16
        stripe_w = pitch.length / n_stripes
        stripe = np.where((np.floor((X + pitch.length / 2) / stripe_w) % 2) == 0, 1.07, 0.93)
        stripe = np.broadcast_to(stripe, (h, w))
    else:
        base = np.array(look.grass_bgr, float)
        stripe = _mowing_pattern(look, pitch, X, Y, ppm)
    light = cv2.GaussianBlur(rng.normal(0, 1, (h, w)).astype(np.float32), (0, 0), 12 * ppm / 8)
    light = 1.0 + 0.06 * light / (np.abs(light).max() + 1e-6)
    fine = 1.0 + 0.05 * rng.normal(0, 1, (h, w)).astype(np.float32)
    outside = ((np.abs(X) > pitch.length / 2 + 2.5) | (np.abs(Y) > pitch.width / 2 + 2.5)).astype(np.float32)
    shade = stripe * light * fine * (1 - 0.08 * outside)
    tex = np.clip(base[None, None, :] * shade[..., None], 0, 255).astype(np.uint8)
    wear = cv2.GaussianBlur(rng.normal(0, 1, (h, w)).astype(np.float32), (0, 0), 1.5)
    wear = np.clip(0.88 + 0.5 * wear / (np.abs(wear).max() + 1e-6), 0.55, 1.0)
    if look is not None:
        wear = wear * _worn_paint(rng, (h, w), ppm, look.wear)
    return tex, (wear * 255).astype(np.uint8)


def _mowing_pattern(look: "Look", pitch: PitchModel, X: np.ndarray, Y: np.ndarray, ppm: float) -> np.ndarray:
    """Brightness factor (h, w) of the mowing pattern, about 1 +- ``look.stripe_contrast``.

    ``X`` (1, w) and ``Y`` (h, 1) are the texels' pitch coordinates (metres).
    Patterns: "bands" across the pitch (the usual), "checks" (bands both
    ways), "diagonal" (bands at 45 degrees), "none" (artificial turf)."""
    if look.stripes == "none":
        return np.ones((Y.shape[0], X.shape[1]), np.float32)
    sw = pitch.length / look.stripe_count
    bx = np.floor((X + pitch.length / 2) / sw)
    if look.stripes == "bands":
        par = bx + 0 * Y
    elif look.stripes == "checks":
        par = bx + np.floor((Y + pitch.width / 2) / (pitch.width / max(round(look.stripe_count * pitch.width / pitch.length), 2)))
    else:  # diagonal
        par = np.floor((X + Y) / (sw * math.sqrt(2.0)))
    s = np.where(par % 2 == 0, 1.0, -1.0).astype(np.float32)
    s = cv2.GaussianBlur(s, (0, 0), 0.25 * ppm)  # a mown edge is soft (about 0.25 m)
    return 1.0 + look.stripe_contrast * s


def _worn_paint(rng, shape: tuple[int, int], ppm: float, wear: float) -> np.ndarray:
    """Paint factor (h, w) in [0, 1]: uneven brightness (metre-scale) and gaps.

    ``wear`` in [0, 1] sets how worn: about ``0.25 * wear`` of the paint is
    missing in gaps 0.3-1.5 m long, and the rest varies by ``+-0.3 * wear``."""
    slow = cv2.GaussianBlur(rng.normal(0, 1, shape).astype(np.float32), (0, 0), 1.0 * ppm)
    slow /= np.abs(slow).max() + 1e-6
    gaps = cv2.GaussianBlur(rng.normal(0, 1, shape).astype(np.float32), (0, 0), 0.4 * ppm)
    gaps /= gaps.std() + 1e-6
    # the share of gaps: P(z > thr) = 0.25 * wear for a normal z
    thr = NormalDist().inv_cdf(1.0 - 0.25 * wear) if wear > 0 else np.inf
    gap = np.clip((gaps - thr) / 0.3, 0.0, 1.0)
    return np.clip((1.0 - 0.3 * wear) + 0.3 * wear * slow, 0.0, 1.0) * (1.0 - gap)


def _crowd_texture(rng, w: int, h: int, blob: float) -> np.ndarray:
    """A stand full of spectators: rows of seats with heads and coloured shirts."""
    img = np.empty((h, w, 3), np.uint8)
    img[:] = (70, 62, 58)
    rows = max(int(h / (3.2 * blob)), 1)
    palette = np.array([[30, 30, 200], [200, 60, 30], [230, 230, 230], [40, 40, 40], [20, 160, 220], [120, 40, 120], [60, 120, 60]])
    for r in range(rows):
        y = int((r + 0.7) * h / rows)
        cv2.line(img, (0, y + int(blob)), (w, y + int(blob)), (50, 45, 42), max(int(blob * 0.5), 1))
        n = int(w / (2.2 * blob))
        xs = (np.arange(n) + rng.uniform(-0.25, 0.25, n)) * 2.2 * blob
        cols = palette[rng.integers(0, len(palette), n)] * rng.uniform(0.6, 1.0, (n, 1))
        skins = np.array([[120, 160, 210], [80, 110, 160], [60, 80, 110]])[rng.integers(0, 3, n)]
        for x, c, s in zip(xs, cols, skins):
            if rng.random() < 0.1:
                continue
            cv2.ellipse(img, (int(x), y), (max(int(blob * 0.9), 1), max(int(blob * 1.1), 1)), 0, 0, 360, tuple(int(v) for v in c), -1)
            cv2.circle(img, (int(x), int(y - blob * 1.3)), max(int(blob * 0.6), 1), tuple(int(v) for v in s), -1)
    return img


def _board_texture(rng, length_m: float, ppm: float) -> np.ndarray:
    """Advertising boards 1 m high: coloured panels with brand words."""
    w, h = int(length_m * ppm), int(ppm)
    img = np.zeros((h, w, 3), np.uint8)
    words = ["ARSTREAM", "PITCHLINE", "GOALCAST", "VISTA", "NORTHWIND", "KICKOFF", "ORBIT", "FIELDTEC"]
    panel = int(10 * ppm)
    for i, x0 in enumerate(range(0, w, panel)):
        bg = tuple(int(v) for v in rng.integers(20, 230, 3))
        cv2.rectangle(img, (x0, 0), (x0 + panel, h), bg, -1)
        fg = (255, 255, 255) if sum(bg) < 360 else (20, 20, 20)
        word = words[rng.integers(0, len(words))]
        scale = h / 40.0
        cv2.putText(img, word, (x0 + int(0.05 * panel), int(h * 0.75)), cv2.FONT_HERSHEY_DUPLEX, scale, fg, max(int(scale * 2), 1), cv2.LINE_AA)
    return img


# ---------------------------------------------------------------------------
@dataclass
class _Player:
    home: np.ndarray  # (2,) metres
    phase: np.ndarray  # wobble phases
    amp: np.ndarray
    kit: tuple  # shirt BGR
    shorts: tuple
    socks: tuple
    height: float


def _straight_strip(a: np.ndarray, b: np.ndarray, hw: float) -> tuple[np.ndarray, np.ndarray, bool]:
    """A straight painted line from ``a`` to ``b`` (pitch metres, (2,)) of half
    width ``hw``, as a strip (left edge (N, 2), right edge (N, 2), closed=False).
    It is extended by half a width at both ends, so that corners are closed."""
    length = float(np.hypot(b[0] - a[0], b[1] - a[1]))  # as Segment.length
    n = max(int(np.ceil(length / 2.0)), 1) + 1
    u = (b - a) / length
    pts = np.linspace(a - hw * u, b + hw * u, n)
    nrm = np.array([-u[1], u[0]])
    return pts + hw * nrm, pts - hw * nrm, False


def _repeat_columns(tex: np.ndarray, width: int) -> np.ndarray:
    """``tex`` (h, w, 3) repeated side by side to ``width`` columns (cropped)."""
    reps = -(-width // tex.shape[1])
    return np.ascontiguousarray(np.tile(tex, (1, reps, 1))[:, :width])


@dataclass
class _Plane:
    """A textured rectangle in 3-D: texel (u, v) -> origin + u * du + v * dv (metres)."""

    tex: np.ndarray
    origin: np.ndarray
    du: np.ndarray
    dv: np.ndarray

    def corners(self) -> np.ndarray:
        h, w = self.tex.shape[:2]
        return np.array([self.origin, self.origin + (w - 1) * self.du, self.origin + (w - 1) * self.du + (h - 1) * self.dv, self.origin + (h - 1) * self.dv])


class SynthClip:
    """A deterministic synthetic broadcast clip.

    Parameters
    ----------
    preset : str, one of :data:`ALL_PRESETS` (the clean :data:`PRESETS` or the
        realistic :data:`REAL_PRESETS`)
    seed : int
    frames : int, number of frames (>= 1)
    size : (width, height) stored pixels (even numbers); default the
        preset's (``RealPreset.size``), else 1280 x 720
    fps : float
    pitch : PitchModel; default 105 x 68 m, or for the realistic family a size
        drawn from the seed (:attr:`look`)
    pixel_aspect : (p, q) or Fraction, the stored pixels' aspect ratio (width
        over height of one pixel); default the preset's, else 1. Frames are
        drawn with square pixels at ``round(width * p / q)`` x height and
        squeezed to ``size``; the cameras are the stored frames' (``K[1, 1] /
        K[0, 0]`` is ``width / size[0]``: p / q up to rounding the drawn width
        to even pixels; exactly 64/45 at 720x576).

    Use :meth:`truth` for the ground truth of frame ``i`` and :meth:`render`
    for its image (BGR uint8, ``size``). :attr:`look` is the realistic
    family's :class:`Look` (None for the clean presets). ``width`` and
    ``height`` are the square-pixel size frames are drawn at (``size`` when
    the pixels are square).
    """

    def __init__(self, preset: str = "wide", seed: int = 0, frames: int = 250, size=None, fps: float = 25.0, pitch: PitchModel | None = None, pixel_aspect=None):
        if preset not in ALL_PRESETS:
            raise ValueError(f"unknown preset {preset!r}; choose from {', '.join(ALL_PRESETS)}")
        if frames < 1:
            raise ValueError(f"frames must be >= 1, got {frames}")
        real = preset in REAL_PRESETS
        size = size if size is not None else (REAL_PRESETS[preset].size if real else (1280, 720))
        w, h = int(size[0]), int(size[1])
        if w < 64 or h < 64 or w % 2 or h % 2:
            raise ValueError(f"size must be even and at least 64x64, got {w}x{h}")
        if not (1.0 <= fps <= 120.0):
            raise ValueError(f"fps must be in [1, 120], got {fps}")
        if pixel_aspect is None:
            pixel_aspect = REAL_PRESETS[preset].pixel_aspect if real else (1, 1)
        pa = Fraction(*pixel_aspect) if isinstance(pixel_aspect, (tuple, list)) else Fraction(pixel_aspect).limit_denominator(1000)
        if not (Fraction(1, 2) <= pa <= 2):
            raise ValueError(f"pixel aspect must be in [1/2, 2], got {pa}")
        self.preset = ALL_PRESETS[preset]
        self.seed = int(seed)
        self.n = int(frames)
        self.size = (w, h)
        self.pixel_aspect = pa
        # drawn with square pixels, then squeezed: x_stored = (x + 0.5) * sx - 0.5
        self.width, self.height = (w, h) if pa == 1 else (2 * round(w * pa / 2), h)
        sx = w / self.width
        self._S_stored_from_drawn = None if pa == 1 else np.array([[sx, 0.0, 0.5 * sx - 0.5], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
        self.fps = float(fps)
        if real:
            rng = np.random.default_rng([self.seed, 100 + list(REAL_PRESETS).index(preset)])
            self.look = draw_look(np.random.default_rng([self.seed, 200 + list(REAL_PRESETS).index(preset)]), self.preset, (self.width, h), w, self.n, pitch=pitch)
            self.pitch = pitch or PitchModel(*self.look.pitch)
        else:
            rng = np.random.default_rng([self.seed, list(PRESETS).index(preset)])
            self.look = None
            self.pitch = pitch or PitchModel()
        self._rng_seed = rng.integers(0, 2**31)
        self._setup_world(rng)
        self._setup_camera(rng)
        self._setup_players(rng)
        self._buffers()

    # --- world -------------------------------------------------------------------
    def _setup_world(self, rng) -> None:
        p = self.pitch
        L, W = p.length / 2, p.width / 2
        self._grass_ppm = 8.0
        self._grass_extent = (L + 10.0, W + 10.0)
        self._grass, self._wear = _grass_texture(rng, p, self._grass_ppm, self._grass_extent, self.preset.white_kit, self.look)
        self._paint = 238.0 if self.look is None else self.look.paint
        ex, ey = self._grass_extent
        s = 1.0 / self._grass_ppm
        self._T_pitch_from_grass = np.array([[s, 0, -ex], [0, s, -ey], [0, 0, 1.0]])
        # stands: ramps rising away from the pitch beyond the boards
        ppm_c = 6.0
        planes = []
        board_d, stand_d, rise, depth = 4.0, 6.0, 22.0, 40.0
        slope = np.array([0.0, depth, rise]) / np.hypot(depth, rise)
        # each stand runs on to the far edge of the ones beside it (the ramps lean
        # outward by ``depth``), so no corner gap shows the grass behind; the
        # textures are drawn at the old lengths and repeated (the same random
        # draws, so every clip's cameras and players stay as they were)
        far_len, far_full = 2 * (L + stand_d + 12), 2 * (L + stand_d + depth)
        tex = _crowd_texture(rng, int(far_len * ppm_c), int(np.hypot(depth, rise) * ppm_c), blob=1.6)
        tex = _repeat_columns(tex, int(far_full * ppm_c))
        planes.append(_Plane(tex[::-1], np.array([-far_full / 2, W + stand_d, 0.0]), np.array([1.0, 0, 0]) / ppm_c, slope / ppm_c))
        side_len, side_full = 2 * (W + stand_d + 12), 2 * (W + stand_d + depth)
        for sgn in (-1.0, 1.0):
            tex = _crowd_texture(rng, int(side_len * ppm_c), int(np.hypot(depth, rise) * ppm_c), blob=1.6)
            tex = _repeat_columns(tex, int(side_full * ppm_c))
            sl = np.array([sgn * depth, 0.0, rise]) / np.hypot(depth, rise)
            planes.append(_Plane(tex[::-1], np.array([sgn * (L + stand_d), -side_full / 2, 0.0]), np.array([0, 1.0, 0]) / ppm_c, sl / ppm_c))
        # boards: vertical, 1 m high, facing the pitch
        ppm_b = 40.0
        boards = []
        blen = 2 * (L + board_d)
        for y in (W + board_d, -(W + board_d)):
            tex = _board_texture(rng, blen, ppm_b)
            boards.append(_Plane(tex, np.array([-blen / 2, y, 1.0]), np.array([1.0, 0, 0]) / ppm_b, np.array([0, 0, -1.0]) / ppm_b))
        glen = 2 * (W + board_d)
        for sgn in (-1.0, 1.0):
            tex = _board_texture(rng, glen, ppm_b)
            boards.append(_Plane(tex, np.array([sgn * (L + board_d), -glen / 2, 1.0]), np.array([0, 1.0, 0]) / ppm_b, np.array([0, 0, -1.0]) / ppm_b))
        self._stands = planes
        self._boards = boards
        self._closeup = _crowd_texture(rng, int(self.width * 1.6), int(self.height * 1.4), blob=self.width / 60)
        # line strips: (name, left edge (N,2), right edge (N,2), closed)
        self._strips = []
        hw = p.line_width / 2
        for m in p.markings.values():
            if isinstance(m, Arc):
                pts = m.sample(0.5)
                c = np.asarray(m.center)
                d = pts - c
                d /= np.linalg.norm(d, axis=1, keepdims=True)
                self._strips.append((pts + hw * d, pts - hw * d, m.is_full_circle))
            else:
                self._strips.append(_straight_strip(np.asarray(m.start), np.asarray(m.end), hw))
        for name, (x, y) in p.spots.items():
            th = np.linspace(0, 2 * np.pi, 16, endpoint=False)
            r = 0.11
            ring = np.column_stack([x + r * np.cos(th), y + r * np.sin(th)])
            self._strips.append((ring, None, True))
        # stadium shadow: the main stand's roof shadow over the far side
        if self.preset.stadium_shadow:
            y0 = rng.uniform(5, 15)
            self._shadow_poly = np.array([[-L - 10, y0 - 8], [L + 10, y0 + 8], [L + 10, W + 10], [-L - 10, W + 10]])
        else:
            self._shadow_poly = None
        self._sun = np.array([rng.uniform(-0.6, 0.6), rng.uniform(0.3, 0.8)])
        # other sports' lines (realistic family): (BGR, [strip]) per line
        self._other_strips = []
        for line in self.look.other_lines if self.look is not None else ():
            a, b = np.asarray(line["points"], float)
            self._other_strips.append((tuple(line["bgr"]), [_straight_strip(a, b, line["width"] / 2)]))

    def _setup_camera(self, rng) -> None:
        pr = self.preset
        n, fps, W = self.n, self.fps, self.width
        if isinstance(pr, RealPreset):
            self.camera_center = np.array([rng.uniform(*pr.camera_x), -self.pitch.width / 2 - rng.uniform(*pr.camera_back), rng.uniform(*pr.camera_height)])
        else:
            self.camera_center = np.array([rng.uniform(-6, 6), -self.pitch.width / 2 - rng.uniform(15, 45), rng.uniform(10, 25)])
        tx = _smooth_signal(rng, n, fps, *pr.target_x)
        ty = _smooth_signal(rng, n, fps, *pr.target_y, freqs=(0.02, 0.08))
        # fast pans: smooth jumps of the target along X
        t = np.arange(n) / fps
        n_fast = rng.poisson(pr.fast_pans * n / fps / 10.0) if pr.fast_pans else 0
        offset = np.zeros(n)
        for _ in range(n_fast):
            t0 = rng.uniform(0, max(n / fps - 0.5, 0.01))
            amp = rng.choice([-1, 1]) * rng.uniform(15, 25)
            offset += amp * _smoothstep((t - t0) / rng.uniform(0.35, 0.6))
        tx = np.clip(tx + offset - np.median(offset), -self.pitch.length / 2 + 8, self.pitch.length / 2 - 8)
        lo, hi = pr.f_range
        if pr.zoom_period > 0:
            ph = rng.uniform(0, 2 * np.pi)
            z = 0.5 * (1 - np.cos(2 * np.pi * t / pr.zoom_period + ph))
            fmul = lo * (hi / lo) ** z
        else:
            fmul = _smooth_signal(rng, n, fps, lo, hi, freqs=(0.02, 0.06), k=2)
        self._f = fmul * W
        self._target = np.column_stack([tx, ty])
        self._roll = _smooth_signal(rng, n, fps, -0.004, 0.004, freqs=(0.01, 0.05), k=2)
        self._tilt_bias = rng.uniform(-0.02, 0.02)
        self._pp = np.array([W / 2 + pr.pp_offset[0], self.height / 2 + pr.pp_offset[1]]) - 0.5
        self._cut = np.zeros(n, bool)
        if pr.cut is not None:
            a = int(pr.cut[0] * n)
            b = a + int(round(pr.cut[1] * fps))
            self._cut[a : min(b, n)] = True

    def _setup_players(self, rng) -> None:
        pr = self.preset
        kits = [(30, 30, 190), (230, 230, 230) if pr.white_kit else (170, 90, 20)]
        shorts = [(240, 240, 240), (40, 40, 40) if pr.white_kit else (240, 240, 240)]
        self._players = []
        L, W = self.pitch.length / 2, self.pitch.width / 2
        for team in range(2):
            for i in range(11):
                if i == 0:
                    home = np.array([(-1 if team == 0 else 1) * (L - 4), 0.0])
                    kit = (20, 200, 200) if team == 0 else (200, 40, 200)
                else:
                    home = np.array([rng.uniform(-L * 0.6, L * 0.6), rng.uniform(-W * 0.8, W * 0.8)])
                    kit = kits[team]
                self._players.append(_Player(home, rng.uniform(0, 2 * np.pi, 3), rng.uniform(2, 6, 2), kit, shorts[team], kit, rng.uniform(1.7, 1.92)))
        for _ in range(3):
            home = np.array([rng.uniform(-L * 0.4, L * 0.4), rng.uniform(-W * 0.5, W * 0.5)])
            self._players.append(_Player(home, rng.uniform(0, 2 * np.pi, 3), rng.uniform(2, 5, 2), (20, 20, 20), (20, 20, 20), (20, 20, 20), 1.78))
        self._ball_wobble = rng.uniform(0, 2 * np.pi, 2)

    def _buffers(self) -> None:
        W, H = self.width, self.height
        rng = np.random.default_rng(self._rng_seed)
        sigma = self.preset.noise
        self._noise = []
        for _ in range(4):
            nz = rng.normal(0, sigma, (H, W, 3))
            self._noise.append((np.clip(nz, 0, 255).astype(np.uint8), np.clip(-nz, 0, 255).astype(np.uint8)))
        self._line_mask = np.zeros((H, W), np.uint8)
        self._shadow_mask = np.zeros((H, W), np.uint8)

    # --- cameras -------------------------------------------------------------------
    def camera(self, i: int) -> Camera | None:
        """True camera of frame ``i`` (None during a crowd cut-away), in the
        stored frame's pixels (``size``, ``pixel_aspect``), distortion included."""
        if self._cut[i]:
            return None
        cam = self._camera_at(i)
        if self._S_stored_from_drawn is None:
            return cam
        return Camera(K=self._S_stored_from_drawn @ cam.K, R=cam.R, t=cam.t, dist=cam.dist)

    def _camera_at(self, i: int) -> Camera:
        """The camera frame ``i`` is drawn with (square pixels, ``width`` x ``height``)."""
        c = self.camera_center
        tgt = np.array([self._target[i, 0], self._target[i, 1], 0.0])
        d = tgt - c
        pan = math.atan2(d[0], d[1])
        tilt = math.atan2(-d[2], math.hypot(d[0], d[1])) + self._tilt_bias
        f = float(self._f[i])
        if self.look is not None:
            dist = (self.look.k1_wide * (self.preset.f_range[0] * self.width / f),)
        else:
            k1 = self.preset.k1 * (self.width / f)  # distortion fades as the lens zooms in
            dist = (k1,) if self.preset.k1 else ()
        return camera_from_ptz(c, PTZ(pan, tilt, float(self._roll[i]), f), self._pp, dist=dist)

    def truth(self, i: int) -> TruthFrame:
        """Ground truth of frame ``i``."""
        cam = self.camera(i)
        pts = i / self.fps
        if cam is None:
            return TruthFrame(i, pts, None, False, False, 0.0)
        marks = self.pitch.sample_points(1.0)
        vis = self._in_image(cam, marks)
        circle = self.pitch["centre_circle"].sample(0.25)
        frac = float(np.mean(self._in_image(cam, circle)))
        return TruthFrame(i, pts, cam, bool(vis.sum() >= 20), frac >= 0.5, frac)

    def _in_image(self, cam: Camera, XY: np.ndarray) -> np.ndarray:
        X = np.column_stack([XY, np.zeros(len(XY))])
        front = cam.in_front(X)
        px = cam.project(X)
        with np.errstate(invalid="ignore"):
            return front & (px[:, 0] >= 0) & (px[:, 0] <= self.size[0] - 1) & (px[:, 1] >= 0) & (px[:, 1] <= self.size[1] - 1)

    # --- rendering -----------------------------------------------------------------
    def render(self, i: int) -> np.ndarray:
        """Frame ``i`` as BGR uint8 (H, W, 3), before video encoding."""
        if self._cut[i]:
            img = self._render_closeup(i)
        else:
            cam = self._camera_at(i)
            img = self._render_view(i, cam)
        self._post(i, img)
        if self._S_stored_from_drawn is not None:
            # the anamorphic squeeze: pixel centres map as x_stored = (x + 0.5) * sx - 0.5
            img = cv2.resize(img, self.size, interpolation=cv2.INTER_AREA)
        return img

    def _render_view(self, i: int, cam: Camera) -> np.ndarray:
        W, H = self.width, self.height
        if cam.dist:
            # render an undistorted view over a larger canvas, then remap
            margin = self._distortion_margin(cam)
            Kc = cam.K.copy()
            Kc[0, 2] += margin
            Kc[1, 2] += margin
            ucam = Camera(K=Kc, R=cam.R, t=cam.t)
            canvas = self._render_pinhole(i, ucam, W + 2 * margin, H + 2 * margin)
            mx, my = self._distortion_maps(cam, margin)
            return cv2.remap(canvas, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        return self._render_pinhole(i, cam, W, H)

    def _distortion_margin(self, cam: Camera) -> int:
        corners = np.array([[0, 0], [self.width - 1, 0], [0, self.height - 1], [self.width - 1, self.height - 1]], float)
        xn = (corners - cam.K[:2, 2]) / cam.K[0, 0]
        xu = undistort_normalized(xn, cam.dist)
        return int(np.ceil(np.abs(xu - xn).max() * cam.K[0, 0])) + 4

    def _distortion_maps(self, cam: Camera, margin: int) -> tuple[np.ndarray, np.ndarray]:
        """Source (undistorted canvas) coordinates for every output pixel, on a coarse
        grid refined by bilinear interpolation (the map is smooth)."""
        W, H = self.width, self.height
        step = 8
        gx = np.arange(0, W + step, step, dtype=np.float64)
        gy = np.arange(0, H + step, step, dtype=np.float64)
        X, Y = np.meshgrid(gx, gy)
        p = np.column_stack([X.ravel(), Y.ravel()])
        xn = (p - cam.K[:2, 2]) / cam.K[0, 0]
        xu = undistort_normalized(xn, cam.dist)
        src = xu * cam.K[0, 0] + cam.K[:2, 2] + margin
        sx = src[:, 0].reshape(X.shape).astype(np.float32)
        sy = src[:, 1].reshape(X.shape).astype(np.float32)
        mx = _upsample(sx, step)
        my = _upsample(sy, step)
        return np.ascontiguousarray(mx[:H, :W]), np.ascontiguousarray(my[:H, :W])

    def _render_pinhole(self, i: int, cam: Camera, W: int, H: int) -> np.ndarray:
        img = np.empty((H, W, 3), np.uint8)
        Hp = cam.H_img_from_pitch
        M = Hp @ self._T_pitch_from_grass
        cv2.warpPerspective(self._grass, M, (W, H), dst=img, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        self._fill_sky(img, cam)
        for plane in self._stands + self._boards:
            self._draw_plane(img, cam, plane)
        for bgr, strips in self._other_strips:
            self._paint_other_line(img, cam, strips, bgr, M, W, H)
        self._draw_lines(img, cam, M, W, H)
        self._draw_goals(img, cam)
        self._draw_players(i, img, cam, W, H)
        if self._shadow_poly is not None:
            self._darken_pitch_poly(img, cam, self._shadow_poly, 0.42, W, H)
        if self.look is not None and self.look.shadow is not None:
            poly = self.look.shadow_polygon(i / self.fps)
            if poly is not None:
                self._darken_pitch_poly(img, cam, poly, self.look.shadow["strength"], W, H, blur=0.7, clip=True)
        return img

    def _fill_sky(self, img, cam: Camera) -> None:
        """Paint everything at or above the horizon (plus a margin) as sky."""
        H, W = img.shape[:2]
        h = cam.horizon  # positive on the pitch side
        # the part of the frame on the sky side of the horizon (h . x < 0)
        poly = _clip_halfplane(np.array([[0, 0], [W - 1, 0], [W - 1, H - 1], [0, H - 1]], float), -h, 0.0)
        if len(poly) >= 3:
            cv2.fillPoly(img, [np.round(poly * 16).astype(np.int32)], (200, 170, 140), cv2.LINE_8, shift=4)

    def _draw_plane(self, img, cam: Camera, plane: _Plane) -> None:
        H, W = img.shape[:2]
        C = plane.corners()
        if np.any(cam.to_camera(C)[:, 2] < 1.0):
            if self.look is None:
                return
            # (realistic family) keep the part at least 1 m in front of the camera:
            # depth is linear in the texel coordinates (u, v)
            h, w = plane.tex.shape[:2]
            r3 = cam.R[2]
            uv = _clip_halfplane(np.array([[0, 0], [w - 1, 0], [w - 1, h - 1], [0, h - 1]], float), np.array([r3 @ plane.du, r3 @ plane.dv, r3 @ plane.origin + cam.t[2]]), 1.0)
            if len(uv) < 3:
                return
            C = plane.origin + uv[:, :1] * plane.du + uv[:, 1:] * plane.dv
        q = cam.project(C) if not cam.dist else _project_pinhole(cam, C)
        x0, y0 = np.floor(q.min(axis=0)).astype(int)
        x1, y1 = np.ceil(q.max(axis=0)).astype(int) + 1
        x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, W), min(y1, H)
        if x1 <= x0 or y1 <= y0:
            return
        A = np.column_stack([plane.du, plane.dv, plane.origin])
        Hm = cam.P @ np.vstack([A, [0, 0, 1.0]])
        T = np.array([[1.0, 0, -x0], [0, 1.0, -y0], [0, 0, 1.0]])
        roi = img[y0:y1, x0:x1]
        warped = cv2.warpPerspective(plane.tex, T @ Hm, (x1 - x0, y1 - y0), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
        mask = np.zeros(roi.shape[:2], np.uint8)
        cv2.fillConvexPoly(mask, np.round((q - [x0, y0]) * 16).astype(np.int32), 255, cv2.LINE_8, shift=4)
        cv2.copyTo(warped, mask, roi)

    def _draw_lines(self, img, cam: Camera, M_img_from_grass, W, H) -> None:
        mask = self._line_mask if mask_fits(self._line_mask, W, H) else np.zeros((H, W), np.uint8)
        mask[:] = 0
        self._fill_strips(mask, cam, self._strips)
        # worn paint: the wear map is attached to the pitch
        wear = cv2.warpPerspective(self._wear, M_img_from_grass, (W, H), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        alpha = cv2.multiply(mask, wear, scale=1 / 255.0)
        a3 = cv2.merge([alpha, alpha, alpha])
        inv = cv2.subtract(np.full_like(img, self._paint), img)
        cv2.add(img, cv2.multiply(inv, a3, scale=1 / 255.0), dst=img)

    def _paint_other_line(self, img, cam: Camera, strips, bgr, M_img_from_grass, W, H) -> None:
        """Blend an other sport's coloured line (``strips``) into ``img``, worn like the white paint."""
        mask = self._line_mask if mask_fits(self._line_mask, W, H) else np.zeros((H, W), np.uint8)
        mask[:] = 0
        self._fill_strips(mask, cam, strips)
        ys, xs = np.nonzero(mask)
        if len(ys) == 0:
            return
        y0, y1, x0, x1 = ys.min(), ys.max() + 1, xs.min(), xs.max() + 1
        T = np.array([[1.0, 0, -x0], [0, 1.0, -y0], [0, 0, 1.0]])
        wear = cv2.warpPerspective(self._wear, T @ M_img_from_grass, (x1 - x0, y1 - y0), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        a = (mask[y0:y1, x0:x1].astype(np.float32) * wear.astype(np.float32) / (255.0 * 255.0))[..., None]
        roi = img[y0:y1, x0:x1]
        roi[:] = np.clip(roi * (1 - a) + np.array(bgr, np.float32) * a + 0.5, 0, 255).astype(np.uint8)

    def _fill_strips(self, mask: np.ndarray, cam: Camera, strips) -> None:
        """Fill the projected strips (spots, closed rings, open strips) into ``mask`` (255, anti-aliased)."""
        polys = []
        for left, right, closed in strips:
            if right is None:  # a spot: filled disc
                polys_spot = self._project_runs(cam, left, closed=True)
                for p in polys_spot:
                    cv2.fillPoly(mask, [p], 255, cv2.LINE_AA, shift=4)
                continue
            if closed:
                outer = self._project_runs(cam, left, closed=True)
                inner = self._project_runs(cam, right, closed=True)
                if len(outer) == 1 and len(inner) == 1:
                    cv2.fillPoly(mask, [outer[0], inner[0]], 255, cv2.LINE_AA, shift=4)
                    continue
                # partly behind the camera: draw as open quads
                left = np.vstack([left, left[:1]])
                right = np.vstack([right, right[:1]])
            polys.extend(self._strip_polys(cam, left, right))
        if polys:
            cv2.fillPoly(mask, polys, 255, cv2.LINE_AA, shift=4)

    def _project_runs(self, cam: Camera, XY: np.ndarray, closed: bool) -> list[np.ndarray]:
        X = np.column_stack([XY, np.zeros(len(XY))])
        if np.any(cam.to_camera(X)[:, 2] < 0.5):
            return []
        q = _project_pinhole(cam, X)
        return [np.round(q * 16).astype(np.int32)]

    def _strip_polys(self, cam: Camera, left: np.ndarray, right: np.ndarray) -> list[np.ndarray]:
        """Polygons of a strip, split where it passes behind the camera."""
        XL = np.column_stack([left, np.zeros(len(left))])
        XR = np.column_stack([right, np.zeros(len(right))])
        ok = (cam.to_camera(XL)[:, 2] > 0.5) & (cam.to_camera(XR)[:, 2] > 0.5)
        ql = _project_pinhole(cam, XL)
        qr = _project_pinhole(cam, XR)
        out = []
        start = None
        for k in range(len(ok) + 1):
            good = k < len(ok) and ok[k]
            if good and start is None:
                start = k
            if not good and start is not None:
                if k - start >= 2:
                    poly = np.vstack([ql[start:k], qr[start:k][::-1]])
                    if np.all(np.abs(poly) < 1e5):
                        out.append(np.round(poly * 16).astype(np.int32))
                start = None
        return out

    def _draw_goals(self, img, cam: Camera) -> None:
        L = self.pitch.length / 2 - self.pitch.line_width / 2
        for sgn in (-1.0, 1.0):
            x = sgn * L
            a = np.array([[x, -GOAL_WIDTH / 2 - 0.06, 0], [x, -GOAL_WIDTH / 2 - 0.06, GOAL_HEIGHT + 0.06], [x, GOAL_WIDTH / 2 + 0.06, GOAL_HEIGHT + 0.06], [x, GOAL_WIDTH / 2 + 0.06, 0]])
            back = a + [sgn * 2.0, 0, 0]
            back[1:3, 2] = 1.0
            if np.any(cam.to_camera(np.vstack([a, back]))[:, 2] < 1.0):
                continue
            q = _project_pinhole(cam, a)
            qb = _project_pinhole(cam, back)
            depth = cam.to_camera(a[:1])[0, 2]
            th = max(int(round(0.12 * cam.focal / depth)), 1)
            for u, v in ((qb[0], qb[1]), (qb[1], qb[2]), (qb[2], qb[3]), (q[1], qb[1]), (q[2], qb[2])):
                cv2.line(img, _pt(u), _pt(v), (190, 190, 190), 1, cv2.LINE_AA, shift=4)
            cv2.polylines(img, [np.round(q * 16).astype(np.int32)], False, (250, 250, 250), th, cv2.LINE_AA, shift=4)

    def _player_positions(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        t = i / self.fps
        ball = self._target[i] + 3.0 * np.array([np.sin(0.9 * t + self._ball_wobble[0]), np.sin(0.7 * t + self._ball_wobble[1])])
        pos = []
        for p in self._players:
            centre = 0.55 * p.home + 0.45 * np.array([ball[0] + 0.25 * p.home[0], ball[1] + 0.3 * p.home[1]])
            wob = p.amp * np.array([np.sin(0.31 * t + p.phase[0]), np.sin(0.23 * t + p.phase[1])])
            pos.append(centre + wob)
        return np.array(pos), ball

    def _draw_players(self, i: int, img, cam: Camera, W: int, H: int) -> None:
        pos, ball = self._player_positions(i)
        order = np.argsort(-cam.to_camera(np.column_stack([pos, np.zeros(len(pos))]))[:, 2])
        # shadows first (on the grass)
        smask = self._shadow_mask if mask_fits(self._shadow_mask, W, H) else np.zeros((H, W), np.uint8)
        smask[:] = 0
        polys = []
        for k in order:
            p, pl = pos[k], self._players[k]
            d = self._sun * pl.height * 0.7
            side = np.array([-self._sun[1], self._sun[0]]) / np.linalg.norm(self._sun) * 0.25
            quad = np.array([p + side, p - side, p + d - side * 0.6, p + d + side * 0.6])
            X = np.column_stack([quad, np.zeros(4)])
            if np.all(cam.to_camera(X)[:, 2] > 1.0):
                polys.append(np.round(_project_pinhole(cam, X) * 16).astype(np.int32))
        for poly in polys:
            cv2.fillConvexPoly(smask, poly, 110, cv2.LINE_AA, shift=4)
        _darken(img, smask)
        t = i / self.fps
        for k in order:
            p, pl = pos[k], self._players[k]
            base = np.array([p[0], p[1], 0.0])
            if cam.to_camera(base[None])[0, 2] < 2.0:
                continue
            pts = _project_pinhole(cam, np.array([base, base + [0, 0, pl.height]]))
            b, top = pts
            hpx = np.linalg.norm(top - b)
            if not (np.all(np.isfinite(pts)) and -hpx < b[0] < W + hpx and -hpx < b[1] < H + 2 * hpx):
                continue
            up = (top - b) / max(hpx, 1e-6)
            right = np.array([-up[1], up[0]])
            if right[0] < 0:
                right = -right
            s = hpx / pl.height
            stride = 0.18 * np.sin(2 * np.pi * 1.6 * t + pl.phase[2])

            def part(z0, z1, w, off=0.0):
                c0 = b + up * z0 * s + right * off * s
                c1 = b + up * z1 * s + right * off * s
                hw = right * w * s / 2
                return np.round(np.array([c0 - hw, c0 + hw, c1 + hw, c1 - hw]) * 16).astype(np.int32)

            skin = (90, 130, 185)
            cv2.fillConvexPoly(img, part(0.0, 0.5, 0.13, -0.1 + stride), pl.socks, cv2.LINE_AA, shift=4)
            cv2.fillConvexPoly(img, part(0.0, 0.5, 0.13, 0.1 - stride), pl.socks, cv2.LINE_AA, shift=4)
            cv2.fillConvexPoly(img, part(0.45, 0.85, 0.3, 0.0), skin, cv2.LINE_AA, shift=4)
            cv2.fillConvexPoly(img, part(0.8, 1.02, 0.4), pl.shorts, cv2.LINE_AA, shift=4)
            cv2.fillConvexPoly(img, part(1.0, 1.5, 0.46), pl.kit, cv2.LINE_AA, shift=4)
            cv2.fillConvexPoly(img, part(1.05, 1.45, 0.1, 0.27), pl.kit, cv2.LINE_AA, shift=4)
            cv2.fillConvexPoly(img, part(1.05, 1.45, 0.1, -0.27), pl.kit, cv2.LINE_AA, shift=4)
            head_c = b + up * (pl.height - 0.13) * s
            cv2.circle(img, _pt(head_c), max(int(round(0.12 * s * 16)), 8), skin, -1, cv2.LINE_AA, shift=4)
        ballX = np.array([[ball[0], ball[1], 0.11]])
        if cam.to_camera(ballX)[0, 2] > 1.0:
            q = _project_pinhole(cam, ballX)[0]
            r = 0.11 * cam.focal / cam.to_camera(ballX)[0, 2]
            cv2.circle(img, _pt(q), max(int(round(r * 16)), 8), (245, 245, 245), -1, cv2.LINE_AA, shift=4)

    def _darken_pitch_poly(self, img, cam: Camera, poly_xy: np.ndarray, strength: float, W: int, H: int, blur: float = 2.0, clip: bool = False) -> None:
        """Darken the image of a convex pitch polygon (N, 2) by the share ``strength``,
        its edge blurred by ``blur`` pixels. ``clip``: cut the polygon where it
        passes within 0.5 m of the camera's image plane (else it is skipped)."""
        if clip:
            # depth of a pitch point (X, Y, 0): R[2, 0] X + R[2, 1] Y + t[2]
            poly_xy = _clip_halfplane(poly_xy, np.array([cam.R[2, 0], cam.R[2, 1], cam.t[2]]), 0.5)
            if len(poly_xy) < 3:
                return
        X = np.column_stack([poly_xy, np.zeros(len(poly_xy))])
        if np.any(cam.to_camera(X)[:, 2] < (0.5 - 1e-9 if clip else 0.5)):
            # clip against a plane in front of the camera on the pitch: keep it simple, skip
            return
        q = _project_pinhole(cam, X)
        smask = self._shadow_mask if mask_fits(self._shadow_mask, W, H) else np.zeros((H, W), np.uint8)
        smask[:] = 0
        cv2.fillPoly(smask, [np.round(q * 16).astype(np.int32)], int(255 * strength), cv2.LINE_AA, shift=4)
        smask[:] = cv2.GaussianBlur(smask, (0, 0), blur)
        _darken(img, smask)

    def _render_closeup(self, i: int) -> np.ndarray:
        H, W = self.height, self.width
        t = i / self.fps
        ch, cw = self._closeup.shape[:2]
        x = int((cw - W) * (0.5 + 0.4 * np.sin(0.3 * t)))
        y = int((ch - H) * (0.5 + 0.3 * np.sin(0.5 * t + 1)))
        return self._closeup[y : y + H, x : x + W].copy()

    def _post(self, i: int, img: np.ndarray) -> None:
        pr = self.preset
        if not self._cut[i] and pr.blur > 0:
            v = self._image_motion(i)
            length = float(np.hypot(*v)) * pr.blur
            if length > 1.5:
                k = int(min(np.ceil(length), 41)) | 1
                kern = np.zeros((k, k), np.float32)
                c = k // 2
                d = v / (np.hypot(*v) + 1e-9)
                for s in np.linspace(-length / 2, length / 2, 4 * k):
                    xx, yy = int(round(c + s * d[0])), int(round(c + s * d[1]))
                    if 0 <= xx < k and 0 <= yy < k:
                        kern[yy, xx] += 1
                kern /= kern.sum()
                cv2.filter2D(img, -1, kern, dst=img)
        if self.look is not None:
            cv2.GaussianBlur(img, (0, 0), self.look.softness, dst=img)  # the lens is not perfectly sharp
        pos, neg = self._noise[(i * 7 + self.seed) % len(self._noise)]
        cv2.add(img, pos, dst=img)
        cv2.subtract(img, neg, dst=img)
        if self.look is None:
            self._score_graphic(i, img)
        else:
            for g in self.look.graphics:
                if g["frames"][0] <= i <= g["frames"][1]:
                    _draw_graphic(img, g, i / self.fps)

    def _image_motion(self, i: int) -> np.ndarray:
        """Pixel motion per frame of the image centre (central difference)."""
        a, b = max(i - 1, 0), min(i + 1, self.n - 1)
        if a == b or self._cut[a] or self._cut[b]:
            return np.zeros(2)
        ca, cb, c = self._camera_at(a), self._camera_at(b), self._camera_at(i)
        ray = np.linalg.solve(c.K, [self.width / 2, self.height / 2, 1.0])
        X = c.center + 100.0 * (c.R.T @ ray)
        pa, pb = _project_pinhole(ca, X[None])[0], _project_pinhole(cb, X[None])[0]
        return (pb - pa) / (b - a)

    def _score_graphic(self, i: int, img: np.ndarray) -> None:
        s = self.width / 1280.0
        x0, y0 = int(36 * s), int(28 * s)
        w, h = int(290 * s), int(34 * s)
        roi = img[y0 : y0 + h, x0 : x0 + w]
        roi[:] = (roi * 0.25 + np.array([60, 25, 20]) * 0.75).astype(np.uint8)
        secs = 23 * 60 + 17 + i / self.fps
        text = f"ARS  1 - 0  FCV   {int(secs // 60):02d}:{int(secs % 60):02d}"
        cv2.putText(img, text, (x0 + int(10 * s), y0 + int(24 * s)), cv2.FONT_HERSHEY_SIMPLEX, 0.62 * s, (255, 255, 255), max(int(1.5 * s), 1), cv2.LINE_AA)
        cv2.rectangle(img, (x0, y0 + h - max(int(3 * s), 1)), (x0 + w, y0 + h), (40, 200, 240), -1)


# ---------------------------------------------------------------------------
def _fit_text(img: np.ndarray, text: str, box, colour, fill: float = 0.62, thick: float = 0.09) -> None:
    """Write ``text`` centred-left in ``box`` (x0, y0, x1, y1), its height ``fill`` of the box's."""
    x0, y0, x1, y1 = box
    font = cv2.FONT_HERSHEY_DUPLEX
    (tw, th), _ = cv2.getTextSize(text, font, 1.0, 1)
    scale = min(fill * (y1 - y0) / max(th, 1), 0.92 * (x1 - x0) / max(tw, 1))
    t = max(int(round(thick * scale * th)), 1)
    cv2.putText(img, text, (x0 + int(0.04 * (x1 - x0)), int(round((y0 + y1) / 2 + scale * th / 2))), font, scale, colour, t, cv2.LINE_AA)


def _draw_graphic(img: np.ndarray, g: dict, t: float) -> None:
    """Draw one on-screen graphic (:attr:`Look.graphics` item) at time ``t`` (s) into ``img`` (display pixels)."""
    H, W = img.shape[:2]
    x0, y0, x1, y1 = g["display_box"]
    x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, W), min(y1, H)
    if x1 - x0 < 4 or y1 - y0 < 4:
        return
    roi = img[y0:y1, x0:x1]
    over = roi.copy()
    w, h = x1 - x0, y1 - y0
    kind, bgr, text = g["kind"], tuple(g["bgr"]), g["text"]
    if kind == "score":
        over[:] = bgr
        over[:, : int(0.12 * w)] = (235, 235, 235)
        clock = 60 * 23 + 17 + t
        _fit_text(over, f"{text}  {int(clock // 60):02d}:{int(clock % 60):02d}", (int(0.14 * w), 0, w, h), (255, 255, 255))
    elif kind == "caption":
        over[: h // 2] = bgr
        over[h // 2 :] = (240, 240, 240)
        top, bottom = text.split("|")
        _fit_text(over, top, (0, 0, w, h // 2), (255, 255, 255))
        _fit_text(over, bottom, (0, h // 2, w, h), (60, 60, 60))
    elif kind == "black box":
        over[:] = 0
        _fit_text(over, text, (0, 0, w, h), (255, 255, 255), fill=0.5)
    else:  # logo, watermark: white letters over the picture
        _fit_text(over, text, (0, 0, w, h), (255, 255, 255), fill=0.75, thick=0.14)
    o = float(g["opacity"])
    if o >= 1.0:
        roi[:] = over
    else:
        cv2.addWeighted(over, o, roi, 1.0 - o, 0.0, dst=roi)


# ---------------------------------------------------------------------------
def mask_fits(mask: np.ndarray, W: int, H: int) -> bool:
    return mask.shape == (H, W)


def _upsample(grid: np.ndarray, step: int) -> np.ndarray:
    """Bilinear upsampling of a coarse map whose node (r, c) sits at pixel (r*step, c*step)."""
    gh, gw = grid.shape
    ys = np.arange((gh - 1) * step + 1) / step
    xs = np.arange((gw - 1) * step + 1) / step
    y0 = np.minimum(ys.astype(int), gh - 2)
    x0 = np.minimum(xs.astype(int), gw - 2)
    fy = (ys - y0)[:, None].astype(np.float32)
    fx = (xs - x0)[None, :].astype(np.float32)
    g00 = grid[y0][:, x0]
    g01 = grid[y0][:, x0 + 1]
    g10 = grid[y0 + 1][:, x0]
    g11 = grid[y0 + 1][:, x0 + 1]
    return (g00 * (1 - fx) + g01 * fx) * (1 - fy) + (g10 * (1 - fx) + g11 * fx) * fy


def _project_pinhole(cam: Camera, X: np.ndarray) -> np.ndarray:
    """Project (N, 3) world points with ``K [R|t]`` only (no distortion): (N, 2)."""
    Xc = X @ cam.R.T + cam.t
    with np.errstate(divide="ignore", invalid="ignore"):
        xn = Xc[:, :2] / Xc[:, 2:3]
    return xn @ cam.K[:2, :2].T + cam.K[:2, 2]


def _pt(p) -> tuple[int, int]:
    return int(round(p[0] * 16)), int(round(p[1] * 16))


def _darken(img: np.ndarray, mask: np.ndarray) -> None:
    """img *= (1 - mask/255) where mask > 0, on the mask's bounding box only."""
    ys, xs = np.nonzero(mask[::4, ::4])
    if len(ys) == 0:
        return
    y0, y1 = max(ys.min() * 4 - 4, 0), min(ys.max() * 4 + 8, mask.shape[0])
    x0, x1 = max(xs.min() * 4 - 4, 0), min(xs.max() * 4 + 8, mask.shape[1])
    inv = cv2.subtract(255, mask[y0:y1, x0:x1])
    roi = img[y0:y1, x0:x1]
    roi[:] = cv2.multiply(roi, cv2.merge([inv, inv, inv]), scale=1 / 255.0)


def _clip_halfplane(poly: np.ndarray, n: np.ndarray, offset: float) -> np.ndarray:
    """Clip a convex polygon (N, 2) to the half-plane ``n . (x, y, 1) >= offset``
    (Sutherland-Hodgman against one edge)."""
    out = []
    vals = poly @ n[:2] + n[2] - offset
    for k in range(len(poly)):
        a, b = poly[k], poly[(k + 1) % len(poly)]
        va, vb = vals[k], vals[(k + 1) % len(poly)]
        if va >= 0:
            out.append(a)
        if (va >= 0) != (vb >= 0):
            s = va / (va - vb)
            out.append(a + s * (b - a))
    return np.array(out) if out else np.zeros((0, 2))


# ---------------------------------------------------------------------------
def generate(out_dir, *, preset: str = "wide", seed: int = 0, frames: int = 250, size=None, fps: float = 25.0, crf: int | None = None, pixel_aspect=None, pitch=None, progress=None) -> dict:
    """Write ``clip.mp4``, ``truth.jsonl`` and ``header.json`` into ``out_dir``.

    ``pitch``: the pitch's size, a PitchModel or (length, width) in metres
    (default: 105 x 68, or the realistic family's size drawn per seed).

    ``size``, ``crf`` and ``pixel_aspect`` default to the preset's (the
    realistic family's :class:`~arstream.presets.RealPreset`), else 1280 x 720,
    23 and square pixels. A pixel aspect other than 1 is written into the
    stream as its sample aspect ratio. The header records the pitch size, and
    for the realistic family (or non-square pixels) ``pixel_aspect`` [p, q]
    and ``look`` (:class:`Look`: shadow, other sports' lines, graphics' boxes).

    Returns the header dict plus ``generation_fps`` (measured frames per second,
    not written to the header so that the same seed gives identical files).
    """
    import time

    from arstream.sink import JsonlWriter, VideoSink

    if pitch is not None and not isinstance(pitch, PitchModel):
        pitch = PitchModel(*(float(v) for v in pitch))
    clip = SynthClip(preset, seed, frames, size, fps, pitch=pitch, pixel_aspect=pixel_aspect)
    if crf is None:
        crf = clip.preset.crf if isinstance(clip.preset, RealPreset) else 23
    w, h = clip.size
    sar = clip.pixel_aspect if clip.pixel_aspect != 1 else None
    os.makedirs(out_dir, exist_ok=True)
    t0 = time.perf_counter()
    with VideoSink(os.path.join(out_dir, "clip.mp4"), w, h, fps, crf=crf, preset="veryfast", sample_aspect=sar, reproducible=True) as sink, JsonlWriter(os.path.join(out_dir, "truth.jsonl")) as truth:
        for i in range(clip.n):
            sink.write(clip.render(i), pts=i / fps)
            truth.write(clip.truth(i).to_record())
            if progress:
                progress(i + 1, clip.n)
    elapsed = time.perf_counter() - t0
    header = {
        "generator": "arstream.synth",
        "version": GENERATOR_VERSION,
        "preset": asdict(clip.preset),
        "seed": seed,
        "frames": clip.n,
        "size": [w, h],
        "fps": fps,
        "pitch": {"length": clip.pitch.length, "width": clip.pitch.width, "line_width": clip.pitch.line_width},
        "camera_center": clip.camera_center.tolist(),
    }
    # (the clean presets' headers stay as they were: no pixel_aspect means 1:1)
    if clip.look is not None or sar is not None:
        header["pixel_aspect"] = [clip.pixel_aspect.numerator, clip.pixel_aspect.denominator]
        header["crf"] = crf
    if clip.look is not None:
        header["look"] = asdict(clip.look)
    with open(os.path.join(out_dir, "header.json"), "w") as f:
        json.dump(header, f, indent=2)
    return {**header, "generation_fps": round(clip.n / elapsed, 2)}
