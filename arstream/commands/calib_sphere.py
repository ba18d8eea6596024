"""``arstream calib sphere``: intrinsics from images of a sphere.

Each image must show the sphere once (the same camera, fixed zoom and focus,
the sphere elsewhere in every image). The command finds each outline
(:func:`calib.sphere.fit_sphere_outline`), estimates ``K``
(:func:`calib.sphere.intrinsics_from_spheres`, with the edge points, so the
answer is the geometric refinement) and, from the radius, the sphere's centre
in each image's camera frame. It prints one JSON object, as every calibration
tool does, or a summary for people with ``--summary``.
"""

from __future__ import annotations

import argparse
import os

import cv2
import numpy as np

from arstream.commands.calib import add_output_arguments, print_report

ORDER = 10


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "sphere",
        help="intrinsics from three or more images of a sphere",
        description=(
            "Calibrate a camera from images of a sphere (rank-1 constraint of the sphere's "
            "outline and the image of the absolute conic). Each image shows the sphere once. "
            "Prints JSON (--summary: a summary for people)."
        ),
    )
    p.add_argument("images", nargs="+", metavar="IMAGE", help="image files (3 or more), one sphere each")
    p.add_argument("--radius", type=float, required=True, help="sphere radius (sets the units of the centres)")
    p.add_argument("--summary", action="store_true", help="print a summary for people instead of the JSON")
    p.add_argument("--json", action="store_true", help=argparse.SUPPRESS)  # the default; accepted for older scripts
    p.add_argument("--square-pixels", action="store_true", help="assume fx = fy (and zero skew)")
    p.add_argument("--skew", action="store_true", help="estimate a skew term too")
    add_output_arguments(p)
    p.set_defaults(func=run)


def _read(path: str) -> np.ndarray:
    if not os.path.isfile(path):
        raise OSError(f"image not found: {path}")
    img = cv2.imread(path, cv2.IMREAD_COLOR)
    if img is None:
        raise OSError(f"cannot read image (unknown format or corrupt file): {path}")
    return img


def run(args: argparse.Namespace) -> int:
    from calib import sphere

    if not (np.isfinite(args.radius) and args.radius > 0):
        raise ValueError(f"--radius must be positive, got {args.radius}")
    if args.square_pixels and args.skew:
        raise ValueError("--square-pixels and --skew exclude each other")
    if args.summary and (args.json or args.pretty):
        raise ValueError("--summary prints text: it excludes --json and --pretty")
    if len(args.images) < 3:
        raise ValueError(f"sphere calibration needs at least 3 images, got {len(args.images)}")
    images = [_read(path) for path in args.images]  # fail early on a missing file
    outlines = []
    for path, img in zip(args.images, images):
        try:
            outlines.append(sphere.fit_sphere_outline(img))
        except ValueError as exc:
            raise ValueError(f"{path}: {exc}") from None
    res = sphere.intrinsics_from_spheres(
        [o.conic for o in outlines],
        edge_points=[o.edge_points for o in outlines],
        square_pixels=args.square_pixels,
        zero_skew=not args.skew,
    )
    centres = res.centres(args.radius)
    report = {
        "K": res.K.tolist(),
        "model": res.model,
        "constraint_set": res.constraint_set,
        "rms_px": res.rms,
        "focal_sigma": res.focal_sigma,
        "weak": res.weak,
        "K_linear": res.K_linear.tolist(),
        "images": [
            {
                "path": path,
                "conic": o.conic.tolist(),
                "ellipse": {"center": list(o.ellipse.center), "axes": list(o.ellipse.axes), "angle": o.ellipse.angle},
                "n_points": int(len(o.edge_points)),
                "support": o.support,
                "fit_rms_px": o.rms,
                "residual_px": float(res.residuals[i]),
                "imaged_centre": res.imaged_centres[i].tolist(),
                "centre": centres[i].tolist(),
            }
            for i, (path, o) in enumerate(zip(args.images, outlines))
        ],
    }
    if not args.summary:
        print_report(report, args)
        return 0
    K = res.K
    print(f"K ({res.model}, {res.constraint_set}; rms {res.rms:.3f} px):")
    for row in K:
        print("  [" + ", ".join(f"{v:10.3f}" for v in row) + "]")
    print(f"focal length: fx {K[0, 0]:.2f}, fy {K[1, 1]:.2f} px (relative std {res.focal_sigma:.2%})")
    if res.weak:
        print("WARNING: weak result: these sphere images constrain the focal length poorly")
    for item in report["images"]:
        c = item["centre"]
        print(
            f"{item['path']}: {item['n_points']} edge points, fit rms {item['fit_rms_px']:.3f} px, "
            f"centre ({c[0]:.4f}, {c[1]:.4f}, {c[2]:.4f})"
        )
    return 0
