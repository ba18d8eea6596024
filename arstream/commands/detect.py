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
            "straight lines (homogeneous, a^2+b^2=1, with their uncertainty) and the circle "
            "ellipses (conic matrices with unit Frobenius norm, docs/formats.md); --draw writes the detections "
            "over the frame (line points red, lines blue, the centre-circle candidate yellow, "
            "penalty arcs orange, outside the pitch dimmed)."
        ),
    )
    from arstream.framein import add_frame_arguments

    add_frame_arguments(p, draw_help="write the frame with line pixels, lines and ellipses drawn")
    p.set_defaults(func=run)


def draw(image, det):
    """The frame with the detections drawn (BGR uint8 copy)."""
    from arstream.detect import draw_detections

    return draw_detections(image, det)


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
        best = det.ellipses[0] if det.ellipses else None
        print(
            f"pitch {'visible' if det.pitch_visible else 'not visible'}: {len(det.line_points)} line points, "
            f"{len(det.lines)} lines, {len(det.ellipses)} ellipses"
            + (f" (best: {best.kind}, coverage {best.coverage:.2f}, rms {best.rms:.2f} px)" if best else "")
        )
    if args.draw:
        try:
            ok = cv2.imwrite(args.draw, draw(image, det))
        except cv2.error:
            ok = False
        if not ok:
            raise InputError(f"cannot write {args.draw} (an image file: .png, .jpg, ...)")
    return 0
