"""Structured-light benchmark: a camera + laser light plane calibrated with a sphere.

Monte Carlo on synthetic data with exact truth and fixed seeds. Camera
fx = 1000, fy = 1010, principal point (330, 235), 640 x 480; a laser line
projector 0.3 m to the right of the camera whose light plane passes through
the optical axis 1 m away (about 73 degrees from the image plane); a sphere of
radius 5 cm placed at M positions 0.6-1.5 m away, each cut by the plane
(centre within 0.7 r of it). Per image: the outline's edge points (one per
pixel of perimeter) and the visible, lit stripe (one point per pixel of arc
length), both with isotropic Gaussian noise.

Reported: focal error (from the outlines alone, and after the joint
refinement), the angle between the estimated and the true plane normal, the
plane distance error; and a *test* sphere (radius 4 cm, not used in the
calibration) measured with the calibrated system (:func:`measure_sphere`):
its radius error, and the distance of its triangulated stripe points from the
true sphere's surface relative to the working distance (with the pixel noise;
and calibration error only, i.e. noise-free pixels triangulated with the
estimated vs the true calibration). A few trials run the full path from
rendered images (stripe extraction, outline fitting).

Usage::

    .venv/bin/python bench/structured_light_calibration.py [--trials 30] [--image-trials 3] [--json out.json]
    .venv/bin/python bench/structured_light_calibration.py --setups --trials 20   # sphere size / range / M table
    .venv/bin/python bench/structured_light_calibration.py --aimed --trials 20    # the plane aimed at the working range
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from calib import structured_light as SL  # noqa: E402
from calib import synthetic as syn  # noqa: E402
from calib.sphere import outline_conic  # noqa: E402
from geometry.conics import ellipse_from_conic, fit_ellipse, sampson_distance  # noqa: E402

K0 = np.array([[1000.0, 0.0, 330.0], [0.0, 1010.0, 235.0], [0.0, 0.0, 1.0]])
SIZE = (640, 480)
R = 0.05
R_TEST = 0.04
ZRANGE = (0.6, 1.5)
PROJ = np.array([0.3, 0.0, 0.0])
PLANE = SL.LightPlane.from_point_normal(PROJ, [1.0, 0.0, 0.3])


def aimed_plane(z0: float) -> SL.LightPlane:
    """The projector's light plane turned to cross the optical axis at depth ``z0``."""
    return SL.LightPlane.from_point_normal(PROJ, [1.0, 0.0, PROJ[0] / z0])


def centres(rng, n, r=R, max_offset=0.7, zrange=ZRANGE, plane=None):
    """n sphere centres at depths drawn from zrange, cut by the plane, the whole outline in the image.

    Depths at which no such position exists are redrawn, so the depths actually used can span
    less than zrange (the plane leaves the image's right edge close to the camera).
    """
    plane = plane or PLANE
    out, tries = [], 0
    while len(out) < n:
        tries += 1
        if tries > 200000:
            raise RuntimeError(f"no sphere position of radius {r} in the image at depths {zrange}")
        z = rng.uniform(*zrange)
        y = rng.uniform(-0.18, 0.18) * z
        off = rng.uniform(-max_offset, max_offset) * r
        x = (plane.d + off - plane.normal[1] * y - plane.normal[2] * z) / plane.normal[0]
        X = np.array([x, y, z])
        p = K0 @ X
        p = p[:2] / p[2]
        rad = K0[0, 0] * r / z
        if rad + 5 < p[0] < SIZE[0] - rad - 5 and rad + 5 < p[1] < SIZE[1] - rad - 5:
            try:
                SL.stripe_points(K0, X, r, plane, 10, projector=PROJ)
            except ValueError:
                continue
            out.append(X)
    return np.array(out)


def per_pixel_counts(X, r, plane=None):
    """Edge points: one per pixel of perimeter; stripe points: one per pixel of arc."""
    e = ellipse_from_conic(outline_conic(K0, X, r))
    n_edge = int(np.pi * (e.axes[0] + e.axes[1]))
    arc = SL.stripe_points(K0, X, r, plane or PLANE, 400, projector=PROJ)
    n_stripe = max(20, int(np.linalg.norm(np.diff(arc, axis=0), axis=1).sum()))
    return n_edge, n_stripe


def observe(rng, X, r, noise, plane=None):
    plane = plane or PLANE
    n_edge, n_stripe = per_pixel_counts(X, r, plane)
    e = syn.sphere_outline_points(K0, X, r, n_edge, noise=noise, rng=rng)
    s = SL.stripe_points(K0, X, r, plane, n_stripe, projector=PROJ, noise=noise, rng=rng)
    return e, s


def apparent_radius(X, r):
    """Mean semi-axis (px) of the sphere's outline ellipse."""
    return float(np.mean(ellipse_from_conic(outline_conic(K0, X, r)).axes))


def trial(rng, M, noise, r=R, r_test=R_TEST, zrange=ZRANGE, plane=None):
    R, R_TEST = r, r_test  # noqa: N806  (the module defaults unless a setup overrides them)
    pl = plane or PLANE
    X = centres(rng, M, r=R, zrange=zrange, plane=pl)
    edges, stripes = zip(*(observe(rng, x, R, noise, pl) for x in X))
    conics = [fit_ellipse(e).conic for e in edges]
    t0 = time.perf_counter()
    res = SL.calibrate(conics, list(stripes), radius=R, edge_points=list(edges))
    dt = time.perf_counter() - t0
    # test sphere
    Xt = centres(rng, 1, r=R_TEST, max_offset=0.6, zrange=zrange, plane=pl)[0]
    et, st = observe(rng, Xt, R_TEST, noise, pl)
    m = SL.measure_sphere(res.K, res.plane, fit_ellipse(et).conic, st)
    wd = float(np.linalg.norm(Xt))
    surf = np.abs(np.linalg.norm(m.points - Xt, axis=1) - R_TEST) / wd
    clean = SL.stripe_points(K0, Xt, R_TEST, pl, 100, projector=PROJ)
    calib_only = np.linalg.norm(SL.triangulate(res.K, res.plane, clean) - SL.triangulate(K0, pl, clean), axis=1) / wd
    # the same data with the intrinsics known (only the spheres and the plane estimated)
    resK = SL.calibrate(conics, list(stripes), radius=R, edge_points=list(edges), K=K0)
    mK = SL.measure_sphere(K0, resK.plane, fit_ellipse(et).conic, st)
    surfK = np.abs(np.linalg.norm(mK.points - Xt, axis=1) - R_TEST) / wd
    calib_onlyK = np.linalg.norm(SL.triangulate(K0, resK.plane, clean) - SL.triangulate(K0, pl, clean), axis=1) / wd
    return {
        "known_K_calib_only_max": float(calib_onlyK.max()),
        "known_K_normal_deg": float(np.degrees(resK.plane.angle_to(pl))),
        "known_K_d_err": float(abs(resK.plane.d / pl.d - 1)),
        "known_K_test_radius_err": float(abs(mK.radius / R_TEST - 1)),
        "known_K_surface_rms": float(np.sqrt(np.mean(surfK**2))),
        "shape_rms": float(m.rms / wd),
        "focal_spheres": float(max(abs(res.K_spheres[0, 0] / K0[0, 0] - 1), abs(res.K_spheres[1, 1] / K0[1, 1] - 1))),
        "focal": float(max(abs(res.K[0, 0] / K0[0, 0] - 1), abs(res.K[1, 1] / K0[1, 1] - 1))),
        "normal_init_deg": float(np.degrees(res.plane_init.angle_to(pl))),
        "normal_deg": float(np.degrees(res.plane.angle_to(pl))),
        "d_err": float(abs(res.plane.d / pl.d - 1)),
        "test_radius_err": float(abs(m.radius / R_TEST - 1)),
        "surface_rms": float(np.sqrt(np.mean(surf**2))),
        "surface_max": float(surf.max()),
        "calib_only_max": float(calib_only.max()),
        "time_s": dt,
        "n_stripe": res.n_stripe_points,
        "apparent_px": float(np.median([apparent_radius(x, R) for x in X])),
        "z_min": float(X[:, 2].min()),
        "z_max": float(X[:, 2].max()),
    }


def summary(rows, key):
    v = np.array([r[key] for r in rows])
    return {"mean": float(v.mean()), "median": float(np.median(v)), "p90": float(np.percentile(v, 90)), "max": float(v.max())}


def run_synthetic(trials, M, noise, seed):
    rng = np.random.default_rng(seed)
    rows, fails = [], 0
    for _ in range(trials):
        try:
            rows.append(trial(rng, M, noise))
        except ValueError as exc:
            fails += 1
            print("   failure:", exc)
    keys = [
        "focal_spheres", "focal", "normal_init_deg", "normal_deg", "d_err", "test_radius_err", "surface_rms",
        "surface_max", "calib_only_max", "shape_rms", "time_s", "known_K_normal_deg", "known_K_d_err",
        "known_K_test_radius_err", "known_K_surface_rms", "known_K_calib_only_max",
    ]
    out = {k: summary(rows, k) for k in keys}
    out["failures"] = fails
    pct = lambda k, s="mean": 100 * out[k][s]  # noqa: E731
    print(
        f"  M = {M:2d}, noise {noise} px: focal outlines {pct('focal_spheres'):.2f} % -> joint {pct('focal'):.2f} % (mean; "
        f"median {pct('focal', 'median'):.2f}) | normal {out['normal_init_deg']['mean']:.3f} -> {out['normal_deg']['mean']:.3f} deg "
        f"(median {out['normal_deg']['median']:.3f}, 90th pct {out['normal_deg']['p90']:.3f}) | d {pct('d_err'):.2f} %",
        flush=True,
    )
    print(
        f"     test sphere radius {pct('test_radius_err'):.2f} % (median {pct('test_radius_err', 'median'):.2f}, 90th pct "
        f"{pct('test_radius_err', 'p90'):.2f}) | surface points rms {pct('surface_rms'):.3f} %, max {pct('surface_max'):.3f} % of the "
        f"working distance (mean over trials); calibration only: max {pct('calib_only_max'):.3f} % | "
        f"{1000 * out['time_s']['mean']:.0f} ms per calibration | failures {fails}",
        flush=True,
    )
    print(
        f"     shape (points about the measured sphere) rms {pct('shape_rms'):.3f} % | with K known: normal "
        f"{out['known_K_normal_deg']['mean']:.3f} deg (90th pct {out['known_K_normal_deg']['p90']:.3f}), d {pct('known_K_d_err'):.2f} %, "
        f"test radius {pct('known_K_test_radius_err'):.2f} %, surface rms {pct('known_K_surface_rms'):.3f} %, "
        f"calibration only max {pct('known_K_calib_only_max'):.3f} %",
        flush=True,
    )
    return out


SETUP_RADII = (0.05, 0.10)
SETUP_RANGES = ((0.6, 1.5), (0.4, 0.9))
SETUP_M = (10, 20)


def run_setups(trials, noise=0.5, seed=300):
    """Sphere radius x working range x number of positions (test sphere 0.8 R; camera and plane unchanged)."""
    out = {}
    print(
        f"setups at {noise} px, {trials} trials each; mean (median) over trials. 'px': apparent sphere radius, median over "
        "positions; 'depths': range of the calibration spheres' depths actually drawn (positions must fit in the image)",
        flush=True,
    )
    hdr = (
        "| R | range | M | px | depths | focal (joint) | normal (deg) | test radius | surface rms | surface rms, K known | fail |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    )
    print("\n".join(hdr), flush=True)
    i = 0
    for r in SETUP_RADII:
        for zr in SETUP_RANGES:
            for M in SETUP_M:
                rng = np.random.default_rng(seed + i)
                i += 1
                rows, fails = [], 0
                for _ in range(trials):
                    try:
                        rows.append(trial(rng, M, noise, r=r, r_test=0.8 * r, zrange=zr))
                    except ValueError as exc:
                        fails += 1
                        print("   failure:", exc, flush=True)
                keys = ("apparent_px", "focal", "normal_deg", "test_radius_err", "surface_rms", "known_K_surface_rms")
                s = {k: summary(rows, k) for k in keys}
                s["z_min"] = min(row["z_min"] for row in rows)
                s["z_max"] = max(row["z_max"] for row in rows)
                s["failures"] = fails
                out[f"R{r}_z{zr[0]}-{zr[1]}_M{M}"] = s
                pc = lambda k: f"{100 * s[k]['mean']:.2f} % ({100 * s[k]['median']:.2f})"  # noqa: E731
                print(
                    f"| {100 * r:.0f} cm | {zr[0]}-{zr[1]} m | {M} | {s['apparent_px']['mean']:.0f} ({s['apparent_px']['median']:.0f}) "
                    f"| {s['z_min']:.2f}-{s['z_max']:.2f} m | {pc('focal')} "
                    f"| {s['normal_deg']['mean']:.3f} ({s['normal_deg']['median']:.3f}) | {pc('test_radius_err')} "
                    f"| {pc('surface_rms')} | {pc('known_K_surface_rms')} | {fails} |",
                    flush=True,
                )
    return out


AIMED = ((0.05, (0.4, 0.9), 20), (0.10, (0.4, 0.9), 10), (0.10, (0.4, 0.9), 20), (0.10, (0.6, 1.5), 20), (0.10, (0.4, 0.9), 40))


def run_aimed(trials, noise=0.5, seed=500):
    """The light plane turned to cross the optical axis in the middle of the working
    range (projector where it was), for sphere radius x range x M (test sphere 0.8 R)."""
    out = {}
    print(f"light plane aimed at the middle of the range, {noise} px, {trials} trials each; mean (median) over trials", flush=True)
    print("| R | range | M | triangulation angle | focal (joint) | normal (deg) | test radius | surface rms | surface rms, K known | fail |", flush=True)
    print("|---|---|---|---|---|---|---|---|---|---|", flush=True)
    for i, (r, zr, M) in enumerate(AIMED):
        plane = aimed_plane(0.5 * (zr[0] + zr[1]))
        angle = float(np.degrees(np.arcsin(abs(plane.normal[2]))))
        rng = np.random.default_rng(seed + i)
        rows, fails = [], 0
        for _ in range(trials):
            try:
                rows.append(trial(rng, M, noise, r=r, r_test=0.8 * r, zrange=zr, plane=plane))
            except ValueError as exc:
                fails += 1
                print("   failure:", exc, flush=True)
        keys = ("focal", "normal_deg", "test_radius_err", "surface_rms", "known_K_surface_rms")
        s = {k: summary(rows, k) for k in keys}
        s["failures"], s["angle_deg"] = fails, angle
        out[f"aimed_R{r}_z{zr[0]}-{zr[1]}_M{M}"] = s
        pc = lambda k: f"{100 * s[k]['mean']:.3f} % ({100 * s[k]['median']:.3f})"  # noqa: E731
        print(
            f"| {100 * r:.0f} cm | {zr[0]}-{zr[1]} m | {M} | {angle:.0f} deg | {pc('focal')} | {s['normal_deg']['mean']:.3f} ({s['normal_deg']['median']:.3f}) "
            f"| {pc('test_radius_err')} | {pc('surface_rms')} | {pc('known_K_surface_rms')} | {fails} |",
            flush=True,
        )
    return out


def run_images(trials, M, seed):
    rng = np.random.default_rng(seed)
    rows = []
    for t in range(trials):
        X = centres(rng, M)
        imgs = [SL.render_laser_image(K0, x, R, PLANE, SIZE, projector=PROJ, rng=rng) for x in X]
        ext = []
        for x, img in zip(X, imgs):
            mask = SL._inside_mask(img.shape[:2], outline_conic(K0, x, R), 1.5)
            p = SL.extract_stripe(img, mask=mask)
            ext.append(np.abs(sampson_distance(p, SL.stripe_conic(K0, x, R, PLANE))))
        ext = np.concatenate(ext)
        t0 = time.perf_counter()
        try:
            res = SL.calibrate(imgs, radius=R)
        except ValueError as exc:
            print("   failure:", exc)
            continue
        rows.append(
            {
                "extract_median_px": float(np.median(ext)),
                "extract_p90_px": float(np.percentile(ext, 90)),
                "focal": float(max(abs(res.K[0, 0] / K0[0, 0] - 1), abs(res.K[1, 1] / K0[1, 1] - 1))),
                "normal_deg": float(np.degrees(res.plane.angle_to(PLANE))),
                "d_err": float(abs(res.plane.d / PLANE.d - 1)),
                "outline_rms": res.outline_rms,
                "stripe_rms": res.stripe_rms,
                "skipped": list(res.skipped),
                "time_s": time.perf_counter() - t0,
            }
        )
        r = rows[-1]
        print(
            f"  images trial {t}: stripe extraction median {r['extract_median_px']:.3f} px (90th pct {r['extract_p90_px']:.3f}) | "
            f"focal {100 * r['focal']:.2f} % | normal {r['normal_deg']:.3f} deg | d {100 * r['d_err']:.2f} % | "
            f"rms outline {r['outline_rms']:.2f} px, stripe {r['stripe_rms']:.2f} px | skipped {r['skipped']} | {r['time_s']:.1f} s",
            flush=True,
        )
    return rows


def noise_free():
    rng = np.random.default_rng(1)
    worst = [0.0, 0.0]
    for _ in range(10):
        X = centres(rng, 6)
        conics = [outline_conic(K0, x, R) for x in X]
        stripes = [SL.stripe_points(K0, x, R, PLANE, 50, projector=PROJ) for x in X]
        res = SL.calibrate(conics, stripes, radius=R)
        worst[0] = max(worst[0], np.abs(res.K - K0).max() / K0[0, 0])
        worst[1] = max(worst[1], np.degrees(res.plane.angle_to(PLANE)))
    print(f"  noise-free: max |K - K_true| / f = {worst[0]:.1e}; max normal error {worst[1]:.1e} deg", flush=True)
    return {"K": worst[0], "normal_deg": worst[1]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=30, help="trials per configuration (README figures: 50)")
    ap.add_argument("--image-trials", type=int, default=3)
    ap.add_argument("--json", help="write the numbers to this file")
    ap.add_argument(
        "--setups", action="store_true",
        help="instead: a table over sphere radius {5, 10 cm} x working range {0.6-1.5, 0.4-0.9 m} x M {10, 20} "
        "positions at 0.5 px (use --trials 20)",
    )
    ap.add_argument(
        "--aimed", action="store_true",
        help="instead: the light plane aimed at the middle of the working range (crossing the optical axis there), "
        "for a few sphere sizes, ranges and M (use --trials 20)",
    )
    args = ap.parse_args(argv)
    t0 = time.time()
    if args.setups or args.aimed:
        res = {"setups": run_setups(args.trials)} if args.setups else {"aimed": run_aimed(args.trials)}
        print(f"total {time.time() - t0:.0f} s")
        if args.json:
            Path(args.json).write_text(json.dumps(res, indent=2))
        return 0
    res = {"noise_free": noise_free(), "synthetic": {}}
    for M, noise in ((10, 0.5), (6, 0.5), (10, 1.0), (16, 0.5)):
        res["synthetic"][f"M{M}_noise{noise}"] = run_synthetic(args.trials, M, noise, seed=100 + M)
    if args.image_trials:
        print(f"rendered images, 10 positions, full path, {args.image_trials} trials", flush=True)
        res["images"] = run_images(args.image_trials, 10, seed=7)
    print(f"total {time.time() - t0:.0f} s")
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
