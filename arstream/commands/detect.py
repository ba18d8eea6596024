"""``arstream detect``: the pitch detector on one frame (debug view)."""

from __future__ import annotations

import json

ORDER = 20


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "detect",
        help="detect grass, lines and circle ellipses in one frame (JSON, drawing)",
        description=(
            "Run the pitch detector on one frame: an image, or frame N of a video. Prints the "
            "straight lines (homogeneous, a^2+b^2=1) and the circle ellipses (conic matrices, "
            "DESIGN.md conventions); --draw writes the detections over the frame."
        ),
    )
    from arstream.framein import add_frame_arguments

    add_frame_arguments(p, draw_help="write the frame with line pixels, lines and ellipses drawn")
    p.set_defaults(func=run)


def draw(image, det):
    """The frame with the detections drawn (BGR uint8 copy)."""
    import cv2
    import numpy as np

    out = image.copy()
    green = np.zeros_like(out)
    green[det.grass_mask == 0] = (60, 0, 60)
    cv2.addWeighted(out, 1.0, green, 0.5, 0, dst=out)
    ix = np.round(det.line_points).astype(int)
    out[ix[:, 1], ix[:, 0]] = (0, 0, 255)
    for l in det.lines:
        a, b = l.endpoints
        cv2.line(out, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), (255, 80, 0), 2, cv2.LINE_AA)
    for k, e in enumerate(det.ellipses):
        el = e.ellipse
        color = (0, 255, 255) if k == 0 else (0, 160, 255)
        cv2.ellipse(out, (int(round(el.center[0])), int(round(el.center[1]))), (int(round(el.axes[0])), int(round(el.axes[1]))), np.degrees(el.angle), 0, 360, color, 2, cv2.LINE_AA)
    return out


def run(args) -> int:
    import cv2

    from arstream.detect import detect
    from arstream.errors import InputError
    from arstream.framein import read_frame

    image = read_frame(args.input, args.frame)
    det = detect(image)
    if args.json:
        print(json.dumps(det.to_json()))
    else:
        print(
            f"pitch {'visible' if det.pitch_visible else 'not visible'}: {len(det.line_points)} line pixels, "
            f"{len(det.lines)} lines, {len(det.ellipses)} ellipses"
            + (f" (best: coverage {det.ellipses[0].coverage:.2f}, rms {det.ellipses[0].rms:.2f} px)" if det.ellipses else "")
        )
    if args.draw and not cv2.imwrite(args.draw, draw(image, det)):
        raise InputError(f"cannot write {args.draw}")
    return 0
