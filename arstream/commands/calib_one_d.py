"""``arstream calib one-d``: 1-D calibration (a rod about a fixed point, or a
sphere moved away from a fixed position).

Three inputs, one of them:

* ``--points FILE`` (Zhang's method, :func:`calib.one_d.zhang_1d`) with
  ``--length`` and ``--ratio``: a CSV file with one row per view and columns
  ``ax, ay, bx, by, cx, cy`` (a header row naming them is optional), or a
  JSON file ``{"a": [[x, y], ...], "b": [...], "c": [...]}`` (optionally with
  ``"length"`` and ``"ratio"``) or ``{"views": [{"a": [x, y], "b": ..., "c": ...}, ...]}``.
* ``--spheres FILE`` (:func:`calib.one_d.from_two_spheres`) with ``--radius``:
  a JSON file ``{"fixed": C, "moving": [C, ...]}`` where each ``C`` is a 3x3
  conic or an ellipse ``{"center": [x, y], "axes": [a, b], "angle": rad}``;
  ``"fixed"`` may be a list (one outline per view); optional
  ``"fixed_points"`` / ``"moving_points"`` (edge points) and ``"radius"``.
* ``--fixed-image IMAGE --moving-images IMAGE ...`` with ``--radius``: the
  sphere's outline is found in every image
  (:func:`calib.sphere.fit_sphere_outline`).

Prints one JSON object on stdout (docs/calib.md has a worked example of each input).
"""

from __future__ import annotations

import argparse
import csv
import json
import os

import numpy as np

from arstream.commands.calib import add_output_arguments, print_report
from arstream.errors import InputError

ORDER = 20


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "one-d",
        help="1-D calibration: a rod about a fixed point (Zhang 2004), or a sphere moved from a fixed position",
        description=(
            "Calibrate a camera from a 1-D object. Either image points of a rod turning about a fixed "
            "end (--points, with --length and --ratio), or outlines of a sphere imaged at a fixed "
            "position and moved to others (--spheres, or --fixed-image and --moving-images, with "
            "--radius). Prints JSON."
        ),
    )
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--points", metavar="FILE", help="CSV or JSON with the image points a, b, c of every view")
    src.add_argument("--spheres", metavar="FILE", help="JSON with the outline conics of the fixed and moved sphere")
    src.add_argument("--fixed-image", metavar="IMAGE", help="image of the sphere at the fixed position")
    p.add_argument("--moving-images", nargs="+", metavar="IMAGE", help="images of the sphere at the other positions")
    p.add_argument("--length", type=float, help="rod length |AB| (points mode)")
    p.add_argument("--ratio", type=float, help="|AC| / |AB| of the marker C (points mode; default 0.5)")
    p.add_argument("--radius", type=float, help="sphere radius (sphere modes; sets the units)")
    p.add_argument("--square-pixels", action="store_true", help="assume fx = fy (and zero skew)")
    p.add_argument("--skew", action="store_true", help="estimate a skew term too (Zhang's general model)")
    p.add_argument("--no-refine", action="store_true", help="report the closed-form solution only")
    add_output_arguments(p)
    p.set_defaults(func=run)


# --------------------------------------------------------------------------
# input
# --------------------------------------------------------------------------


def _read_text(path: str) -> str:
    if not os.path.isfile(path):
        raise InputError(f"file not found: {path}")
    try:
        with open(path, encoding="utf-8") as f:
            return f.read()
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read {path}: {exc}") from None


def _read_json(path: str):
    text = _read_text(path)
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not valid JSON ({exc})") from None


def _points_from_csv(path: str) -> dict:
    rows = [r for r in csv.reader(_read_text(path).splitlines()) if r and any(c.strip() for c in r)]
    if not rows:
        raise InputError(f"{path}: no rows")
    names = ["ax", "ay", "bx", "by", "cx", "cy"]
    header = [c.strip().lower() for c in rows[0]]
    if all(n in header for n in names):
        cols = [header.index(n) for n in names]
        rows = rows[1:]
    else:
        cols = list(range(6))
    try:
        data = np.array([[float(r[c]) for c in cols] for r in rows], dtype=np.float64)
    except (ValueError, IndexError):
        raise InputError(f"{path}: every row needs six numbers ax, ay, bx, by, cx, cy") from None
    if len(data) == 0:
        raise InputError(f"{path}: no views")
    return {"a": data[:, 0:2], "b": data[:, 2:4], "c": data[:, 4:6]}


def _points_from_json(path: str) -> dict:
    d = _read_json(path)
    try:
        if isinstance(d, dict) and "views" in d:
            views = d["views"]
            out = {k: np.array([v[k] for v in views], dtype=np.float64) for k in ("a", "b", "c")}
        elif isinstance(d, dict):
            out = {k: np.array(d[k], dtype=np.float64) for k in ("a", "b", "c")}
        else:
            raise KeyError("a")
    except (KeyError, TypeError, ValueError):
        raise InputError(f'{path}: expected {{"a": [[x, y], ...], "b": ..., "c": ...}} or {{"views": [...]}}') from None
    for k in ("length", "ratio"):
        if isinstance(d, dict) and k in d:
            out[k] = d[k]
    return out


def _conic(obj, where: str) -> np.ndarray:
    from geometry.conics import Ellipse

    try:
        if isinstance(obj, dict):
            return Ellipse(center=tuple(obj["center"]), axes=tuple(obj["axes"]), angle=float(obj.get("angle", 0.0))).conic
        C = np.array(obj, dtype=np.float64)
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"{where}: not a conic (3x3) or an ellipse {{center, axes, angle}}: {exc}") from None
    if C.shape != (3, 3):
        raise InputError(f"{where}: a conic must be 3x3, got shape {C.shape}")
    return C


def _is_single_conic(obj) -> bool:
    if isinstance(obj, dict):
        return True
    a = np.asarray(obj, dtype=object)
    return a.shape == (3, 3)


def _spheres_from_json(path: str) -> dict:
    d = _read_json(path)
    if not isinstance(d, dict) or "fixed" not in d or "moving" not in d:
        raise InputError(f'{path}: expected {{"fixed": conic, "moving": [conic, ...]}}')
    fixed = d["fixed"]
    fixed = [_conic(fixed, f"{path}: fixed")] if _is_single_conic(fixed) else [_conic(c, f"{path}: fixed[{i}]") for i, c in enumerate(fixed)]
    if not isinstance(d["moving"], list):
        raise InputError(f"{path}: moving must be a list of conics")
    moving = [_conic(c, f"{path}: moving[{i}]") for i, c in enumerate(d["moving"])]
    out = {"fixed": fixed, "moving": moving}
    for k in ("fixed_points", "moving_points"):
        if d.get(k) is not None:
            try:
                out[k] = [np.array(p, dtype=np.float64) for p in d[k]]
            except (TypeError, ValueError):
                raise InputError(f"{path}: {k} must be lists of [x, y] points") from None
    if "radius" in d:
        out["radius"] = d["radius"]
    return out


def _read_image(path: str):
    import cv2

    if not os.path.isfile(path):
        raise InputError(f"image not found: {path}")
    img = cv2.imread(path, cv2.IMREAD_COLOR)
    if img is None:
        raise InputError(f"cannot read image (unknown format or corrupt file): {path}")
    return img


# --------------------------------------------------------------------------
# run
# --------------------------------------------------------------------------


def _report(res, extra: dict) -> dict:
    out = {
        "method": res.method,
        "K": res.K.tolist(),
        "focal": res.focal,
        "model": res.model,
        "stage": res.stage,
        "residual_rms_px": res.residual_rms,
        "K_linear": None if res.K_linear is None else res.K_linear.tolist(),
        "fixed_point": res.fixed_point.tolist(),
        "views": [
            {
                "free_point": res.free_points[i].tolist(),
                "marker": res.markers[i].tolist(),
                "length": float(res.lengths[i]),
                "rms_px": float(res.per_view_rms[i]),
            }
            for i in range(len(res.free_points))
        ],
    }
    if res.geometry is not None:
        g = res.geometry
        out["init"] = res.init
        out["geometry"] = {
            "fixed_centre": g.fixed_centre.tolist(),
            "free_centres": g.free_centres.tolist(),
            "midpoints": g.midpoints.tolist(),
            "vanishing_points": g.vanishing_points.tolist(),
            "depth_ratios": g.depth_ratios.tolist(),
        }
    out.update(extra)
    return out


def run(args: argparse.Namespace) -> int:
    from calib import one_d

    if args.square_pixels and args.skew:
        raise InputError("--square-pixels and --skew exclude each other")
    model = {"square_pixels": args.square_pixels, "zero_skew": not args.skew}
    refine = not args.no_refine
    if args.points:
        data = _points_from_csv(args.points) if not args.points.lower().endswith(".json") else _points_from_json(args.points)
        length = args.length if args.length is not None else data.get("length")
        ratio = args.ratio if args.ratio is not None else data.get("ratio", 0.5)
        if length is None:
            raise InputError("--length is required with --points (the rod length |AB|)")
        res = one_d.zhang_1d(data["a"], data["b"], data["c"], length=length, ratio=ratio, refine=refine, **model)
        report = _report(res, {"source": args.points, "length": float(length), "ratio": float(ratio)})
    else:
        if args.spheres:
            data = _spheres_from_json(args.spheres)
            source = args.spheres
            images = None
        else:
            if not args.moving_images:
                raise InputError("--fixed-image needs --moving-images (two or more)")
            from calib.sphere import fit_sphere_outline

            outs = []
            for path in [args.fixed_image] + list(args.moving_images):
                try:
                    outs.append(fit_sphere_outline(_read_image(path)))
                except ValueError as exc:
                    raise ValueError(f"{path}: {exc}") from None
            data = {
                "fixed": [outs[0].conic],
                "moving": [o.conic for o in outs[1:]],
                "fixed_points": [outs[0].edge_points],
                "moving_points": [o.edge_points for o in outs[1:]],
            }
            source = args.fixed_image
            images = [args.fixed_image] + list(args.moving_images)
        radius = args.radius if args.radius is not None else data.get("radius")
        if radius is None:
            raise InputError("--radius is required with spheres (the sphere radius)")
        res = one_d.from_two_spheres(
            data["fixed"],
            data["moving"],
            radius=radius,
            fixed_points=data.get("fixed_points"),
            moving_points=data.get("moving_points"),
            refine=refine,
            **model,
        )
        extra = {"source": source, "radius": float(radius)}
        if images is not None:
            extra["images"] = images
        report = _report(res, extra)
    print_report(report, args)
    return 0
