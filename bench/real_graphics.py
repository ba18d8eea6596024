"""Benchmark: ``arstream register`` on the real reference frames under broadcast
graphics (issue 29, points 1 and 3).

Every frame with a reference camera (the shared stills, the three Premier
League frames with their pixel aspect 16/9, and every 25th frame of the two
shared clips) is registered as a still, clean and with graphics drawn over it
the way broadcasts do: a lower-third caption, a score box with a channel
logo, an opaque bar over the bottom quarter or third (a ticker, a replay
wipe), letterbox and pillarbox bars, and the frame scaled to 854 x 480 and
saved as a strong JPEG; and two looks of the picture itself, an evening
match (darker, flatter), a soft picture (a 1.2 px blur) and a stand's
shadow across the pitch (a sunny afternoon); and the frame at
other resolutions (scaled by 0.75 and by 1.5: a 1280 x 720 frame at 960 x 540
and at 1920 x 1080). These hide or
fade markings but do not move them, so the reference camera is still the
truth (scaled with the frame). Two variants move the markings, with the
reference camera moved with the picture: the frame flipped left to right
and its centre enlarged 1.33 times (``GEOMETRIC``).

For each variant the table counts the frames registered, those within 5 px
of the reference, and those **beyond 20 px: wrong cameras that would be
drawn** (DESIGN 5b: never draw with a wrong camera). Distances are means over
the markings in the reference's view, in pixels of a 1280-wide frame.

Usage::

    python bench/real_graphics.py [--variants NAME ...] [--items PREFIX ...] [--show] [--draw DIR]

The material is read from ``../shared/data/real-broadcast`` (skipped with a
message where it is absent).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from arstream.evaluate_video import draw_overlay  # noqa: E402
from geometry.camera import Camera  # noqa: E402
from geometry.pitch import PitchModel  # noqa: E402
from arstream.evaluate import distance_1280  # noqa: E402
from real_footage import CLIPS, EPL_ASPECT, SHARED, STILLS, _register, reference_frames, references  # noqa: E402

#: pitch sizes of the clips whose pitch is not 105 x 68 (bench/real_footage.py --pitch)
PITCHES = {"artificial_turf_multisport": (100.0, 68.0)}


def _text(img: np.ndarray, text: str, org, scale: float, thickness: int) -> None:
    cv2.putText(img, text, (int(org[0]), int(org[1])), cv2.FONT_HERSHEY_SIMPLEX, scale, (255, 255, 255), thickness, cv2.LINE_AA)


def lower_third(img: np.ndarray) -> np.ndarray:
    """A caption box over the lower left: 60 % of the width, 13 % of the height."""
    out = img.copy()
    H, W = img.shape[:2]
    x0, y0, x1, y1 = int(0.06 * W), int(0.78 * H), int(0.66 * W), int(0.91 * H)
    out[y0:y1, x0:x1] = (90, 40, 10)
    out[y0 : y0 + max(2, H // 180), x0:x1] = (0, 200, 255)
    s = H / 720
    _text(out, "17  MARTINEZ  Forward", (x0 + 20 * s, y0 + 0.45 * (y1 - y0)), 1.1 * s, max(1, round(2 * s)))
    _text(out, "Goals this season 14", (x0 + 20 * s, y0 + 0.85 * (y1 - y0)), 0.8 * s, max(1, round(2 * s)))
    return out


def score_box(img: np.ndarray) -> np.ndarray:
    """A score box at the top left and a half-transparent channel logo at the top right."""
    out = img.copy()
    H, W = img.shape[:2]
    s = H / 720
    x0, y0, x1, y1 = int(0.04 * W), int(0.05 * H), int(0.30 * W), int(0.11 * H)
    out[y0:y1, x0:x1] = (30, 30, 30)
    _text(out, "ARS 1-0 CHE  63:12", (x0 + 12 * s, y1 - 0.25 * (y1 - y0)), 0.8 * s, max(1, round(2 * s)))
    logo = out.copy()
    _text(logo, "SPORT 1 HD", (0.80 * W, 0.10 * H), 1.2 * s, max(2, round(3 * s)))
    return cv2.addWeighted(logo, 0.6, out, 0.4, 0)


def bottom_bar(share: float):
    def draw(img: np.ndarray) -> np.ndarray:
        out = img.copy()
        H, W = img.shape[:2]
        y0 = int(round((1 - share) * H))
        out[y0:] = (40, 40, 40)
        s = H / 720
        _text(out, "GERMANY 1 - 0 ARGENTINA", (0.04 * W, y0 + 0.5 * (H - y0)), 1.2 * s, max(1, round(3 * s)))
        return out

    draw.__doc__ = f"An opaque bar with a caption over the bottom {share:.0%} of the frame."
    return draw


def barred(img: np.ndarray, variant: str) -> np.ndarray:
    """The BGR frame with black bars of ``variant`` drawn over it:
    ``letter:SHARE`` (the top and bottom SHARE of the rows) or
    ``pillar:SHARE`` (the left and right SHARE of the columns)."""
    kind, share = variant.split(":")
    out = img.copy()
    H, W = img.shape[:2]
    if kind == "letter":
        b = int(round(float(share) * H))
        out[:b] = 0
        out[H - b :] = 0
    elif kind == "pillar":
        b = int(round(float(share) * W))
        out[:, :b] = 0
        out[:, W - b :] = 0
    else:
        raise ValueError(f"a variant is letter:SHARE or pillar:SHARE, got {variant!r}")
    return out


def letterbox(img: np.ndarray) -> np.ndarray:
    """Black bars over the top and bottom 12.5 % (a 2.35:1 picture in a 16:9 frame)."""
    return barred(img, "letter:0.125")


def pillarbox(img: np.ndarray) -> np.ndarray:
    """Black bars over the left and right 12.5 % (a 4:3 picture in a 16:9 frame)."""
    return barred(img, "pillar:0.125")


def small_jpeg(img: np.ndarray) -> np.ndarray:
    """The frame scaled (area averaging) to 480 rows and saved as a JPEG of quality 35."""
    H, W = img.shape[:2]
    h = 480
    w = int(round(W * h / H / 2)) * 2
    small = cv2.resize(img, (w, h), interpolation=cv2.INTER_AREA)
    ok, buf = cv2.imencode(".jpg", small, [cv2.IMWRITE_JPEG_QUALITY, 35])
    return cv2.imdecode(buf, cv2.IMREAD_COLOR)


def dim(img: np.ndarray) -> np.ndarray:
    """An evening match under floodlights: the picture darker and flatter
    (``255 * 0.7 * (x / 255) ** 1.3 + 8``), a painted line's contrast about
    halved in the shadows."""
    x = img.astype(np.float32) / 255.0
    return np.clip(255.0 * 0.7 * x**1.3 + 8.0, 0, 255).astype(np.uint8)


def soft(img: np.ndarray) -> np.ndarray:
    """A soft picture (an upconverted or slightly defocused broadcast): a
    Gaussian blur of 1.2 px, which leaves a far line one or two pixels wide
    fainter than the paint's contrast."""
    return cv2.GaussianBlur(img, (0, 0), 1.2)


def shadow(img: np.ndarray) -> np.ndarray:
    """A stand's shadow across the pitch on a sunny afternoon: the frame above
    a slanted line (from 55 % of the height at the left edge to 30 % at the
    right) lit by the sky alone (red and green scaled by 0.45, blue by 0.55),
    its edge a 3 px penumbra. The shadow's edge is a long straight step of
    brightness on the grass, as bright on one side as a painted line is."""
    H, W = img.shape[:2]
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float32)
    edge = 0.55 * H + (0.30 - 0.55) * H * xx / max(W - 1, 1)
    lit = np.clip((yy - edge) / 3.0 + 0.5, 0.0, 1.0)[..., None]  # 1 in the sun, 0 in the shade
    shade = np.array([0.55, 0.45, 0.45], np.float32)  # B, G, R
    return np.clip(img.astype(np.float32) * (shade + (1.0 - shade) * lit), 0, 255).astype(np.uint8)


def rescaled(scale: float):
    """The frame resized by ``scale`` (area averaging down, bicubic up): the
    same view broadcast or grabbed at another resolution (0.75: 1280 x 720
    -> 960 x 540; 1.5: 1280 x 720 -> 1920 x 1080)."""

    def f(img: np.ndarray) -> np.ndarray:
        H, W = img.shape[:2]
        size = (int(round(W * scale / 2)) * 2, int(round(H * scale / 2)) * 2)
        return cv2.resize(img, size, interpolation=cv2.INTER_AREA if scale < 1 else cv2.INTER_CUBIC)

    return f


def mirrored(cam: Camera, W: int) -> Camera:
    """The camera of the frame flipped left to right (pixel ``u`` goes to ``W - 1 - u``):
    the view of the pitch mirrored in its halfway line's normal (X -> -X), which the
    pitch's markings map onto themselves. ``F K [R | t] M = K' D [R | t] M`` with
    ``D = diag(-1, 1, 1)``, so ``R' = D R D`` (still a rotation) and ``t' = D t``."""
    D = np.diag([-1.0, 1.0, 1.0])
    K = cam.K.copy()
    K[0, 2] = W - 1 - K[0, 2]
    K[0, 1] = -K[0, 1]
    return Camera(K=K, R=D @ cam.R @ D, t=D @ cam.t, dist=cam.dist)  # radial: symmetric


def mirror(img: np.ndarray) -> np.ndarray:
    """The frame flipped left to right: the same kind of view of the other half or end."""
    return img[:, ::-1].copy()


ZOOM = 1.33


def _crop_box(W: int, H: int, zoom: float) -> tuple[int, int, int, int]:
    x0, y0 = int(round(W * (1 - 1 / zoom) / 2)), int(round(H * (1 - 1 / zoom) / 2))
    return x0, y0, W - 2 * x0, H - 2 * y0


def zoomed(img: np.ndarray) -> np.ndarray:
    """The centre 1/1.33 of the frame enlarged back to its size (the view of a longer
    lens; markings at the edges leave it)."""
    H, W = img.shape[:2]
    x0, y0, cw, ch = _crop_box(W, H, ZOOM)
    return cv2.resize(img[y0 : y0 + ch, x0 : x0 + cw], (W, H), interpolation=cv2.INTER_LINEAR)


def _zoom_camera(cam: Camera, W: int, H: int) -> Camera:
    """The camera of :func:`zoomed`'s picture of a ``W`` x ``H`` frame seen by ``cam``."""
    x0, y0, cw, ch = _crop_box(W, H, ZOOM)
    shifted = Camera(K=np.array([[1.0, 0.0, -x0], [0.0, 1.0, -y0], [0.0, 0.0, 1.0]]) @ cam.K, R=cam.R, t=cam.t, dist=cam.dist)
    return scaled(shifted, W / cw, H / ch)


#: variants that move the markings: (the picture, the reference camera of the result
#: given the frame's reference camera and size (W, H))
GEOMETRIC = {
    "mirror": (mirror, lambda cam, W, H: mirrored(cam, W)),
    "zoom-1.33": (zoomed, _zoom_camera),
}


VARIANTS = {
    "clean": lambda img: img,
    "lower-third": lower_third,
    "score-box": score_box,
    "bar-25": bottom_bar(0.25),
    "bar-33": bottom_bar(0.33),
    "letterbox": letterbox,
    "pillarbox": pillarbox,
    "480p-jpeg35": small_jpeg,
    "dim": dim,
    "soft-1.2": soft,
    "shadow": shadow,
    "scale-0.75": rescaled(0.75),
    "scale-1.5": rescaled(1.5),
    **{k: v[0] for k, v in GEOMETRIC.items()},
}


def items(prefixes=None):
    """(name, BGR frame, pixel aspect, reference Camera, PitchModel) of every
    frame with a reference camera."""
    out = []
    for s in STILLS:
        img = cv2.imread(str(SHARED / "stills" / f"{s}.png"))
        for k, (cam, pitch) in references(s).items():
            out.append((s, img, 1.0, cam, pitch))
    for k, (cam, pitch) in sorted(references("sequence_epl").items()):
        out.append((f"sequence_epl {k:02d}", cv2.imread(str(SHARED / "sequence-epl" / f"frame_{k:02d}.jpg")), EPL_ASPECT, cam, pitch))
    for name in CLIPS:
        out += [(f"{name} {k:03d}", img, 1.0, cam, pitch) for k, img, cam, pitch in reference_frames(name)]
    if prefixes:
        out = [it for it in out if any(it[0].startswith(p) for p in prefixes)]
    return out


def scaled(cam: Camera, sx: float, sy: float) -> Camera:
    """The camera of the same frame resized by (sx, sy) (pixel centres at
    integers: pixel ``u`` goes to ``sx u + (sx - 1) / 2``, as OpenCV resizes)."""
    S = np.array([[sx, 0.0, (sx - 1) / 2], [0.0, sy, (sy - 1) / 2], [0.0, 0.0, 1.0]])
    return Camera(K=S @ cam.K, R=cam.R, t=cam.t, dist=cam.dist)


def run(variants, prefixes=None, show: bool = False, draw: Path | None = None) -> list[dict]:
    rows = []
    frames = items(prefixes)
    for v in variants:
        got = near = wrong = 0
        t0 = time.perf_counter()
        for name, img, aspect, ref, pitch in frames:
            H0, W0 = img.shape[:2]
            im = VARIANTS[v](img)
            H, W = im.shape[:2]
            truth = GEOMETRIC[v][1](ref, W0, H0) if v in GEOMETRIC else scaled(ref, W / W0, H / H0)
            item = name.split(" ")[0]
            est, cam = _register(im, aspect, PitchModel(*PITCHES[item]) if item in PITCHES else None)
            d = float("nan")
            if cam is not None:
                got += 1
                d = distance_1280(truth, cam, (W, H), pitch, est.info["pitch"].model(), pixel_aspect=aspect)
                near += d <= 5.0
                wrong += not d <= 20.0
            if show:
                sup = (est.info or {}).get("support")
                print(f"  {v:12s} {name:32s} {est.status:5s} support {sup if sup is None else round(sup, 3)}  distance {d:.1f} px" + ("" if cam is not None else f"  ({(est.info or {}).get('reason')})"), flush=True)
            if draw is not None and cam is not None and not d <= 20.0:
                draw.mkdir(parents=True, exist_ok=True)
                cv2.imwrite(str(draw / f"{v}_{name.replace(' ', '_')}.jpg"), draw_overlay(im, cam, f"{v} {name}: {d:.0f} px", pitch=est.info["pitch"].model(), pixel_aspect=aspect))
        rows.append({"variant": v, "frames": len(frames), "registered": got, "within_5px": near, "beyond_20px": wrong, "seconds": (time.perf_counter() - t0) / max(len(frames), 1)})
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=list(VARIANTS))
    ap.add_argument("--items", nargs="+", help="only the frames whose name starts with one of these")
    ap.add_argument("--show", action="store_true", help="print every frame's result")
    ap.add_argument("--draw", type=Path, help="write overlays of the wrong cameras (beyond 20 px) into this folder")
    a = ap.parse_args(argv)
    if not SHARED.exists():
        print(f"skipped: {SHARED} is absent")
        return 0
    rows = run(a.variants, a.items, a.show, a.draw)
    print("| variant | frames | registered | within 5 px | beyond 20 px (wrong) | s per frame |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['variant']} | {r['frames']} | {r['registered']} | {r['within_5px']} | {r['beyond_20px']} | {r['seconds']:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
