"""The tracker on real frames (paint mode): the frame's own motion starts the
refinement in a whip pan, and a change of its pace lets the measurement
through the paint noise; at a long focal length k1 is not estimated; the
tripod centre frozen from weak views moves to that of more certain ones."""

from __future__ import annotations

import numpy as np
import pytest
from cameras import looking_at
from test_circle_view import _frame

from arstream.solve import k1_observable
from arstream.track import Tracker
from geometry.camera import PTZ, camera_from_ptz, ptz_from_camera

SIZE = (640, 360)


def _panned(cam, dpan):
    centre, ptz = ptz_from_camera(cam)
    return camera_from_ptz(centre, PTZ(ptz.pan + dpan, ptz.tilt, ptz.roll, ptz.f), cam.principal_point)


def _tracker_after(cam):
    """A tracker in paint mode whose last output (the previous frame's) was ``cam``."""
    tr = Tracker(*SIZE)
    tr._paint = True
    tr.centre = cam.center.copy()
    tr._last_cam = (0, cam)
    return tr


@pytest.mark.parametrize("moved_px", [12.0, 30.0])
def test_the_frames_own_motion_moves_the_prediction(moved_px):
    # the last frame's camera, and this frame's panned by ``moved_px`` at the
    # image centre; the prediction (the motion model's) did not pan at all
    cam0 = looking_at((0.0, -60.0, 14.0), (-20.0, 5.0, 0.0), 1.4 * SIZE[0], SIZE)
    cam1 = _panned(cam0, moved_px / cam0.focal)
    tr = _tracker_after(cam0)
    g0, g1 = tr._grey(_frame(cam0, SIZE, seed=1)), tr._grey(_frame(cam1, SIZE, seed=2))
    got, manoeuvre = tr._moved_by_image(1, cam0, g0, g1)
    assert got is not None and not manoeuvre  # (no motion measured on the frame before)
    # where the moved camera puts the pitch point under the centre, against the
    # truth: within the refinement's narrowest radius (2.5 px) that it starts.
    # (A pan is no pure translation of the picture, and this one's structure is
    # a few lines on noise: the translation the phase correlation finds is off
    # by about a pixel)
    X = cam1.backproject_to_pitch(np.array([[(SIZE[0] - 1) / 2, (SIZE[1] - 1) / 2]]))
    X3 = np.column_stack([X, [0.0]])
    pred_off = np.linalg.norm(cam0.project(X3) - cam1.project(X3))
    assert np.linalg.norm(got.project(X3) - cam1.project(X3)) < 2.5 < pred_off


def test_a_prediction_that_moved_as_the_frame_did_is_kept():
    cam0 = looking_at((0.0, -60.0, 14.0), (-20.0, 5.0, 0.0), 1.4 * SIZE[0], SIZE)
    cam1 = _panned(cam0, 10.0 / cam0.focal)
    tr = _tracker_after(cam0)
    got, _ = tr._moved_by_image(1, cam1, tr._grey(_frame(cam0, SIZE, seed=1)), tr._grey(_frame(cam1, SIZE, seed=2)))
    assert got is None  # within 3 px of the frame's motion: the motion model holds


def test_a_change_of_pace_is_a_manoeuvre():
    cam0 = looking_at((0.0, -60.0, 14.0), (-20.0, 5.0, 0.0), 1.4 * SIZE[0], SIZE)
    cams = [cam0, _panned(cam0, 4.0 / cam0.focal), _panned(cam0, 8.0 / cam0.focal), _panned(cam0, 28.0 / cam0.focal)]
    tr = _tracker_after(cam0)
    greys = [tr._grey(_frame(c, SIZE, seed=k)) for k, c in enumerate(cams)]
    flags = []
    for k in range(1, 4):
        tr._last_cam = (k - 1, cams[k - 1])
        flags.append(tr._moved_by_image(k, cams[k - 1], greys[k - 1], greys[k])[1])
    # 4 px, 4 px (steady), then 20 px a frame: the pace changed by 16 px
    assert flags == [False, False, True]


@pytest.mark.parametrize(
    "focal_widths, size, expect",
    [
        (0.8, (640, 360), True),  # a wide shot
        (1.7, (640, 360), True),
        (1.8, (640, 360), False),  # a k1 of 0.1 moves the corners by under 4 px
        (3.4, (640, 360), False),  # israel_league_wide's main camera
        (2.4, (1280, 720), True),  # more pixels: more of the bend to see
        (3.3, (1280, 720), False),
    ],
)
def test_k1_observable(focal_widths, size, expect):
    assert k1_observable(focal_widths * size[0], size) is expect


def test_a_centre_frozen_from_weak_views_moves_to_that_of_more_certain_ones():
    from arstream.detect import detect
    from arstream.evaluate import frame_error
    from arstream.initialise import paint_view
    from arstream.solve import LineIndex, refine_camera
    from arstream.track import _ptz_vector
    from geometry.pitch import PitchModel

    # a penalty-area view: lines at several depths fix the centre well
    cam = looking_at((-5.0, -60.0, 14.0), (-38.0, 4.0, 0.0), 1.6 * SIZE[0], SIZE)
    img = _frame(cam, SIZE)
    det = detect(img)
    lidx = LineIndex(np.concatenate([det.line_points, paint_view(img, det).points]))
    wrong = cam.center + np.array([1.5, -2.5, 0.4])
    tr = Tracker(*SIZE)
    tr._paint = True
    tr.centre = wrong.copy()
    tr._centres = [(0.3, wrong + 0.05 * k) for k in range(5)]  # five weak views froze it
    start = camera_from_ptz(wrong, ptz_from_camera(cam)[1], cam.principal_point)
    meas = refine_camera(start, lidx, SIZE, tr.model, center=wrong, radii=(8.0, 4.0, 2.5))
    tr._kf = tr._new_filter(_ptz_vector(meas.camera, wrong), np.eye(4) * 1e-6)
    moved = []
    for k in range(5):
        out = tr._check_centre(100 + 10 * k, meas, lidx)
        if out is not meas:
            moved.append((100 + 10 * k, out))
    # the third more certain view makes them the most of the five most certain:
    # their median moves
    assert tr.stats["centre_moves"] == 1 and [k for k, _ in moved] == [120]
    out = moved[0][1]
    # at least half way: along the line of sight the paint's whole-pixel
    # (2 px wide) lines leave the fit flat, and it stops short of the truth
    # (the detector's sub-pixel centres alone reach it, but real frames' faint
    # lines are in the paint only)
    assert np.linalg.norm(tr.centre - cam.center) < 0.5 * np.linalg.norm(wrong - cam.center), tr.centre
    pitch = PitchModel()
    assert frame_error(cam, out.camera, SIZE, pitch.sample_points(0.5), pitch.symmetries).mean < frame_error(cam, meas.camera, SIZE, pitch.sample_points(0.5), pitch.symmetries).mean
    # the filter's angles follow: its state is the new measurement's
    assert np.allclose(tr._kf.x[0::2, 0], _ptz_vector(out.camera, tr.centre), atol=1e-9)
    assert tr._kf_id == 120  # a new run for the smoother
