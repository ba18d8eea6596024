"""Example inputs of the calibration tools (``arstream calib``), with their truth.

The worked examples of ``docs/calib.md`` run on these files. One camera takes
every example: ``K = [[900, 0, 330], [0, 910, 235], [0, 0, 1]]`` (pixels),
640 x 480 images, no distortion. The inputs are synthetic (exact forward
models of :mod:`calib.synthetic` and :mod:`calib.structured_light`, with fixed
seeds and a little noise), so the answer each tool should give is known.

    python -m calib.examples DIR

writes into ``DIR`` (made if missing):

========================== ================================= ===============================
file                       what                              tool
========================== ================================= ===============================
``sphere-1..4.png``        a ball of radius 0.1 in four      ``calib sphere``
                           places (shaded, over clutter)
``rod.csv``                12 views of a 70 cm rod turning   ``calib one-d --points``
                           about its fixed end A, marker C
                           at its middle (0.3 px noise)
``spheres.json``           outlines of a ball of radius      ``calib one-d --spheres``
                           0.05 at a fixed place and moved
                           to 5 others (ellipses)
``laser.json``             outlines of a ball of radius      ``calib laser --data``
                           0.05 in 6 places and the laser
                           stripe's pixels on each
``view-1.txt``,            100 matches of two views, 20 of   ``calib fmatrix``
``view-2.txt``             them wrong (0.5 px noise)
``six-1.json``,            six exact matches, the first      ``calib fmatrix --coplanar``
``six-2.json``             four on one plane
``truth.json``             K, the light plane, F             (to compare with)
========================== ================================= ===============================

The text files (everything but the PNG images) are committed in
``docs/examples/calib/``; ``--no-images`` writes only those.
"""

from __future__ import annotations

import argparse
import json
import os

import numpy as np

__all__ = ["K", "IMAGE_SIZE", "write_examples"]

#: The examples' camera (pixels): fx 900, fy 910, principal point (330, 235).
K = np.array([[900.0, 0.0, 330.0], [0.0, 910.0, 235.0], [0.0, 0.0, 1.0]])
IMAGE_SIZE = (640, 480)

_ROD_A = np.array([0.0, 35.0, 150.0])  # the rod's fixed end, camera frame (cm)
_ROD_LENGTH = 70.0
_BALL = 0.05  # radius of the ball of the one-d and laser examples
_PROJECTOR = np.array([0.3, 0.0, 0.0])  # the laser's position, camera frame


def _ellipse(C) -> dict:
    """An outline conic as the ``{"center", "axes", "angle"}`` the tools read."""
    from geometry.conics import ellipse_from_conic

    e = ellipse_from_conic(C)
    return {"center": [round(float(v), 4) for v in e.center], "axes": [round(float(v), 4) for v in e.axes], "angle": round(float(e.angle), 6)}


def _fitted(points) -> np.ndarray:
    from geometry.conics import fit_ellipse

    return fit_ellipse(points).conic


def _rod(rng) -> str:
    from calib.one_d import project_rod

    th = rng.uniform(np.pi / 6, 5 * np.pi / 6, 12)
    ph = rng.uniform(np.pi, 2 * np.pi, 12)
    d = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], axis=1)
    a, b, c = (p + rng.normal(0.0, 0.3, p.shape) for p in project_rod(K, _ROD_A, d, length=_ROD_LENGTH, ratio=0.5))
    rows = ["ax,ay,bx,by,cx,cy"] + [",".join(f"{v:.3f}" for v in (*a[i], *b[i], *c[i])) for i in range(len(a))]
    return "\n".join(rows) + "\n"


def _spheres(rng) -> dict:
    from calib import synthetic as syn

    X = syn.random_sphere_centres(K, IMAGE_SIZE, 6, radius=_BALL, image_radius=(35.0, 60.0), min_separation=2.0, rng=rng)
    outlines = [_ellipse(_fitted(syn.sphere_outline_points(K, x, _BALL, 200, noise=0.2, rng=rng))) for x in X]
    return {"fixed": outlines[0], "moving": outlines[1:]}


def _plane():
    from calib.structured_light import LightPlane

    return LightPlane.from_point_normal(_PROJECTOR, [1.0, 0.0, 0.3])


def _laser(rng) -> dict:
    from calib import structured_light as sl
    from calib import synthetic as syn

    plane = _plane()
    centres = []
    while len(centres) < 6:  # balls the plane cuts, their outlines inside the image
        z = rng.uniform(0.6, 1.5)
        y = rng.uniform(-0.18, 0.18) * z
        x = (plane.d + rng.uniform(-0.7, 0.7) * _BALL - plane.normal[1] * y - plane.normal[2] * z) / plane.normal[0]
        p = K @ [x, y, z]
        u, v, r = p[0] / p[2], p[1] / p[2], K[0, 0] * _BALL / z
        if r + 5 < u < IMAGE_SIZE[0] - r - 5 and r + 5 < v < IMAGE_SIZE[1] - r - 5:
            centres.append(np.array([x, y, z]))
    conics = [_ellipse(_fitted(syn.sphere_outline_points(K, c, _BALL, 200, noise=0.2, rng=rng))) for c in centres]
    stripes = [np.round(sl.stripe_points(K, c, _BALL, plane, 40, projector=_PROJECTOR, noise=0.2, rng=rng), 2).tolist() for c in centres]
    return {"conics": conics, "stripe_points": stripes}


def _two_views(rng):
    from calib.synthetic import look_at
    from geometry.camera import Camera

    cams = []
    for centre in ([0.0, 0.0, -4.0], [1.2, -0.3, -3.8]):
        R = look_at(centre, [0.0, 0.0, 0.0])
        cams.append(Camera(K=K, R=R, t=-R @ np.array(centre)))
    return cams


def _matches(rng, cams) -> tuple[str, str]:
    n, wrong = 100, 20
    X = rng.uniform([-1.0, -0.8, -0.8], [1.0, 0.8, 0.8], (n, 3))
    x1, x2 = (c.project(X) + rng.normal(0.0, 0.5, (n, 2)) for c in cams)
    x2[:wrong] = rng.uniform([0.0, 0.0], IMAGE_SIZE, (wrong, 2))  # wrong matches
    text = ["# x y (pixels), one match a row: row i of view-1.txt matches row i of view-2.txt"]
    return tuple("\n".join(text + [f"{u:.2f} {v:.2f}" for u, v in x]) + "\n" for x in (x1, x2))


def _six(cams) -> tuple[dict, dict]:
    X = np.array([[-0.6, -0.5, 0.0], [0.7, -0.4, 0.0], [0.5, 0.6, 0.0], [-0.4, 0.5, 0.0], [0.1, 0.2, 0.7], [-0.3, -0.1, -0.6]])  # 0-3 on z = 0
    return tuple({"points": np.round(c.project(X), 6).tolist()} for c in cams)


def _truth(cams) -> dict:
    from calib.fmatrix import fundamental_from_cameras

    F = fundamental_from_cameras(cams[0].P, cams[1].P)
    F = F / np.linalg.norm(F) * np.sign(F[2, 2])
    plane = _plane()
    return {
        "K": K.tolist(),
        "sphere_radius": 0.1,
        "rod": {"fixed_point": _ROD_A.tolist(), "length": _ROD_LENGTH, "ratio": 0.5},
        "ball_radius": _BALL,
        "plane": {"normal": plane.normal.tolist(), "d": float(plane.d)},
        "F": F.tolist(),
        "wrong_matches": list(range(20)),
    }


def _json_text(obj: dict) -> str:
    """A JSON object with one top-level key a line (readable, and short for the small ones)."""
    return "{\n" + ",\n".join(f"  {json.dumps(k)}: {json.dumps(v)}" for k, v in obj.items()) + "\n}\n"


def write_examples(out_dir, *, images: bool = True) -> list[str]:
    """Write the example inputs (see the module docstring) into ``out_dir``.

    Parameters
    ----------
    out_dir : folder, made if missing
    images : also render the sphere images (about a second each)

    Returns
    -------
    list of str, the files written (names, in ``out_dir``).
    """
    os.makedirs(out_dir, exist_ok=True)
    written: dict[str, str | dict] = {}
    cams = _two_views(np.random.default_rng(5))
    written["rod.csv"] = _rod(np.random.default_rng(1))
    written["spheres.json"] = _spheres(np.random.default_rng(2))
    written["laser.json"] = _laser(np.random.default_rng(3))
    written["view-1.txt"], written["view-2.txt"] = _matches(np.random.default_rng(4), cams)
    written["six-1.json"], written["six-2.json"] = _six(cams)
    written["truth.json"] = _truth(cams)
    for name, content in written.items():
        with open(os.path.join(out_dir, name), "w", encoding="utf-8") as f:
            f.write(content if isinstance(content, str) else _json_text(content))
    names = list(written)
    if images:
        import cv2

        from calib import synthetic as syn

        rng = np.random.default_rng(6)
        X = syn.random_sphere_centres(K, IMAGE_SIZE, 4, radius=0.1, image_radius=(70.0, 110.0), rng=rng)
        for i, x in enumerate(X, 1):
            name = f"sphere-{i}.png"
            cv2.imwrite(os.path.join(out_dir, name), syn.render_spheres(K, x, 0.1, IMAGE_SIZE, rng=rng))
            names.append(name)
    return names


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m calib.examples", description="Write the example inputs of the calibration tools (docs/calib.md).")
    p.add_argument("out", metavar="DIR", help="output folder (made if missing)")
    p.add_argument("--no-images", action="store_true", help="only the text inputs (those committed in docs/examples/calib/)")
    args = p.parse_args(argv)
    names = write_examples(args.out, images=not args.no_images)
    print(f"wrote {len(names)} files in {args.out}: {', '.join(names)}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
