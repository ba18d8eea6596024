"""Synthetic broadcast frames with a known camera and grass matte (tests, benchmark, docs).

Not a simulator (``arstream synth`` is): a mown pitch with its markings, a
few standing players and dark stands, drawn with OpenCV for a given camera,
plus the exact grass matte of the picture.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from geometry.camera import PTZ, Camera, camera_from_ptz
from geometry.pitch import PitchModel

__all__ = ["main_camera", "pitch_frame", "PLAYERS"]

#: A few player positions (x, y) in metres and shirt colours (BGR).
PLAYERS = (
    ((-17.0, -13.5), (40, 40, 220)),
    ((-23.5, -15.0), (230, 230, 230)),
    ((-9.0, -4.0), (40, 40, 220)),
    ((12.0, 6.0), (230, 230, 230)),
    ((21.0, -8.0), (40, 40, 220)),
    ((26.0, 2.0), (230, 230, 230)),
)


def main_camera(width: int = 1280, height: int = 720, *, pan_deg: float = 0.0, tilt_deg: float = 17.0,
                roll_deg: float = 0.0, hfov_deg: float = 62.0, center=(0.0, -62.0, 21.0),
                principal_point=None, dist: tuple = ()) -> Camera:
    """A main-stand broadcast camera: behind the near touchline, above the halfway line.

    Parameters
    ----------
    width, height : image size in pixels
    pan_deg, tilt_deg, roll_deg : orientation (see ``geometry.camera.rotation_from_ptr``)
    hfov_deg : horizontal field of view; sets the focal length
    center : (3,) camera centre in the pitch frame, metres
    principal_point : (2,) pixels, default the image centre
    dist : radial distortion coefficients
    """
    f = 0.5 * width / math.tan(math.radians(hfov_deg) / 2)
    pp = ((width - 1) / 2, (height - 1) / 2) if principal_point is None else principal_point
    ptz = PTZ(math.radians(pan_deg), math.radians(tilt_deg), math.radians(roll_deg), f)
    return camera_from_ptz(np.asarray(center, float), ptz, pp, dist=dist)


def pitch_frame(camera: Camera, width: int, height: int, *, players=PLAYERS, pitch: PitchModel | None = None,
                seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Draw a broadcast-looking frame.

    Returns
    -------
    frame : (H, W, 3) uint8 BGR
    grass_matte : (H, W) uint8, 255 where the pixel is grass (markings,
        players and the stands are not grass)
    """
    pitch = pitch or PitchModel()
    rng = np.random.default_rng(seed)
    vv, uu = np.mgrid[0:height, 0:width]
    XY = camera.backproject_to_pitch(np.column_stack([uu.ravel(), vv.ravel()]).astype(np.float64))
    X, Y = XY[:, 0].reshape(height, width), XY[:, 1].reshape(height, width)
    ground = np.isfinite(X) & (np.abs(X) < pitch.length / 2 + 6) & (np.abs(Y) < pitch.width / 2 + 5)
    stripe = (np.floor(np.nan_to_num(X) / (pitch.length / 18)).astype(int) % 2).astype(bool)
    frame = np.empty((height, width, 3), np.uint8)
    frame[:] = (48, 52, 58)  # stands
    light, dark = np.array([62, 150, 70], np.uint8), np.array([50, 128, 58], np.uint8)
    frame[ground & stripe] = light
    frame[ground & ~stripe] = dark
    noise = rng.normal(0.0, 3.0, (height, width, 1))
    frame = np.clip(frame + noise, 0, 255).astype(np.uint8)
    matte = np.where(ground, 255, 0).astype(np.uint8)

    # markings: project densely sampled centrelines, draw ~line-width strokes
    lines = np.zeros((height, width), np.uint8)
    for poly in pitch.polylines(0.25):
        P = np.column_stack([poly, np.zeros(len(poly))])
        ok = camera.in_front(P)
        if ok.sum() < 2:
            continue
        px = camera.project(P[ok])
        depth = camera.to_camera(P[ok])[:, 2].mean()
        th = max(1, int(round(camera.focal * pitch.line_width / depth)))
        cv2.polylines(lines, [np.round(px * 16).astype(np.int32)], False, 255, th, cv2.LINE_AA, shift=4)
    a = lines.astype(np.float32)[..., None] / 255.0
    frame = (frame * (1 - a) + np.array([235, 240, 240], np.float32) * a).astype(np.uint8)
    matte = np.minimum(matte, 255 - lines)

    # players: coloured bodies with dark shorts, heads, standing at their positions
    for (x, y), shirt in players:
        foot = np.array([[x, y, 0.0]])
        if not camera.in_front(foot)[0]:
            continue
        pts = camera.project(np.array([[x, y, 0.0], [x, y, 1.8], [x + 0.25, y, 0.9], [x - 0.25, y, 0.9]]))
        (fx, fy), (hx, hy) = pts[0], pts[1]
        hw = max(2, int(abs(pts[2, 0] - pts[3, 0]) / 2 + 0.5))
        body = np.zeros((height, width), np.uint8)
        h = fy - hy
        cv2.rectangle(body, (int(fx - hw), int(hy + 0.18 * h)), (int(fx + hw), int(fy - 0.45 * h)), 255, -1)
        legs = np.zeros_like(body)
        cv2.rectangle(legs, (int(fx - hw * 0.8), int(fy - 0.45 * h)), (int(fx + hw * 0.8), int(fy)), 255, -1)
        head = np.zeros_like(body)
        cv2.circle(head, (int(hx), int(hy + 0.09 * h)), max(2, int(0.09 * h)), 255, -1)
        frame[body > 0] = shirt
        frame[legs > 0] = (30, 30, 30)
        frame[head > 0] = (120, 150, 190)
        matte[(body | legs | head) > 0] = 0
    return frame, matte
