"""``arstream calib laser``: a camera and its laser light plane from images of a sphere.

Inputs, one of them:

* ``IMAGE ...``: images of the sphere (light grey is best) crossed by the
  laser line; the outline and the stripe are found in each
  (:func:`calib.sphere.fit_sphere_outline`, :func:`calib.structured_light.extract_stripe`).
* ``--data FILE``: JSON ``{"conics": [C, ...], "stripe_points": [[[x, y], ...] | null, ...]}``,
  each ``C`` a 3x3 conic or an ellipse ``{"center", "axes", "angle"}``;
  optional ``"edge_points"`` (outline points per image), ``"radius"``, ``"K"``.

``--radius`` is the sphere's radius (units of the answer); ``--intrinsics
FILE`` (JSON with ``"K"``) fixes known intrinsics. Prints one JSON object:
``K``, the plane ``{"normal", "d"}`` (``normal . X = d`` in the camera frame),
the sphere centres and the residuals.
"""

from __future__ import annotations

import argparse

import numpy as np

from arstream.commands.calib import add_output_arguments, print_report
from arstream.commands.calib_one_d import _conic, _read_image, _read_json
from arstream.errors import InputError

ORDER = 30


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "laser",
        help="camera + laser light plane from images of a sphere crossed by the laser line",
        description=(
            "Calibrate a camera and a laser line projector (its light plane) from images of a sphere "
            "of known radius crossed by the laser stripe, or from outline conics and stripe points "
            "(--data). Prints JSON."
        ),
    )
    p.add_argument("images", nargs="*", metavar="IMAGE", help="images of the sphere with the laser stripe")
    p.add_argument("--data", metavar="FILE", help="JSON with outline conics and stripe points instead of images")
    p.add_argument("--radius", type=float, help="sphere radius (sets the units)")
    p.add_argument("--intrinsics", metavar="FILE", help='JSON with a known "K" (3x3): only the plane is estimated')
    p.add_argument("--channel", default="red", choices=["red", "green", "blue", "grey"], help="laser colour (images)")
    p.add_argument("--square-pixels", action="store_true", help="assume fx = fy (and zero skew)")
    p.add_argument("--skew", action="store_true", help="estimate a skew term too")
    p.add_argument("--no-refine", action="store_true", help="skip the joint refinement")
    add_output_arguments(p)
    p.set_defaults(func=run)


def _K_from_file(path: str) -> np.ndarray:
    d = _read_json(path)
    try:
        K = np.array(d["K"] if isinstance(d, dict) else d, dtype=np.float64)
    except (KeyError, TypeError, ValueError):
        raise InputError(f'{path}: expected {{"K": [[...], [...], [...]]}}') from None
    if K.shape != (3, 3):
        raise InputError(f"{path}: K must be 3x3, got shape {K.shape}")
    return K


def run(args: argparse.Namespace) -> int:
    from calib import structured_light as sl

    if args.square_pixels and args.skew:
        raise InputError("--square-pixels and --skew exclude each other")
    if bool(args.images) == bool(args.data):
        raise InputError("give either images or --data FILE (not both)")
    K = _K_from_file(args.intrinsics) if args.intrinsics else None
    radius = args.radius
    if args.data:
        d = _read_json(args.data)
        if not isinstance(d, dict) or "conics" not in d or "stripe_points" not in d:
            raise InputError(f'{args.data}: expected {{"conics": [...], "stripe_points": [...]}}')
        if not isinstance(d["conics"], list) or not isinstance(d["stripe_points"], list):
            raise InputError(f"{args.data}: conics and stripe_points must be lists")
        inputs = [_conic(c, f"{args.data}: conics[{i}]") for i, c in enumerate(d["conics"])]
        try:
            stripes = [None if s is None else np.array(s, dtype=np.float64).reshape(-1, 2) for s in d["stripe_points"]]
            edges = None if d.get("edge_points") is None else [np.array(e, dtype=np.float64) for e in d["edge_points"]]
        except (TypeError, ValueError):
            raise InputError(f"{args.data}: stripe_points and edge_points must be lists of [x, y] points") from None
        if radius is None:
            radius = d.get("radius")
        if K is None and d.get("K") is not None:
            K = np.array(d["K"], dtype=np.float64)
        source = args.data
    else:
        inputs = [_read_image(p) for p in args.images]
        stripes, edges = None, None
        source = args.images
    if radius is None:
        raise InputError("--radius is required (the sphere radius)")
    res = sl.calibrate(
        inputs,
        stripes,
        radius=radius,
        edge_points=edges,
        K=K,
        square_pixels=args.square_pixels,
        zero_skew=not args.skew,
        channel=args.channel,
        refine=not args.no_refine,
    )
    report = {
        "source": source,
        "radius": float(radius),
        "K": res.K.tolist(),
        "model": res.model,
        "stage": res.stage,
        "plane": {"normal": res.plane.normal.tolist(), "d": res.plane.d},
        "centres": res.centres.tolist(),
        "rms_px": res.rms,
        "outline_rms_px": res.outline_rms,
        "stripe_rms_px": res.stripe_rms,
        "plane_rms": res.plane_rms,
        "n_stripe_points": res.n_stripe_points,
        "skipped_images": list(res.skipped),
        "K_spheres": res.K_spheres.tolist(),
        "plane_init": {"normal": res.plane_init.normal.tolist(), "d": res.plane_init.d},
    }
    print_report(report, args)
    return 0
