"""Round trips and degenerate inputs for geometry.camera and geometry.pitch."""

import numpy as np
import pytest

from geometry import camera as gcam
from geometry import pitch as gp
from geometry.conics import ellipse_distance, ellipse_from_conic
from geometry.homography import transfer_conic, transfer_points


def broadcast_camera(rng, pp=(640.0, 360.0)):
    """A random main-camera view: behind the near touchline, looking at the pitch."""
    center = np.array([rng.uniform(-20, 20), rng.uniform(-34 - 45, -34 - 15), rng.uniform(10, 25)])
    ptz = gcam.PTZ(pan=rng.uniform(-0.8, 0.8), tilt=rng.uniform(0.15, 0.45), roll=rng.uniform(-0.02, 0.02), f=rng.uniform(1280, 4500))
    return gcam.camera_from_ptz(center, ptz, pp)



def test_pan_tilt_roll_rotation_is_the_documented_product():
    # rotation_from_ptr is Rz(roll) Rx(tilt) R0 Rz(pan), R0 looking along +Y with
    # image y down; ptr_from_rotation (on plain floats) inverts it over the whole
    # range (tilt inside (-pi/2, pi/2), where pan and roll are defined)
    def Rz(a):
        return np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])

    def Rx(a):
        return np.array([[1.0, 0.0, 0.0], [0.0, np.cos(a), -np.sin(a)], [0.0, np.sin(a), np.cos(a)]])

    R0 = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    rng = np.random.default_rng(8)
    for pan, tilt, roll in rng.uniform((-np.pi, -1.5, -np.pi), (np.pi, 1.5, np.pi), (2000, 3)):
        R = gcam.rotation_from_ptr(pan, tilt, roll)
        np.testing.assert_allclose(R, Rz(roll) @ Rx(tilt) @ R0 @ Rz(pan), rtol=0, atol=4e-16)
        np.testing.assert_allclose(gcam.ptr_from_rotation(R), (pan, tilt, roll), rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    "R, message",
    [
        (2.0 * np.eye(3), "rotation"),
        (np.diag([1.0, 1.0, -1.0]), "rotation"),  # a reflection
        (np.eye(3)[[1, 0, 2]], "rotation"),  # rows swapped: det -1
        (np.eye(3) + 1e-5, "rotation"),
        (np.full((3, 3), np.nan), "finite 3x3"),
        (np.eye(2), "finite 3x3"),
    ],
)
def test_rotations_are_checked(R, message):
    with pytest.raises(ValueError, match=message):
        gcam.ptr_from_rotation(R)
    gcam.ptr_from_rotation(np.eye(3)[[0, 2, 1]] * [1, 1, -1] + 1e-7)  # within 1e-6 of a rotation: taken

@pytest.mark.parametrize("seed", range(12))
def test_ptz_round_trip(seed):
    rng = np.random.default_rng(seed)
    cam = broadcast_camera(rng)
    c, ptz = gcam.ptz_from_camera(cam)
    cam2 = gcam.camera_from_ptz(c, ptz, cam.principal_point)
    assert np.allclose(cam2.R, cam.R, atol=1e-12) and np.allclose(cam2.t, cam.t, atol=1e-9)
    # the optical axis points as documented
    axis = cam.R[2]
    want = [np.sin(ptz.pan) * np.cos(ptz.tilt), np.cos(ptz.pan) * np.cos(ptz.tilt), -np.sin(ptz.tilt)]
    assert np.allclose(axis, want)


@pytest.mark.parametrize("seed", range(12))
def test_P_decomposition_round_trip(seed):
    rng = np.random.default_rng(seed)
    cam = broadcast_camera(rng, pp=tuple(rng.uniform(600, 700, 2)))
    K = cam.K.copy()
    K[0, 1] = rng.uniform(-2, 2)  # skew survives too
    K[1, 1] *= rng.uniform(0.9, 1.1)
    P = gcam.P_from_KRt(K, cam.R, cam.t) * rng.uniform(-5, 5)
    K2, R2, t2 = gcam.KRt_from_P(P)
    assert np.allclose(K2, K, rtol=1e-9) and np.allclose(R2, cam.R, atol=1e-9) and np.allclose(t2, cam.t, atol=1e-7)


@pytest.mark.parametrize("seed", range(12))
def test_homography_decomposition_round_trip(seed):
    rng = np.random.default_rng(seed)
    pp = tuple(rng.uniform(630, 650, 2))
    cam = broadcast_camera(rng, pp)
    H = cam.H_img_from_pitch * rng.uniform(0.1, 10)
    cam2 = gcam.camera_from_homography(H, pp)
    assert abs(cam2.focal / cam.focal - 1) < 1e-8
    assert np.allclose(cam2.R, cam.R, atol=1e-8)
    assert np.allclose(cam2.center, cam.center, atol=1e-6)


def test_batched_decomposition_matches_one_by_one():
    rng = np.random.default_rng(5)
    pp = (640.0, 360.0)
    cams = [broadcast_camera(rng, pp) for _ in range(6)]
    H = [c.H_img_from_pitch * rng.uniform(0.1, 10) for c in cams]
    bad = [
        (np.diag([1.0, 1.0, 0.0]), "singular"),
        (np.array([[1000.0, 0, 640], [0, 1000.0, 360], [0, 0, 1.0]]), "focal"),
        (cams[0].H_img_from_pitch @ np.diag([1.0, -1.0, 1.0]), "below the pitch"),
    ]
    poses = gcam.decompose_homographies(np.array(H + [b for b, _ in bad]), pp)
    assert poses.ok.tolist() == [True] * 6 + [False] * 3
    for k, c in enumerate(cams):
        assert abs(poses.focal[k] / c.focal - 1) < 1e-8
        assert np.allclose(poses.R[k], c.R, atol=1e-8) and np.allclose(poses.centre[k], c.center, atol=1e-6)
        one = gcam.camera_from_homography(H[k], pp)
        assert np.allclose(one.R, poses.R[k], atol=1e-12) and np.allclose(one.t, poses.t[k], atol=1e-9)
    for k, (Hb, message) in enumerate(bad):
        with pytest.raises(ValueError, match=message):
            gcam.camera_from_homography(Hb, pp)


@pytest.mark.parametrize("seed", range(8))
def test_project_backproject_round_trip(seed):
    rng = np.random.default_rng(seed)
    cam = broadcast_camera(rng)
    cam = gcam.Camera(K=cam.K, R=cam.R, t=cam.t, dist=(rng.uniform(-0.1, 0.1),))
    xy = cam.backproject_to_pitch(np.column_stack([rng.uniform(0, 1280, 50), rng.uniform(300, 720, 50)]))
    xy = xy[np.all(np.isfinite(xy), axis=1)]
    px = cam.project_pitch(xy)
    assert np.allclose(cam.backproject_to_pitch(px), xy, atol=1e-6)
    # without distortion, projection equals the homography
    cam0 = gcam.Camera(K=cam.K, R=cam.R, t=cam.t)
    assert np.allclose(cam0.project_pitch(xy), transfer_points(cam0.H_img_from_pitch, xy), atol=1e-6)
    # the horizon: pitch points are on its positive side; rays above it miss the pitch
    h = cam0.horizon
    assert np.all(np.column_stack([cam0.project_pitch(xy), np.ones(len(xy))]) @ h > 0)
    above = np.array([[640.0, (-h[2] - h[0] * 640.0) / h[1] - 5.0]])
    assert np.all(np.isnan(cam0.backproject_to_pitch(above)))


def test_iac_round_trip():
    K = gcam.intrinsic_matrix(1500.0, 650.0, 350.0, aspect=1.02, skew=0.5)
    assert np.allclose(gcam.K_from_iac(gcam.iac(K)), K)
    # the IAC contains no real point: x^T omega x > 0 for every real x
    x = np.random.default_rng(0).normal(size=(20, 3))
    w = gcam.iac(K)
    assert np.all(np.einsum("ij,jk,ik->i", x, w, x) > 0)


def test_distortion_inverse():
    xn = np.random.default_rng(1).uniform(-0.5, 0.5, (100, 2))
    for dist in [(0.05,), (-0.08, 0.01)]:
        assert np.allclose(gcam.undistort_normalized(gcam.distort_normalized(xn, dist), dist), xn, atol=1e-10)


def test_camera_dict_round_trip():
    cam = broadcast_camera(np.random.default_rng(2))
    d = cam.to_dict()
    cam2 = gcam.Camera.from_dict(d)
    assert np.allclose(cam2.P, cam.P)
    H = np.array(d["H"])
    assert np.allclose(H / H[2, 2], cam.H_img_from_pitch / cam.H_img_from_pitch[2, 2])


# ---- pitch model ------------------------------------------------------------
def test_pitch_dimensions_follow_law_1():
    p = gp.PitchModel()
    h = 0.06
    assert np.isclose(p["touchline_near"].start[1], -34 + h)
    assert np.isclose(p["centre_circle"].radius, 9.15 - h)
    front = p["penalty_area_right_front"]
    assert np.isclose(front.start[0], 52.5 - 16.5 + h)
    assert np.isclose(p["penalty_area_right_near"].start[1], -(20.16 - h))
    assert np.isclose(p["goal_area_left_front"].start[0], -(52.5 - 5.5 + h))
    assert p.spots["penalty_mark_right"] == (41.5, 0.0)
    # the penalty arc ends on the penalty area's outer edge
    arc = p["penalty_arc_right"]
    end = arc.sample(0.1)[[0, -1]]
    assert np.allclose(end[:, 0], 52.5 - 16.5)
    assert np.all(arc.sample(0.1)[:, 0] <= 52.5 - 16.5 + 1e-9)
    assert len(p.segments) == 17 and len(p.arcs) == 7


@pytest.mark.parametrize("size", [(105, 68), (100, 64), (120, 90), (90, 45)])
def test_pitch_symmetries_and_sampling(size):
    p = gp.PitchModel(*size)
    pts = p.sample_points(0.25)
    for S in p.symmetries:
        mapped = pts @ S[:2, :2].T
        # every mapped point is (nearly) on some marking: nearest neighbour within the spacing
        d = np.min(np.linalg.norm(mapped[::7, None, :] - pts[None, :, :], axis=2), axis=1)
        assert d.max() < 0.25
    for name, m in p.markings.items():
        s = m.sample(0.25)
        steps = np.linalg.norm(np.diff(s, axis=0), axis=1)
        assert steps.max() <= 0.25 + 1e-9, name
    assert sum(len(pl) for pl in p.polylines()) >= len(pts)


def test_projected_circle_matches_conic_transfer():
    cam = broadcast_camera(np.random.default_rng(4))
    p = gp.PitchModel()
    E = transfer_conic(cam.H_img_from_pitch, p.circles["centre_circle"])
    e = ellipse_from_conic(E)
    px = cam.project_pitch(p["centre_circle"].sample(0.25))
    assert np.max(ellipse_distance(px, e)) < 1e-6


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: gp.PitchModel(130, 68), "90-120"),
        (lambda: gp.PitchModel(105, 40), "45-90"),
        (lambda: gp.PitchModel(95, 92), "45-90"),
        (lambda: gp.PitchModel(105, 68, line_width=0.2), "line width"),
        (lambda: gp.PitchModel().sample(0.0), "spacing"),
        (lambda: gcam.camera_from_homography(broadcast_camera(np.random.default_rng(0)).H_img_from_pitch @ np.diag([1.0, -1.0, 1.0]), (640, 360)), "below the pitch"),
        (lambda: gcam.camera_from_homography(np.diag([1.0, 1.0, 0.0]), (640, 360)), "singular"),
        (lambda: gcam.camera_from_homography(np.array([[1000.0, 0, 640], [0, 1000.0, 360], [0, 0, 1.0]]), (640, 360)), "focal"),
        (lambda: gcam.Camera(K=np.eye(3), R=np.diag([1.0, 1.0, -1.0]), t=np.zeros(3)), "rotation"),
        (lambda: gcam.Camera(K=np.diag([1.0, 1.0, 2.0]), R=np.eye(3), t=np.zeros(3)), r"K\[2, 2\]"),
        (lambda: gcam.Camera(K=np.eye(3), R=np.eye(3), t=np.zeros(2)), r"\(3,\)"),
        (lambda: gcam.intrinsic_matrix(-5.0, 0, 0), "positive"),
        (lambda: gcam.K_from_iac(np.diag([1.0, -1.0, 1.0])), "positive definite"),
        (lambda: gcam.KRt_from_P(np.zeros((3, 4))), "singular"),
        (lambda: gcam.Camera.from_dict({"K": None}), "lacks"),
    ],
)
def test_degenerate_inputs(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def _seen_pitch_points(cam, size=(1280, 720), step=4.0):
    """Points (N, 2) of the pitch plane on a 4 m grid that ``cam`` sees."""
    XY = np.stack(np.meshgrid(np.arange(-150.0, 150.0, step), np.arange(-60.0, 150.0, step)), -1).reshape(-1, 2)
    X3 = np.column_stack([XY, np.zeros(len(XY))])
    px = cam.project(X3)
    seen = cam.in_front(X3) & (px[:, 0] >= 0) & (px[:, 0] < size[0]) & (px[:, 1] >= 0) & (px[:, 1] < size[1])
    return XY[seen]


@pytest.mark.parametrize("seed", range(5))
def test_camera_at_centre_keeps_the_picture(seed):
    # at its own centre: the camera itself (the start is exact: the fit
    # stays there to the LM's tolerance); moved 1.4 times as far back along
    # the line of sight (a long lens's depth-zoom ambiguity) and back again:
    # the focal length and rotation come back to the fit's picture error,
    # a small fraction of a pixel here as the view's own depth varies
    rng = np.random.default_rng(seed)
    cam = broadcast_camera(rng)
    XY = _seen_pitch_points(cam)
    X3 = np.column_stack([XY, np.zeros(len(XY))])
    same = gcam.camera_at_centre(cam, cam.center, XY)
    assert np.abs(same.project(X3) - cam.project(X3)).max() < 1e-6
    g = X3.mean(axis=0)
    far = g + 1.4 * (cam.center - g)
    moved = gcam.camera_at_centre(cam, far, XY)
    np.testing.assert_allclose(moved.center, far, atol=1e-9)
    assert moved.focal > cam.focal  # farther back, a longer lens
    back = gcam.camera_at_centre(moved, cam.center, XY)
    moved_err = np.abs(moved.project(X3) - cam.project(X3)).max()
    back_err = np.abs(back.project(X3) - cam.project(X3)).max()
    assert back_err < max(0.5, 0.2 * moved_err), (moved_err, back_err)


@pytest.mark.parametrize(
    "args, message",
    [
        (lambda cam: (cam.center, np.zeros((2, 2))), "at least 3 pitch points"),
        (lambda cam: (np.array([0.0, np.nan, 10.0]), np.array([[0.0, 0.0], [5.0, 0.0], [0.0, 5.0]])), "finite"),
        (lambda cam: (np.array([0.0, 80.0, 10.0]), np.array([[0.0, 0.0], [5.0, 0.0], [0.0, 5.0]])), "in front of both"),
    ],
)
def test_camera_at_centre_bad_input(args, message):
    cam = broadcast_camera(np.random.default_rng(0))
    with pytest.raises(ValueError, match=message):
        gcam.camera_at_centre(cam, *args(cam))


@pytest.mark.parametrize("rotvec", [[0.1, -0.2, 0.3], [0.0, 0.0, 0.0], [2.9, 0.4, -1.1], [1e-9, 0.0, 0.0]])
def test_rotation_derivatives_match_finite_differences(rotvec):
    from scipy.spatial.transform import Rotation

    R, dR = gcam.rotation_with_derivatives(rotvec)
    assert np.allclose(R, Rotation.from_rotvec(rotvec).as_matrix(), atol=1e-15)
    e = 1e-6
    for i in range(3):
        d = np.zeros(3)
        d[i] = e
        num = (Rotation.from_rotvec(np.add(rotvec, d)).as_matrix() - Rotation.from_rotvec(np.subtract(rotvec, d)).as_matrix()) / (2 * e)
        # (central differences: error of order e^2 times the third derivative, and 1e-16 / e of rounding)
        assert np.allclose(dR[i], num, atol=1e-8), i


def test_camera_near_homography_s_jacobian_and_answer():
    from geometry.camera import _HomographyCameraFit

    rng = np.random.default_rng(7)
    cam = gcam.camera_from_ptz(np.array([5.0, -60.0, 18.0]), gcam.PTZ(pan=0.3, tilt=0.25, roll=0.01, f=1500.0), (640.0, 360.0))
    XY = rng.uniform([-20, -30], [30, 30], (50, 2))
    X3 = np.column_stack([XY, np.zeros(50)])
    fit = _HomographyCameraFit(X3, cam.project(X3) + rng.normal(0, 0.5, (50, 2)), 640.0, 360.0, 1.0)
    p = np.concatenate([[0.2, -0.1, 0.05], [4.0, -58.0, 17.0], [np.log(1400.0)]])
    J = fit.jacobian(p)
    num = np.empty_like(J)
    for k in range(7):
        d = np.zeros(7)
        d[k] = 1e-6
        num[:, k] = (fit.residuals(p + d) - fit.residuals(p - d)) / 2e-6
    assert np.allclose(J, num, rtol=1e-5, atol=1e-4 * np.abs(num).max())
    # the camera of the homography of an exact camera is that camera
    H = cam.K @ np.column_stack([cam.R[:, 0], cam.R[:, 1], cam.t])
    got = gcam.camera_near_homography(H / H[2, 2], (640.0, 360.0), XY)
    assert np.allclose(got.center, cam.center, atol=1e-6) and abs(got.focal - 1500.0) < 1e-6
