"""Line support and the jitter proxy (arstream.support): exact thresholds on
constructed images, round trips on the committed synthetic clip with its exact
cameras, and analytic camera sequences for the jitter proxy."""

from pathlib import Path

import numpy as np
import pytest
from numpy.lib.stride_tricks import sliding_window_view

from arstream.sink import read_jsonl
from arstream.source import VideoSource
from arstream.support import MIN_POINTS, Support, bright_mask, jitter_proxy, line_support, marking_points, pixel_support
from geometry.camera import Camera, intrinsic_matrix, ptr_from_rotation, rotation_from_ptr
from cameras import grass_seen
from geometry.pitch import PitchModel

SAMPLE = Path(__file__).resolve().parents[1] / "samples" / "wide"


# --- bright pixels --------------------------------------------------------------
def _reference_bright(luma: np.ndarray, threshold_times_225: float) -> np.ndarray:
    """Bright pixels by brute force: 225 y - (15x15 sum, edges replicated) > 225 * threshold."""
    y = luma.astype(np.int64)
    s = sliding_window_view(np.pad(y, 7, mode="edge"), (15, 15)).sum(axis=(2, 3))
    return 225 * y - s > threshold_times_225


@pytest.mark.parametrize("seed", [0, 1])
def test_bright_pixels_match_brute_force(seed):
    # few grey levels: many pixels sit exactly on the threshold (225 y - sum == 2700)
    rng = np.random.default_rng(seed)
    luma = (rng.integers(0, 4, size=(70, 90)) * 6 + 100).astype(np.uint8)
    luma[10:60:7, :] = 140
    got = bright_mask(luma, reach=0)
    want = _reference_bright(luma, 225 * 12)
    assert want.any() and not want.all()
    np.testing.assert_array_equal(got, want)
    # video range: the threshold scaled by 219/255 (10.306 levels)
    np.testing.assert_array_equal(bright_mask(luma, reach=0, video_range=True), _reference_bright(luma, 225 * 12 * 219 / 255))


@pytest.mark.parametrize(
    "offset, video_range, bright",
    [
        # one pixel `offset` above a flat background exceeds its box mean by offset * 224/225
        (12, False, False),
        (13, False, True),  # 12.94 > 12
        (10, True, False),  # 9.96 < 10.31
        (11, True, True),  # 10.95 > 10.31
    ],
)
def test_threshold_of_a_single_pixel(offset, video_range, bright):
    luma = np.full((31, 31), 100, np.uint8)
    luma[15, 15] += offset
    assert bool(bright_mask(luma, reach=0, video_range=video_range)[15, 15]) is bright


@pytest.mark.parametrize("offset, bright", [(25, False), (26, True)])
def test_border_is_replicated(offset, bright):
    # a bright first column: replicated, it fills 8 of the box's 15 columns, so the
    # pixel exceeds its mean by offset * 7/15 (> 12 from 26 levels on)
    luma = np.full((30, 30), 100, np.uint8)
    luma[:, 0] += offset
    assert bool(bright_mask(luma, reach=0)[15, 0]) is bright


def test_dilation_reaches_two_pixels():
    luma = np.full((40, 40), 50, np.uint8)
    luma[20, 17] = 200
    m = bright_mask(luma)
    ys, xs = np.nonzero(m)
    assert (ys.min(), ys.max(), xs.min(), xs.max()) == (18, 22, 15, 19)
    assert m.sum() == 25 and m.dtype == bool
    assert not bright_mask(np.full((40, 40), 50, np.uint8)).any()


def test_within_reach_widens_the_bright_pixels_as_bright_mask_does():
    # the scan's two masks from one pass over the frame: the on-paint pixels
    # (reach 0) widened afterwards are bright_mask's own (reach 2)
    from arstream.support import within_reach

    luma = np.random.default_rng(4).integers(0, 256, (60, 80), dtype=np.uint8)
    on = bright_mask(luma, reach=0)
    np.testing.assert_array_equal(within_reach(on), bright_mask(luma))
    np.testing.assert_array_equal(within_reach(on, 1), bright_mask(luma, reach=1))
    assert within_reach(on, 0) is on and on.sum() < bright_mask(luma).sum()


@pytest.mark.parametrize(
    "luma, kwargs, message",
    [
        (np.zeros((10, 10), np.float32), {}, "luma must be a 2-D uint8 array (H, W), got float32 array of shape (10, 10)"),
        (np.zeros((10, 10, 3), np.uint8), {}, "luma must be a 2-D uint8 array (H, W), got uint8 array of shape (10, 10, 3)"),
        ([[1, 2]], {}, "luma must be a 2-D uint8 array (H, W), got list"),
        (np.zeros((10, 10), np.uint8), {"box": 14}, "box must be an odd integer >= 3, got 14"),
        (np.zeros((10, 10), np.uint8), {"reach": -1}, "reach must be a non-negative integer, got -1"),
        (np.zeros((10, 10), np.uint8), {"threshold": float("nan")}, "threshold must be finite and >= 0, got nan"),
    ],
)
def test_bright_mask_rejects(luma, kwargs, message):
    with pytest.raises(ValueError) as e:
        bright_mask(luma, **kwargs)
    assert str(e.value) == message


# --- marking points ---------------------------------------------------------------
def test_marking_points_are_the_markings_without_spots():
    pitch = PitchModel(100.0, 64.0)
    P = marking_points(pitch)
    assert P is marking_points(PitchModel(100.0, 64.0))  # cached per size
    assert not P.flags.writeable and P.shape[1] == 3 and np.all(P[:, 2] == 0)
    assert len(P) == sum(len(m.sample(0.25)) for m in (*pitch.segments, *pitch.arcs))
    for name in ("penalty_mark_left", "penalty_mark_right"):
        assert np.min(np.hypot(*(P[:, :2] - pitch.spots[name]).T)) > 5.0
    # consecutive samples of a marking at most 0.25 m apart
    seg = pitch["touchline_near"].sample(0.25)
    assert np.max(np.hypot(*np.diff(seg, axis=0).T)) <= 0.25 + 1e-12
    assert len(marking_points(pitch, 0.5)) < len(P)
    with pytest.raises(ValueError, match="spacing must be positive, got 0"):
        marking_points(pitch, 0)


# --- line support on constructed masks --------------------------------------------
def test_pixel_support_counts_points_inside():
    mask = np.zeros((10, 20), bool)
    mask[:, :10] = True
    px = np.array([[0.0, 0.0], [9.4, 9.4], [9.6, 5.0], [19.49, 0.0], [19.5, 0.0], [-0.51, 3.0], [np.nan, 1.0], [5.0, -0.4]])
    s = pixel_support(px, mask, min_points=1)
    # inside: (0,0), (9.4,9.4), (9.6->10,5), (19.49->19,0), (5,-0.4->0); supported: the first, second and last
    assert s == Support(share=3 / 5, n_inside=5, n_supported=3)
    assert pixel_support(px, mask).share is None  # fewer than MIN_POINTS inside
    assert pixel_support(np.zeros((0, 2)), mask, min_points=0) == Support(None, 0, 0)
    with pytest.raises(ValueError, match=r"pixels must have shape \(N, 2\), got \(3,\)"):
        pixel_support(np.zeros(3), mask)


# --- line support on the committed synthetic clip ----------------------------------
@pytest.fixture(scope="module")
def sample_frames():
    """Every 30th frame of samples/wide/clip.mp4 with its exact camera and bright mask."""
    truth = read_jsonl(SAMPLE / "truth.jsonl")
    out = []
    with VideoSource(SAMPLE / "clip.mp4") as src:
        for f in src:
            if f.index % 30 == 0:
                out.append((Camera.from_dict(truth[f.index]), bright_mask(f.gray, video_range=True), (f.width, f.height)))
    return out


def _shifted(cam: Camera, d) -> Camera:
    """The camera moved by d (3,) metres in the pitch frame."""
    return Camera(cam.K, cam.R, cam.t - cam.R @ np.asarray(d, float))


def _turned(cam: Camera, dpan: float, dtilt: float) -> Camera:
    """The camera panned and tilted by the given degrees about its own centre."""
    pan, tilt, roll = ptr_from_rotation(cam.R)
    R = rotation_from_ptr(pan + np.radians(dpan), tilt + np.radians(dtilt), roll)
    return Camera(cam.K, R, -R @ cam.center)


def test_true_camera_is_supported(sample_frames):
    # over all 250 frames of the sample the exact camera scores 0.982-1.000 (median 0.997)
    shares = [line_support(cam, m).share for cam, m, _ in sample_frames]
    assert len(shares) == 9 and min(shares) >= 0.95


@pytest.mark.parametrize(
    "wrong",
    [
        lambda c: _shifted(c, (2.0, 2.0, 0.0)),  # 0.07-0.10 on the whole sample
        lambda c: _turned(c, 2.0, 1.0),  # 0.26-0.39
        lambda c: _turned(c, 2.0, 0.0),  # 0.13-0.37
    ],
    ids=["moved 2 m in X and Y", "pan 2 deg, tilt 1 deg", "pan 2 deg"],
)
def test_wrong_camera_is_not_supported(sample_frames, wrong):
    # a move or turn along one axis only can keep the markings parallel to it on
    # their paint (a tilt of 1 deg scores up to 0.61 on the sample): these move every marking
    shares = [line_support(wrong(cam), m).share for cam, m, _ in sample_frames]
    assert max(shares) < 0.5


def test_support_undefined_when_markings_are_out_of_view(sample_frames):
    cam, m, _ = sample_frames[0]
    sky = _turned(cam, 0.0, -40.0)  # looking above the stadium
    s = line_support(sky, m)
    assert s.share is None and s.n_inside < MIN_POINTS
    # a pitch of another size is another set of points
    s100 = line_support(cam, m, marking_points(PitchModel(100.0, 64.0)))
    assert s100.defined and s100.n_inside != line_support(cam, m).n_inside


# --- two cameras' markings on the paint, point for point ---------------------------
def test_paint_dispute_of_the_true_camera_and_a_moved_one(sample_frames):
    from arstream.support import PaintDispute, paint_dispute

    for cam, m, _ in sample_frames:
        X = marking_points()
        wrong = _shifted(cam, (1.0, 1.0, 0.0))
        d = paint_dispute(cam, X, wrong, X, m)
        # the true camera lays most of the disputed points on paint, the moved one few
        assert d.first >= 5 * max(d.second, 1) and d.first + d.second <= d.disputed <= d.in_view, d
        assert paint_dispute(wrong, X, cam, X, m) == PaintDispute(d.second, d.first, d.disputed, d.in_view)
        same = paint_dispute(cam, X, cam, X, m)
        assert same.first == same.second == same.disputed == 0 and same.in_view == line_support(cam, m).n_inside


def test_paint_dispute_counts_markings_out_of_one_view():
    # a 105 x 72 m pitch painted as the main camera sees it; the same camera
    # given a 105 x 68 pitch lays the far touchline 4 m short, inside the
    # picture, off the paint: the disputed points are the far half's, and
    # all but a few (where the lines cross) are the 72 m pitch's
    from arstream.pitch_size import corresponding_samples
    from arstream.solve import ModelSamples
    from arstream.support import paint_dispute
    from cameras import looking_at

    size = (1280, 720)
    cam = looking_at((0.0, -60.0, 20.0), (0.0, 0.0, 0.0), 1400.0, size)
    true, wrong = PitchModel(105.0, 72.0), PitchModel(105.0, 68.0)
    mask = bright_mask(_painted(cam, size, pitch=true)[..., 1])
    a, b = (np.column_stack([p, np.zeros(len(p))]) for p in corresponding_samples(true, wrong))
    d = paint_dispute(cam, a, cam, b, mask)
    assert d.first >= 20 * max(d.second, 1) and d.disputed >= 0.3 * d.in_view, d
    # the centre circle is the same on both pitches, in view at the same place: not disputed
    samples = ModelSamples.from_pitch(true, 0.25)
    circle = samples.marking == samples.names.index("centre_circle")
    on_circle = paint_dispute(cam, a[circle], cam, b[circle], mask)
    assert on_circle.disputed == 0 and on_circle.in_view == circle.sum() > 100, on_circle


def test_paint_dispute_counts_a_marking_drawn_on_bare_grass():
    # a 105 x 72 m pitch painted as a main camera sees it, the near touchline
    # just below the picture; the same camera given a 105 x 68 pitch draws
    # its near touchline across the grass at the bottom, where there is none,
    # and the 72 m pitch's is outside the picture: those points count against
    # the 68 m pitch (second_missing), not for either on paint
    from arstream.pitch_size import corresponding_samples
    from arstream.solve import ModelSamples
    from arstream.support import MISSING_SHARE, paint_dispute
    from cameras import looking_at

    size = (1280, 720)
    cam = looking_at((0.0, -70.0, 25.0), (0.0, -4.0, 0.0), 1400.0, size)
    true, wrong = PitchModel(105.0, 72.0), PitchModel(105.0, 68.0)
    frame = _painted(cam, size, pitch=true)
    mask = bright_mask(frame[..., 1])
    a, b = (np.column_stack([p, np.zeros(len(p))]) for p in corresponding_samples(true, wrong))
    ids = ModelSamples.from_pitch(true, 0.25).marking
    near = ids == ModelSamples.from_pitch(true, 0.25).names.index("touchline_near")
    pb = cam.project(b[near])
    drawn = (pb[:, 0] >= 0) & (pb[:, 0] < 1279.5) & (pb[:, 1] >= 0) & (pb[:, 1] < 719.5)
    assert drawn.sum() > 100 and not ((pa := cam.project(a[near]))[:, 1] < 719.5).any()  # (in view at 68 m only)
    ground = np.ones(size[::-1], bool)
    d = paint_dispute(cam, a, cam, b, mask, ground=ground, markings=ids)
    assert d.first_missing == 0 and drawn.sum() - 6 <= d.second_missing <= drawn.sum(), d  # (but where it crosses the halfway line's paint)
    assert (d.for_first, d.for_second) == (d.first + d.second_missing, d.second)
    plain = paint_dispute(cam, a, cam, b, mask)
    assert plain.first_missing == plain.second_missing == 0 and (plain.first, plain.second, plain.disputed, plain.in_view) == (d.first, d.second, d.disputed, d.in_view)
    assert paint_dispute(cam, b, cam, a, mask, ground=ground, markings=ids) == d.swapped()
    # not bare grass (a caption over the bottom of the picture): no evidence
    covered = ground.copy()
    covered[int(pb[drawn, 1].min()) - 3 :] = False
    assert paint_dispute(cam, a, cam, b, mask, ground=covered, markings=ids).second_missing == 0
    # a marking with paint along a stretch of it is faint, not missing
    faint = mask.copy()
    run = np.flatnonzero(drawn)[: int(np.ceil(2 * MISSING_SHARE * drawn.sum()))]
    for x, y in np.round(pb[run]).astype(int):
        faint[max(y - 1, 0) : y + 2, max(x - 1, 0) : x + 2] = True
    assert paint_dispute(cam, a, cam, b, faint, ground=ground, markings=ids).second_missing == 0
    # in view of both only: nothing is in view of one camera alone
    both = paint_dispute(cam, a, cam, b, mask, in_both=True, ground=ground, markings=ids)
    assert both.first_missing == both.second_missing == 0
    with pytest.raises(ValueError, match="one marking per point"):
        paint_dispute(cam, a, cam, b, mask, ground=ground, markings=ids[:-1])


def test_paint_dispute_in_view_of_both_leaves_out_samples_slid_into_one_view():
    # a penalty view of a 105 x 68 m pitch; the camera a 100 x 68 m pitch
    # would be given lays its penalty area on the same paint (the camera
    # moved 2.5 m along the length). The two pitches' samples are the same
    # fractions along each line, so the near touchline's slide 0-2.5 m
    # towards the goal: at the image's edge some come into the second
    # camera's view only, on the painted line, and count for it. In view of
    # both, they are left out, and the wrong size wins nothing
    from arstream.pitch_size import corresponding_samples
    from arstream.support import paint_dispute
    from cameras import looking_at

    size = (1280, 720)
    cam = looking_at((20.0, -45.0, 15.0), (40.0, 0.0, 0.0), 1600.0, size)
    short = _shifted(cam, (-2.5, 0.0, 0.0))
    true = PitchModel(105.0, 68.0)
    mask = bright_mask(_painted(cam, size, pitch=true)[..., 1])
    a, b = (np.column_stack([p, np.zeros(len(p))]) for p in corresponding_samples(true, PitchModel(100.0, 68.0)))
    either = paint_dispute(cam, a, short, b, mask)
    both = paint_dispute(cam, a, short, b, mask, in_both=True)
    assert either.second > either.first, either
    assert both.second <= both.first and both.in_view < either.in_view and both.first == either.first, both
    assert both.in_view == np.count_nonzero(_inside(cam.project(a), size) & _inside(short.project(b), size))


def _inside(px: np.ndarray, size) -> np.ndarray:
    """Which projected points' nearest pixels lie in an image of ``size`` (W, H)."""
    ix = np.floor(px + 0.5)
    return (ix[:, 0] >= 0) & (ix[:, 0] < size[0]) & (ix[:, 1] >= 0) & (ix[:, 1] < size[1])


def test_paint_dispute_wants_the_same_samples():
    from arstream.support import paint_dispute

    cam = _cam()
    with pytest.raises(ValueError, match="the same samples on both pitches: 3 and 2 points"):
        paint_dispute(cam, np.zeros((3, 3)), cam, np.zeros((2, 3)), np.zeros((720, 1280), bool))


# --- jitter proxy ------------------------------------------------------------------
SIZE = (1280, 720)
CENTRE = np.array([-2.0, -60.0, 20.0])


def _cam(pan=0.0, tilt=0.3, f=1500.0, cx=639.5, cy=359.5, centre=CENTRE) -> Camera:
    R = rotation_from_ptr(pan, tilt, 0.0)
    return Camera(intrinsic_matrix(f, cx, cy), R, -R @ np.asarray(centre, float))


def test_jitter_of_a_still_camera_is_zero():
    j = jitter_proxy([_cam(0.1)] * 6, SIZE)
    assert j.rms == 0.0 and j.n_triples == 4 and j.second_differences.shape == (4, 2)


def test_jitter_of_a_sliding_principal_point():
    # the image moves by cx(i) = 3 + 0.8 i^2 / 2, cy(i) = -0.3 i^2 / 2: every point's
    # second difference is (0.8, -0.3) px, whichever point is followed
    cams = [_cam(cx=639.5 + 3 + 0.4 * i * i, cy=359.5 - 0.15 * i * i) for i in range(8)]
    j = jitter_proxy(cams, SIZE)
    assert j.n_triples == 6
    np.testing.assert_allclose(j.second_differences, np.tile([0.8, -0.3], (6, 1)), atol=1e-9)
    assert j.rms == pytest.approx(np.hypot(0.8, 0.3), abs=1e-9)
    assert j.scaled(0.5, 2.0) == pytest.approx(np.hypot(0.4, 0.6), abs=1e-9)


def test_jitter_of_a_camera_accelerating_sideways():
    # a camera (no roll) moving along its own x axis with acceleration a (metres a
    # frame^2): the ground point under the centre is at depth D = h / sin(tilt) in
    # every frame, so its image moves with second difference f a / D along x only
    tilt, f, a = 0.3, 1500.0, 0.02
    R = rotation_from_ptr(0.2, tilt, 0.0)
    axis = R[0]  # camera x in the world: horizontal
    cams = [Camera(intrinsic_matrix(f, 639.5, 359.5), R, -R @ (CENTRE + 0.5 * a * i * i * axis)) for i in range(7)]
    j = jitter_proxy(cams, SIZE)
    D = CENTRE[2] / np.sin(tilt)
    np.testing.assert_allclose(j.second_differences, np.tile([-f * a / D, 0.0], (5, 1)), atol=1e-9)
    assert j.rms == pytest.approx(f * a / D, rel=1e-9)


def test_jitter_skips_gaps_and_the_sky():
    c = _cam()
    assert jitter_proxy([c, None, c, c, None, c, c], SIZE).n_triples == 0
    j = jitter_proxy([c, c, None, c, c, c], SIZE)
    assert j.n_triples == 1 and j.rms == 0.0
    sky = _cam(tilt=-0.2)  # the image centre sees no ground
    j = jitter_proxy([sky] * 5, SIZE)
    assert j.rms is None and j.n_triples == 0 and j.scaled(1, 1) is None
    assert jitter_proxy([], SIZE).rms is None
    with pytest.raises(ValueError, match=r"size must be positive \(width, height\), got \(0, 720\)"):
        jitter_proxy([c] * 3, (0, 720))



# --- the run-time judgement: support and the spread of markings on paint -------------
def test_backed_support_of_the_true_camera_at_either_spacing(sample_frames):
    from arstream.support import backed_support

    for cam, m, _ in sample_frames:
        full = line_support(cam, m).share
        for spacing in (0.25, 0.5):
            share, spread = backed_support(cam, m, spacing=spacing)
            # every other point of the same markings: the share moves by at most the
            # weight of the points left out (a few points of ~1000 near an edge)
            assert abs(share - full) < 0.02 and spread == 1.0


def test_one_marking_on_paint_is_not_a_camera(sample_frames):
    # paint only where the true camera puts one long marking (the far touchline):
    # the points on it may be many, but one marking of those in view is on paint
    from arstream.support import _marking_ids, backed_support, marking_spread

    cam, m, (W, H) = sample_frames[0]
    pitch = PitchModel()
    X = marking_points(pitch)
    ids = _marking_ids(pitch.length, pitch.width, pitch.line_width, 0.25)
    far = [k for k, s in enumerate(pitch.segments) if s.name == "touchline_far"][0]
    px = np.floor(cam.project(X[ids == far]) + 0.5).astype(int)
    ok = (px[:, 0] >= 0) & (px[:, 0] < W) & (px[:, 1] >= 0) & (px[:, 1] < H)
    only = np.zeros((H, W), bool)
    only[px[ok, 1], px[ok, 0]] = True
    seen, backed = marking_spread(cam, only, pitch)
    assert seen >= 3 and backed == 1
    share, spread = backed_support(cam, only, pitch)
    assert spread == 1 / seen


# --- markings on the grass -------------------------------------------------------
def test_grass_region_reaches_a_share_of_the_width():
    from arstream.support import GRASS_REACH, grass_region

    g = np.zeros((90, 160), np.uint8)
    g[45, 80] = 255
    region = grass_region(g)
    r = round(GRASS_REACH * 160)  # 2 px
    assert region.dtype == bool and region[45, 80 + r] and region[45 - r, 80] and not region[45, 80 + r + 1] and not region[45 + r + 1, 80]
    assert grass_region(np.zeros((9, 16), bool)).sum() == 0  # (at least 1 px of reach, none without grass)
    with pytest.raises(ValueError, match=r"grass must be \(h, w\)"):
        grass_region(np.zeros((9, 16, 3), np.uint8))


def test_markings_of_the_true_camera_lie_on_the_grass(sample_frames):
    from arstream.support import grass_region, on_grass

    for cam, _, size in sample_frames:
        region = grass_region(grass_seen(cam, size))
        # every marking point in view is on the pitch (the touchlines 3 m inside
        # the grass, whose small copy is 8 frame pixels a pixel)
        assert on_grass(cam, region, size) == 1.0
        # the frame's size or any other with its aspect: the points are scaled to the mask
        assert on_grass(cam, grass_region(grass_seen(cam, size, small=(320, 180))), size) == 1.0


def test_on_grass_undefined_with_few_markings_in_view(sample_frames):
    from arstream.support import grass_region, on_grass

    cam, _, size = sample_frames[0]
    assert on_grass(_turned(cam, 0.0, -40.0), grass_region(np.full((90, 160), 255, np.uint8)), size) is None


# --- markings on painted lines, not along bright steps ------------------------------
def _painted(cam: Camera, size, *, step: bool = False, pitch: PitchModel | None = None) -> np.ndarray:
    """A frame of ``size`` seen by ``cam``: grass (BGR 60, 140, 70) with every
    marking painted white at its true width (the pitch-plane polygon of each
    sample's stripe), or with ``step`` no paint but the pitch beyond the far
    touchline's centreline filled with sand (170, 190, 200): a bright step
    where the far touchline is."""
    import cv2

    p = pitch or PitchModel()
    W, H = size
    v, u = np.mgrid[0:H, 0:W]
    XY = cam.backproject_to_pitch(np.column_stack([u.ravel(), v.ravel()]).astype(float)).reshape(H, W, 2)
    img = np.empty((H, W, 3), np.uint8)
    img[:] = (60, 140, 70)
    with np.errstate(invalid="ignore"):
        if step:
            img[XY[..., 1] > p.width / 2] = (170, 190, 200)
            return img
        X = marking_points(p, 0.05)[:, :2]
        from scipy.spatial import cKDTree

        d, _ = cKDTree(X).query(np.nan_to_num(XY.reshape(-1, 2), nan=1e6), distance_upper_bound=1.0)
    img[(d <= p.line_width / 2).reshape(H, W)] = (235, 240, 240)
    return cv2.GaussianBlur(img, (3, 3), 0)


@pytest.mark.parametrize(
    "centre, target, f",
    [
        ((0.0, -60.0, 20.0), (0.0, 0.0, 0.0), 1400.0),  # the main camera: far lines 2 px wide
        # a penalty area's corner from 17 m: lines 8 px wide (read at 4.5 px
        # from the crest whatever the width, 0.44)
        ((-30.0, -35.0, 10.0), (-37.0, -20.0, 0.0), 2500.0),
    ],
    ids=["wide", "close"],
)
def test_the_true_cameras_markings_lie_on_painted_lines(centre, target, f):
    from arstream.support import on_lines, white_mask
    from cameras import looking_at

    size = (1280, 720)
    cam = looking_at(centre, target, f, size)
    img = _painted(cam, size)
    assert on_lines(cam, img, white_mask(img)) >= 0.95


def test_markings_along_a_bright_step_are_not_on_lines():
    # the far touchline on the edge of a bright sand track: line support backs
    # it (the bright side is within 2 px), the profile across does not
    from arstream.support import line_support, on_lines, white_mask
    from cameras import looking_at

    size = (1280, 720)
    cam = looking_at((0.0, -60.0, 20.0), (0.0, 20.0, 0.0), 2400.0, size)
    img = _painted(cam, size, step=True)
    bright = white_mask(img)
    assert line_support(cam, bright).n_supported >= 100
    assert on_lines(cam, img, bright) < 0.1


@pytest.mark.parametrize(
    "image, bright, message",
    [
        (np.zeros((72, 128), np.uint8), np.zeros((72, 128), bool), r"image must be a BGR uint8 array \(H, W, 3\), got uint8 \(72, 128\)"),
        (np.zeros((72, 128, 3), np.float32), np.zeros((72, 128), bool), r"image must be a BGR uint8 array \(H, W, 3\), got float32"),
        (np.zeros((72, 128, 3), np.uint8), np.zeros((36, 64), bool), r"bright must be the frame's size \(72, 128\), got \(36, 64\)"),
    ],
)
def test_on_lines_bad_input(image, bright, message):
    from arstream.support import on_lines
    from cameras import looking_at

    with pytest.raises(ValueError, match=message):
        on_lines(looking_at((0.0, -60.0, 20.0), (0.0, 0.0, 0.0), 140.0, (128, 72)), image, bright)


def test_on_lines_undefined_without_markings_on_paint():
    from arstream.support import on_lines
    from cameras import looking_at

    cam = looking_at((0.0, -60.0, 20.0), (0.0, 0.0, 0.0), 1400.0)
    img = np.full((720, 1280, 3), 100, np.uint8)
    assert on_lines(cam, img, np.zeros((720, 1280), bool)) is None
