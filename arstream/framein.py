"""Read one frame from an image file or a video (for the single-frame commands)."""

from __future__ import annotations

import os

import cv2
import numpy as np

from arstream.errors import InputError

IMAGE_EXT = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp"}


def add_frame_arguments(parser, *, draw_help: str) -> None:
    """The arguments of the single-frame commands: INPUT, --frame, --json, --draw."""
    parser.add_argument("input", help="image file (PNG, JPEG, ...) or video")
    parser.add_argument("--frame", type=int, default=0, help="frame index when INPUT is a video (default: 0)")
    parser.add_argument("--json", action="store_true", help="print JSON (default: a short summary)")
    parser.add_argument("--draw", metavar="OUT.png", help=draw_help)


def read_frame(path: str, frame: int = 0) -> np.ndarray:
    """BGR uint8 (H, W, 3) image of ``path`` (an image) or of frame ``frame`` of a video.

    Raises InputError for a missing or unreadable file or a frame past the end.
    """
    if not os.path.exists(path):
        raise InputError(f"input not found: {path}")
    if os.path.splitext(path)[1].lower() in IMAGE_EXT:
        img = cv2.imread(path, cv2.IMREAD_COLOR)
        if img is None:
            raise InputError(f"cannot read {path} as an image")
        return img
    from arstream.source import VideoSource

    if frame < 0:
        raise InputError(f"frame must be >= 0, got {frame}")
    with VideoSource(path) as src:
        for f in src:
            if f.index == frame:
                return f.image
        if src.errors:
            raise InputError(f"{path}: {src.errors[0]}")
    raise InputError(f"{path} has no frame {frame}")
