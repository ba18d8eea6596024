"""Benchmark: how much of a clip's jitter proxy is the picture's own motion.

The jitter proxy (``arstream eval --video``, issue 29) is the RMS second
difference of the picture point under each frame's centre, projected with
the cameras of the frame before, the frame itself and the frame after. A
camera that pans at a steady rate scores 0; one that speeds up or slows
down scores its acceleration, however right its cameras are. A broadcast
whip pan (the picture's centre from 10 to 68 px a frame in four frames)
is several pixels of second difference on its own.

This bench measures the picture's own motion without the cameras: a
broadcast camera turns about a fixed point, so consecutive frames are
related by one homography for every static thing in view (grass, boards,
crowd), whatever its depth. Corners tracked from frame to frame (OpenCV's
pyramidal Lucas-Kanade, checked forward and back) give that homography
(RANSAC, 1 px), with the picture's static overlays (score graphics, logos:
pixels that hardly change over the clip) left out. Per frame with a camera
before and after, it reports:

* ``cameras``: the proxy's second difference, as ``arstream eval`` takes it;
* ``picture``: the same second difference of the picture's own motion, the
  centre carried to the frames before and after by the homographies: what a
  perfect camera would score;
* ``cameras - picture``: how the drawn markings move against the picture,
  which is the jitter a viewer sees.

It prints the RMS of each over the clip (pixels of a 1280-wide frame), with
and without the frames of the clip's fastest change of motion, and what
those frames alone put into a perfect camera's proxy over the whole clip.
On a synthetic clip (``--truth truth.jsonl``) it also scores the truth's
cameras.

How far the picture's measure can be trusted: its random part (two halves
of the corners against each other) is 0.1 px on the shared real clip. On
``israel_league_wide`` the corners on the grass and the corners everywhere
(two independent measures) agree within 0.27 px at the median, more in the
whip pan's blur. On synthetic clips it is not reliable: against their exact
cameras it errs by 0.5-0.8 px RMS (the ``zoom`` and ``hard`` presets, seed
1), its corners being players, lines (which slide along themselves) and a
periodic crowd. Use it on real footage, and read it where the picture's own
second differences are large against those errors (a whip pan's 10-25 px).

Usage::

    python bench/jitter_floor.py CLIP --pred cameras.jsonl [--truth truth.jsonl] [--csv OUT]

Lens distortion is left out of the homographies (the frames' centres, where
the proxy is taken, move least under it).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from arstream.evaluate_video import cameras_by_frame  # noqa: E402
from arstream.sink import read_jsonl  # noqa: E402
from arstream.source import VideoSource  # noqa: E402
from arstream.support import jitter_proxy  # noqa: E402

#: a pixel whose grey level moves less than this (standard deviation over
#: the clip's frames) is a static overlay, not the scene
OVERLAY_STD = 3.0
#: corners tracked per frame pair
CORNERS = 600
#: forward-backward disagreement (px) beyond which a tracked corner is dropped
FB_MAX = 0.5
#: RANSAC reprojection threshold of the frame-to-frame homography (px)
RANSAC_PX = 1.0
#: fewest inliers of a homography that is used
MIN_INLIERS = 40


def grass(image: np.ndarray) -> np.ndarray:
    """H x W bool: the grass of a BGR frame by its hue (green, saturated),
    closed over the lines and players on it (30 px)."""
    hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
    g = cv2.inRange(hsv, (30, 40, 30), (95, 255, 255))
    g = cv2.morphologyEx(g, cv2.MORPH_CLOSE, np.ones((31, 31), np.uint8))
    return cv2.erode(g, np.ones((9, 9), np.uint8)) > 0


def grey_frames(path, on_grass: bool) -> tuple[list[np.ndarray], list[np.ndarray | None], tuple[int, int]]:
    """The clip's frames in grey (uint8, H x W), their grass (:func:`grass`,
    or None without ``on_grass``) and the clip's (width, height)."""
    out, masks = [], []
    with VideoSource(path) as src:
        size = (src.width, src.height)
        for f in src:
            out.append(f.gray.copy())
            masks.append(grass(f.image) if on_grass else None)
    return out, masks, size


def overlay_mask(frames: list[np.ndarray]) -> np.ndarray:
    """H x W bool: pixels that hardly change over the clip (graphics, bars), grown by 8 px."""
    sample = np.stack(frames[:: max(1, len(frames) // 60)]).astype(np.float32)
    still = sample.std(axis=0) < OVERLAY_STD
    return cv2.dilate(still.astype(np.uint8), np.ones((17, 17), np.uint8)).astype(bool)


def step_homography(a: np.ndarray, b: np.ndarray, keep: np.ndarray, rng: np.random.Generator) -> tuple[tuple | None, int]:
    """The homography carrying frame ``a``'s pixels to frame ``b``'s (3 x 3,
    pixel coordinates), from corners of ``a`` inside ``keep``: (H, H1, H2),
    H from all the RANSAC inliers (least squares), H1 and H2 from two random
    halves of them (for the measure's noise), and the inlier count; (None,
    n) with fewer than :data:`MIN_INLIERS` inliers."""
    p0 = cv2.goodFeaturesToTrack(a, CORNERS, 0.01, 8, mask=keep.astype(np.uint8))
    if p0 is None or len(p0) < MIN_INLIERS:
        return None, 0
    lk = dict(winSize=(21, 21), maxLevel=4, criteria=(cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01))
    p1, st1, _ = cv2.calcOpticalFlowPyrLK(a, b, p0, None, **lk)
    p2, st2, _ = cv2.calcOpticalFlowPyrLK(b, a, p1, None, **lk)
    good = (st1[:, 0] == 1) & (st2[:, 0] == 1) & (np.linalg.norm((p2 - p0)[:, 0], axis=1) < FB_MAX)
    if np.count_nonzero(good) < MIN_INLIERS:
        return None, int(np.count_nonzero(good))
    H, inl = cv2.findHomography(p0[good], p1[good], cv2.RANSAC, RANSAC_PX)
    n = int(inl.sum()) if inl is not None else 0
    if H is None or n < MIN_INLIERS:
        return None, n
    x0, x1 = p0[good][inl[:, 0] == 1], p1[good][inl[:, 0] == 1]
    half = rng.permutation(n) < n // 2
    return tuple(cv2.findHomography(x0[m], x1[m], 0)[0] for m in (np.ones(n, bool), half, ~half)), n


def _apply(H: np.ndarray, p: np.ndarray) -> np.ndarray:
    q = H @ np.array([p[0], p[1], 1.0])
    return q[:2] / q[2]


def picture_second_differences(steps: list[np.ndarray | None], size: tuple[int, int]) -> dict[int, np.ndarray]:
    """Frame i -> the second difference (2,) of its centre carried to frames
    i - 1 and i + 1 by the picture's homographies (``steps[i]``: 3 x 3,
    frame i to i + 1, or None); frames whose two steps were not measured
    are left out."""
    W, H = size
    c = np.array([(W - 1) / 2.0, (H - 1) / 2.0])
    out = {}
    for i in range(1, len(steps)):
        back, fwd = steps[i - 1], steps[i]
        if back is None or fwd is None:
            continue
        out[i] = _apply(np.linalg.inv(back), c) - 2 * c + _apply(fwd, c)
    return out


def camera_second_differences(cams: list, size: tuple[int, int]) -> dict[int, np.ndarray]:
    """Frame i -> the jitter proxy's second difference (2,) at frame i
    (:func:`arstream.support.jitter_proxy` of its three frames)."""
    out = {}
    for i in range(1, len(cams) - 1):
        j = jitter_proxy(cams[i - 1 : i + 2], size)
        if j.n_triples:
            out[i] = j.second_differences[0]
    return out


def _cams(path, n: int) -> list:
    by = cameras_by_frame(read_jsonl(path), Path(path).name)
    return [by.get(i, ("missing", None))[1] for i in range(n)]


def _rms(d: list[np.ndarray]) -> float:
    return float(np.sqrt(np.mean([v @ v for v in d]))) if d else float("nan")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("clip")
    ap.add_argument("--pred", required=True, help="the product's cameras.jsonl")
    ap.add_argument("--truth", help="a synthetic clip's truth.jsonl, also scored")
    ap.add_argument("--features", choices=("grass", "all"), default="grass", help="track corners on the grass only (the pitch plane: right whether or not the camera turns about a fixed point), or everywhere but the overlays")
    ap.add_argument("--csv", help="per-frame second differences (px @1280)")
    ap.add_argument("--burst", type=int, default=8, help="frames either side of the largest picture second difference left out of the second row")
    a = ap.parse_args(argv)
    frames, on, size = grey_frames(a.clip, a.features == "grass")
    keep = ~overlay_mask(frames)
    steps, inliers = [], []
    rng = np.random.default_rng(0)
    for i in range(len(frames) - 1):
        Hs, n = step_homography(frames[i], frames[i + 1], keep if on[i] is None else keep & on[i], rng)
        steps.append(Hs)
        inliers.append(n)
    scale = 1280.0 / size[0]
    pic, h1, h2 = ({i: v * scale for i, v in picture_second_differences([s and s[k] for s in steps], size).items()} for k in range(3))
    # (each half's error has twice the variance of the whole's: their difference four times)
    noise = _rms([h1[i] - h2[i] for i in h1]) / 2
    sets = {"pred": _cams(a.pred, len(frames))}
    if a.truth:
        sets["truth"] = _cams(a.truth, len(frames))
    cam = {k: {i: v * scale for i, v in camera_second_differences(c, size).items()} for k, c in sets.items()}
    print(f"{a.clip}: {len(frames)} frames {size[0]}x{size[1]}, {sum(s is not None for s in steps)} of {len(steps)} steps measured (corners on {a.features}, inliers median {int(np.median(inliers))}), overlay {100 * (1 - keep.mean()):.1f} % of the picture")
    print(f"the picture measure's own noise (split halves of the corners): {noise:.2f} px RMS")
    worst = max(pic, key=lambda i: pic[i] @ pic[i]) if pic else None
    print(f"largest picture second difference: frame {worst} ({np.linalg.norm(pic[worst]):.1f} px)" if worst is not None else "no picture motion measured")
    print("| cameras | frames | cameras | picture | cameras - picture | the same without frames within %d of %s |" % (a.burst, worst))
    print("|---|---|---|---|---|---|")
    for k, d in cam.items():
        both = sorted(set(d) & set(pic))
        rest = [i for i in both if worst is None or abs(i - worst) > a.burst]
        row = [_rms([d[i] for i in both]), _rms([pic[i] for i in both]), _rms([d[i] - pic[i] for i in both])]
        row2 = [_rms([d[i] for i in rest]), _rms([pic[i] for i in rest]), _rms([d[i] - pic[i] for i in rest])]
        print(f"| {k} | {len(both)} | {row[0]:.2f} | {row[1]:.2f} | {row[2]:.2f} | {row2[0]:.2f} / {row2[1]:.2f} / {row2[2]:.2f} |")
    if worst is not None:
        burst = [pic[i] for i in pic if abs(i - worst) <= a.burst]
        print(f"the {len(burst)} frames within {a.burst} of frame {worst} alone: a perfect camera's proxy over the clip's {len(pic)} measured frames at least {np.sqrt(sum(v @ v for v in burst) / len(pic)):.2f} px")
    if a.csv:
        with open(a.csv, "w") as fh:
            fh.write("frame,inliers," + ",".join(f"{k}_x,{k}_y" for k in cam) + ",picture_x,picture_y\n")
            for i in range(1, len(frames) - 1):
                vals = [f"{v:.3f}" for k in cam for v in (cam[k].get(i, (np.nan, np.nan)))]
                p = pic.get(i, (np.nan, np.nan))
                fh.write(f"{i},{inliers[i]}," + ",".join(vals) + f",{p[0]:.3f},{p[1]:.3f}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
