"""``arstream register``: the camera of one still image (no temporal help)."""

from __future__ import annotations

import json

ORDER = 25


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "register",
        help="solve the camera of a single frame (PNG/JPEG or a frame of a clip)",
        description=(
            "Solve the camera of one still: detect the pitch markings, initialise from the centre "
            "circle (pole-polar relations) or, when it is out of view, from line correspondences "
            "(penalty areas), and refine against every visible marking. Prints the camera as a "
            "cameras.jsonl record."
        ),
    )
    from arstream.framein import add_frame_arguments

    add_frame_arguments(p, draw_help="write the image with the projected pitch model drawn over it")
    p.set_defaults(func=run)


def run(args) -> int:
    import cv2
    import numpy as np

    from arstream.detect import detect
    from arstream.framein import read_frame
    from arstream.initialise import register_frame
    from geometry.pitch import PitchModel

    image = read_frame(args.input, args.frame)
    H, W = image.shape[:2]
    det = detect(image)
    est = register_frame(det, (W, H), image=image)
    rec = est.to_record()
    rec.pop("frame", None)
    rec.pop("pts", None)
    if args.json:
        print(json.dumps(rec))
    elif est.camera is None:
        print(f"lost: {est.info.get('reason', 'no camera')}")
    else:
        c = est.camera
        print(f"ok  f={c.focal:.1f}px  centre=({c.center[0]:.2f}, {c.center[1]:.2f}, {c.center[2]:.2f}) m  k1={c.dist[0] if c.dist else 0:.4f}  confidence={est.confidence:.2f}")
    if args.draw:
        out = image.copy()
        if est.camera is not None:
            for poly in PitchModel().polylines(0.25):
                X = np.column_stack([poly, np.zeros(len(poly))])
                px = est.camera.project(X)
                ok = np.all(np.isfinite(px), axis=1)
                for a, b in zip(px[:-1][ok[:-1] & ok[1:]], px[1:][ok[:-1] & ok[1:]]):
                    cv2.line(out, (int(round(a[0] * 16)), int(round(a[1] * 16))), (int(round(b[0] * 16)), int(round(b[1] * 16))), (0, 0, 255), 1, cv2.LINE_AA, shift=4)
        if not cv2.imwrite(args.draw, out):
            from arstream.errors import InputError

            raise InputError(f"cannot write {args.draw}")
    return 0 if est.camera is not None else 1
