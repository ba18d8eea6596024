"""Monte Carlo benchmark of calib.sphere (issue 10): accuracy, not speed.

Run from the repository root::

    .venv/bin/python bench/sphere_calibration.py            # ~2-3 minutes
    .venv/bin/python bench/sphere_calibration.py --trials 30 --json out.json

What it measures (all on synthetic data with exact truth, fixed seeds):

1. Noise-free recovery: the largest relative error of K (all entries, in
   units of f) of the linear, rank-1 and geometric estimates.
2. Intrinsics at 0.5 and 1 px of Gaussian noise on the outline points
   (640 x 480 images, fx = fy = 1000, principal point (320, 240), 5 spheres,
   200 points each, apparent radii 40-70 px anywhere in the image):
   median focal error of the linear, rank-1 and final (geometric) estimates;
   the maximum-likelihood reference (geometric refinement started from the
   TRUE K on the same data); and, on the same number of images with the same
   point noise, OpenCV's calibrateCamera on a chessboard (9 x 6 corners, and
   20 x 10 = 200 corners, the sphere's point count), same 4-parameter model
   (fx, fy, cx, cy; no distortion).
   Focal error of a trial: (|fx - f| + |fy - f|) / (2 f).
3. Rig: 3 cameras on a 60-degree arc 3 m from a 0.8 m cube, 20 sphere
   positions (radius 0.1 m, about 33 px), 200 outline points per view at
   0.5 px noise: rotation error and translation-direction error of cameras
   1 and 2 relative to camera 0, before and after bundle adjustment.
4. Rendered images: the full path from pixels (shaded ball with a specular
   highlight over background clutter, sensor noise) to K, a few trials.

The figures quoted in bench/README.md ("Spheres") come from this script.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from calib import sphere as S  # noqa: E402
from calib import synthetic as syn  # noqa: E402
from geometry.conics import fit_ellipse  # noqa: E402

SIZE = (640, 480)
K_TRUE = np.array([[1000.0, 0.0, 320.0], [0.0, 1000.0, 240.0], [0.0, 0.0, 1.0]])
RADIUS = 0.1


def focal_err(K, K0=K_TRUE) -> float:
    return float(0.5 * (abs(K[0, 0] - K0[0, 0]) + abs(K[1, 1] - K0[1, 1])) / K0[0, 0])


def sphere_trial(rng, noise, n_spheres=5, n_points=200):
    X = syn.random_sphere_centres(K_TRUE, SIZE, n_spheres, radius=RADIUS, image_radius=(40.0, 70.0), rng=rng)
    pts = [syn.sphere_outline_points(K_TRUE, x, RADIUS, n_points, noise=noise, rng=rng) for x in X]
    conics = [fit_ellipse(p).conic if noise > 0 else S.outline_conic(K_TRUE, x, RADIUS) for p, x in zip(pts, X)]
    return conics, pts


def board_poses(rng, n_views, cols, rows, square):
    """Random, well-spread chessboard poses fully inside the image."""
    obj = np.zeros((rows * cols, 3), np.float64)
    obj[:, :2] = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * square
    obj[:, :2] -= obj[:, :2].mean(axis=0)
    poses = []
    while len(poses) < n_views:
        axis = rng.normal(size=2)
        axis /= np.linalg.norm(axis)
        tilt = np.radians(rng.uniform(20, 45))
        spin = rng.uniform(-np.pi, np.pi)
        R_tilt = cv2.Rodrigues(np.array([axis[0], axis[1], 0.0]) * tilt)[0]
        R_spin = cv2.Rodrigues(np.array([0.0, 0.0, spin]))[0]
        R = R_tilt @ R_spin
        width = square * (cols - 1)
        z = 1000.0 * width / rng.uniform(250, 380)
        t = np.array([rng.uniform(-0.15, 0.15) * z * 0.64, rng.uniform(-0.15, 0.15) * z * 0.48, z])
        p = (obj @ R.T + t) @ K_TRUE.T
        p = p[:, :2] / p[:, 2:]
        if p.min() < 10 or p[:, 0].max() > SIZE[0] - 11 or p[:, 1].max() > SIZE[1] - 11:
            continue
        poses.append((R, t, p))
    return obj, poses


def chessboard_trial(rng, noise, n_views=5, cols=9, rows=6):
    obj, poses = board_poses(rng, n_views, cols, rows, square=0.03)
    objs = [obj.astype(np.float32) for _ in poses]
    imgs = [(p + rng.normal(0.0, noise, p.shape)).astype(np.float32) for _, _, p in poses]
    flags = cv2.CALIB_FIX_K1 | cv2.CALIB_FIX_K2 | cv2.CALIB_FIX_K3 | cv2.CALIB_ZERO_TANGENT_DIST
    _, K, _, _, _ = cv2.calibrateCamera(objs, imgs, SIZE, None, None, flags=flags)
    return K


def bench_noise_free(trials):
    worst = {"linear": 0.0, "rank1": 0.0, "geometric": 0.0}
    for k in range(trials):
        rng = np.random.default_rng(100 + k)
        conics, pts = sphere_trial(rng, 0.0)
        res = S.intrinsics_from_spheres(conics, edge_points=pts)
        for name, K in (("linear", res.K_linear), ("rank1", res.K_rank1), ("geometric", res.K)):
            worst[name] = max(worst[name], float(np.abs(K - K_TRUE).max() / K_TRUE[0, 0]))
    return worst


def bench_intrinsics(noise, trials):
    rows = []
    fails = 0
    weak = 0
    for k in range(trials):
        rng = np.random.default_rng(1000 + k)
        conics, pts = sphere_trial(rng, noise)
        try:
            res = S.intrinsics_from_spheres(conics, edge_points=pts)
        except ValueError:
            fails += 1
            continue
        weak += res.weak
        ml = S.refine_intrinsics(K_TRUE, conics, pts)
        crng = np.random.default_rng(5000 + k)
        Kc = chessboard_trial(crng, noise)
        Kc200 = chessboard_trial(crng, noise, cols=20, rows=10)
        rows.append(
            [focal_err(res.K_linear), focal_err(res.K_rank1), focal_err(res.K), focal_err(ml.K), focal_err(Kc), focal_err(Kc200), res.focal_sigma]
        )
    a = np.array(rows)
    med = np.median(a, axis=0)
    p90 = np.percentile(a, 90, axis=0)
    names = ["linear", "rank1", "final", "ml_from_truth", "chessboard_9x6", "chessboard_20x10", "predicted_sigma"]
    return {
        "noise_px": noise,
        "trials": trials,
        "failures": fails,
        "weak": int(weak),
        "median": dict(zip(names, med.tolist())),
        "p90": dict(zip(names, p90.tolist())),
        "rank1_over_linear": float(med[1] / med[0]),
        "final_over_ml": float(med[2] / med[3]),
        "final_over_chessboard_9x6": float(med[2] / med[4]),
        "final_over_chessboard_20x10": float(med[2] / med[5]),
    }


def _rot_err(Ra, Rb):
    return float(np.degrees(np.arccos(np.clip((np.trace(Ra @ Rb.T) - 1) / 2, -1, 1))))


def _dir_err(a, b):
    return float(np.degrees(np.arccos(np.clip(a @ b / np.linalg.norm(a) / np.linalg.norm(b), -1, 1))))


def bench_rig(trials, noise=0.5, n_positions=20):
    rot, tdir, rot0, tdir0, scale = [], [], [], [], []
    for k in range(trials):
        rng = np.random.default_rng(7000 + k)
        cams = syn.rig_cameras(3, f=1000.0, distance=3.0, spread_deg=60.0, rng=rng, jitter=0.1)
        Xw = syn.random_rig_centres(cams, n_positions, radius=RADIUS, box=0.8, rng=rng)
        conics, edges = [], []
        for c in cams:
            tc, te = [], []
            for X in Xw:
                p = syn.sphere_outline_points(c.K, c.R @ X + c.t, RADIUS, 200, noise=noise, rng=rng)
                te.append(p)
                tc.append(fit_ellipse(p, refine=False).conic)
            conics.append(tc)
            edges.append(te)
        res = S.rig_extrinsics([c.K for c in cams], conics, RADIUS, edge_point_tracks=edges)
        for j in (1, 2):
            R_true = cams[j].R @ cams[0].R.T
            t_true = cams[j].t - R_true @ cams[0].t
            rot.append(_rot_err(res.R[j], R_true))
            tdir.append(_dir_err(res.t[j], t_true))
            rot0.append(_rot_err(res.R_init[j], R_true))
            tdir0.append(_dir_err(res.t_init[j], t_true))
            scale.append(abs(np.linalg.norm(res.t[j]) / np.linalg.norm(t_true) - 1))
    f = lambda v: {"median": float(np.median(v)), "p95": float(np.percentile(v, 95)), "max": float(np.max(v))}  # noqa: E731
    return {
        "noise_px": noise,
        "trials": trials,
        "rotation_deg": f(rot),
        "translation_direction_deg": f(tdir),
        "translation_scale_rel": f(scale),
        "rotation_deg_absolute_orientation": f(rot0),
        "translation_direction_deg_absolute_orientation": f(tdir0),
    }


def bench_rendered(trials, n_images=5):
    K = np.array([[800.0, 0.0, 320.0], [0.0, 800.0, 240.0], [0.0, 0.0, 1.0]])
    errs, sig, edge_rms = [], [], []
    for k in range(trials):
        rng = np.random.default_rng(9000 + k)
        X = syn.random_sphere_centres(K, SIZE, n_images, radius=RADIUS, image_radius=(35.0, 70.0), margin=8, rng=rng)
        outlines = [S.fit_sphere_outline(syn.render_spheres(K, x, RADIUS, SIZE, rng=rng)) for x in X]
        res = S.intrinsics_from_spheres([o.conic for o in outlines], edge_points=[o.edge_points for o in outlines])
        errs.append(focal_err(res.K, K))
        sig.append(res.focal_sigma)
        edge_rms.append(np.mean([o.rms for o in outlines]))
    return {
        "trials": trials,
        "images": n_images,
        "focal_error_median": float(np.median(errs)),
        "focal_error_max": float(np.max(errs)),
        "predicted_sigma_median": float(np.median(sig)),
        "edge_rms_px_median": float(np.median(edge_rms)),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=100, help="Monte Carlo trials per noise level")
    ap.add_argument("--rig-trials", type=int, default=15)
    ap.add_argument("--render-trials", type=int, default=4)
    ap.add_argument("--json", type=Path, help="also write the results here")
    args = ap.parse_args(argv)
    out = {}
    t0 = time.time()

    out["noise_free_max_rel_error"] = bench_noise_free(20)
    print("noise-free, 20 trials, max |K - K_true| / f:")
    for k, v in out["noise_free_max_rel_error"].items():
        print(f"  {k:10s} {v:.1e}")

    out["intrinsics"] = []
    for noise in (0.5, 1.0):
        r = bench_intrinsics(noise, args.trials)
        out["intrinsics"].append(r)
        print(f"\nintrinsics, {noise} px noise, {r['trials']} trials ({r['failures']} failed, {r['weak']} flagged weak):")
        print("  median (90th percentile) focal error:")
        for name in r["median"]:
            print(f"    {name:18s} {100 * r['median'][name]:6.2f} %  ({100 * r['p90'][name]:6.2f} %)")
        print(f"  rank-1 / linear          {r['rank1_over_linear']:.2f}   (target <= 0.8)")
        print(f"  final / ML from truth    {r['final_over_ml']:.3f}  (target <= 1.25)")
        print(f"  final / chessboard 9x6   {r['final_over_chessboard_9x6']:.1f}")
        print(f"  final / chessboard 20x10 {r['final_over_chessboard_20x10']:.1f}")

    r = bench_rig(args.rig_trials)
    out["rig"] = r
    print(f"\nrig, 3 cameras, 20 positions, {r['noise_px']} px, {r['trials']} trials (cameras 1 and 2):")
    for name in ("rotation_deg", "translation_direction_deg", "translation_scale_rel", "rotation_deg_absolute_orientation", "translation_direction_deg_absolute_orientation"):
        v = r[name]
        print(f"  {name:48s} median {v['median']:.4f}  p95 {v['p95']:.4f}  max {v['max']:.4f}")
    print("  targets: rotation <= 0.2 deg, translation direction <= 0.5 deg")

    if args.render_trials > 0:
        r = bench_rendered(args.render_trials)
        out["rendered"] = r
        print(f"\nrendered images (f = 800, 5 images, clutter), {r['trials']} trials:")
        print(f"  focal error median {100 * r['focal_error_median']:.2f} %, max {100 * r['focal_error_max']:.2f} %, "
              f"predicted sigma {100 * r['predicted_sigma_median']:.2f} %, edge rms {r['edge_rms_px_median']:.3f} px")

    print(f"\ntotal {time.time() - t0:.0f} s")
    if args.json:
        args.json.write_text(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
