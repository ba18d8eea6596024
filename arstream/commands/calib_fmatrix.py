"""``arstream calib fmatrix``: the fundamental matrix of two views from point matches.

Reads two point files (``N x 2`` text or CSV, or JSON: a list of ``[x, y]``, or
an object with a ``"points"`` list), row ``i`` of one matching row ``i`` of the
other, runs :func:`calib.fmatrix.estimate` (robust, default) or
:func:`calib.fmatrix.six_point` (``--coplanar`` given: exactly six matches, four
of them coplanar), and prints one JSON object.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from arstream.errors import InputError

ORDER = 40


def _read_points(path: str) -> np.ndarray:
    p = Path(path)
    if not p.is_file():
        raise InputError(f"point file not found: {path}")
    text = p.read_text()
    if p.suffix.lower() == ".json" or text.lstrip().startswith(("[", "{")):
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise InputError(f"{path}: not valid JSON ({exc})") from None
        if isinstance(data, dict):
            data = data.get("points")
        try:
            pts = np.asarray(data, dtype=np.float64)
        except (TypeError, ValueError):
            raise InputError(f"{path}: expected a list of [x, y] pairs") from None
    else:
        rows = []
        for k, line in enumerate(text.splitlines(), 1):
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            fields = line.replace(",", " ").replace(";", " ").split()
            try:
                rows.append([float(v) for v in fields])
            except ValueError:
                if not rows and k == 1:  # a CSV header
                    continue
                raise InputError(f"{path}:{k}: not a number in {line!r}") from None
        pts = np.asarray(rows, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise InputError(f"{path}: expected N rows of 2 coordinates, got shape {pts.shape}")
    return pts


def _parse_indices(text: str) -> list[int]:
    try:
        return [int(v) for v in text.replace(" ", "").split(",") if v]
    except ValueError:
        raise InputError(f"--coplanar expects comma-separated integers, got {text!r}") from None


def _run(args: argparse.Namespace) -> int:
    from calib import fmatrix

    from arstream.commands.calib import print_report

    x1 = _read_points(args.points1)
    x2 = _read_points(args.points2)
    if args.coplanar is not None:
        res = fmatrix.six_point(x1, x2, coplanar=_parse_indices(args.coplanar), method=args.six_point_method)
    else:
        res = fmatrix.estimate(
            x1, x2, method=args.method, threshold=args.threshold, confidence=args.confidence,
            refine_cost=args.refine, seed=args.seed,
        )
    e1, e2 = fmatrix.epipoles(res.F)
    out = {
        "method": res.method,
        "F": res.F.tolist(),
        "n_points": int(len(x1)),
        "n_inliers": res.n_inliers,
        "rms_sampson_px": res.rms,
        "epipole1": e1.tolist(),
        "epipole2": e2.tolist(),
        "H2_from_1": None if res.H2_from_1 is None else res.H2_from_1.tolist(),
        "iterations": res.iterations,
    }
    if args.per_point:
        out["inliers"] = res.inliers.astype(int).tolist()
        out["residuals_px"] = res.residuals.tolist()
    print_report(out, args)
    return 0


def register(subparsers) -> None:
    from arstream.commands.calib import add_output_arguments
    from calib.fmatrix import REFINE_COSTS, ROBUST_METHODS, SIX_POINT_METHODS

    p = subparsers.add_parser(
        "fmatrix",
        help="fundamental matrix from point matches (robust, or six points with four coplanar)",
        description=(
            "Estimate F (x2^T F x1 = 0) from matching points of two images and print JSON. "
            "Point files: N x 2 text/CSV (whitespace, comma or semicolon separated; '#' comments) "
            "or JSON ([[x, y], ...] or {\"points\": [...]})."
        ),
    )
    p.add_argument("points1", help="points in image 1 (pixels)")
    p.add_argument("points2", help="the matching points in image 2, same order")
    p.add_argument("--method", choices=ROBUST_METHODS, default="plane_parallax", help="robust estimator (default: %(default)s)")
    p.add_argument("--threshold", type=float, default=1.0, help="inlier threshold on the Sampson distance, px (default: %(default)s)")
    p.add_argument("--confidence", type=float, default=0.999, help="RANSAC confidence (default: %(default)s)")
    p.add_argument("--refine", choices=REFINE_COSTS, default="sampson", help="final refinement cost (default: %(default)s)")
    p.add_argument("--seed", type=int, default=0, help="random seed of the sampling (default: %(default)s)")
    p.add_argument(
        "--coplanar", metavar="I,J,K,L", default=None,
        help="six-point mode: indices of the 4 coplanar matches among exactly 6",
    )
    p.add_argument("--six-point-method", choices=SIX_POINT_METHODS, default="projective", help="six-point formulation (default: %(default)s)")
    p.add_argument("--per-point", action="store_true", help="also print the inlier mask and the residuals")
    add_output_arguments(p)
    p.set_defaults(func=_run)
