"""Reference cameras for the shared real broadcast material (issue 29, item 7).

The references are the yardstick the product is judged against on real
frames, so they are made independently of the product's detector and solver:

1. **A person's rough correspondences.** For each reference frame a person
   looked at the frame (crops enlarged with a labelled pixel grid, see
   ``--grid``) and wrote down 4-10 image points of identifiable marking
   features with their names. They are stored in the committed data
   (``tests/data/real_reference/<item>.json``, ``correspondences``), each as
   ``{"label", "image_xy", "pitch_xy"}``. A label names a pitch feature
   (:func:`feature_xy`): ``"A x B"`` is the crossing of the centrelines of the
   two markings ``A`` and ``B`` of :class:`geometry.pitch.PitchModel`
   (``"touchline_far x goal_line_left"`` is the far left corner); where an arc
   meets a line twice, a trailing ``" +"`` / ``" -"`` picks the crossing with
   the larger / smaller pitch coordinate along the line; ``"centre_mark"`` and
   the penalty marks are the spots. ``pitch_xy`` is recomputed from the label
   for the item's pitch size.
2. **An initial camera** from them: the plane homography
   (``cv2.findHomography``, plain DLT) decomposed by
   :func:`geometry.camera.camera_from_homography` with the principal point at
   the image centre and the item's pixel aspect; where that fails, a small
   grid of focal lengths with ``cv2.solvePnP``. For a clip frame whose
   correspondences are too few, the previous reference frame's camera.
3. **Refinement to the painted lines** (:func:`refine`): the focal length,
   the rotation, the camera centre, ``k1`` and, where the view constrains them
   (``pitch.fit`` in the entry), the pitch length and/or width are fitted with
   ``scipy.optimize.least_squares`` (Cauchy loss on the line term with a
   shrinking scale, 12 -> 1.2 px) to the distance transform of a
   *line-centre* mask (:func:`fit_mask`): pixels whose luma exceeds the mean
   of a box about twice the widest line's width by more than 8 (lower than
   the support's 12: far lines after compression stand only about 10 levels
   above the grass), that are the ridge of that response across the line,
   that are white (unsaturated or less saturated than the grass around; not
   yellow: the lines of other sports are left out) and that have grass
   around them. The markings are sampled every 0.25 m and projected with the
   full model (distortion included). Gaussian priors keep the fit honest:
   the correspondences (8 px), ``k1`` (4 px of displacement at the image
   corner) and a fitted pitch size (105 +- 10 x 68 +- 8 m).
   A clip frame may start from the previous reference frame's camera turned
   onto its correspondences (``"init": "previous_frame"``), or from any other
   reference frame's (``"init": "frame N"``: a pan's far end fitted first),
   where its own points do not fix a camera.
4. **Checked by eye** on an overlay of every marking (``--draw``), with crops
   of the far lines and corners, and with its **line support**
   (:func:`line_support`: the issue's definition) stored beside it. A
   reference frame that cannot be fitted honestly (too few markings, or lines
   the fit cannot tell from other bright edges) is listed in the item's
   ``left_out`` with its reason instead of being guessed.

Usage (from the repository root)::

    .venv/bin/python bench/reference_cameras.py --draw DIR            # redraw every overlay
    .venv/bin/python bench/reference_cameras.py --draw DIR --sheets   # ... and docs/images/real_reference_<item>.jpg
    .venv/bin/python bench/reference_cameras.py --draw DIR --item ucl_2009
    .venv/bin/python bench/reference_cameras.py --fit ITEM [--frame N] # re-fit from the stored correspondences
    .venv/bin/python bench/reference_cameras.py --fit ITEM --frame N --from-previous  # start from frame N-25's camera
    .venv/bin/python bench/reference_cameras.py --grid ITEM --frame N --out DIR [--crop x0,y0,x1,y1]

``--fit`` writes the refined camera, its line support and the
correspondences' reprojection RMS back into the item's JSON file (the notes
and correspondences are kept); look at the overlay before committing it.
To change a reference: edit its correspondences (or ``pitch.fit``) in the
JSON, re-fit, redraw, look.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

import cv2
import numpy as np
from scipy.ndimage import map_coordinates
from scipy.optimize import least_squares

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from geometry.camera import Camera, intrinsic_matrix  # noqa: E402
from geometry.pitch import Arc, PitchModel, Segment  # noqa: E402

DATA_DIR = ROOT / "tests" / "data" / "real_reference"
SHARED = "../shared/data/real-broadcast"
SPACING = 0.25  # metres between marking samples (the line-support definition)

#: The items: where each frame comes from (relative to the repository root).
ITEMS = {
    "ucl_2009": {"kind": "still", "path": f"{SHARED}/stills/ucl_2009.png", "frames": [0]},
    "world_cup_2006": {"kind": "still", "path": f"{SHARED}/stills/world_cup_2006.png", "frames": [0]},
    "world_cup_2018": {"kind": "still", "path": f"{SHARED}/stills/world_cup_2018.png", "frames": [0]},
    "sequence_epl": {"kind": "sequence", "path": f"{SHARED}/sequence-epl/frame_{{:02d}}.jpg", "frames": [0, 25, 50]},
    "artificial_turf_multisport": {"kind": "clip", "path": f"{SHARED}/clips/artificial_turf_multisport.mp4", "frames": list(range(0, 176, 25))},
    "israel_league_wide": {"kind": "clip", "path": f"{SHARED}/clips/israel_league_wide.mp4", "frames": list(range(0, 404, 25))},
}


# --------------------------------------------------------------------------- frames
def source_path(item: str, frame: int) -> str:
    """The frame's file, relative to the repository root."""
    spec = ITEMS[item]
    return spec["path"].format(frame) if spec["kind"] == "sequence" else spec["path"]


def load_frame(item: str, frame: int, root: Path = ROOT) -> np.ndarray:
    """The reference frame as a BGR uint8 image (H, W, 3); clip frames are
    decoded with PyAV and indexed by decode order from 0."""
    spec = ITEMS[item]
    path = root / source_path(item, frame)
    if spec["kind"] != "clip":
        img = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if img is None:
            raise ValueError(f"cannot read {path}")
        return img
    import av

    with av.open(str(path)) as container:
        for i, fr in enumerate(container.decode(video=0)):
            if i == frame:
                return fr.to_ndarray(format="bgr24")
    raise ValueError(f"{path} has no frame {frame}")


def load_clip_frames(item: str, frames, root: Path = ROOT) -> dict[int, np.ndarray]:
    """Several frames of one clip in one decode pass: index -> BGR image."""
    import av

    want = set(frames)
    out = {}
    with av.open(str(root / ITEMS[item]["path"])) as container:
        for i, fr in enumerate(container.decode(video=0)):
            if i in want:
                out[i] = fr.to_ndarray(format="bgr24")
            if len(out) == len(want):
                break
    return out


# --------------------------------------------------------------------------- line support
def line_support(img: np.ndarray, cam: Camera, pitch: PitchModel) -> float | None:
    """Line support of a camera on a BGR frame (issue 29's definition, computed by
    :mod:`arstream.support` on the frame's full-range luma, ``cv2.COLOR_BGR2GRAY``;
    clip frames are PyAV's ``bgr24`` conversion); None when undefined."""
    from arstream.support import bright_mask as support_mask
    from arstream.support import line_support as support_of
    from arstream.support import marking_points as support_points

    mask = support_mask(cv2.cvtColor(img, cv2.COLOR_BGR2GRAY))
    return support_of(cam, mask, support_points(pitch)).share


# --------------------------------------------------------------------------- features
def feature_xy(label: str, pitch: PitchModel) -> np.ndarray:
    """Pitch coordinates (2,) metres of a named marking feature.

    ``"A x B"``: the crossing of the centrelines of markings ``A`` and ``B``
    (two segments; or an arc and a segment, with a trailing ``" +"`` or ``" -"``
    choosing the crossing with the larger or smaller coordinate along the
    segment's direction); a spot name (``"centre_mark"``, ``"penalty_mark_left"``,
    ``"penalty_mark_right"``); ``"centre_circle @ DEG"``: the centre circle's
    centreline at that angle (degrees, counter-clockwise from +X).
    """
    if label in pitch.spots:
        return np.asarray(pitch.spots[label], float)
    if " @ " in label:
        name, deg = label.split(" @ ")
        arc = pitch[name.strip()]
        a = np.radians(float(deg))
        return np.array([arc.center[0] + arc.radius * np.cos(a), arc.center[1] + arc.radius * np.sin(a)])
    sign = 0
    if label.endswith(" +") or label.endswith(" -"):
        sign = 1 if label.endswith("+") else -1
        label = label[:-2]
    try:
        a_name, b_name = (s.strip() for s in label.split(" x "))
    except ValueError:
        raise ValueError(f"feature label {label!r} is not 'A x B', a spot or 'circle @ deg'") from None
    a, b = pitch[a_name], pitch[b_name]
    if isinstance(a, Segment) and isinstance(b, Segment):
        p = np.cross(a.line, b.line)
        return p[:2] / p[2]
    arc, seg = (a, b) if isinstance(a, Arc) else (b, a)
    if not isinstance(seg, Segment) or not isinstance(arc, Arc) or sign == 0:
        raise ValueError(f"feature {label!r}: an arc-line crossing needs one arc, one segment and ' +' or ' -'")
    p0, d = np.asarray(seg.start, float), np.subtract(seg.end, seg.start)
    d = d / np.linalg.norm(d)
    c = np.asarray(arc.center, float)
    # |p0 + s d - c| = r
    q = p0 - c
    bq, cq = q @ d, q @ q - arc.radius**2
    disc = bq * bq - cq
    if disc < 0:
        raise ValueError(f"feature {label!r}: the arc does not meet the line")
    s = -bq + sign * np.sqrt(disc)
    return p0 + s * d


def pitch_of(entry: dict) -> PitchModel:
    return PitchModel(entry["pitch"]["length"], entry["pitch"]["width"])


# --------------------------------------------------------------------------- the fit
def fit_mask(img: np.ndarray, box: int, threshold: float = 8.0, max_saturation: int = 90, white_margin: float = 6.0) -> np.ndarray:
    """(H, W) bool line-centre mask for the fit: bright-line ridge pixels (luma above
    its ``box`` mean by > ``threshold``, maximal across the line), not strongly
    coloured, with grass around them."""
    luma = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY).astype(np.float32)
    resp = luma - cv2.blur(luma, (box, box))
    if img.shape[1] > 1000:  # smooth the ridge of the wider lines of large frames (not the 1-2 px lines of small ones)
        resp = cv2.GaussianBlur(resp, (0, 0), img.shape[1] / 1920)
    r = max(2, box // 6)
    hmax = cv2.dilate(resp, np.ones((1, 2 * r + 1), np.uint8))
    vmax = cv2.dilate(resp, np.ones((2 * r + 1, 1), np.uint8))
    ridge = (resp > threshold) & ((resp >= hmax) | (resp >= vmax))
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    grass = ((hsv[..., 0] >= 28) & (hsv[..., 0] <= 95) & (hsv[..., 1] >= 40) & (hsv[..., 2] >= 25)).astype(np.float32)
    k = 2 * box + 1
    grass_share = cv2.blur(grass, (k, k))
    sat = cv2.blur(hsv[..., 1], (3, 3)).astype(np.float32)
    # white paint: unsaturated, or clearly less saturated than the grass around it
    # (thin far lines blur into the grass); the yellow lines of other sports are neither
    white = (sat < max_saturation) | (sat < cv2.blur(sat, (box, box)) - white_margin)
    # ... and not yellow / orange (red and green both well above blue, more than around it)
    b, g, r = (c.astype(np.float32) for c in cv2.split(cv2.blur(img, (5, 5))))
    yellow = np.minimum(r, g) - b
    white &= yellow < cv2.blur(yellow, (box, box)) + 12
    return ridge & (grass_share > 0.3) & white


class _Model:
    """Parameter vector <-> camera and pitch: [log f, rvec (3), centre (3), k1, (L), (W)]."""

    def __init__(self, size, aspect, fit_length, fit_width, length, width, free_pp=False, free_aspect=False):
        self.w, self.h = size
        self.aspect = aspect
        self.fit_length, self.fit_width = fit_length, fit_width
        self.length, self.width = length, width
        self.free_pp = free_pp
        self.free_aspect = free_aspect

    def pack(self, cam: Camera, length: float, width: float) -> np.ndarray:
        rvec = cv2.Rodrigues(cam.R)[0].ravel()
        k1 = cam.dist[0] if cam.dist else 0.0
        x = [np.log(cam.focal), *rvec, *cam.center, k1]
        if self.fit_length:
            x.append(length)
        if self.fit_width:
            x.append(width)
        if self.free_pp:
            x += list(cam.principal_point)
        if self.free_aspect:
            x.append(np.log(cam.K[1, 1] / cam.K[0, 0]))
        return np.array(x, float)

    def unpack(self, x) -> tuple[Camera, float, float]:
        f = float(np.exp(x[0]))
        R = cv2.Rodrigues(np.asarray(x[1:4], float))[0]
        C = np.asarray(x[4:7], float)
        i = 8
        L, W = self.length, self.width
        if self.fit_length:
            L, i = float(x[i]), i + 1
        if self.fit_width:
            W, i = float(x[i]), i + 1
        cx, cy = (x[i], x[i + 1]) if self.free_pp else ((self.w - 1) / 2, (self.h - 1) / 2)
        i += 2 if self.free_pp else 0
        K = intrinsic_matrix(f, cx, cy, float(np.exp(x[i])) if self.free_aspect else self.aspect)
        return Camera.trusted(K, R, -R @ C, (float(x[7]),)), L, W


def _pitch_points(L: float, W: float, counts: dict[str, int]) -> np.ndarray:
    """(N, 2) marking points of an L x W pitch with a fixed number of points per
    marking (``counts``: name -> N), so that the fit's residual vector keeps its
    length while L and W vary."""
    pitch = PitchModel(min(max(L, 90.0), 120.0), min(max(W, 45.0), 90.0))
    out = []
    for name, n in counts.items():
        m = pitch[name]
        s = np.linspace(0.0, 1.0, n)
        if isinstance(m, Segment):
            out.append(np.outer(1 - s, m.start) + np.outer(s, m.end))
        else:
            th = m.start_angle + s * (m.end_angle - m.start_angle)
            out.append(np.column_stack([m.center[0] + m.radius * np.cos(th), m.center[1] + m.radius * np.sin(th)]))
    return np.concatenate(out)


def _camera_from_points(img_xy, pitch_xy, size, aspect) -> Camera:
    """Initial camera from >= 4 correspondences, principal point at the image
    centre: for a grid of focal lengths the planar pose (``cv2.solvePnP``,
    IPPE), the best one then polished (f, R, t) by least squares on the
    points. (The decomposition of the plain homography,
    :func:`geometry.camera.camera_from_homography`, is ill-conditioned on these
    long-lens views: the points' few pixels of error move f by a factor 2.)"""
    w, h = size
    cx, cy = (w - 1) / 2, (h - 1) / 2
    img_xy, pitch_xy = np.asarray(img_xy, float), np.asarray(pitch_xy, float)
    if len(img_xy) < 4:
        raise ValueError(f"an initial camera needs at least 4 correspondences, got {len(img_xy)}")
    obj = np.column_stack([pitch_xy, np.zeros(len(pitch_xy))])
    best = None
    for f in np.geomspace(0.4 * w, 10 * w, 60):
        K = intrinsic_matrix(f, cx, cy, aspect)
        ok, rvec, tvec = cv2.solvePnP(obj, img_xy, K, None, flags=cv2.SOLVEPNP_IPPE)
        if not ok:
            continue
        proj, _ = cv2.projectPoints(obj, rvec, tvec, K, None)
        err = np.sqrt(((proj.reshape(-1, 2) - img_xy) ** 2).sum(1).mean())
        if best is None or err < best[0]:
            best = (err, f, rvec.ravel(), tvec.ravel())
    if best is None:
        raise ValueError("no initial camera from these correspondences")

    def res(x):
        K = intrinsic_matrix(np.exp(x[0]), cx, cy, aspect)
        proj, _ = cv2.projectPoints(obj, x[1:4], x[4:7], K, None)
        return (proj.reshape(-1, 2) - img_xy).ravel()

    x = least_squares(res, np.r_[np.log(best[1]), best[2], best[3]], x_scale="jac", max_nfev=2000).x
    R = cv2.Rodrigues(x[1:4])[0]
    return Camera(intrinsic_matrix(float(np.exp(x[0])), cx, cy, aspect), R, x[4:7])


def refine(img: np.ndarray, entry: dict, init: Camera | None = None, verbose: bool = False) -> tuple[Camera, float, float]:
    """Fit (f, R, C, k1[, L][, W]) of a reference entry to the painted lines.

    ``entry`` holds ``correspondences``, ``pitch`` (length, width, and the
    optional ``fit`` list naming ``"length"`` / ``"width"``), ``pixel_aspect``
    and ``fit`` options (``box``, ``max_saturation``, ``prior_px``, ``k1``
    fixed or free). Returns ``(camera, length, width)``.
    """
    h, w = img.shape[:2]
    aspect = float(entry.get("pixel_aspect", 1.0))
    opts = entry.get("fit_options", {})
    box = int(opts.get("box", 2 * round(w / 1280 * 12) + 1))
    mask = fit_mask(img, box, float(opts.get("threshold", 8.0)), int(opts.get("max_saturation", 90)), float(opts.get("white_margin", 6.0)))
    for x0, y0, x1, y1 in opts.get("exclude", []):  # boxes (pixels) the fit must ignore: graphics on the pitch
        mask[y0:y1, x0:x1] = False
    dt = cv2.distanceTransform((~mask).astype(np.uint8), cv2.DIST_L2, 5)
    fit_p = entry["pitch"].get("fit", [])
    # a fitted dimension starts from the nominal pitch (so that a re-fit does not depend on the last one)
    L0 = 105.0 if "length" in fit_p else float(entry["pitch"]["length"])
    W0 = 68.0 if "width" in fit_p else float(entry["pitch"]["width"])
    model = _Model((w, h), aspect, "length" in fit_p, "width" in fit_p, L0, W0, bool(opts.get("free_principal_point")), bool(opts.get("free_aspect")))
    corr = entry.get("correspondences", [])
    labels = [c["label"] for c in corr]
    img_xy = np.array([c["image_xy"] for c in corr], float).reshape(-1, 2)
    prior_px = float(opts.get("prior_px", 8.0))
    k1_px = float(opts.get("k1_px", 4.0))
    if init is None:
        pitch = PitchModel(L0, W0)
        init = _camera_from_points(img_xy, [feature_xy(s, pitch) for s in labels], (w, h), aspect)
    free_k1 = opts.get("k1", "free") == "free"
    x0 = model.pack(init, L0, W0)
    if not free_k1:
        x0[7] = float(opts.get("k1", 0.0))
    counts = {name: len(p) for name, p in PitchModel(L0, W0).sample(SPACING).items()}
    cache = {}

    def residuals(x, scale_px):
        if not free_k1:
            x = x.copy()
            x[7] = x0[7]
        try:
            cam, L, W = model.unpack(x)
            key = (round(L, 6), round(W, 6))
            if key not in cache:
                cache[key] = _pitch_points(L, W, counts)
        except ValueError:  # a trial step to no camera or no pitch (f overflows, W >= L): the worst cost, so it is refused
            return np.full(n_res, 1e6)
        pts = cache[key]
        px = cam.project_pitch(pts)
        ok = np.isfinite(px).all(axis=1) & (px[:, 0] >= 0) & (px[:, 0] <= w - 1) & (px[:, 1] >= 0) & (px[:, 1] <= h - 1)
        d = np.zeros(len(pts))
        d[ok] = map_coordinates(dt, [px[ok, 1], px[ok, 0]], order=1, mode="nearest")
        # line term: normalised so that the whole view weighs like 400 points
        # Cauchy loss on the line term only (the priors stay Gaussian)
        d = scale_px * np.sqrt(np.log1p((d / scale_px) ** 2))
        line = d * np.sqrt(400.0 / max(ok.sum(), 1))
        pitch = PitchModel(min(max(L, 90.0), 120.0), min(max(W, 45.0), 90.0))
        if len(labels):
            pp = cam.project_pitch(np.array([feature_xy(s, pitch) for s in labels]))
            pr = np.nan_to_num((pp - img_xy) / prior_px, nan=50.0).ravel()
        else:
            pr = np.zeros(0)
        # k1: a prior toward 0 of k1_px pixels of displacement at the image corner, so that
        # a long lens (small field of view) does not take a large k1 the lines hardly see
        rc = np.hypot(w / 2 / cam.K[0, 0], h / 2 / cam.K[1, 1])
        extra = [cam.dist[0] * rc**3 * cam.K[0, 0] / k1_px]
        if model.fit_length:
            extra.append((L - 105.0) / 10.0)  # priors toward the nominal pitch, not the stored value
        if model.fit_width:
            extra.append((W - 68.0) / 8.0)
        return np.concatenate([line, pr, extra])

    n_res = len(residuals(x0, 12.0))
    x = x0
    if verbose:
        print(f"  initial: f {init.focal:.1f} C {np.round(init.center, 2)} rms {reprojection_rms(init, entry, PitchModel(L0, W0))}")
    for scale in opts.get("scales", (12.0, 5.0, 2.5, 1.2, 2.5, 1.2)):
        res = least_squares(residuals, x, args=(scale,), x_scale="jac", max_nfev=400)
        x = res.x
        if verbose:
            cam, L, W = model.unpack(x)
            print(f"  scale {scale}: cost {res.cost:.1f} f {cam.focal:.1f} C {np.round(cam.center, 2)} k1 {x[7]:.4f} L {L:.2f} W {W:.2f}")
    if not free_k1:
        x[7] = x0[7]
    return model.unpack(x)


def _turn_to_points(cam: Camera, entry: dict, pitch: PitchModel) -> Camera:
    """A previous frame's camera turned and zoomed (rotation and focal length; the
    centre, principal point and k1 kept) onto this entry's correspondences: the
    start of a clip frame whose points alone do not fix a camera (e.g. only
    the halfway line's crossings)."""
    corr = entry.get("correspondences", [])
    if len(corr) < 2:
        return cam
    xy = np.array([c["image_xy"] for c in corr], float)
    P = np.column_stack([[feature_xy(c["label"], pitch) for c in corr], np.zeros(len(corr))])
    C = cam.center
    a = cam.K[1, 1] / cam.K[0, 0]

    def make(x):
        R = cv2.Rodrigues(x[1:4])[0]
        K = intrinsic_matrix(float(np.exp(x[0])), cam.K[0, 2], cam.K[1, 2], a)
        return Camera.trusted(K, R, -R @ C, cam.dist)

    def res(x):
        return np.nan_to_num(make(x).project(P) - xy, nan=1e4).ravel()

    x0 = np.r_[np.log(cam.focal), cv2.Rodrigues(cam.R)[0].ravel()]
    return make(least_squares(res, x0, x_scale="jac").x)


def reprojection_rms(cam: Camera, entry: dict, pitch: PitchModel) -> float | None:
    """RMS (pixels) of the correspondences' reprojection errors; None without any."""
    corr = entry.get("correspondences", [])
    if not corr:
        return None
    pp = cam.project_pitch(np.array([feature_xy(c["label"], pitch) for c in corr]))
    err = pp - np.array([c["image_xy"] for c in corr], float)
    return float(np.sqrt((err**2).sum(axis=1).mean()))


# --------------------------------------------------------------------------- data
def data_path(item: str) -> Path:
    return DATA_DIR / f"{item}.json"


def load_item(item: str) -> dict:
    return json.loads(data_path(item).read_text())


def save_item(item: str, doc: dict) -> None:
    """Write an item's JSON (indented, with lists of numbers on one line)."""
    text = json.dumps(doc, indent=1)
    text = re.sub(r"\[\s*(-?[\d.e+-]+(?:,\s*-?[\d.e+-]+)*)\s*\]", lambda m: "[" + re.sub(r"\s+", " ", m.group(1)) + "]", text)
    data_path(item).parent.mkdir(parents=True, exist_ok=True)
    data_path(item).write_text(text + "\n")


def entry_of(doc: dict, frame: int) -> dict:
    for e in doc["frames"]:
        if e["frame"] == frame:
            return e
    raise KeyError(f"{doc['item']} has no frame {frame}")


def fit_entry(item: str, doc: dict, frame: int, img: np.ndarray, from_previous: bool = False, verbose: bool = True) -> dict:
    """Refine one entry and store camera, pitch, support and RMS in it."""
    e = entry_of(doc, frame)
    init = None
    if from_previous:
        e["init"] = "previous_frame"
    spec = e.get("init")
    src = None
    if isinstance(spec, str) and spec.startswith("frame "):  # "frame N": start from that reference frame's camera
        src = entry_of(doc, int(spec.split()[1]))
        if not src.get("camera"):
            raise ValueError(f"{item} frame {frame}: init {spec!r} has no camera yet")
    elif spec == "previous_frame" or len(e.get("correspondences", [])) < 4:
        prev = [p for p in doc["frames"] if p["frame"] < frame and p.get("camera")]
        if not prev:
            raise ValueError(f"{item} frame {frame}: fewer than 4 correspondences and no previous camera")
        src = prev[-1]
    if src is not None:
        init = _turn_to_points(Camera.from_dict(src["camera"]), e, PitchModel(src["pitch"]["length"], src["pitch"]["width"]))
    cam, L, W = refine(img, e, init, verbose=verbose)
    e["image_size"] = [int(img.shape[1]), int(img.shape[0])]
    e["pitch"]["length"], e["pitch"]["width"] = round(L, 3), round(W, 3)
    pitch = PitchModel(e["pitch"]["length"], e["pitch"]["width"])
    d = cam.to_dict()
    d.pop("H", None)
    e["camera"] = d
    e["line_support"] = round(line_support(img, cam, pitch), 4)
    rms = reprojection_rms(cam, e, pitch)
    e["reprojection_rms_px"] = None if rms is None else round(rms, 2)
    for c in e.get("correspondences", []):
        c["pitch_xy"] = [round(float(v), 3) for v in feature_xy(c["label"], pitch)]
    if verbose:
        print(f"{item} {frame}: support {e['line_support']:.3f} rms {e['reprojection_rms_px']} f {cam.focal:.1f} k1 {cam.dist[0]:.4f} C {np.round(cam.center, 2)} pitch {L:.2f} x {W:.2f}")
    return e


# --------------------------------------------------------------------------- drawing
def draw_overlay(img: np.ndarray, cam: Camera, pitch: PitchModel, corr=(), thickness: int = 1) -> np.ndarray:
    """The frame with every projected marking drawn as a thin coloured line (lines
    red, arcs magenta) and the correspondences (green: as read, yellow dot:
    reprojected)."""
    out = img.copy()
    h, w = img.shape[:2]
    for m in pitch.markings.values():
        p = m.sample(0.1)
        px = cam.project_pitch(p)
        colour = (0, 0, 255) if isinstance(m, Segment) else (255, 0, 255)
        good = np.isfinite(px).all(axis=1) & (np.abs(px) < 4 * max(w, h)).all(axis=1)
        runs = np.split(np.arange(len(px)), np.where(~good)[0])
        for r in runs:
            r = r[good[r]]
            if len(r) > 1:
                cv2.polylines(out, [np.round(px[r] * 4).astype(np.int32)], False, colour, thickness, cv2.LINE_AA, shift=2)
    for c in corr:
        x, y = c["image_xy"]
        cv2.circle(out, (int(round(x)), int(round(y))), 6, (0, 255, 0), 1, cv2.LINE_AA)
        q = cam.project_pitch(np.array([feature_xy(c["label"], pitch)]))[0]
        if np.isfinite(q).all():
            cv2.circle(out, (int(round(q[0])), int(round(q[1]))), 2, (0, 255, 255), -1, cv2.LINE_AA)
    return out


def grid_view(img: np.ndarray, crop=None, step: int | None = None, scale: float | None = None) -> np.ndarray:
    """A crop (x0, y0, x1, y1) enlarged with a labelled pixel grid (labels in
    full-frame pixel coordinates), for reading positions by eye."""
    h, w = img.shape[:2]
    x0, y0, x1, y1 = crop if crop else (0, 0, w, h)
    sub = img[y0:y1, x0:x1]
    if scale is None:
        scale = min(1600 / sub.shape[1], 1000 / sub.shape[0])
    big = cv2.resize(sub, None, fx=scale, fy=scale, interpolation=cv2.INTER_CUBIC if scale > 1 else cv2.INTER_AREA)
    if step is None:  # grid lines about 40-100 display pixels apart
        step = next(s for s in (2, 5, 10, 20, 25, 50, 100, 200) if s * scale >= 40)
    for gx in range((x0 // step + 1) * step, x1, step):
        X = int(round((gx - x0) * scale))
        strong = gx % (step * 5) == 0
        cv2.line(big, (X, 0), (X, big.shape[0]), (0, 255, 255) if strong else (0, 160, 255), 1)
        cv2.putText(big, str(gx), (X + 2, 12), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1)
    for gy in range((y0 // step + 1) * step, y1, step):
        Y = int(round((gy - y0) * scale))
        strong = gy % (step * 5) == 0
        cv2.line(big, (0, Y), (big.shape[1], Y), (0, 255, 255) if strong else (0, 160, 255), 1)
        cv2.putText(big, str(gy), (2, Y - 2), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1)
    return big


def frames_of(item: str, frames) -> dict[int, np.ndarray]:
    if ITEMS[item]["kind"] == "clip":
        return load_clip_frames(item, frames)
    return {f: load_frame(item, f) for f in frames}


def draw_item(item: str, out_dir: Path) -> list[Path]:
    """Overlay PNGs of every fitted reference frame of an item."""
    doc = load_item(item)
    entries = [e for e in doc["frames"] if e.get("camera")]
    imgs = frames_of(item, [e["frame"] for e in entries])
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for e in entries:
        img = imgs[e["frame"]]
        cam = Camera.from_dict(e["camera"])
        ov = draw_overlay(img, cam, pitch_of(e), e.get("correspondences", []))
        label = f"{item} #{e['frame']}  support {e['line_support']:.3f}  rms {e['reprojection_rms_px']}"
        fs = 0.4 + 0.4 * img.shape[1] / 1280
        (tw, th), _ = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX, fs, 1)
        cv2.rectangle(ov, (4, img.shape[0] - th - 16), (tw + 14, img.shape[0] - 4), (0, 0, 0), -1)
        cv2.putText(ov, label, (9, img.shape[0] - 10), cv2.FONT_HERSHEY_SIMPLEX, fs, (255, 255, 255), 1, cv2.LINE_AA)
        p = out_dir / f"{item}_{e['frame']:03d}.png"
        cv2.imwrite(str(p), ov)
        paths.append(p)
    return paths


def contact_sheet(paths, out: Path, tile_width: int = 800, cols: int = 2, quality: int = 85, pixel_aspect: float = 1.0) -> None:
    """Tiles of the overlays (display aspect restored) as one JPEG."""
    tiles = []
    for p in paths:
        im = cv2.imread(str(p))
        th = int(round(tile_width * im.shape[0] / (im.shape[1] * pixel_aspect)))
        tiles.append(cv2.resize(im, (tile_width, th), interpolation=cv2.INTER_AREA))
    th = max(t.shape[0] for t in tiles)
    tiles = [cv2.copyMakeBorder(t, 0, th - t.shape[0], 0, 0, cv2.BORDER_CONSTANT) for t in tiles]
    cols = min(cols, len(tiles))
    while len(tiles) % cols:
        tiles.append(np.zeros_like(tiles[0]))
    rows = [np.hstack(tiles[i : i + cols]) for i in range(0, len(tiles), cols)]
    cv2.imwrite(str(out), np.vstack(rows), [cv2.IMWRITE_JPEG_QUALITY, quality])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--draw", type=Path, help="redraw the overlays of every item (or --item) into DIR")
    ap.add_argument("--sheets", action="store_true", help="with --draw: also write docs/images/real_reference_<item>.jpg")
    ap.add_argument("--item", help="one item only")
    ap.add_argument("--fit", metavar="ITEM", help="re-fit an item's frames from their correspondences")
    ap.add_argument("--frame", type=int, action="append", help="with --fit / --grid: the frame(s)")
    ap.add_argument("--from-previous", action="store_true", help="with --fit: start from the previous reference frame's camera")
    ap.add_argument("--grid", metavar="ITEM", help="write a gridded crop of a frame (for reading points) to --out")
    ap.add_argument("--crop", help="x0,y0,x1,y1 for --grid")
    ap.add_argument("--out", type=Path, default=Path("/tmp"))
    args = ap.parse_args(argv)
    if args.fit:
        doc = load_item(args.fit)
        frames = args.frame or [e["frame"] for e in doc["frames"]]
        imgs = frames_of(args.fit, frames)
        for f in frames:
            fit_entry(args.fit, doc, f, imgs[f], from_previous=args.from_previous)
            save_item(args.fit, doc)
    if args.grid:
        for f in args.frame or [0]:
            img = frames_of(args.grid, [f])[f]
            crop = tuple(int(v) for v in args.crop.split(",")) if args.crop else None
            args.out.mkdir(parents=True, exist_ok=True)
            cv2.imwrite(str(args.out / f"grid_{args.grid}_{f:03d}.png"), grid_view(img, crop))
    if args.draw:
        for item in [args.item] if args.item else list(ITEMS):
            if not data_path(item).exists():
                continue
            paths = draw_item(item, args.draw)
            print(f"{item}: {len(paths)} overlays in {args.draw}")
            if args.sheets and paths:
                aspect = load_item(item)["frames"][0].get("pixel_aspect", 1.0)
                contact_sheet(paths, ROOT / "docs" / "images" / f"real_reference_{item}.jpg", pixel_aspect=aspect)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
