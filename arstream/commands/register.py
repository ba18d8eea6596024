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
            "(penalty areas), and refine against every visible marking; on real broadcast frames, "
            "from the straight lines of the white paint. A camera is reported only when the "
            "frame's paint backs it (line support >= 0.7, docs/evaluate.md). Without --pitch the "
            "pitch's size is an unknown: the camera is made at 105 x 68 m (where the markings fit "
            "that camera poorly, line support below 0.95, the still is registered at "
            "100/105/110 x 64/68/72 m, on every core, and the size whose camera they fit clearly better taken), then "
            "the size the view constrains (e.g. the width when both touchlines are seen) is "
            "estimated with it and kept when the paint backs it as well. Prints the camera and the size it was made at "
            "(--json: a cameras.jsonl record with a \"pitch\" entry)."
        ),
    )
    from arstream.commands.eval import _pitch, _positive
    from arstream.framein import add_frame_arguments

    add_frame_arguments(p, draw_help="write the image with the projected pitch model drawn over it")
    p.add_argument("--pitch", type=_pitch, default=None, metavar="LxW", help="pitch size in metres, where known (default: estimated from 105x68, or from the scan's size, as far as the view constrains it)")
    p.add_argument(
        "--pixel-aspect", type=_positive(float), default=1.0, metavar="A",
        help="a pixel's width over its height, for frames resized from another shape (e.g. 1.7778 for 16:9 squeezed to a square); the camera's K then has K[1][1]/K[0][0] = A (default 1)",
    )  # fmt: skip
    p.add_argument("--workers", type=_positive(int), default=None, metavar="N", help="processes the scan of sizes registers the still on, one size each (default: every core; 1: one after another)")
    p.set_defaults(func=run)


def run(args) -> int:
    import cv2

    from arstream.evaluate_video import draw_overlay
    from arstream.framein import read_frame
    from arstream.initialise import register_image
    from arstream.workers import cores
    from geometry.pitch import PitchModel

    image = read_frame(args.input, args.frame)
    # (square pixels for the solver, the picture inside any black bars; mapped back to the frame)
    est = register_image(image, pixel_aspect=args.pixel_aspect, pitch=PitchModel(*args.pitch) if args.pitch else None, workers=args.workers or cores())
    made_at = est.info.get("pitch")
    pitch = made_at.model() if made_at is not None else PitchModel(*args.pitch) if args.pitch else PitchModel()
    rec = est.to_record()
    # (the frame's index in INPUT: the record pairs with it in ``eval --video INPUT``)
    rec["frame"] = args.frame
    rec.pop("pts", None)
    if made_at is not None:
        rec["pitch"] = made_at.to_dict()
    if est.camera is None:
        rec["reason"] = est.info.get("reason", "no camera")
    if args.json:
        print(json.dumps(rec))
    elif est.camera is None:
        print(f"lost: {rec['reason']}")
    else:
        c = est.camera
        sup = est.info.get("support")
        print(
            f"ok  f={c.focal:.1f}px  centre=({c.center[0]:.2f}, {c.center[1]:.2f}, {c.center[2]:.2f}) m  k1={c.dist[0] if c.dist else 0:.4f}  "
            f"confidence={est.confidence:.2f}" + (f"  line support={sup:.2f}" if sup is not None else "")
        )
        if made_at is not None:
            print(made_at.describe())
    if args.draw:
        out = draw_overlay(image, est.camera, est.status if est.camera is None else f"{est.status}  line support {est.info.get('support', float('nan')):.2f}", pitch=pitch, pixel_aspect=args.pixel_aspect)
        if not cv2.imwrite(args.draw, out):
            from arstream.errors import InputError

            raise InputError(f"cannot write {args.draw}")
    return 0 if est.camera is not None else 1
