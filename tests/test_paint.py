"""The paint initialiser for real frames (issue 29): the white-paint mask and
its straight lines (arstream.detect.paint), cameras from ordered pairs of
lines (arstream.solve_lines.cameras_from_line_pairs), the camera nearest to a
homography (geometry.camera.camera_near_homography), the registration of a
single still with its line-support test (arstream.initialise.register_frame),
and, on the shared real stills, registration against the reference cameras
(tests/data/real_reference, made independently by bench/reference_cameras.py).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from arstream.detect import detect
from arstream.detect.paint import MIN_RIDGE_SHARE, bright_across, grass_beside, paint_lines, paint_mask
from arstream.evaluate import distance_1280, frame_error
from arstream.initialise import paint_view, register_frame
from arstream.solve_lines import cameras_from_line_pairs
from geometry.lines import line_through
from arstream.support import bright_mask, line_support, marking_points
from geometry.camera import Camera, camera_from_ptz, camera_near_homography, PTZ
from geometry.pitch import PitchModel

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "tests" / "data" / "real_reference"
SHARED = ROOT.parent / "shared" / "data" / "real-broadcast"
PITCH = PitchModel()
GRASS = (40, 120, 50)  # BGR


def _grass(h=360, w=640, seed=0):
    rng = np.random.default_rng(seed)
    img = np.empty((h, w, 3), np.uint8)
    img[:] = GRASS
    return np.clip(img + rng.normal(0, 3, img.shape), 0, 255).astype(np.uint8)


# ---------------------------------------------------------------------------
# the paint mask: white paint only, thin only


def test_paint_mask_keeps_white_lines_and_drops_coloured_lines_and_blobs():
    img = _grass()
    cv2.line(img, (20, 100), (620, 130), (235, 235, 235), 2)  # white paint
    cv2.line(img, (20, 250), (620, 260), (40, 220, 230), 2)  # a yellow line of another sport (BGR)
    cv2.line(img, (320, 20), (330, 340), (230, 120, 40), 2)  # a blue one
    cv2.circle(img, (500, 300), 15, (240, 240, 240), -1)  # a white blob (a kit, the ball up close)
    m = paint_mask(img)
    assert m.dtype == np.uint8 and m.shape == img.shape[:2]
    on_white = m[[100 + 30 * x // 600 for x in range(40, 600, 40)], list(range(60, 640, 40))[:14]]
    assert (on_white > 0).mean() >= 0.9
    assert not m[245:265, 30:300].any(), "a yellow line is not a marking"
    assert not m[150:330, 316:336].any(), "a blue line is not a marking (away from its crossing with the white one)"
    assert not m[292:308, 492:508].any(), "the inside of a blob is no line"


def test_paint_mask_region_and_border():
    img = _grass()
    cv2.line(img, (0, 100), (639, 100), (235, 235, 235), 2)
    region = np.zeros(img.shape[:2], np.uint8)
    region[:, 320:] = 255
    m = paint_mask(img, region, border=6)
    assert not m[:, :320].any() and m[99:102, 330:630].any()
    assert not m[:, -6:].any()
    # a region of another size is scaled to the frame
    m2 = paint_mask(img, cv2.resize(region, (160, 90), interpolation=cv2.INTER_NEAREST))
    assert np.array_equal(m2 > 0, m > 0)


@pytest.mark.parametrize(
    "image, message",
    [
        (np.zeros((10, 10), np.uint8), "image must be a BGR uint8 array"),
        (np.zeros((10, 10, 3), np.float32), "image must be a BGR uint8 array"),
        ("frame.png", "image must be a BGR uint8 array"),
    ],
)
def test_paint_mask_bad_input(image, message):
    with pytest.raises(ValueError, match=message):
        paint_mask(image)


# ---------------------------------------------------------------------------
# straight lines of the paint


def _line_angle_offset(line, p0, p1):
    """Angle (deg) between a detected line and the segment p0-p1, and the
    largest distance (px) of the segment's ends from the line."""
    d = np.subtract(p1, p0, dtype=float)
    d /= np.linalg.norm(d)
    ang = np.degrees(np.arcsin(min(1.0, abs(line[0] * d[0] + line[1] * d[1]))))
    off = max(abs(line[:2] @ p0 + line[2]), abs(line[:2] @ p1 + line[2]))
    return ang, off


def test_paint_lines_recover_lines_across_players():
    img = _grass(720, 1280)
    segs = [((40, 620), (1240, 560)), ((100, 200), (1180, 260)), ((300, 700), (700, 150))]
    for a, b in segs:
        cv2.line(img, a, b, (230, 230, 230), 3, cv2.LINE_AA)
    # players on the lines: short dark gaps of 20-30 px
    for x, y in ((400, 604), (900, 585), (600, 230)):
        cv2.rectangle(img, (x - 12, y - 40), (x + 12, y + 10), (60, 40, 160), -1)
    lines = paint_lines(paint_mask(img), img)
    assert len(lines) >= 3
    for a, b in segs:
        best = min((_line_angle_offset(dl.line, np.array(a, float), np.array(b, float)) for dl in lines), key=lambda r: r[1])
        # a 3 px anti-aliased line, pooled to a 1000 px grid and refitted: well under a pixel
        assert best[0] < 0.3 and best[1] < 1.5, best
    # every line is unit-normalised and runs along its support: the mask is
    # pooled 2:1 (1280 -> 640) and a pixel within 2 pooled pixels of the line
    # is support, so 2 x 2 frame pixels plus the pooled pixel's half-width
    for dl in lines:
        assert abs(np.hypot(*dl.line[:2]) - 1) < 1e-12
        assert np.abs(dl.points @ dl.line[:2] + dl.line[2]).max() <= 4.5


def test_an_edge_with_grass_on_one_side_only_comes_after_the_lines():
    img = _grass(720, 1280)
    img[:200] = (120, 60, 140)  # the boards: purple above the pitch
    cv2.rectangle(img, (0, 194), (1279, 196), (230, 230, 230), -1)  # their bright lower edge
    cv2.line(img, (40, 500), (1240, 470), (230, 230, 230), 3)  # a painted line
    cv2.line(img, (200, 700), (900, 300), (230, 230, 230), 3)  # another
    lines = paint_lines(paint_mask(img), img)
    both = grass_beside(lines, img)
    assert len(lines) >= 3
    k_edge = int(np.argmin(both))
    assert both[k_edge] < 0.5 and abs(lines[k_edge].endpoints[:, 1].mean() - 195) < 8
    assert all(b >= 0.5 for b in both[:k_edge]) and k_edge == len(lines) - 1


def test_a_shadow_s_sunlit_edge_is_no_painted_line():
    # a stand's shadow across the pitch (bench/real_graphics.py's shadow: the
    # frame above a slanted line lit by the sky alone): the sunlit grass
    # along its edge is brighter than its box mean in every channel, a long
    # straight line of the paint mask with grass on both sides, but it is a
    # step, not brighter than the grass beyond it
    sys.path.insert(0, str(ROOT / "bench"))
    from real_graphics import shadow

    img = np.clip(_grass(720, 1280).astype(np.int16) + 40, 0, 255).astype(np.uint8)  # sunlit grass (80, 160, 90)
    segs = [((40, 620), (1240, 560)), ((300, 700), (700, 150)), ((100, 250), (1180, 300))]  # in the sun, across, in the shade
    for a, b in segs:
        cv2.line(img, a, b, (230, 230, 230), 3, cv2.LINE_AA)
    img = shadow(img)
    edge = (np.array([0.0, 0.55 * 720]), np.array([1279.0, 0.30 * 720]))
    mask = paint_mask(img)
    # the mask's lines, before the test across them: the edge among them
    unjudged = paint_lines(mask)
    assert min(_line_angle_offset(dl.line, *edge)[1] for dl in unjudged) < 3
    lines = paint_lines(mask, img)
    assert min(_line_angle_offset(dl.line, *edge)[1] for dl in lines) > 20
    for a, b in segs:  # the painted lines kept, in the sun and in the shade
        best = min((_line_angle_offset(dl.line, np.array(a, float), np.array(b, float)) for dl in lines), key=lambda r: r[1])
        assert best[0] < 0.3 and best[1] < 1.5, best
    ridge = bright_across(unjudged, img)
    on_edge = np.array([_line_angle_offset(dl.line, *edge)[1] < 3 for dl in unjudged])
    assert ridge[on_edge].max() < MIN_RIDGE_SHARE <= ridge[~on_edge].min(), ridge


def test_paint_lines_of_an_empty_mask():
    assert paint_lines(np.zeros((360, 640), np.uint8)) == []
    with pytest.raises(ValueError, match="mask must be a 2-D array"):
        paint_lines(np.zeros((4, 4, 3), np.uint8))


# ---------------------------------------------------------------------------
# the camera nearest to a homography


def _broadcast_camera(pan=0.35, tilt=0.22, f=1500.0, size=(1280, 720)):
    return camera_from_ptz(np.array([-5.0, -60.0, 14.0]), PTZ(pan=pan, tilt=tilt, roll=0.0, f=f), ((size[0] - 1) / 2, (size[1] - 1) / 2))


def test_camera_near_homography_round_trip():
    cam = _broadcast_camera()
    grid = np.stack(np.meshgrid(np.arange(0, 52, 4.0), np.arange(-30, 34, 4.0)), -1).reshape(-1, 2)
    got = camera_near_homography(cam.H_img_from_pitch, cam.principal_point, grid)
    # an exact camera homography: the decomposition is already the answer (f to ~1e-9 relative)
    assert abs(got.focal / cam.focal - 1) < 1e-7
    assert np.linalg.norm(got.center - cam.center) < 1e-5
    with pytest.raises(ValueError, match="at least 4 pitch points"):
        camera_near_homography(cam.H_img_from_pitch, cam.principal_point, grid[:3])


def test_camera_near_homography_fits_the_picture_of_a_perturbed_homography():
    # a homography off the camera family (8 dof against 7): the nearest camera
    # draws the picture closer than the decomposition of its columns does
    cam = _broadcast_camera()
    rng = np.random.default_rng(3)
    Hn = cam.H_img_from_pitch @ (np.eye(3) + np.diag([0.01, -0.01, 0.0]) + 0.002 * rng.standard_normal((3, 3)) * np.array([[0, 1, 0], [1, 0, 0], [0, 0, 0]]))
    grid = np.stack(np.meshgrid(np.arange(0, 52, 2.0), np.arange(-30, 34, 2.0)), -1).reshape(-1, 2)
    X = np.column_stack([grid, np.ones(len(grid))]) @ Hn.T
    target = X[:, :2] / X[:, 2:]
    seen = (target[:, 0] >= 0) & (target[:, 0] < 1280) & (target[:, 1] >= 0) & (target[:, 1] < 720)
    from geometry.camera import camera_from_homography

    def rms(c):
        p = c.project(np.column_stack([grid[seen], np.zeros(seen.sum())]))
        return float(np.sqrt(np.mean(np.sum((p - target[seen]) ** 2, axis=1))))

    near = camera_near_homography(Hn, cam.principal_point, grid[seen])
    assert rms(near) < rms(camera_from_homography(Hn, cam.principal_point))


# ---------------------------------------------------------------------------
# cameras from ordered pairs of lines, on a synthetic penalty-area view


def _penalty_view(size=(1280, 720), cam=None):
    W, H = size
    cam = cam or camera_from_ptz(np.array([-8.0, -62.0, 15.0]), PTZ(pan=-0.55, tilt=0.2, roll=0.0, f=1.6 * W), ((W - 1) / 2, (H - 1) / 2))
    img = _grass(H, W)
    for poly in PITCH.polylines(0.1):
        px = cam.project(np.column_stack([poly, np.zeros(len(poly))]))
        ok = np.all(np.isfinite(px), axis=1) & np.all(np.abs(px) < 4 * W, axis=1)
        pts = np.rint(px[ok] * 16).astype(np.int32)
        if len(pts) >= 2:
            cv2.polylines(img, [pts], False, (225, 225, 225), 2, cv2.LINE_AA, shift=4)
    return cam, img


def test_cameras_from_line_pairs_find_a_penalty_area_view():
    cam, img = _penalty_view()
    H, W = img.shape[:2]
    mask = paint_mask(img)
    lines = paint_lines(mask, img)[:10]
    near = cv2.dilate(mask, np.ones((5, 5), np.uint8))
    hy = cameras_from_line_pairs([dl.line for dl in lines], [dl.endpoints for dl in lines], (W, H), cam.principal_point, near, PITCH)
    assert hy.cameras and hy.n_plausible > 0 and len(hy.scores) == len(hy.cameras)
    assert np.all(np.diff(hy.scores) <= 1e-12)
    pts = PITCH.sample_points(0.5)
    best = min(frame_error(cam, c, (W, H), pts, PITCH.symmetries).mean for c in hy.cameras[:3])
    # unrefined, from 4-8 lines fitted to 2 px paint: a few pixels
    assert best < 6.0, best


def test_corner_homographies_are_the_line_dlt_s_of_every_pairing():
    # two image lines of each direction against two model lines of each: the
    # closed form of their four corners is the homography the line DLT gives
    # on the same four lines, for every pairing, in the order of the pairs
    from itertools import combinations

    from arstream.solve_lines import _corner_homographies
    from geometry.homography import homographies_from_lines

    cam, img = _penalty_view()
    H, W = img.shape[:2]
    Hp = cam.K @ np.column_stack([cam.R[:, 0], cam.R[:, 1], cam.t])  # pitch (Z = 0) -> image
    xs, ys = [36.0, 47.0, 52.5], [-20.16, -9.16, 9.16, 20.16]
    Hit = np.linalg.inv(Hp).T
    L = np.array([Hit @ [1.0, 0, -x] for x in (36.0, 47.0, 52.5)] + [Hit @ [0, 1.0, -y] for y in (-20.16, 9.16)])
    L /= np.linalg.norm(L[:, :2], axis=1, keepdims=True)
    ia, ib = list(combinations(range(3), 2)), [(3, 4)]
    ma, mb = list(combinations(xs, 2)), list(combinations(ys, 2))
    Hc, ok = _corner_homographies(L, ia, ib, ma, mb, (W / 2, H / 2), W, 52.5)
    src = [[[1.0, 0, -a[0]], [1.0, 0, -a[1]], [0, 1.0, -b[0]], [0, 1.0, -b[1]]] for _ in ia for _ in ib for a in ma for b in mb]
    dst = [[L[i[0]], L[i[1]], L[j[0]], L[j[1]]] for i in ia for j in ib for _ in ma for _ in mb]
    Hl, okl = homographies_from_lines(np.array(src), np.array(dst))
    assert ok.all() and okl.all() and len(Hc) == 3 * 1 * 3 * 6
    assert np.allclose(Hc, Hl, atol=1e-10)
    # the right pairing is the camera's own
    k = ((ia.index((0, 1)) * len(ib) + 0) * len(ma) + ma.index((36.0, 47.0))) * len(mb) + mb.index((-20.16, 9.16))
    assert np.allclose(Hc[k], Hp / np.linalg.norm(Hp) * np.sign(Hp[2, 2]), atol=1e-9)
    # a repeated image line meets the other direction's at one point twice: no homography
    _, ok2 = _corner_homographies(np.vstack([L, L[:1]]), [(0, 5)], ib, ma[:1], mb[:1], (W / 2, H / 2), W, 52.5)
    assert ok2.tolist() == [False]


@pytest.mark.parametrize(
    "centre, focal, expect",
    [
        ((-8.0, -62.0, 15.0), 2048.0, True),  # the penalty view's camera
        ((-8.0, -62.0, 2.0), 2048.0, False),  # below 3 m
        ((-8.0, -62.0, 90.0), 2048.0, False),  # above 80 m
        ((-8.0, -35.0, 15.0), 2048.0, False),  # not 3 m outside the near touchline
        ((80.0, -62.0, 15.0), 2048.0, False),  # beyond the goal lines by more than 20 m
        ((-8.0, -62.0, 15.0), 300.0, False),  # a focal length under 0.3 widths (a fisheye's)
        ((-8.0, -62.0, 15.0), 16000.0, False),  # over 12 widths
        ((-8.0, -140.0, 15.0), 2048.0, False),  # more than 100 m outside the near touchline
        ((-8.0, -132.0, 15.0), 2048.0, True),  # (98 m)
        ((-8.0, -62.0, float("nan")), 2048.0, False),
    ],
)
def test_plausible_broadcast_cameras(centre, focal, expect):
    from arstream.solve_lines import plausible

    assert plausible(np.array([centre]), np.array([focal]), 1280, PITCH).tolist() == [expect]


def test_cameras_from_line_pairs_with_the_lines_across_the_flatter():
    # a long lens near the halfway line looking along the pitch at the goal area
    # (israel_league_wide frame 175's reference camera, f = 3.3 widths, drawn):
    # the lines across the pitch are then the flatter family in the picture,
    # which the lines along it usually are; the lines are tried both ways round
    ref = {e["frame"]: e for e in json.loads((REFERENCE / "israel_league_wide.json").read_text())["frames"]}
    cam, img = _penalty_view(cam=Camera.from_dict(ref[175]["camera"]))
    H, W = img.shape[:2]
    seen = _visible_lines(cam, (W, H))

    def flatness(lines):
        return np.median([abs(x[0][1]) for x in lines])

    assert flatness([x for x in seen if x[2]]) > flatness([x for x in seen if not x[2]])
    mask = paint_mask(img)
    lines = paint_lines(mask, img)[:10]
    near = cv2.dilate(mask, np.ones((5, 5), np.uint8))
    hy = cameras_from_line_pairs([dl.line for dl in lines], [dl.endpoints for dl in lines], (W, H), cam.principal_point, near, PITCH)
    pts = PITCH.sample_points(0.5)
    best = min(frame_error(cam, c, (W, H), pts, PITCH.symmetries).mean for c in hy.cameras[:3])
    # unrefined, from lines fitted to 2 px paint, at 3.3 widths (where a
    # thousandth of a radian is 4 px): under 10 px
    assert best < 10.0, best
    # refined against the paint's whole pixels, the narrow view's depth-zoom
    # ambiguity (f and distance together) leaves it near the still target's 5 px
    est = register_frame(detect(img), (W, H), image=img)
    assert est.status == "ok" and frame_error(cam, est.camera, (W, H), pts, PITCH.symmetries).mean < 5.0


def test_cameras_from_line_pairs_need_two_lines_of_each_direction():
    cam, img = _penalty_view()
    near = np.ones((720, 1280), np.uint8)
    one_way = [np.array([0.0, 1.0, -300.0]), np.array([0.02, 1.0, -400.0]), np.array([0.04, 1.0, -500.0])]
    ends = [np.array([[100.0, 300.0], [900.0, 300.0]]), np.array([[100.0, 398.0], [900.0, 382.0]]), np.array([[100.0, 496.0], [900.0, 464.0]])]
    hy = cameras_from_line_pairs(one_way, ends, (1280, 720), cam.principal_point, near)
    assert hy.cameras == [] and hy.n_tried == 0


def _visible_lines(cam, size, min_px=100.0):
    """The straight markings ``cam`` shows at least ``min_px`` long: (image line, ends, across?)."""
    W, H = size
    out = []
    for sg in PITCH.segments:
        px = cam.project(np.column_stack([sg.sample(0.1), np.zeros(len(sg.sample(0.1)))]))
        ok = np.all(np.isfinite(px), axis=1) & (px[:, 0] >= 0) & (px[:, 0] < W) & (px[:, 1] >= 0) & (px[:, 1] < H)
        if ok.sum() < 2 or np.linalg.norm(px[ok][-1] - px[ok][0]) < min_px:
            continue
        a, b = px[ok][0], px[ok][-1]
        out.append((line_through((*a, 1.0), (*b, 1.0)), np.array([a, b]), abs(sg.start[0] - sg.end[0]) < 1e-9))
    return out


def test_cameras_from_line_pairs_with_one_line_across():
    # three lines along the touchlines and one across them (the goal line behind
    # the net, the far side out of view): four lines leave one degree of freedom
    # of a homography, which the camera's principal point and square pixels fix
    cam, img = _penalty_view()
    H, W = img.shape[:2]
    seen = _visible_lines(cam, (W, H))
    along = [x for x in seen if not x[2]]
    across = max((x for x in seen if x[2]), key=lambda x: np.linalg.norm(x[1][1] - x[1][0]))
    assert len(along) >= 3
    use = along + [across]
    near = cv2.dilate(paint_mask(img), np.ones((5, 5), np.uint8))
    hy = cameras_from_line_pairs([x[0] for x in use], [x[1] for x in use], (W, H), cam.principal_point, near, PITCH)
    assert hy.cameras and hy.n_plausible > 0
    best = min(frame_error(cam, c, (W, H), PITCH.sample_points(0.5), PITCH.symmetries).mean for c in hy.cameras[:3])
    # exact lines: what is left is the scoring grid's and the nearest camera's
    assert best < 2.0, best


# ---------------------------------------------------------------------------
# a single still: register_frame with the line-support test


def test_register_frame_on_a_synthetic_penalty_area_view():
    cam, img = _penalty_view()
    H, W = img.shape[:2]
    est = register_frame(detect(img), (W, H), image=img)
    assert est.status == "ok" and est.info["support"] >= 0.9
    err = frame_error(cam, est.camera, (W, H), PITCH.sample_points(0.5), PITCH.symmetries)
    assert err.mean < 2.0, err


def test_register_frame_refuses_a_camera_the_frame_does_not_support():
    # grass with a few white lines that are no pitch: whatever camera fits them,
    # its markings do not land on paint, so nothing is reported
    img = _grass(720, 1280, seed=5)
    for a, b in (((50, 650), (1200, 600)), ((100, 300), (1250, 280)), ((640, 700), (800, 250)), ((200, 700), (260, 250))):
        cv2.line(img, a, b, (230, 230, 230), 3)
    est = register_frame(detect(img), (1280, 720), image=img)
    assert est.status == "lost" and est.camera is None
    if "support" in est.info:
        assert est.info["support"] < 0.7


# ---------------------------------------------------------------------------
# the shared real stills against their reference cameras

STILLS = ["ucl_2009", "world_cup_2006", "world_cup_2018"]
#: issue 29's targets for stills: line support >= 0.8, mean distance to the
#: reference <= 5 px of a 1280-wide frame over the markings in view
MIN_SUPPORT, MAX_DISTANCE_1280 = 0.8, 5.0
#: a camera this far from the reference (px @1280) is wrong, not imprecise (bench/real_graphics.py)
WRONG_1280 = 20.0


def _reference(item: str, frame: int = 0) -> tuple[Camera, PitchModel, dict]:
    doc = json.loads((REFERENCE / f"{item}.json").read_text())
    entry = next(e for e in doc["frames"] if e["frame"] == frame)
    p = entry["pitch"]
    return Camera.from_dict(entry["camera"]), PitchModel(p["length"], p["width"]), entry


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data/real-broadcast is absent")
@pytest.mark.parametrize("item", STILLS)
@pytest.mark.long
def test_register_a_real_still(item):
    # as ``arstream register`` does it: no size given, the size the view
    # constrains estimated from 105 x 68 (the references' widths are 67.5-68.3 m)
    from arstream.initialise import register_image

    img = cv2.imread(str(SHARED / "stills" / f"{item}.png"))
    H, W = img.shape[:2]
    est = register_image(img)
    assert est.status == "ok", est.info
    made_at = est.info["pitch"]
    assert made_at.source in ("estimated", "default") and abs(made_at.length - 105.0) < 2.0 and abs(made_at.width - 68.0) < 2.0, made_at.describe()
    sup = line_support(est.camera, bright_mask(cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)), marking_points(made_at.model())).share
    assert sup >= MIN_SUPPORT, sup
    ref, pitch, _ = _reference(item)
    d = distance_1280(ref, est.camera, (W, H), pitch, made_at.model())
    assert d <= MAX_DISTANCE_1280, d


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data/real-broadcast is absent")
@pytest.mark.parametrize("frame", [0, 25, 50])
def test_register_a_resized_premier_league_frame(frame):
    # stored 512 x 512, shown 16:9: registered on the frame stretched to square
    # pixels, the camera mapped back with K[1][1] / K[0][0] = 16/9
    from arstream.pipeline.stages import Analysis

    from arstream.initialise import register_image

    img = cv2.imread(str(SHARED / "sequence-epl" / f"frame_{frame:02d}.jpg"))
    H, W = img.shape[:2]
    an = Analysis(W, H, None, pixel_aspect=16 / 9)
    est = register_image(img, pixel_aspect=16 / 9)
    assert est.status == "ok", est.info
    cam = est.camera
    assert abs(cam.K[1, 1] / cam.K[0, 0] - an.sy / an.sx) < 1e-12 and abs(an.sy / an.sx - 16 / 9) < 0.01
    ref, pitch, _ = _reference("sequence_epl", frame)
    # distances in pixels of the frame as shown (square pixels, 16:9), 1280 wide
    assert distance_1280(ref, cam, (W, H), pitch, est.info["pitch"].model(), pixel_aspect=16 / 9) <= MAX_DISTANCE_1280


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data/real-broadcast is absent")
def test_a_premier_league_still_keeps_105_x_68_where_its_camera_fits_the_paint_clearly_better(monkeypatch):
    # frame 0's view gives a size beyond the noise of 105 x 68 (about 105 x
    # 66.3), whose camera passes the still's paint checks but is further from
    # the reference. The 105 x 68 camera lays over twice as many of the points
    # the two dispute on paint, though not more by a scan's margin: the still
    # keeps it (arstream.initialise.size_from_view)
    import arstream.initialise as ini
    from arstream.imaging import active_area
    from arstream.pipeline.stages import Analysis
    from arstream.pitch_size import SCAN_MARGIN, STILL_GAIN_RATIO, estimate_view_size, size_dispute

    calls = []
    real = ini.size_from_view

    def recorded(camera, support, view, size, pitch, min_support=0.7, **kw):
        calls.append((camera, view, size, pitch))
        return real(camera, support, view, size, pitch, min_support, **kw)

    monkeypatch.setattr(ini, "size_from_view", recorded)
    img = cv2.imread(str(SHARED / "sequence-epl" / "frame_00.jpg"))
    H, W = img.shape[:2]
    est = ini.register_image(img, pixel_aspect=16 / 9)
    assert est.status == "ok" and est.info["pitch"].source == "default", est.info["pitch"].describe()
    assert len(calls) == 1
    camera, view, size, pitch = calls[0]
    got = estimate_view_size(camera, view.points, size, pitch)
    assert got.cameras and not got.within_noise((105.0, 68.0)), got.describe()
    # both cameras on the frame as shown (square pixels, 16:9), against the reference
    an = Analysis(W, H, None, pixel_aspect=16 / 9, area=active_area(img))
    ref, ref_pitch, _ = _reference("sequence_epl", 0)

    def distance(c, made_at):
        return distance_1280(ref, an.camera(c), (W, H), ref_pitch, made_at, pixel_aspect=16 / 9)

    kept, other = distance(camera, pitch), distance(got.cameras[0], got.model(pitch.line_width))
    assert kept < other, (kept, other)
    # (what decides: twice as many of the disputed points on paint, under a scan's margin)
    d = size_dispute([camera, got.cameras[0]], [pitch, got.model(pitch.line_width)], view.bright)(0, 1)
    assert d.first >= STILL_GAIN_RATIO * d.second and d.first - d.second < SCAN_MARGIN * d.in_view, d


def _clip_frame(k: int, clip: str = "artificial_turf_multisport") -> np.ndarray:
    """Frame ``k`` of a shared clip, BGR."""
    import av

    with av.open(str(SHARED / "clips" / f"{clip}.mp4")) as c:
        return next(f for i, f in enumerate(c.decode(video=0)) if i == k).to_ndarray(format="bgr24")


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data/real-broadcast is absent")
@pytest.mark.parametrize("frame", [25, 50])
def test_register_a_centre_circle_frame_of_the_turf_clip(frame):
    # artificial_turf_multisport told its size: the detector's camera (the
    # circle's pole-polar camera refined) is 2-4 px from the reference but
    # below INIT_ACCEPT (the ridge detector finds few of the lines); judged
    # by its paint it wins over the paint initialiser's, a member of the
    # circle's family 1.25 and 1.8 times too far (17 and 568 px before)
    img = _clip_frame(frame)
    H, W = img.shape[:2]
    est = register_frame(detect(img), (W, H), image=img, pitch=PitchModel(100.0, 68.0))
    assert est.status == "ok", est.info
    ref, pitch, _ = _reference("artificial_turf_multisport", frame)
    assert distance_1280(ref, est.camera, (W, H), pitch) <= MAX_DISTANCE_1280


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data/real-broadcast is absent")
def test_the_circle_family_member_nearest_the_right_camera_is_refined_before_it_is_judged():
    # frame 175 of artificial_turf_multisport: the centre circle, the halfway
    # line and the far penalty area. The circle's depth-zoom family is fitted
    # on a grid of focal lengths 21 % apart; the members either side of the
    # right camera (f about 1.2 W) lay the far penalty area a few px off its
    # paint, and a member twice too far (f 2.2 W, the penalty area out of
    # view) scored more, so the right camera was never a hypothesis and the
    # paint initialiser took a camera along one line (149 000 px off). For a
    # still the members refined against the paint are judged as well
    from arstream.initialise import circle_view_cameras

    img = _clip_frame(175)
    H, W = img.shape[:2]
    pitch = PitchModel(100.0, 68.0)
    ref, ref_pitch, _ = _reference("artificial_turf_multisport", 175)
    d = detect(img)
    view = paint_view(img, d)
    pp = np.array([(W - 1) / 2, (H - 1) / 2])

    def nearest(cams):
        return min(distance_1280(ref, c, (W, H), ref_pitch) for c in cams)

    assert nearest(circle_view_cameras(view, (W, H), principal_point=pp, pitch=pitch, circles=d.ellipses, lines=d.lines)) > 50
    assert nearest(circle_view_cameras(view, (W, H), principal_point=pp, pitch=pitch, circles=d.ellipses, lines=d.lines, refine=True)) <= MAX_DISTANCE_1280
    est = register_frame(d, (W, H), image=img, pitch=pitch)
    assert est.status == "ok", est.info
    assert distance_1280(ref, est.camera, (W, H), ref_pitch) <= MAX_DISTANCE_1280


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data/real-broadcast is absent")
def test_a_still_keeps_the_camera_that_explains_its_paint():
    # frame 100 of artificial_turf_multisport in a letterbox (black bars over
    # the top and bottom eighths): the detector's camera (the centre circle's,
    # refined) is right, at line support 0.84; the paint initialiser's lays
    # four markings on one line and the edge of the pitch at 0.86. Chosen by
    # support it was kept (583 000 px off); chosen by the paint initialiser's
    # own measure (support plus RECALL_WEIGHT times the paint explained:
    # 0.36 of the paint's pixels against 0.14) the right one is
    img = _clip_frame(100)
    H, W = img.shape[:2]
    img[: H // 8] = 0
    img[H - H // 8 :] = 0
    pitch = PitchModel(100.0, 68.0)
    ref, ref_pitch, _ = _reference("artificial_turf_multisport", 100)
    d = detect(img)
    est = register_frame(d, (W, H), image=img, pitch=pitch)
    assert est.status == "ok", est.info
    assert distance_1280(ref, est.camera, (W, H), ref_pitch) <= MAX_DISTANCE_1280


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data/real-broadcast is absent")
def test_a_still_is_not_drawn_along_the_edges_of_a_running_track():
    # frame 400 of israel_league_wide: a goal area and a penalty area through
    # a long lens, beyond them a sand-coloured track and a wall. The paint
    # initialiser's best camera (684 px off) lays the touchline and the
    # penalty area's lines along the edges between grass, track and wall:
    # line support 0.78, 99 % of its markings on the grass, but only about
    # half of its marking points on paint lie on painted lines
    # (arstream.support.on_lines); the reference camera's 0.95
    from arstream.support import ON_LINES, on_lines, white_mask

    img = _clip_frame(400, "israel_league_wide")
    H, W = img.shape[:2]
    ref, ref_pitch, _ = _reference("israel_league_wide", 400)
    assert on_lines(ref, img, white_mask(img), ref_pitch) >= ON_LINES
    est = register_frame(detect(img), (W, H), image=img)
    assert est.status == "lost" or distance_1280(ref, est.camera, (W, H), ref_pitch) <= MAX_DISTANCE_1280, est.info


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data/real-broadcast is absent")
def test_a_still_in_a_pillarbox_is_registered_from_its_picture():
    # world_cup_2006 with black bars over the left and right eighths (a 4:3
    # picture in a 16:9 frame): each bar's edge is a bright step down the
    # frame that the paint's lines take for a marking, and the still was
    # lost; the picture inside the bars (arstream.imaging.active_area) is
    # registered with the frame's principal point and mapped back
    from arstream.imaging import active_area
    from arstream.initialise import register_image

    img = cv2.imread(str(SHARED / "stills" / "world_cup_2006.png"))
    H, W = img.shape[:2]
    img[:, : W // 8] = 0
    img[:, W - W // 8 :] = 0
    assert active_area(img) == (W // 8, 0, W - W // 8, H)
    est = register_image(img)
    assert est.status == "ok", est.info
    ref, pitch, _ = _reference("world_cup_2006")
    assert distance_1280(ref, est.camera, (W, H), pitch, est.info["pitch"].model()) <= MAX_DISTANCE_1280


def test_paint_view_tracks_pixels_without_finding_lines_first():
    cam, img = _penalty_view((640, 360))
    v = paint_view(img, detect(img))
    assert v._lines is None and len(v.index) > 100 and v.bright.shape == img.shape[:2]
    assert len(v.lines) >= 4 and v._lines is not None


def test_line_families_give_the_next_split_too():
    # the penalty view's straight markings, and a chord of its arc: the best
    # split by line length first, then a different one (the chord with the
    # other family, or a line left out); each family's lines share a point
    from arstream.solve_lines import _line_families

    cam, img = _penalty_view()
    H, W = img.shape[:2]
    seen = _visible_lines(cam, (W, H))
    arc = PITCH["penalty_arc_left"]
    pts = cam.project(np.column_stack([arc.sample(0.1), np.zeros(len(arc.sample(0.1)))]))
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    a, b = pts[len(pts) // 4], pts[3 * len(pts) // 4]
    L = np.array([x[0] for x in seen] + [line_through((*a, 1.0), (*b, 1.0))])
    E = np.array([x[1] for x in seen] + [np.array([a, b])])
    one = _line_families(L, E, 2.0, cam.principal_point, W)
    two = _line_families(L, E, 2.0, cam.principal_point, W, splits=2)
    assert len(one) == 1 and len(two) == 2 and two[0] == one[0] and two[1] != two[0]
    across, chord = {k for k, x in enumerate(seen) if x[2]}, len(seen)
    along, acr = one[0]
    # the best split puts the straight markings right (the chord may join either)
    assert set(acr) - {chord} <= across and not (set(along) - {chord}) & across


# ---------------------------------------------------------------------------
# penalty-area views from the penalty arc and the front line


def _arc_view(right: bool, size=(1280, 720)):
    """A camera on the near side looking at the left (or right) penalty area,
    and the pictures of that penalty arc's circle and of the area's front line."""
    from cameras import looking_at

    sgn = 1.0 if right else -1.0
    cam = looking_at((sgn * 20.0, -50.0, 14.0), (sgn * 40.0, 2.0, 0.0), 2.2 * size[0], size)
    arc_m = PITCH[f"penalty_arc_{'right' if right else 'left'}"]
    front = PITCH[f"penalty_area_{'right' if right else 'left'}_front"]
    return cam, arc_m, front


def _in_frame(px, size):
    return px[np.all(np.isfinite(px), axis=1) & (px[:, 0] >= 0) & (px[:, 0] <= size[0] - 1) & (px[:, 1] >= 0) & (px[:, 1] <= size[1] - 1)]


@pytest.mark.parametrize("right", [False, True])
def test_the_penalty_arc_and_front_line_give_the_camera_at_its_focal_length(right):
    # the pole-polar geometry of a circle and a line not through its centre
    # (the front line 5.44 m from the penalty mark), in the circle's own frame
    # (+X towards the halfway line): the left end's frame is the pitch's
    # shifted, the right end's turned half a circle
    from arstream.solve import cameras_along_circle
    from geometry.homography import transfer_conic, transfer_lines

    cam, arc_m, front = _arc_view(right)
    size = (1280, 720)
    E = transfer_conic(cam.H_img_from_pitch, arc_m.conic)
    lf = transfer_lines(cam.H_img_from_pitch, front.line[None])[0]
    arc, fr = _in_frame(cam.project_pitch(arc_m.sample(0.1)), size), _in_frame(cam.project_pitch(front.sample(0.1)), size)
    assert len(arc) > 100 and len(fr) > 100  # (what the test stands on)
    offset = abs(front.start[0] - arc_m.center[0])
    (got,) = cameras_along_circle(E, lf, arc, fr, cam.principal_point, image_width=size[0], focals=[cam.focal], radius=arc_m.radius, offset=offset)
    M = np.diag([-1.0, -1.0, 1.0]) if right else np.eye(3)
    mark = np.array([*arc_m.center, 0.0])
    # exact pixels: the robust fit's stopping tolerance is what is left
    assert np.linalg.norm(M @ got.center + mark - cam.center) < 0.01
    assert np.abs(got.R @ M - cam.R).max() < 1e-5


def test_cameras_along_circle_refuses_a_line_that_misses_the_circle():
    from arstream.solve import cameras_along_circle
    from geometry.homography import transfer_conic, transfer_lines

    cam, arc_m, front = _arc_view(False)
    E = transfer_conic(cam.H_img_from_pitch, arc_m.conic)
    lf = transfer_lines(cam.H_img_from_pitch, front.line[None])[0]
    arc, fr = cam.project_pitch(arc_m.sample(0.1)), cam.project_pitch(front.sample(0.1))
    with pytest.raises(ValueError, match="the line must cross the circle: offset 9.5 m, radius 9.09 m"):
        cameras_along_circle(E, lf, arc, fr, cam.principal_point, image_width=1280, focals=[cam.focal], radius=arc_m.radius, offset=9.5)


def _drawn(cam, size=(1280, 720), *, skip=(), players=()):
    """Grass with the pitch's markings drawn through ``cam`` (but those named in
    ``skip``), red players standing on the pitch points ``players``, JPEG."""
    W, H = size
    img = _grass(H, W)
    for name, m in PITCH.markings.items():
        if name in skip:
            continue
        px = cam.project_pitch(m.sample(0.1))
        ok = np.all(np.isfinite(px), axis=1) & np.all(np.abs(px) < 4 * W, axis=1)
        if ok.sum() >= 2:
            cv2.polylines(img, [np.rint(px[ok] * 16).astype(np.int32)], False, (225, 225, 225), 2, cv2.LINE_AA, shift=4)
    for p in cam.project_pitch(np.asarray(players, float).reshape(-1, 2)):
        x, y = int(p[0]), int(p[1])
        cv2.rectangle(img, (x - 8, y - 50), (x + 8, y + 3), (30, 30, 160), -1)
    ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, 75])
    return cv2.imdecode(buf, cv2.IMREAD_COLOR)


def test_paint_arcs_find_the_penalty_arc_beside_its_front_line_and_its_camera():
    # the right end (the camera placed at the end that keeps it on the near
    # side), two players on the arc
    from arstream.initialise import penalty_arc_cameras

    cam, arc_m, front = _arc_view(True)
    size = (1280, 720)
    img = _drawn(cam, players=[(34.0, -3.0), (33.5, 4.0)])
    view = paint_view(img, detect(img))
    assert len(view.arcs) >= 1
    pa = view.arcs[0]
    assert pa.arc.kind == "arc"
    # its ellipse runs along the arc's picture (its pixels: of a line 2 px
    # wide, JPEG; those within 1.5 px of the front line are left out, and the
    # ellipse reaches its ends by extrapolation), and its front line is the area's
    from geometry.conics import sampson_distance

    d = np.abs(sampson_distance(cam.project_pitch(arc_m.sample(0.05)), pa.arc.conic))
    assert np.median(d) < 0.5 and d.max() < 2.5, (np.median(d), d.max())
    assert len(pa.arc.points) > 200
    ends = cam.project_pitch(np.array([front.start, front.end]))
    assert np.abs(np.c_[ends, np.ones(2)] @ pa.front.line).max() < 3.0
    # one of its cameras is the camera (the focal grid's member refined to the paint)
    hyps = penalty_arc_cameras(view, size, principal_point=cam.principal_point, pitch=PITCH, refine=True)
    pts = PITCH.sample_points(0.5)
    best = min(frame_error(cam, h, size, pts, PITCH.symmetries[:1]).mean for h in hyps)
    assert best < 1.0, best


def test_paint_arcs_find_no_arc_without_one():
    # the same view with its penalty arc left out: the goal area's and the
    # penalty area's corners are no arcs
    cam, _, _ = _arc_view(True)
    img = _drawn(cam, skip=("penalty_arc_right",))
    view = paint_view(img, detect(img))
    assert len(view.lines) >= 4 and view.arcs == []


def test_the_centre_circle_beside_the_halfway_line_is_no_penalty_arc():
    # either half of the centre circle leaves the halfway line and comes back
    # to it, as a penalty arc does its front line; but a broadcast camera
    # sees it rise off the line by more than its chord along it (a half
    # circle seen from the side), and a penalty arc by at most 0.6 of its
    # chord (paint_arcs' max_rise; with 2, this view's half circle passes)
    from cameras import looking_at

    cam = looking_at((0.0, -45.0, 14.0), (0.0, 0.0, 0.0), 1.4 * 1280, (1280, 720))
    img = _drawn(cam)
    view = paint_view(img, detect(img))
    assert any(abs(dl.line[0]) > 0.9 for dl in view.lines)  # (the halfway line is one of its lines)
    assert view.arcs == []


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data/real-broadcast is absent")
@pytest.mark.long
def test_long_lens_penalty_views_register_from_their_arc():
    # every 25th frame of israel_league_wide from 150 to 375 (a low camera's
    # long lens on the penalty area: the lines across it nearly parallel in
    # the picture, those along it short), registered as stills: before the
    # penalty arc's initialiser 2 of these 10 were within 5 px of their
    # reference and the rest lost; now 8 are (1.1-3.6 px), and none is drawn
    # wrong
    import av

    from arstream.initialise import register_image

    frames = range(150, 376, 25)
    near, wrong = 0, []
    with av.open(str(SHARED / "clips" / "israel_league_wide.mp4")) as c:
        for k, frame in enumerate(c.decode(video=0)):
            if k > frames[-1]:
                break
            if k not in frames:
                continue
            img = frame.to_ndarray(format="bgr24")
            est = register_image(img)
            if est.camera is None:
                continue
            ref, pitch, _ = _reference("israel_league_wide", k)
            d = distance_1280(ref, est.camera, img.shape[1::-1], pitch, est.info["pitch"].model())
            near += d <= MAX_DISTANCE_1280
            if d > 20.0:
                wrong.append((k, d))
    assert near >= 7 and not wrong, (near, wrong)


def test_along_support_tells_a_camera_slid_along_the_lines_across_the_pitch():
    # the markings of a penalty-area view as the frame's paint; the camera
    # moved 4 m along the goal line keeps the lines across the pitch (goal
    # line, the areas' fronts) on their paint and lays the areas' sides off
    # theirs (the touchlines are not counted: a frame without them on paint
    # changes nothing)
    from arstream.support import along_support

    cam, _, _ = _arc_view(True)
    W, H = 1280, 720
    uv = np.floor(cam.project(marking_points()) + 0.5)
    q = uv[np.all(np.isfinite(uv), axis=1) & (uv[:, 0] >= 0) & (uv[:, 0] < W) & (uv[:, 1] >= 0) & (uv[:, 1] < H)].astype(int)
    paint = np.zeros((H, W), np.uint8)
    paint[q[:, 1], q[:, 0]] = 1
    paint = cv2.dilate(paint, np.ones((5, 5), np.uint8)) > 0
    slid = Camera(K=cam.K, R=cam.R, t=cam.t - cam.R @ np.array([0.0, 4.0, 0.0]))
    assert along_support(cam, paint) == 1.0
    assert along_support(slid, paint) < 0.3
    uv = np.floor(cam.project_pitch(np.concatenate([PITCH["touchline_near"].sample(0.1), PITCH["touchline_far"].sample(0.1)])) + 0.5)
    q = uv[np.all(np.isfinite(uv), axis=1) & (uv[:, 0] >= 3) & (uv[:, 0] < W - 3) & (uv[:, 1] >= 3) & (uv[:, 1] < H - 3)].astype(int)
    assert len(q) > 100  # (touchlines in view)
    bare = paint.copy()
    for dx in range(-3, 4):
        for dy in range(-3, 4):
            bare[q[:, 1] + dy, q[:, 0] + dx] = False
    assert along_support(cam, bare) == along_support(cam, paint)
    # (no markings along the pitch in view: undefined)
    assert along_support(cam, np.zeros((H, W), bool), PITCH, min_points=10**6) is None


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data/real-broadcast is absent")
def test_a_pillarboxed_long_lens_penalty_view_is_not_slid_along_its_lines():
    # israel_league_wide frame 275 with 12.5 % pillarbox bars: the penalty
    # arc's family member refined to the paint slid along the lines across
    # the pitch (24.7 px from the reference, line support 0.90) and was drawn;
    # the areas' sides off their paint (0.38 of the markings along the
    # pitch on paint) turn it away. A wrong camera is what this frame
    # showed, so it is held to the bar of a wrong one (20 px, as
    # bench/real_graphics.py counts them and test_real_clips bounds a run's
    # worst frame): with a third of the view under the bars the right
    # camera is 4.4-5.1 px from the reference (stops 86 and 87: one more
    # line, the step at a sunlit patch's edge, left out of the paint moved
    # it 0.7 px; unbarred 0.5 px), and the bench's pillarbox row counts it
    # within 5 px or not
    from arstream.initialise import register_image

    sys.path.insert(0, str(ROOT / "bench"))
    from real_graphics import barred

    img = _clip_frame(275, "israel_league_wide")
    est = register_image(barred(img, "pillar:0.125"))
    ref, pitch, _ = _reference("israel_league_wide", 275)
    assert est.camera is None or distance_1280(ref, est.camera, img.shape[1::-1], pitch, est.info["pitch"].model()) <= WRONG_1280, est.info


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data/real-broadcast is absent")
@pytest.mark.long
@pytest.mark.parametrize("item", ["artificial_turf_multisport 175", "ucl_2009"])
def test_a_still_under_a_stand_s_shadow_is_registered(item):
    # bench/real_graphics.py's shadow variant: the frame above a slanted line
    # lit by the sky alone. The turf clip's centre-circle view, its circle in
    # the shade, was registered 3214 px off: the detector's contrast, set from
    # the mostly sunlit grass, left the shaded circle out, and the paint's
    # lines along the shadow's edge and another sport's lines made a camera
    # at a line support of 0.75. Each line now asked its own grass's share
    # (Detector's ``shade``, on for a still), the circle is found: within
    # 5 px. The Champions League still (1.9 px unshaded) was lost: the
    # shadow's sunlit edge is a long straight line of the paint mask with
    # grass on both sides, and the paint's cameras were made from it; a line
    # that is nowhere brighter than both of its sides is no paint now
    # (paint_lines' test across it): within 5 px
    from arstream.initialise import register_image

    sys.path.insert(0, str(ROOT / "bench"))
    from real_graphics import PITCHES, items, shadow

    (name, img, aspect, ref, pitch), = items([item])
    given = PITCHES.get(name.split(" ")[0])
    est = register_image(shadow(img), pixel_aspect=aspect, pitch=None if given is None else PitchModel(*given))
    assert est.camera is not None, est.info
    assert distance_1280(ref, est.camera, img.shape[1::-1], pitch, est.info["pitch"].model()) <= MAX_DISTANCE_1280


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data/real-broadcast is absent")
@pytest.mark.long
@pytest.mark.parametrize("variant", ["bar-33", "480p-jpeg35"])
def test_a_degraded_long_lens_penalty_view_is_registered_at_its_own_size(variant):
    # israel_league_wide frame 175 with a bar over its lower third, and at
    # 480 rows in a JPEG of quality 35 (bench/real_graphics.py): only the
    # further splits of the paint's lines (MORE_SPLITS) hold the right
    # camera, at a line support of 0.91-0.97 (0.92-0.94 at 480 rows), under
    # PAINT_CHECK (0.95), where both were lost; they are held to
    # MORE_SPLITS_CHECK. Registered at 105 x 72 the frame gets a camera
    # 17-18 px from the reference at a line support near the right one's:
    # with no size given, the still keeps its camera at 105 x 68
    from arstream.initialise import register_image

    sys.path.insert(0, str(ROOT / "bench"))
    from real_graphics import VARIANTS, scaled

    ref, pitch, _ = _reference("israel_league_wide", 175)
    frame = _clip_frame(175, "israel_league_wide")
    img = VARIANTS[variant](frame)
    size = img.shape[1::-1]
    truth = scaled(ref, size[0] / frame.shape[1], size[1] / frame.shape[0])
    wide = register_image(img, pitch=PitchModel(105.0, 72.0))
    assert wide.camera is not None and distance_1280(truth, wide.camera, size, pitch, PitchModel(105.0, 72.0)) > 10.0
    at = register_image(img, pitch=PitchModel())
    assert at.camera is not None, at.info
    assert distance_1280(truth, at.camera, size, pitch) <= MAX_DISTANCE_1280
    est = register_image(img)
    assert est.camera is not None, est.info
    assert distance_1280(truth, est.camera, size, pitch, est.info["pitch"].model()) <= MAX_DISTANCE_1280


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data/real-broadcast is absent")
@pytest.mark.long
@pytest.mark.parametrize("k", [275, 400])
def test_a_soft_long_lens_penalty_view_is_judged_on_the_paint_it_was_found_on(k):
    # israel_league_wide frames 275 and 400 under a 1.2 px blur
    # (bench/real_graphics.py's soft-1.2: an upconverted or defocused
    # picture): the far, thin lines fall under the paint mask's 12 levels,
    # and only the second look at 8 (FAINT_CONTRAST) finds the right
    # camera, whose line support on the usual white paint is 0.90 and 0.80,
    # under PAINT_CHECK: both were lost. Judged on the paint it was found
    # on (faint_support: 0.98 and 0.96) it is kept
    from arstream.initialise import PAINT_CHECK, faint_support, register_image
    from arstream.support import backed_support, white_mask

    sys.path.insert(0, str(ROOT / "bench"))
    from real_graphics import soft

    ref, pitch, _ = _reference("israel_league_wide", k)
    img = soft(_clip_frame(k, "israel_league_wide"))
    usual, _ = backed_support(ref, white_mask(img), pitch)
    assert 0.7 <= usual < PAINT_CHECK <= faint_support(ref, img, pitch)
    est = register_image(img, pitch=PitchModel())
    assert est.camera is not None, est.info
    assert distance_1280(ref, est.camera, img.shape[1::-1], pitch) <= MAX_DISTANCE_1280


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data/real-broadcast is absent")
def test_a_longer_lens_view_is_not_drawn_from_a_camera_twice_as_far():
    # israel_league_wide frame 375's centre enlarged 1.33 times (a longer
    # lens): the paint initialiser's best camera was twice as far with twice
    # the focal length, the lines across the pitch on their paint (line
    # support 0.79, three quarters of its markings on paint) and 337 px from
    # the reference; the areas' sides off their paint (0.33) turn it away
    # (MIN_SIDES); the right camera keeps them all on it (1.0)
    from arstream.initialise import MIN_SIDES, register_image
    from arstream.support import along_support, bright_mask

    sys.path.insert(0, str(ROOT / "bench"))
    from real_graphics import _zoom_camera, zoomed

    img = _clip_frame(375, "israel_league_wide")
    ref, pitch, _ = _reference("israel_league_wide", 375)
    big = zoomed(img)
    truth = _zoom_camera(ref, img.shape[1], img.shape[0])
    assert along_support(truth, bright_mask(cv2.cvtColor(big, cv2.COLOR_BGR2GRAY)), pitch) >= 0.95 > MIN_SIDES
    est = register_image(big)
    assert est.camera is None or distance_1280(truth, est.camera, big.shape[1::-1], pitch, est.info["pitch"].model()) <= MAX_DISTANCE_1280, est.info


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data/real-broadcast is absent")
def test_a_penalty_view_flipped_left_to_right_registers_as_the_view_itself():
    # israel_league_wide frame 275 flipped left to right: the same kind of
    # view of the other end. Its penalty arc is so flat that the closed
    # form's start is far off at every focal length (7.9 px at best, against
    # max_rms 2), and unflipped one focal length happened to converge and
    # seed the others; flipped none did and the family was empty (the frame
    # lost). The nearest fit polished seeds it.
    from arstream.detect import detect
    from arstream.initialise import paint_view, register_image
    from arstream.solve import cameras_along_circle

    sys.path.insert(0, str(ROOT / "bench"))
    from real_graphics import mirror, mirrored

    img = _clip_frame(275, "israel_league_wide")
    ref, pitch, _ = _reference("israel_league_wide", 275)
    flipped = mirror(img)
    H, W = flipped.shape[:2]
    (pa, *_) = paint_view(flipped, detect(flipped)).arcs
    arc_m = PITCH["penalty_arc_left"]
    offset = float(PITCH["penalty_area_left_front"].start[0] - arc_m.center[0])
    args = (pa.arc.conic, pa.front.line, pa.arc.points, pa.front.points, np.array([(W - 1) / 2, (H - 1) / 2]))
    kw = dict(image_width=W, focals=W * np.geomspace(0.4, 10.0, 18), radius=arc_m.radius, offset=offset)
    assert cameras_along_circle(*args, **kw, polish=0) == []
    assert len(cameras_along_circle(*args, **kw)) == 18
    est = register_image(flipped)
    assert est.camera is not None, est.info
    assert distance_1280(mirrored(ref, W), est.camera, (W, H), pitch, est.info["pitch"].model()) <= MAX_DISTANCE_1280


def _paint_alone(img: np.ndarray, pitch, **kw):
    """(paint view, camera, support) of the still paint initialiser alone on a
    BGR frame (the principal point at its centre), ``kw`` to
    :func:`arstream.initialise.still_paint_camera`."""
    from arstream.detect import detect
    from arstream.initialise import paint_view, still_paint_camera

    H, W = img.shape[:2]
    det = detect(img)
    view = paint_view(img, det)
    rp, sp = still_paint_camera(view, (W, H), principal_point=np.array([(W - 1) / 2, (H - 1) / 2]), pitch=pitch, detections=det, **kw)
    return view, rp, sp


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data/real-broadcast is absent")
@pytest.mark.parametrize("frame", [175, 400])
def test_a_long_lens_penalty_view_tries_further_splits_of_its_lines(frame):
    # israel_league_wide frames 175 and 400 as stills: a lens of f ~ 4300 px
    # looking along the pitch at the goal. The lines across the pitch (goal
    # line, goal area, penalty area) are nearly parallel in the picture and a
    # running track's edges and the flat penalty arc's pieces join them, so
    # the two splits of the lines with the most line length pair the wrong
    # lines and nothing is found (both lost before); the further splits
    # (MORE_SPLITS) hold the right one
    from arstream.initialise import MORE_SPLITS_BELOW, register_image

    img = _clip_frame(frame, "israel_league_wide")
    ref, pitch, _ = _reference("israel_league_wide", frame)
    _, rp, sp = _paint_alone(img, pitch, more_splits=0)
    assert rp is None or sp < MORE_SPLITS_BELOW
    est = register_image(img)
    assert est.camera is not None, est.info
    assert distance_1280(ref, est.camera, img.shape[1::-1], pitch, est.info["pitch"].model()) <= MAX_DISTANCE_1280


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data/real-broadcast is absent")
def test_a_still_whose_paint_gives_nothing_looks_again_at_fainter_paint():
    # israel_league_wide frame 225 as a still: at the paint mask's usual
    # contrast (12 levels) only the penalty area's side is found along the
    # pitch, beside the lines across it, and no split of the lines (the
    # further ones too) gives a backed camera; at FAINT_CONTRAST the goal
    # area's sides are found as well
    from arstream.initialise import PAINT_CHECK, paint_verdict, register_image
    from arstream.support import backed_support

    img = _clip_frame(225, "israel_league_wide")
    ref, pitch, _ = _reference("israel_league_wide", 225)
    size = img.shape[1::-1]
    view, rp, _ = _paint_alone(img, pitch)
    assert rp is None or paint_verdict(rp.camera, *backed_support(rp.camera, view.bright, pitch), view, size, pitch) is not None
    est = register_image(img)
    assert est.camera is not None, est.info
    assert est.info["support"] >= PAINT_CHECK
    assert distance_1280(ref, est.camera, size, pitch, est.info["pitch"].model()) <= MAX_DISTANCE_1280


@pytest.mark.parametrize(
    "segments, shows",
    [
        ([((100, 500), (1200, 430))], "1 straight line, no centre circle, no penalty arc"),
        ([((100, 500), (1200, 430)), ((300, 700), (600, 200))], "2 straight lines, no centre circle, no penalty arc"),
    ],
    ids=["one line", "two lines"],
)
def test_a_lost_still_says_what_its_paint_shows(segments, shows, tmp_path, capsys):
    # grass with one or two painted lines: no camera can be made, and the
    # reason says what the initialisers had to work with (register prints it,
    # and its --json record carries it)
    from arstream.cli import main
    from arstream.initialise import register_image

    img = _flat((40, 120, 50))
    for p, q in segments:
        cv2.line(img, p, q, (230, 230, 230), 3, cv2.LINE_AA)
    est = register_image(img, pitch=PitchModel())
    assert est.status == "lost" and est.camera is None
    reason = f"no camera fits the detected markings (the paint shows {shows})"
    assert est.info["reason"] == reason
    png = tmp_path / "still.png"
    cv2.imwrite(str(png), img)
    assert main(["register", str(png), "--pitch", "105x68"]) == 1
    assert capsys.readouterr().out == f"lost: {reason}\n"
    assert main(["register", str(png), "--pitch", "105x68", "--json"]) == 1
    rec = json.loads(capsys.readouterr().out)
    assert rec["status"] == "lost" and rec["K"] is None and rec["reason"] == reason


def _flat(bgr) -> np.ndarray:
    """A 1280 x 720 picture of one colour (BGR) with a little noise."""
    rng = np.random.default_rng(0)
    return np.clip(np.full((720, 1280, 3), bgr, np.float64) + rng.normal(0.0, 3.0, (720, 1280, 3)), 0, 255).astype(np.uint8)


@pytest.mark.parametrize(
    "picture, reason",
    [
        (lambda: cv2.cvtColor(cv2.cvtColor(_flat((40, 120, 50)), cv2.COLOR_BGR2GRAY), cv2.COLOR_GRAY2BGR), "no pitch: the picture has no colour (the grass is found by its green)"),
        (lambda: _flat((160, 90, 40)), "no pitch: no grass in view"),
        (lambda: _flat((40, 120, 50)), "no pitch markings: 0 line pixels on the grass"),
    ],
    ids=["grayscale", "no grass", "bare grass"],
)
def test_a_still_with_no_pitch_says_why(picture, reason):
    from arstream.initialise import register_image

    est = register_image(picture(), pitch=PitchModel())
    assert est.status == "lost" and est.info["reason"] == reason


@pytest.mark.long
def test_a_still_beside_its_paint_under_a_shadow_is_nudged_onto_it(tmp_path, monkeypatch):
    # a realistic synthetic SD still (720 x 576 anamorphic, crf 30; a stand's
    # shadow across half the pitch, the centre circle in it), as the clip
    # stores it. The detector's lines give no camera; the paint initialiser's
    # best lays the circle and the far penalty area a few metres aside (26 px
    # at a line support of 0.77), and refining it does not leave that basin.
    # Starts turned and zoomed about it (initialise.nudged_camera) reach the
    # right camera (the true one scores 0.96 on the frame)
    import av

    import arstream.initialise as ini
    from arstream.initialise import register_image
    from arstream.synth import SynthClip, generate

    generate(tmp_path, preset="real-sd", seed=83, frames=151)
    clip = SynthClip("real-sd", seed=83, frames=151)
    with av.open(str(tmp_path / "clip.mp4")) as c:
        img = next(f for k, f in enumerate(c.decode(video=0)) if k == 150).to_ndarray(format="bgr24")
    aspect, size = float(clip.pixel_aspect), (img.shape[1], img.shape[0])
    truth = clip.camera(150)
    now = register_image(img, pixel_aspect=aspect, pitch=clip.pitch)
    assert now.status == "ok" and now.info["support"] > 0.9, now.info
    assert distance_1280(truth, now.camera, size, clip.pitch, pixel_aspect=aspect) < 5.0
    # without the nudge: registered, and drawn tens of pixels off
    monkeypatch.setattr(ini, "nudged_camera", lambda *a, **k: None)
    before = register_image(img, pixel_aspect=aspect, pitch=clip.pitch)
    assert before.status == "ok" and before.info["support"] < 0.8, before.info
    assert distance_1280(truth, before.camera, size, clip.pitch, pixel_aspect=aspect) > 20.0


# ---------------------------------------------------------------------------
# a still's camera must lay its markings on the detector's centre circle


def _circle_ellipse(cam: Camera, kind: str = "circle"):
    """The detector's ellipse of the centre circle as ``cam`` sees it (its
    points every degree, the ellipse fitted to them)."""
    from arstream.detect.results import DetectedEllipse
    from geometry.conics import conic_from_ellipse, fit_ellipse

    t = np.radians(np.arange(360.0))
    r = PITCH["centre_circle"].radius
    pts = cam.project_pitch(np.column_stack([r * np.cos(t), r * np.sin(t)]))
    fit = fit_ellipse(pts)
    return DetectedEllipse(ellipse=fit.ellipse, conic=conic_from_ellipse(fit.ellipse), points=pts, rms=fit.rms, coverage=1.0, score=1.0, kind=kind)


def test_circle_verdict_refuses_a_camera_whose_markings_miss_the_centre_circle():
    from arstream.initialise import CIRCLE_EXPLAINED, circle_verdict

    size = (1280, 720)
    cam = _broadcast_camera(pan=0.08, tilt=0.25, f=1500.0)
    ell = _circle_ellipse(cam)
    assert circle_verdict(cam, [ell], size, PITCH) is None
    # tilted by 1 degree (about 26 px here): 10 % of the circle's points near a
    # marking (panned by as much, 62 %: the ellipse, 446 x 102 px, is flat,
    # and its long sides slide along themselves)
    turned = _broadcast_camera(pan=0.08, tilt=0.25 + np.radians(1.0), f=1500.0)
    why = circle_verdict(turned, [ell], size, PITCH)
    assert why is not None and why.startswith("its markings miss the centre circle's ellipse"), why
    # moved by 4 px (under the reach of 0.005 W = 6.4 px): still explained
    nudged = _broadcast_camera(pan=0.08, tilt=0.25 + np.arctan(4.0 / 1500.0), f=1500.0)
    assert circle_verdict(nudged, [ell], size, PITCH) is None
    # not judged: no ellipse, or only an arc (a penalty arc's, or a chance curve)
    assert circle_verdict(turned, [], size, PITCH) is None
    assert circle_verdict(turned, [_circle_ellipse(cam, kind="arc")], size, PITCH) is None
    assert 0.0 < CIRCLE_EXPLAINED < 1.0


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data/real-broadcast is absent")
def test_a_downscaled_centre_circle_view_is_not_registered_across_its_circle():
    # israel_league_wide frame 0 (a long lens on the centre circle and the far
    # penalty area) at 960 x 540: the straight lines alone gave a camera 64 m
    # away that laid a penalty area over the centre circle (line support
    # 0.82), registered as "ok". Whatever it gives now must lay its markings on
    # the detector's circle and be near the camera of the frame at 1280 x 720.
    import av

    from arstream.initialise import circle_verdict, register_image

    with av.open(str(SHARED / "clips" / "israel_league_wide.mp4")) as c:
        img = next(iter(c.decode(video=0))).to_ndarray(format="bgr24")
    small = cv2.resize(img, (960, 540), interpolation=cv2.INTER_AREA)
    est = register_image(small)
    if est.camera is None:
        assert est.status == "lost" and est.info.get("reason"), est.info
        return
    full = register_image(img)
    assert full.camera is not None, full.info
    det = detect(small)
    assert circle_verdict(est.camera, det.ellipses, (960, 540), est.info["pitch"].model()) is None
    assert np.linalg.norm(est.camera.center - full.camera.center) < 5.0, (est.camera.center, full.camera.center)


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data/real-broadcast is absent")
@pytest.mark.long
def test_a_still_whose_default_size_missed_its_camera_is_made_again_from_the_scan():
    # israel_league_wide frame 400 at 960 x 540 (a 1280 x 720 broadcast
    # grabbed at qHD): at 105 x 68 the paint's hypotheses gave a camera laid
    # along the running track (line support 0.70, 299 px off its reference),
    # the scan's other sizes the right one (0.97-0.99), and the size rule kept
    # the default's camera. The default is now made again from the scan's
    # cameras: right, at the reference's 105 x 68.
    import av

    from arstream.initialise import register_image

    with av.open(str(SHARED / "clips" / "israel_league_wide.mp4")) as c:
        img = next(f for k, f in enumerate(c.decode(video=0)) if k == 400).to_ndarray(format="bgr24")
    small = cv2.resize(img, (960, 540), interpolation=cv2.INTER_AREA)
    est = register_image(small)
    assert est.status == "ok", est.info
    ref, pitch, _ = _reference("israel_league_wide", 400)
    # (the reference scaled to the frame: pixel u -> 0.75 u - 0.125)
    S = np.array([[0.75, 0.0, -0.125], [0.0, 0.75, -0.125], [0.0, 0.0, 1.0]])
    truth = Camera(K=S @ ref.K, R=ref.R, t=ref.t, dist=ref.dist)
    d = distance_1280(truth, est.camera, (960, 540), pitch, est.info["pitch"].model())
    assert d <= MAX_DISTANCE_1280, d


def test_graphics_mask_keeps_the_graphics_inside_the_picture():
    # a screen graphic inside the picture is cut out of the paint, grown by a
    # cell of its grid, and so is a caption whose bar starts at the frame's
    # left edge; a band the grass detector takes for a graphic along the
    # frame's top or bottom edge (the turf clip's benches at the bottom
    # right) is not
    from types import SimpleNamespace

    from arstream.initialise import graphics_mask

    small = np.zeros((90, 160), np.uint8)
    assert graphics_mask(SimpleNamespace(graphics_small=None), (640, 360)) is None
    small[86:90, 100:160] = 255  # on the last row and column
    assert graphics_mask(SimpleNamespace(graphics_small=small), (640, 360)) is None
    small[76:83, 7:40] = 255  # a caption
    cut = graphics_mask(SimpleNamespace(graphics_small=small), (640, 360))
    assert cut.shape == (360, 640)
    ys, xs = np.nonzero(cut)
    assert (xs.min(), xs.max(), ys.min(), ys.max()) == (6 * 4, 41 * 4 - 1, 75 * 4, 84 * 4 - 1)
    assert not cut[340:, 400:].any()
    small[2:6, 60:100] = 255  # a score box two rows below the top
    small[0:3, 120:150] = 255  # (on the first row: the stands' edge, say)
    small[40:46, 0:30] = 255  # a caption's bar from the left edge
    cut = graphics_mask(SimpleNamespace(graphics_small=small), (640, 360))
    assert cut[40 * 4 : 46 * 4, : 31 * 4].all() and cut[2 * 4 : 6 * 4, 60 * 4 : 100 * 4].all()
    assert not cut[:4, 484:596].any() and not cut[340:, 400:].any()
