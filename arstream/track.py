"""Per-frame camera solving with temporal filtering: the pipeline's solver stage.

For every frame the :class:`Tracker` refines the camera predicted by a Kalman
filter (filterpy) against the detected line pixels; when there is no usable
prediction (start, shot cut, lost track) it initialises from the centre
circle's pole-polar relations or, with the circle out of view, from line
correspondences, and keeps the candidate that explains the most markings.

Broadcast tripod model: the camera centre of a broadcast camera is fixed.
It is estimated from the confident frames' full-pose refinements (those with
a small centre covariance), then frozen, after which only pan, tilt, roll and
f (and k1 if the lens shows distortion) are solved: much better conditioned,
above all at long focal lengths where position and zoom trade off. If a frame
is explained well by a free pose but not with the frozen centre, the centre
assumption is broken (another camera after a cut) and the estimate restarts.

Temporal model: a constant-velocity Kalman filter over (pan, tilt, roll,
log f) and their rates; the measurement noise comes from the refinement's
covariance; Mahalanobis gating rejects outliers; a shot cut (abrupt change of
the frame, or no pitch) resets it. Live mode (``lag=0``) is causal and emits
each frame's estimate at once; offline mode (``lag=N``) runs an RTS smoother
over a sliding window and emits estimates N frames late, so memory stays
bounded (only camera parameters are kept).

Whip pans: when the pan outruns the motion model and blur leaves too few
markings for the refinement from the prediction, the tracker sweeps the pan
angle about the tripod centre (tilt, roll and f kept), scoring each angle by
the share of projected markings with a detected line pixel nearby (the part
of it above its floor must peak clearly: markings along the pan match at every
angle), refines from the peak (or, when the refinement finds too little to fix
tilt, roll and f, keeps the prediction's), sets the pan where the projected
markings lie on the brightest structure across the rows (the smeared bands
the ridge detector misses: the midpoint of the brightness hump's half-height
crossings, since a band as wide as the blur has a flat, uneven top), and
restarts the filter from that measurement at the pan rate since the last one.
Measurements accepted on few line pixels (blur) get the same pan by brightness.

Statuses: "ok" (measured this frame), "tracked" (carried by the filter
through a frame without an accepted measurement, at most ``max_coast``
frames), "lost".
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, replace

import cv2
import numpy as np
from filterpy.common import Q_discrete_white_noise
from filterpy.kalman import KalmanFilter
from scipy.linalg import block_diag

from arstream.estimate import CameraEstimate
from arstream.imaging import grey_thumbnail, sample_bilinear
from arstream.pitch_size import SIZE_MAX_SD, PitchSize, PitchView, estimate_pitch_size
from arstream.tripod import fit_tripod
from arstream.initialise import INIT_ACCEPT, PAINT_CHECK, FrameViews, initialise_camera, initialise_from_paint, paint_score, paint_verdict, paint_view, still_paint_camera, view_supports
from arstream.solve import LineIndex, ModelSamples, Refinement, explained_share, k1_observable, refine_camera, refinements_along_sight, seated
from arstream.solve_lines import plausible
from arstream.support import ON_LINES, backed_support, backs, on_lines, white_mask
from geometry.camera import PTZ, Camera, camera_from_ptz, camera_turned, ptr_from_rotation
from geometry.pitch import PitchModel

__all__ = ["Tracker", "TrackerConfig"]


@dataclass
class TrackerConfig:
    """Tuning of the tracker (defaults suit 25-50 fps broadcast video)."""

    accept: float = 0.7  # least support share to accept a refinement as a measurement
    accept_low: float = 0.55  # ... or this much, when the detected line pixels lie on the markings:
    min_explained: float = 0.9  # share of them within 2.5 px of the projected markings
    trusted: float = 0.9  # support share of a measurement that no motion gate rejects (fast pans)
    init_accept: float = INIT_ACCEPT  # least support share to accept an initialisation
    max_coast: int = 12  # frames carried by the filter without a measurement
    gate: float = 30.0  # Mahalanobis gate (chi-square, 4 dof; 18.5 is p = 0.001)
    cut_threshold: float = 28.0  # mean absolute thumbnail change (grey levels) that signals a cut
    centre_frames: int = 5  # confident free-pose frames before the tripod centre is frozen
    centre_sigma: float = 0.6  # largest centre std (m) of a frame used for the tripod centre
    centre_break: float = 3.0  # metres: a free pose this far from the tripod centre breaks it
    # frames within which two fresh cameras far from the tripod centre, with no shot
    # cut seen since it was set, must agree (centres within centre_break) before
    # the centre is given up for them (Tracker._another_camera)
    other_within: int = 50
    centre_every: int = 10  # real frames: frames between free-pose checks of the frozen centre ...
    centre_move: float = 1.0  # ... which moves it when its more certain views say so by more than this (m)
    centre_sure: float = 0.85  # ... or when a free pose lays this share of the markings in view near a line pixel ...
    centre_gain: float = 0.05  # ... this much more than the measurement about the frozen centre ...
    centre_recall: int = 3  # ... and the frames checked before it (at most this many) are explained better about its centre
    axis_turn: float = 10.0  # degrees the view turns from the one the tripod centre was fixed in before the centre is searched along that view's axis ...
    axis_span: float = 12.0  # ... this far (m) either way, in steps of axis_step ...
    axis_step: float = 2.0
    axis_tries: int = 3  # ... at most this many times a centre
    accel_pan: float = 4.0  # process noise: angular acceleration (rad/s^2) of pan and tilt
    accel_roll: float = 0.05
    accel_logf: float = 2.0  # zoom acceleration (1/s^2 in log f)
    sweep_range: float = 0.1  # pan sweep after a failed track: +- this share of the width (0: none) ...
    sweep_step: float = 0.005  # ... in steps of this share of the width
    sweep_accept: float = 0.25  # least support share of a swept measurement ...
    sweep_explained: float = 0.85  # ... and least share of its detected line pixels explained
    sweep_peak: float = 1.2  # its support over the best support half the range away
    sweep_fine: float = 0.04  # then the pan by brightness along the markings: +- this share of the width
    paint_every: int = 4  # while lost, the paint initialiser (real frames) runs at most every this many frames
    rival_every: int = 1  # ... and checks a fresh camera from the detector's lines (Tracker._paint_rival) at most every this many frames
    paint_accept: float = 0.7  # least line support of a camera from the paint initialiser
    min_support: float = 0.6  # least line support (docs/evaluate.md) of a camera that is output (and drawn) ...
    min_trusted: float = 0.55  # ... or this much within max_coast frames of one that had it (blur hides paint; above the output test's 0.5 by the tracker's sampling of it)
    smooth_slack: float = 0.1  # a smoothed camera this much less supported than the filter's own is not output
    paint_noise: float = 50.0  # real frames (paint mode): the measurement variance over the refinement's covariance
    sure: float = 0.85  # offline, real frames: line support of a camera carried back over the held frames before it (Tracker._carry_back) ...
    carry_gain: float = 0.05  # ... replacing each camera it lays on paint better by this much (and each frame without one) ...
    carry_hold: float = 2.0  # ... which are held (seconds beyond the lag) while they wait for such a camera;
    carry_agree: float = 3.0  # ... where a frame keeps its own camera, backed as well, the carried one must lie within this (px: the refinement's last radius)
    manoeuvre: float = 3.0  # ... but not while the frame's own motion changes pace by more than this (px/frame, analysis frame): a whip pan
    pitch_views: tuple = (6, 12, 24)  # with the pitch's size unknown: estimate it when this many views are collected
    pitch_spacing: int = 5  # frames between two views for the size estimate
    pitch_support: float = 0.7  # least line support of a view for the size estimate


def _hump_centre(x: np.ndarray, y: np.ndarray, k: int) -> float | None:
    """Midpoint of the half-maximum crossings either side of the peak ``k`` of the
    curve ``y(x)`` (its floor: the curve's minimum), interpolated linearly; None
    when the curve does not fall to half on both sides within the window."""
    lo = float(y.min())
    half = lo + 0.5 * (float(y[k]) - lo)
    below = y < half
    left = np.flatnonzero(below[:k])
    right = np.flatnonzero(below[k + 1 :])
    if not len(left) or not len(right):
        return None
    i, j = left[-1], k + 1 + right[0]
    xl = x[i] + (half - y[i]) / (y[i + 1] - y[i]) * (x[i + 1] - x[i])
    xr = x[j - 1] + (half - y[j - 1]) / (y[j] - y[j - 1]) * (x[j] - x[j - 1])
    return 0.5 * (xl + xr)


def _ptz_vector(cam: Camera, centre: np.ndarray) -> np.ndarray:
    """(pan, tilt, roll, log f) of ``cam`` about ``centre``."""
    # the angles of a rotation do not depend on the centre it turns about
    pan, tilt, roll = ptr_from_rotation(cam.R)
    return np.array([pan, tilt, roll, np.log(cam.focal)])


def _image_shift(a: Camera, b: Camera, centre: np.ndarray, size) -> float:
    """About how far (pixels) the image moves from camera ``a`` to ``b`` (same
    tripod ``centre``): pan/tilt times the focal length, roll and zoom at the
    frame's edge."""
    za, zb = _ptz_vector(a, centre), _ptz_vector(b, centre)
    d = zb - za
    d[0] = _wrap(d[0])
    return float(b.focal * np.hypot(d[0], d[1]) + 0.5 * size[0] * (abs(d[2]) + abs(d[3])))


def widest_line(cam: Camera, size, line_width: float) -> float | None:
    """The width (pixels) of a painted line ``line_width`` metres wide where the
    pitch plane comes nearest the camera in the image: at the frame's bottom
    edge (its corners and middle; a line running toward the camera keeps its
    full width, ``f w / depth``). None when a point of that edge does not see
    the pitch plane in front of the camera (looking up, or from below it).
    Lens distortion is left out (a few per cent at the edge)."""
    C = cam.center
    if not C[2] > 0:
        return None
    w, h = size
    Kinv = np.linalg.inv(cam.K)
    r3 = cam.R[:, 2]  # the world's Z of a camera-frame direction: r3 . d
    depth = np.inf
    for u in (0.0, 0.5 * (w - 1), w - 1.0):
        d = Kinv @ np.array([u, h - 1.0, 1.0])  # the ray at depth 1
        down = -float(r3 @ d)  # metres the ray falls per metre of depth
        if not down > 0:
            return None
        depth = min(depth, C[2] / down)
    return float(cam.focal * line_width / depth)


def _wrap(a: float) -> float:
    return (a + np.pi) % (2 * np.pi) - np.pi


def _panned_views(cam: Camera, centre: np.ndarray, offsets_px: np.ndarray, points: np.ndarray, size, margin: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    """The model samples ``points`` (N, 3) through ``cam`` turned in pan about the tripod ``centre`` by
    each of ``offsets_px`` (D,) (pixels at its focal length; tilt, roll, f and the
    lens kept), all at once: pixels (D, N, 2) and the in-view mask (D, N) (in
    front, inside the frame by ``margin``, as ``solve._visible``).

    A pan by ``d`` right-multiplies the rotation by ``Rz(d)``
    (:func:`geometry.camera.rotation_from_ptr`), so the camera-frame points are
    ``R Rz(d) (X - C)``; the lens is the refinement's (one radial term, as
    :func:`arstream.solve_kernels.marking_residuals`)."""
    d = np.asarray(offsets_px, dtype=np.float64) / cam.focal
    c, s = np.cos(d)[:, None], np.sin(d)[:, None]
    Y = points - centre
    ax = c * Y[:, 0] - s * Y[:, 1]  # (D, N) components, each contiguous
    ay = s * Y[:, 0] + c * Y[:, 1]
    R = cam.R
    X0 = R[0, 0] * ax + R[0, 1] * ay + R[0, 2] * Y[:, 2]
    X1 = R[1, 0] * ax + R[1, 1] * ay + R[1, 2] * Y[:, 2]
    X2 = R[2, 0] * ax + R[2, 1] * ay + R[2, 2] * Y[:, 2]
    W, H = size
    f, cx, cy = cam.K[0, 0], cam.K[0, 2], cam.K[1, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        xn, yn = X0 / X2, X1 / X2
    # in front; the lens model only near the frame by the pinhole projection (a
    # lens bends far less than a tenth of the frame)
    near = (X2 > 0.5) & (f * xn > -0.1 * W - cx) & (f * xn < 1.1 * W - cx) & (f * yn > -0.1 * H - cy) & (f * yn < 1.1 * H - cy)
    xs, ys = xn[near], yn[near]
    if cam.dist:  # the refinement's lens model (solve_kernels.marking_residuals): one radial term
        g = 1.0 + cam.dist[0] * (xs * xs + ys * ys)
        xs, ys = xs * g, ys * g
    px = np.full(near.shape + (2,), np.nan)
    px[near, 0] = f * xs + cx
    px[near, 1] = f * ys + cy
    inside = near & (px[..., 0] >= margin) & (px[..., 0] <= W - 1 - margin) & (px[..., 1] >= margin) & (px[..., 1] <= H - 1 - margin)
    return px, inside


def _window_points(cam: Camera, centre: np.ndarray, offsets_px: np.ndarray, points: np.ndarray, size) -> np.ndarray:
    """The model samples among ``points`` (N, 3) that come into view (or near it) at
    some pan of ``cam`` within the window ``offsets_px`` (sorted, pixels; see
    :func:`_panned_views`): a sample moves one way across the frame as the pan
    turns, so its views at the window's ends and middle tell."""
    _, near = _panned_views(cam, centre, offsets_px[[0, len(offsets_px) // 2, -1]], points, size, margin=-0.1 * size[0])
    return points[near.any(axis=0)]


@dataclass(frozen=True)
class _CameraStep:
    """How one camera differs from another: ``b`` is ``a`` moved by ``dC``
    (3,) metres, turned by the rotation vector ``dr`` (3,) (pitch frame,
    ``R_b = exp(dr) R_a``) and zoomed by ``exp(dlogf)``."""

    dC: np.ndarray
    dr: np.ndarray
    dlogf: float

    @classmethod
    def between(cls, a: Camera, b: Camera) -> "_CameraStep":
        dr = cv2.Rodrigues(b.R @ a.R.T)[0].ravel()
        return cls(b.center - a.center, dr, float(np.log(b.focal / a.focal)))

    def apply(self, cam: Camera, w: float) -> Camera:
        """``cam`` moved by the share ``w`` (0-1) of the step: centre, rotation
        (about the pitch frame's axes) and log focal length alike; its lens
        terms kept."""
        return camera_turned(cam, w * self.dr, w * self.dlogf, cam.center + w * self.dC)


#: what an estimate carries only while the offline smoother holds it
#: (Tracker._smooth, Tracker._carry_back), dropped when it is output (Tracker._final)
_HELD = ("kf", "smoothed", "image", "carried", "seeded")


def _unsupported(index: int, pts: float, sup: float, spread: float) -> CameraEstimate:
    """The "lost" estimate of a frame whose paint does not back its camera."""
    return CameraEstimate.lost(index, pts, reason=f"unsupported camera (line support {sup:.2f}, {spread:.0%} of its markings in view on paint)")


class Tracker:
    """The solver stage: detections in, camera estimates out.

    Parameters
    ----------
    width, height : frame size (pixels)
    fps : frame rate (sets the filter's time step)
    lag : 0 for live (causal) output; N > 0 for an RTS smoother over a sliding
        window, estimates emitted N frames late (on real frames up to
        ``config.carry_hold`` seconds later while weakly backed frames wait
        for a camera to be carried back to them: :meth:`_carry_back`)
    pitch : PitchModel (default 105 x 68 m)
    estimate_pitch : start from ``pitch`` (None: 105 x 68 m) and estimate
        the size from the first views of the clip
        (:func:`arstream.pitch_size.estimate_pitch_size`; :attr:`pitch_size`
        says what was found). Experimental: on synthetic clips the length
        comes out within about 1 m, with an understated uncertainty
    watch_pitch : keep the views the size's estimate would take (as
        ``estimate_pitch`` does) but track at ``pitch`` throughout;
        :meth:`pitch_seen` estimates the size from them (whether the clip
        fits ``pitch`` as well as its line support says)
    principal_point : (2,) pixels; default the image centre
    config : TrackerConfig
    support_reach : int, the line-support test's tolerance (pixels of the
        frames given; 2 at the frame's own resolution, 1 on frames scaled to
        half of it, so that the test matches the 2 px of the frame that docs/evaluate.md defines)
    views : :class:`arstream.initialise.FrameViews` shared with the other
        trackers fed the same frames (a pitch-size scan's, one per size: a
        frame's paint is the same at every size); None: its own
    """

    def __init__(self, width: int, height: int, *, fps: float = 25.0, lag: int = 0, pitch: PitchModel | None = None, principal_point=None, config: TrackerConfig | None = None, support_reach: int = 2, estimate_pitch: bool = False, watch_pitch: bool = False, views: FrameViews | None = None):
        if width <= 0 or height <= 0:
            raise ValueError(f"invalid frame size {width}x{height}")
        if lag < 0:
            raise ValueError(f"lag must be >= 0, got {lag}")
        self.size = (int(width), int(height))
        self.fps = float(fps)
        self.lag = int(lag)
        self.pitch = pitch or PitchModel()
        self.pitch_size = PitchSize(self.pitch.length, self.pitch.width, source="default" if pitch is None else "given")
        self._pitch_views: list[PitchView] | None = [] if estimate_pitch or watch_pitch else None
        self._watch_pitch = bool(watch_pitch) and not estimate_pitch
        self._pitch_view_at = -(10**9)
        self.pp = np.array(principal_point if principal_point is not None else ((width - 1) / 2, (height - 1) / 2), dtype=np.float64)
        self.cfg = config or TrackerConfig()
        self.model = ModelSamples.from_pitch(self.pitch, 0.5)
        self.centre: np.ndarray | None = None
        # the tripod centre given up with a camera its paint stopped backing:
        # a fresh camera is still checked against it (the same tripod?) until
        # a centre is frozen again (see reset)
        self._given_up: np.ndarray | None = None
        self._cut_seen = False  # a shot cut since the tripod centre was set
        self._other: tuple[int, np.ndarray] | None = None  # (frame, centre) of the last fresh camera far from it
        self._centres: list[tuple[float, np.ndarray]] = []  # (largest sd, centre) of free-pose measurements
        self._centre_check_at = -(10**9)  # the frame the frozen centre was last checked on (real frames)
        self._centre_views: deque = deque(maxlen=self.cfg.centre_recall)  # (line index, camera, confidence) of the frames checked last
        self._centre_cur: np.ndarray | None = None
        self._centre_view: tuple | None = None  # (line index, camera) of the view the centre was fixed in, while not searched along its axis
        self._axis_tries = 0
        self.k1: float | None = None  # None: unknown yet; 0: no distortion
        self._k1_samples: list[float] = []
        self._prev_thumb: np.ndarray | None = None
        self._grey_last: np.ndarray | None = None  # real frames: the last frame, grey and halved (its image motion)
        self._hann: np.ndarray | None = None
        self._flow: tuple[int, np.ndarray] | None = None  # (frame, its image motion in px) of the last frame measured
        self._last_cam: tuple[int, Camera] | None = None  # (frame, camera) last output unsmoothed
        self._kf: KalmanFilter | None = None
        self._coast = 0
        self._conf_ref = 1.0  # running level of accepted confidences (the clip's line recall)
        self._gated_prev = False  # the previous frame's measurement was gated
        self._swept_prev = False  # the previous frame's measurement came from a pan sweep
        self._kf_at = 0  # the frame the filter's state is at
        self._motions: dict = {}  # steps -> (F, Q)
        self._motion_at: dict = {}  # frame -> sideways image motion (px/frame) or None, recent frames
        self._motion_last: float | None = None
        self._width_at: dict = {}  # frame -> the widest painted line's width (px) or None, recent frames
        self._last_z: tuple[int, np.ndarray] | None = None  # (frame, ptz vector) of the last measurement
        self._paint_noise = self.cfg.paint_noise  # real frames: the running paint noise (see _solve)
        self._judged: dict = {}  # id(camera) -> (frame, camera, its _support) of this frame's cameras judged
        self._last_f = None
        self._window: deque = deque()
        self._hold = int(round(self.cfg.carry_hold * self.fps)) if self.lag else 0
        self._cuts: set[int] = set()  # offline: the frames held that open a shot (a cut before them)
        self._smoother = KalmanFilter(dim_x=8, dim_z=4)  # only its rts_smoother is used
        self._image: np.ndarray | None = None  # the frame being solved (for the line-support gate)
        self._unsupported = 0  # consecutive frames whose camera the paint did not back
        self._supported_at = -(10**9)  # the last frame whose camera the paint backed
        self.support_reach = int(support_reach)
        self.views = views if views is not None else FrameViews()
        self._paint_at = -(10**9)  # the frame the paint initialiser last ran on
        self._paint = False  # the clip needs its paint (the paint initialiser found a camera, or lines no marking explains): track on its paint pixels too
        self._bright: dict[int, np.ndarray] = {}  # frame -> line-support mask, while the smoother holds it
        self.stats = {"ok": 0, "tracked": 0, "lost": 0, "cuts": 0, "inits": 0, "gated": 0, "reanchored": 0, "swept": 0, "pan_only": 0, "paint_inits": 0, "unsupported": 0, "pitch_changes": 0, "manoeuvres": 0, "centre_moves": 0, "unsmoothed": 0, "implausible": 0, "backfilled": 0, "other_cameras": 0, "other_refused": 0, "paint_rivals": 0, "axis_moves": 0, "paint_turns": 0}

    # --- filter ----------------------------------------------------------------
    def _new_filter(self, z: np.ndarray, Rz: np.ndarray, rate: np.ndarray | None = None) -> KalmanFilter:
        """A filter started at the measurement ``z`` (pan, tilt, roll, log f) with noise
        ``Rz``, at rest or moving at ``rate`` (per second, same order)."""
        kf = KalmanFilter(dim_x=8, dim_z=4)
        kf.F, kf.Q = self._motion(1)
        kf.H = np.zeros((4, 8))
        for k in range(4):
            kf.H[k, 2 * k] = 1.0
        kf.x = np.zeros((8, 1))
        kf.x[0::2, 0] = z
        if rate is not None:
            kf.x[1::2, 0] = rate
        kf.P = np.diag([Rz[0, 0], 0.5, Rz[1, 1], 0.5, Rz[2, 2], 0.05, Rz[3, 3], 0.5])
        kf.R = Rz
        return kf

    def _motion(self, steps: int) -> tuple[np.ndarray, np.ndarray]:
        """Transition F (8, 8) and process noise Q (8, 8) of the constant-rate model over
        ``steps`` frame intervals (more than one where a live source dropped frames)."""
        fq = self._motions.get(steps)
        if fq is None:
            dt = steps / self.fps
            F1 = np.array([[1.0, dt], [0.0, 1.0]])
            c = self.cfg
            Q = block_diag(
                Q_discrete_white_noise(2, dt, c.accel_pan**2),
                Q_discrete_white_noise(2, dt, c.accel_pan**2),
                Q_discrete_white_noise(2, dt, c.accel_roll**2),
                Q_discrete_white_noise(2, dt, c.accel_logf**2),
            )
            fq = (block_diag(F1, F1, F1, F1), Q)
            for a in fq:
                a.flags.writeable = False  # shared by every step of that length (filterpy only reads them)
            self._motions[steps] = fq
        return fq

    def _camera_from_state(self, x: np.ndarray, centre: np.ndarray) -> Camera:
        x = np.asarray(x).ravel()
        f = float(np.exp(x[6]))
        k1 = self._k1_for(f)
        return camera_from_ptz(centre, PTZ(pan=float(x[0]), tilt=float(x[2]), roll=float(x[4]), f=f), self.pp, dist=(k1,) if k1 else ())

    def _k1_for(self, f: float) -> float:
        if not self.k1:
            return 0.0
        # a zoom lens bends less as it zooms in: scale with 1/f from the last estimate
        return float(self.k1 * (self._k1_f / f)) if self._k1_f else float(self.k1)

    def _measurement_noise(self, r: Refinement, *, own: bool = False) -> np.ndarray:
        """The measurement's noise (4, 4) in the filter's terms (pan, tilt, roll,
        log f) from the refinement's covariance; on real frames scaled by the
        paint noise (the clip's running factor, see :meth:`_solve`) unless
        ``own``."""
        names = list(r.params)
        cov = r.covariance
        ang = [names.index(n) for n in ("rx", "ry", "rz")]
        va = float(np.nanmean(np.diag(cov)[ang])) if np.all(np.isfinite(np.diag(cov)[ang])) else 1e-4
        vf = float(cov[names.index("logf"), names.index("logf")]) if np.isfinite(cov[names.index("logf"), names.index("logf")]) else 1e-4
        va = max(va, 1e-9) * 4.0
        vf = max(vf, 1e-9) * 4.0
        if self._paint and not own:
            # real frames: the paint pixels are whole mask pixels, and the neighbours
            # along a painted line share its error, so the refinement's covariance
            # (independent pixels) understates the noise of a measurement
            va *= self._paint_noise
            vf *= self._paint_noise
        return np.diag([va, va, va, vf])

    # --- public API --------------------------------------------------------------
    def image_motion(self, frame: int | None = None) -> float | None:
        """How far the image moved sideways per frame (pixels, from the filter's pan
        rate and focal length) as of frame ``frame`` (default: the last one solved),
        or None where unknown (no filter running then, or a frame not solved or
        long gone). Asked by frame, the answer does not depend on how far the
        tracker has got: a detector one frame ahead on another thread gets the
        same hint as one in step."""
        # (single dict operations: atomic under the GIL, whatever the solving thread does)
        return self._motion_last if frame is None else self._motion_at.get(frame)

    def line_width(self, frame: int) -> float | None:
        """The widest painted line's width in the image (pixels; :func:`widest_line`)
        with the camera solved for frame ``frame``, or None where unknown (not
        solved, lost, long gone, or the frame's bottom edge does not see the
        pitch plane). Like :meth:`image_motion`, a hint for the detector."""
        return self._width_at.get(frame)

    def reset(self, *, keep_centre: bool = True, wrong: bool = False) -> None:
        """Forget the temporal state (after a cut). The tripod centre is kept unless asked.

        ``wrong``: the filter's camera lost its paint's backing (three frames
        in a row, in a whip pan or after a wrong camera). Its centre is given
        up, but a fresh camera far from it is still checked against it as
        against a frozen centre (refined about it, or believed only when a
        second one agrees: :meth:`_another_camera`) until a centre is frozen
        again: the main camera has not left its tripod, and a paint camera
        right after a whip pan can lay a penalty area on its paint from a
        centre tens of metres away."""
        self._kf = None
        self._coast = 0
        self._conf_ref = 1.0
        self._gated_prev = self._swept_prev = False
        self._last_z = None
        self._paint_noise = self.cfg.paint_noise
        if not keep_centre:
            self._given_up = self._tripod() if wrong else None
            self.centre = None
            self._centre_view = None
            self._centres.clear()
            self._centre_views.clear()

    def process(self, index: int, pts: float, image: np.ndarray | None, detections, *, thumbnail: np.ndarray | None = None) -> list[CameraEstimate]:
        """Solve frame ``index``; returns the estimates that became final (one per call
        in live mode, lagging by ``lag`` frames in offline mode).

        ``image``: the frame (BGR, the tracker's size) or None; ``detections``:
        the detector's result for it. ``thumbnail``: the frame's
        :func:`arstream.imaging.grey_thumbnail`, when the caller has it (the shot-cut
        test; by default made from ``image``). Give it for every frame of a
        clip or for none: the test compares consecutive thumbnails."""
        self._image = image
        try:
            est = self._solve(index, pts, image, detections, thumbnail)
        finally:
            self._image = None
        self.stats[est.status] += 1
        kf = self._kf
        self._motion_last = None if kf is None else float(abs(kf.x[1, 0]) * np.exp(kf.x[6, 0]) / self.fps)
        self._motion_at[index] = self._motion_last
        self._width_at[index] = None if est.camera is None else widest_line(est.camera, self.size, self.pitch.line_width)
        if len(self._motion_at) > 16:  # keep the last 8 frames (frames may be skipped)
            for k in [k for k in self._motion_at if k <= index - 8]:
                del self._motion_at[k]
                self._width_at.pop(k, None)
        if self.lag == 0:
            return [self._final(est)]
        if self._paint and image is not None and "image" not in est.info and (est.camera is None or self._weak(est)):
            est.info["image"] = image.copy()  # (while held: a later camera may better it, _carry_back)
        self._window.append(est)
        if self._paint:
            self._carry_back(len(self._window) - 2)  # (its successor known now: the motion to carry back)
        self._smooth(len(self._window) - 1 - self.lag)
        out = []
        while len(self._window) > self.lag and not (len(self._window) <= self.holds and self._waits(self._window[0])):
            out.append(self._final(self._smooth_pop()))
        return out

    @property
    def holds(self) -> int:
        """The most frames whose estimates are not final yet: ``lag``, and
        offline on real frames ``cfg.carry_hold`` seconds more while the
        oldest waits for a camera to be carried back to it
        (:meth:`_carry_back`)."""
        return self.lag + self._hold

    def flush(self) -> list[CameraEstimate]:
        """Emit the estimates still held by the offline smoother."""
        if self._paint:
            self._carry_back(len(self._window) - 1)
        out = []
        while self._window:
            out.append(self._final(self._smooth_pop()))
        return out

    # --- offline smoothing ---------------------------------------------------------
    def _smooth(self, i: int) -> None:
        """Smooth the held estimate at window position ``i``, once: the RTS
        smoother over the run of filtered frames that starts with it (until a
        reset, the window's end or the lag's frames ahead), then a centre
        move's step (:meth:`_move_centre`). Done when the frame is ``lag``
        frames old, as the fixed-lag smoother pops it: a frame held longer,
        waiting for a camera carried back (:meth:`_carry_back`), keeps what it
        had then (with the clip's later k1 estimate, the artificial-turf
        clip's held opening was bent off its paint, 0.98 -> 0.87)."""
        if i < 0 or i >= len(self._window) or self._window[i].info.get("smoothed"):
            return
        est = self._window[i]
        run = []
        for j in range(i, min(len(self._window), i + self.lag + 1)):
            e = self._window[j]
            if "kf" not in e.info or e.info["kf"][4] != est.info.get("kf", (None,) * 5)[4]:
                break
            run.append(e)
        if len(run) >= 2 and "kf" in est.info:
            Xs = np.array([e.info["kf"][0] for e in run])
            Ps = np.array([e.info["kf"][1] for e in run])
            Fs = np.array([e.info["kf"][2] for e in run])
            Qs = np.array([e.info["kf"][3] for e in run])
            xs, _, _, _ = self._smoother.rts_smoother(Xs, Ps, Fs, Qs)
            centre = est.info["centre"]
            cam = self._camera_from_state(xs[0], centre)
            est = CameraEstimate(est.frame, est.pts, est.status, cam, est.confidence, {k: v for k, v in est.info.items() if k != "kf"})
        ramp = est.info.pop("ramp", None)
        if ramp and est.camera is not None:
            cam = est.camera
            for w, step in ramp:
                cam = step.apply(cam, w)
            est = CameraEstimate(est.frame, est.pts, est.status, cam, est.confidence, est.info)
        est.info["smoothed"] = True
        self._window[i] = est

    def _smooth_pop(self) -> CameraEstimate:
        """Pop the oldest estimate of the window, smoothed (:meth:`_smooth`)."""
        self._smooth(0)
        return self._window.popleft()

    # --- the per-frame logic ---------------------------------------------------------
    def _is_cut(self, image, thumb=None) -> bool:
        if thumb is None:
            if image is None:
                return False
            thumb = grey_thumbnail(image)
        prev, self._prev_thumb = self._prev_thumb, thumb
        return prev is not None and float(np.mean(np.abs(thumb - prev))) > self.cfg.cut_threshold

    def _solve(self, index: int, pts: float, image, det, thumbnail=None) -> CameraEstimate:
        cut = self._is_cut(image, thumbnail)
        if cut:
            self.stats["cuts"] += 1
            self._cut_seen = True
            if self.lag:
                self._cuts = {k for k in self._cuts if k > index - self.holds} | {index}
            self.reset()
        if det is None or not getattr(det, "pitch_visible", True) or len(det.line_points) < 30:
            self.reset()
            return CameraEstimate.lost(index, pts, reason="no pitch")
        view = None
        if self._paint and image is not None:
            view = self._paint_view(index, image, det)
            lidx = LineIndex(np.concatenate([det.line_points, view.points]))
        else:
            lidx = LineIndex(det.line_points)
        kf = self._kf
        pred_cam = None
        meas: Refinement | None = None
        centre = self.centre if self.centre is not None else self._centre_cur
        before, self._grey_last = (None if cut else self._grey_last), (self._grey(image) if self._paint and image is not None else None)
        swept_prev, self._swept_prev = self._swept_prev, False
        source = "track"
        manoeuvre = False
        if kf is not None:
            # over the frames since the filter's last step (a live source drops frames)
            kf.F, kf.Q = self._motion(min(max(index - self._kf_at, 1), 25))
            kf.predict()
            self._kf_at = index
            pred_cam = self._camera_from_state(kf.x, centre)
            want_k1 = self._want_k1(pred_cam.focal)
            flow_cam, manoeuvre = self._moved_by_image(index, pred_cam, before, self._grey_last) if before is not None and self._grey_last is not None else (None, False)

            def track_refine(cam: Camera, radii) -> Refinement:
                return refine_camera(cam, lidx, self.size, self.model, center=self.centre, estimate_k1=want_k1, radii=radii, max_points=400)

            # the image moved otherwise than the motion model says (real frames: a
            # whip pan starting or stopping): start from where the image's own
            # motion puts the camera, and from the prediction only if that fails
            for start in (flow_cam, pred_cam) if flow_cam is not None else (pred_cam,):
                # (in a whip pan that the sweep is following, the wide search only fails)
                for radii in ((4.0,),) if swept_prev else ((4.0,), (25.0, 10.0, 4.0, 2.5)):
                    # a close prediction needs one short round (a second when it moved the
                    # camera, matches being nearest neighbours); a fast pan a wider search.
                    # A round that moved the camera by more than 2 px had not converged (a
                    # sudden change of pan speed): up to two more at the same radius
                    # before the last, narrower one, which would settle on a partial fit
                    # (unless it found too little to be a measurement: the wide search is next)
                    try:
                        r = track_refine(start, radii)
                        if len(radii) == 1:
                            moved = step = _image_shift(start, r.camera, centre, self.size)
                            for _ in range(2):
                                if step <= 2.0 or r.confidence < self.cfg.accept_low:
                                    break
                                r2 = track_refine(r.camera, radii)
                                step = _image_shift(r.camera, r2.camera, centre, self.size)
                                r = r2
                            if moved > 1.0:
                                r = track_refine(r.camera, (2.5,))
                    except ValueError:
                        continue
                    if meas is None or r.confidence > meas.confidence:
                        meas = r
                        source = "flow" if start is flow_cam else "track"
                    # as good as this clip's recent frames: no need to search wider
                    if meas.confidence >= min(0.85, self._conf_ref - 0.05):
                        break
                if meas is not None and meas.confidence >= self.cfg.accept_low:
                    break
            if meas is not None and meas.confidence < self.cfg.accept:
                # blur or occlusion hides markings (low recall): still a measurement
                # when what was detected lies on the projected markings (precision)
                if self._paint and image is not None and meas.confidence >= self._complete(self.cfg.accept_low) and backs(*self._support(index, meas.camera, image), self.cfg.min_support):
                    # real frames: the paint pixels' recall is lower than a clean
                    # picture's, and much of the paint is no marking (boards, shirts):
                    # the frame's white paint backs the camera, as the output test
                    # asks, and it is about as complete as this clip's are (_complete)
                    pass
                elif meas.confidence < self.cfg.accept_low or explained_share(meas.camera, lidx, self.size, self.model) < self.cfg.min_explained:
                    meas = None
                elif image is not None and self.centre is not None:
                    meas = self._pan_by_brightness(meas, image, lidx)
        swept_rates = None  # the filter's rates when a sweep restarts it
        filt_cam: Camera | None = None  # the filter's camera after its update, when judged there
        if meas is None and pred_cam is not None and self.centre is not None and self.cfg.sweep_range > 0:
            # a pan faster than the motion model (a whip pan): blur leaves few markings
            # and the prediction falls behind; search the pan angle, which such a move changes
            meas = self._pan_sweep(pred_cam, lidx, image)
            if meas is not None:
                source = "sweep"
                self.stats["swept"] += 1
                self._swept_prev = True
                swept_rates = self._kf.x[1::2, 0].copy()
                self._kf = None  # re-anchored: restart the filter from this measurement
        rival = None  # the paint initialiser's (refinement, support), when it beat the detector's camera
        # the detector's camera where it falls short of init_accept: judged on
        # the paint with the paint initialiser's hypotheses, not dropped (a
        # real frame's paint leaves the detector's lines short of the markings:
        # the circle's right camera at 0.59 lost to a hypothesis on lines of
        # other sports, docs/real-footage.md point 2)
        weak = None
        if meas is None:
            r = initialise_camera(det, lidx, self.size, self.model, principal_point=self.pp, pitch=self.pitch, centre=None, estimate_k1=False, prior=pred_cam)
            if r is not None and r.confidence >= self.cfg.init_accept and image is not None and index - self._paint_at >= self.cfg.rival_every:
                view = view or self._paint_view(index, image, det)
                rival = self._paint_rival(index, r, view, det)
                if rival is not None:
                    r = None  # (taken as the paint initialiser's camera below)
            if r is not None and r.confidence >= self.cfg.init_accept:
                meas = r
                source = "init"
                self.stats["inits"] += 1
                tripod = self._tripod()
                if tripod is not None and np.linalg.norm(r.camera.center - tripod) > self.cfg.centre_break:
                    # is it the same tripod? try the frozen centre
                    try:
                        rc = refine_camera(r.camera, lidx, self.size, self.model, center=tripod, estimate_k1=self._want_k1(r.camera.focal))
                    except ValueError:
                        rc = None
                    if rc is not None and rc.confidence >= r.confidence - 0.05:
                        meas = rc
                    elif self._another_camera(index, r.camera):
                        self.reset(keep_centre=False)
                    else:
                        meas = None
                elif self.centre is not None:
                    try:
                        rc = refine_camera(r.camera, lidx, self.size, self.model, center=self.centre, estimate_k1=self._want_k1(r.camera.focal))
                        if rc.confidence >= r.confidence - 0.05:
                            meas = rc
                    except ValueError:
                        pass
                if self._kf is not None and pred_cam is not None:
                    self._kf = None  # re-anchored: restart the filter from this measurement
            elif r is not None:
                weak = r.camera
        if meas is None and image is not None and (rival is not None or index - self._paint_at >= self.cfg.paint_every):
            # real frames: faint, thin lines the ridge detector misses; straight
            # lines of the white paint, scored against the frame (costly: not every frame)
            self._paint_at = index
            view = view or self._paint_view(index, image, det)
            r, sup = rival or initialise_from_paint(view, self.size, principal_point=self.pp, pitch=self.pitch, circles=det.ellipses, lines=det.lines, seeds=() if weak is None else (weak,))
            if r is not None and sup >= self.cfg.paint_accept:
                meas, source = r, "paint"
                self.stats["paint_inits"] += 1
                self._paint = True
                self._kf = None
                tripod = self._tripod(pred_cam)
                far = tripod is not None and np.linalg.norm(r.camera.center - tripod) > self.cfg.centre_break
                if self.centre is not None or far:
                    # the same tripod? the frozen centre, unless the frame's
                    # paint backs it clearly less (the paint's initialiser
                    # knows no centre); a centre given up only where the
                    # camera is far from it
                    try:
                        rc = refine_camera(r.camera, lidx, self.size, self.model, center=tripod, estimate_k1=self._want_k1(r.camera.focal), radii=(10.0, 5.0, 3.0))
                    except ValueError:
                        rc = None
                    sc = None if rc is None else self._support(index, rc.camera, image)[0]
                    if sc is not None and sc >= min(sup, self.cfg.paint_accept) - 0.05:
                        meas = rc
                    elif far:
                        if self._another_camera(index, r.camera):
                            self.reset(keep_centre=False)
                        else:
                            meas = None
        if meas is not None and not plausible(meas.camera.center, meas.camera.focal, self.size[0], self.pitch)[0]:
            # no main broadcast camera (a refinement that slid along one line to a
            # camera on the grass or a fisheye): no measurement
            self.stats["implausible"] += 1
            meas = None
        if meas is None:
            if self._kf is not None and self._coast < self.cfg.max_coast and pred_cam is not None:
                self._coast += 1
                return self._estimate(index, pts, "tracked", pred_cam, 0.3 * (1 - self._coast / (self.cfg.max_coast + 1)), centre)
            self.reset()
            lost = CameraEstimate.lost(index, pts, reason="no camera")
            if self.lag and image is not None:
                lost.info["image"] = image.copy()  # (while held: a later camera may reach it, _carry_back)
            return lost
        self._learn(meas, lidx)
        if self._paint and self.centre is not None and self._kf is not None and source in ("track", "flow") and index - self._centre_check_at >= self.cfg.centre_every:
            meas = self._check_centre(index, meas, lidx)
        centre = self.centre if self.centre is not None else meas.camera.center
        self._centre_cur = centre
        z = _ptz_vector(meas.camera, centre)
        Rz = self._measurement_noise(meas)
        if self._paint and manoeuvre:
            # the operator changing the pan's pace: the paint noise would make the
            # filter lag it by several frames; the measurement's own noise, this frame
            Rz = self._measurement_noise(meas, own=True)
            self.stats["manoeuvres"] += 1
        if self._kf is None:
            rate = None
            if swept_rates is not None and self._last_z is not None:
                # panning on at the pace since the last measurement, not from rest; tilt,
                # roll and zoom at the filter's rates (two blurred frames would make them noise)
                rate = swept_rates
                rate[0] = _wrap(z[0] - self._last_z[1][0]) * self.fps / max(index - self._last_z[0], 1)
            self._kf = self._new_filter(z, Rz, rate)
            self._kf_id = self._kf_at = index
        else:
            kf = self._kf
            y = z - (kf.H @ kf.x).ravel()
            y[0] = _wrap(y[0])
            S = kf.H @ kf.P @ kf.H.T + Rz
            d2 = float(y @ np.linalg.solve(S, y))
            gated = d2 > self.cfg.gate and source == "track" and meas.confidence < self.cfg.trusted
            if gated and self._gated_prev and meas.confidence >= self.cfg.accept:
                # a second well-supported measurement in a row against the motion model:
                # the model is wrong (a sudden pan), not the measurements; restart from it
                self.stats["reanchored"] += 1
                self._kf = kf = self._new_filter(z, Rz)
                self._kf_id = self._kf_at = index
            elif gated:
                # an outlier against the motion model: carry the prediction instead
                self.stats["gated"] += 1
                self._gated_prev = True
                self._coast += 1
                if self._coast > self.cfg.max_coast:
                    self.reset()
                    return CameraEstimate.lost(index, pts, reason="gated")
                return self._estimate(index, pts, "tracked", pred_cam, 0.3, centre)
            else:
                x0, P0 = kf.x.copy(), kf.P.copy()
                kf.update(z, R=Rz)
                if self._paint and not manoeuvre and self.centre is not None:
                    filt_cam = self._camera_from_state(kf.x, centre)
                    if self._lags(index, meas, filt_cam):
                        # the filter's camera lies off the paint its measurement is
                        # on: the pan changed pace more gently than the image-motion
                        # test sees, or the paint noise is too much for this clip's
                        # measurements and keeps the filter behind a pan. This
                        # measurement with its own noise (and the filter sure of a
                        # state that is off by the innovation), and less paint
                        # noise from here on; it grows back while the filter keeps up
                        kf.x, kf.P = x0, P0
                        kf.P[0::2, 0::2] += np.diag(y**2)
                        kf.update(z, R=self._measurement_noise(meas, own=True))
                        filt_cam = None  # (the state moved)
                        self._paint_noise = max(1.0, self._paint_noise / 4.0)
                        self.stats["manoeuvres"] += 1
                    else:
                        self._paint_noise = min(self.cfg.paint_noise, self._paint_noise * 1.25)
        self._gated_prev = False
        self._coast = 0
        self._last_z = (index, z)
        self._conf_ref = meas.confidence if self._conf_ref >= 1.0 else 0.9 * self._conf_ref + 0.1 * meas.confidence
        if self.centre is None:
            # no tripod centre yet: the filter's state (angles about each frame's own,
            # poorly determined centre) is not a camera to output; the measurement is
            return self._estimate(index, pts, "ok", meas.camera, meas.confidence, centre, source=source, rms=meas.rms, filtered=False)
        # (the filter's camera once a frame: its line support is judged again below)
        cam = filt_cam if filt_cam is not None else self._camera_from_state(self._kf.x, centre)
        if self._paint and self._lags(index, meas, cam):
            # the filter still off the paint its measurement is on (a whip pan's
            # change of pace): the measurement, unsmoothed
            self.stats["unsmoothed"] += 1
            return self._estimate(index, pts, "ok", meas.camera, meas.confidence, centre, source=source, rms=meas.rms, filtered=False)
        est = self._estimate(index, pts, "ok", cam, meas.confidence, centre, source=source, rms=meas.rms)
        # the size's views on the white paint's pixels where the clip's paint is
        # used: the detector's line pixels also lie on lines of other sports and on
        # the boards' edges, which pull a size estimate toward them
        self._observe_pitch(index, est, view.points if view is not None else lidx.points)
        return est

    # --- the pitch's size ---------------------------------------------------------
    def _observe_pitch(self, index: int, est: CameraEstimate, points: np.ndarray) -> None:
        """With the pitch's size unknown, keep frame ``index`` as a view for its
        estimate (a measured camera about the frozen tripod centre that the paint
        backs, every ``pitch_spacing`` frames; ``points``: (N, 2) its line pixels); at ``pitch_views`` views, estimate
        it and, if it differs from the current size by more than its
        uncertainty, track with it from here on."""
        views, c = self._pitch_views, self.cfg
        if views is None or len(views) >= c.pitch_views[-1] or est.status != "ok" or est.camera is None:
            return
        if index - self._pitch_view_at < c.pitch_spacing or (est.info.get("support") or 0.0) < c.pitch_support:
            return
        self._pitch_view_at = index
        views.append(PitchView(est.camera, np.array(points, np.float64), self.size))
        if self._watch_pitch or len(views) not in c.pitch_views:
            return
        try:
            size = estimate_pitch_size(views, self.pitch, centre=self.centre)
        except ValueError:
            return
        self.pitch_size = size
        if not any(size.constrained):
            return
        if all(size.constrained):
            self._pitch_views = None  # both fixed: once per clip
        dl = abs(size.length - self.pitch.length)
        dw = abs(size.width - self.pitch.width)
        if dl <= max(2 * (size.length_sd or 0.0), 0.25) and dw <= max(2 * (size.width_sd or 0.0), 0.25):
            return  # the current size is within the estimate's uncertainty
        self.pitch = size.model(self.pitch.line_width)
        self.model = ModelSamples.from_pitch(self.pitch, 0.5)
        self.centre = np.asarray(size.centre, np.float64)
        self._centres.clear()
        self.stats["pitch_changes"] += 1
        if self._pitch_views is not None:
            # the views' cameras were made with the old size: the next estimate starts from the new one
            self._pitch_views = [PitchView(cam, v.points, v.size) for cam, v in zip(size.cameras, self._pitch_views)]
        # the filter goes on from this frame's camera under the new size, at its rates
        z = _ptz_vector(size.cameras[-1], self.centre)
        rates = self._kf.x[1::2, 0].copy() if self._kf is not None else None
        Rz = self._kf.R.copy() if self._kf is not None else np.diag([1e-6, 1e-6, 1e-6, 1e-5])
        self._kf = self._new_filter(z, Rz, rates)
        self._kf_id = self._kf_at = index

    def pitch_seen(self, max_sd: float = SIZE_MAX_SD) -> PitchSize | None:
        """The pitch's size estimated from the views kept so far (with
        ``watch_pitch``: all of them made at the size tracked with; a
        dimension they do not fix, its standard deviation over ``max_sd``
        metres, keeps that size, with no standard deviation), or None without ``watch_pitch``, with fewer than the
        first estimate's count of views (``TrackerConfig.pitch_views``), or
        when their markings do not match their paint. Of the
        (at most ``pitch_views[-1]``) views kept, ``pitch_views[1]`` evenly
        spread are fitted: the estimate's jackknife costs a fit per view,
        and half of 24 views estimate the size as all of them do on the
        realistic synthetic clips (within 0.1 m at 105 x 68; 1-3.5 s
        against 4-14 s on this machine's 2 cores)."""
        views = self._pitch_views
        if not self._watch_pitch or views is None or len(views) < self.cfg.pitch_views[0]:
            return None
        n = min(len(views), self.cfg.pitch_views[1])
        views = [views[int(i)] for i in np.round(np.linspace(0, len(views) - 1, n))]
        try:
            return estimate_pitch_size(views, self.pitch, centre=self.centre, max_sd=max_sd)
        except ValueError:
            return None

    def _pan_sweep(self, pred: Camera, lidx: LineIndex, image: np.ndarray | None = None) -> Refinement | None:
        """Re-find the camera after a pan the filter did not follow: score pan angles
        around the prediction ``pred`` (tripod centre fixed; tilt, roll and f kept) by
        the share of projected markings with a detected line pixel nearby, refine
        from the best, and accept it only if that peak is clear of the rest and the
        refinement explains the detected line pixels. With the frame (``image``,
        BGR or grey) the pan is then set by :meth:`_pan_by_brightness`.

        A refinement that finds the markings (``sweep_accept``) but leaves
        more than ``1 - sweep_explained`` of the detected line pixels
        unexplained means those pixels are not all markings (the lines of
        other sports, boards): the tracker turns to the frame's paint, as it
        does once the paint initialiser has found a camera (``_paint``), so
        that later refinements are judged by the paint, not refused for the
        detector's other lines (on `real-multisport` 21 the pan-only sweeps
        that followed carried the zoom rate of one step for 12 frames)."""
        c = self.cfg
        W = self.size[0]
        ptz = PTZ(*ptr_from_rotation(pred.R), f=pred.focal)
        step_px = max(c.sweep_step * W, 1.0)
        n = int(round(c.sweep_range / c.sweep_step))
        offsets = np.arange(-n, n + 1)
        dist = (self._k1_for(pred.focal),) if self.k1 else ()
        base = camera_from_ptz(self.centre, ptz, self.pp, dist=dist)
        pts = _window_points(base, self.centre, offsets * step_px, self.model.points, self.size)
        px, inside = _panned_views(base, self.centre, offsets * step_px, pts, self.size)
        support = view_supports(px, inside, lidx, 0.5 * step_px + 1.0, 150)
        k = int(np.argmax(support))
        away = np.abs(offsets - offsets[k]) > n // 2  # beyond the peak's own hump
        # markings along the pan (the touchlines in a horizontal whip) match at every
        # pan: the floor of the support says nothing about the pan, the rest must peak
        floor = support.min()
        if support[k] <= 0 or (away.any() and support[k] - floor < c.sweep_peak * (support[away].max() - floor)):
            return None
        try:
            start = camera_from_ptz(self.centre, PTZ(ptz.pan + offsets[k] * step_px / ptz.f, ptz.tilt, ptz.roll, ptz.f), self.pp, dist=dist)
            r = refine_camera(start, lidx, self.size, self.model, center=self.centre, estimate_k1=False, radii=(10.0, 4.0, 2.5), max_points=400)
        except ValueError:
            return None
        trusted = True
        if r.confidence < c.sweep_accept or explained_share(r.camera, lidx, self.size, self.model) < c.sweep_explained:
            if image is None or support[k] < c.sweep_accept:
                return None
            if r.confidence >= c.sweep_accept and not self._paint:
                # the markings found their line pixels, but many line pixels
                # are no marking (other sports' lines): the detector's lines
                # do not judge a camera here; the frame's paint does, from now on
                self._paint = True
                self.stats["paint_turns"] += 1
            # too few line pixels to fix tilt, roll and zoom (heavy blur): keep the
            # prediction's, which change slowly, and set only the pan
            r = replace(r, camera=start)
            self.stats["pan_only"] += 1
            trusted = False
        return self._pan_by_brightness(r, image, lidx if trusted else None) if image is not None else r

    def _pan_by_brightness(self, r: Refinement, image: np.ndarray, lidx: LineIndex | None = None) -> Refinement:
        """Set the pan of a measurement ``r`` (swept, or accepted on few line pixels)
        where the projected markings lie on the brightest structure across the rows.

        In a whip pan the markings across the motion (the halfway line, the sides
        of the centre circle) are smeared into wide faint bands that the ridge
        detector misses: the line pixels fix tilt, roll and zoom (lines along
        the motion stay sharp) but leave the pan loose by several pixels. A band
        is still brighter than the grass beside it, and centred on the marking's
        mid-exposure position: the mean of the frame's brightness above its
        running horizontal mean (61 px), taken along the projected markings,
        peaks at the right pan. Pans within ``sweep_fine`` of the width around
        ``r`` are scored a pixel apart; the pan is the midpoint of the score's
        half-height crossings (:func:`_hump_centre`: a band as wide as the blur
        gives a flat, uneven top), or its parabolic peak when the score does not
        fall to half inside the window. With the line pixels (``lidx``), tilt, roll
        and f are then refined again at that pan: the first refinement, with the
        pan loose, bent them to make up for it (by 1-2 px)."""
        c = self.cfg
        gray = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        g = gray.astype(np.float32)
        bright = cv2.subtract(g, cv2.blur(g, (61, 1)))
        np.maximum(bright, 0.0, out=bright)
        ptz = PTZ(*ptr_from_rotation(r.camera.R), f=r.camera.focal)
        dist = r.camera.dist
        n = max(int(round(c.sweep_fine * self.size[0])), 1)
        offsets = np.arange(-n, n + 1, dtype=np.float64)

        def camera(dx: float) -> Camera:
            return camera_from_ptz(self.centre, PTZ(ptz.pan + dx / ptz.f, ptz.tilt, ptz.roll, ptz.f), self.pp, dist=dist)

        pts = _window_points(r.camera, self.centre, offsets, self.model.points, self.size)
        if len(pts) > 1200:  # at most 1200 of them
            pts = pts[np.linspace(0, len(pts) - 1, 1200).astype(np.intp)]
        px, inside = _panned_views(r.camera, self.centre, offsets, pts, self.size)
        counts = inside.sum(axis=1)
        q = px[inside].astype(np.float32)  # row-major: the pans' samples one after the other
        vals = sample_bilinear(bright, q)
        sums = np.bincount(np.repeat(np.arange(len(offsets)), counts), weights=vals, minlength=len(offsets))
        score = np.where(counts >= 20, sums / np.maximum(counts, 1), 0.0)
        k = int(np.argmax(score))
        if not 0 < k < len(score) - 1 or score[k] <= 0:
            return r  # no peak inside the window: keep the line pixels' pan
        dx = _hump_centre(offsets, score, k)
        if dx is None:
            a, b, d = score[k - 1], score[k], score[k + 1]
            den = a - 2 * b + d
            dx = offsets[k] + (0.5 * (a - d) / den if den < 0 else 0.0)
        cam = camera(dx)
        if lidx is not None and abs(dx) >= 0.5:
            try:
                rf = refine_camera(cam, lidx, self.size, self.model, center=self.centre, fixed_pan=True, radii=(4.0, 2.5), max_points=400)
            except ValueError:
                rf = None
            if rf is not None and rf.confidence >= r.confidence - 0.05:
                cam = rf.camera
        return replace(r, camera=cam)

    def _grey(self, image: np.ndarray) -> np.ndarray:
        """The frame grey and halved (float32), for its image motion."""
        g = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        return cv2.resize(g, (g.shape[1] // 2, g.shape[0] // 2), interpolation=cv2.INTER_AREA).astype(np.float32)

    def _moved_by_image(self, index: int, pred: Camera, before: np.ndarray, grey: np.ndarray) -> tuple[Camera | None, bool]:
        """Real frames: the frame's own motion since the last one (phase
        correlation of the two, grey and halved: :func:`cv2.phaseCorrelate`).

        Returns (camera, manoeuvre). The camera is the prediction with its pan
        and tilt set so that the picture moved from the last frame's camera as
        the frame did, when that differs from the prediction by more than 3 px
        (else None). Manoeuvre: the motion changed pace since the last frame by
        more than ``TrackerConfig.manoeuvre`` pixels (a whip pan starting or
        stopping).

        The filter's constant-rate model lags a whip pan's start by several
        frames, and on real frames (paint noise) by more: a refinement started
        from the lagging prediction settles on markings beside their paint. The
        frame's own motion (grass, lines and stands; the players move less than
        a whip pan) does not lag."""
        flow_prev, self._flow = self._flow, None
        if before.shape != grey.shape:
            return None, False
        if self._hann is None or self._hann.shape != grey.shape:
            self._hann = cv2.createHanningWindow(grey.shape[::-1], cv2.CV_32F)
        # (copies: OpenCV 4.x and 5.0 multiply the inputs by the window in place
        # where their size needs no FFT padding, so the frame kept for the next
        # call was windowed twice; 5.1 does not)
        (dx, dy), response = cv2.phaseCorrelate(before.copy(), grey.copy(), self._hann)
        if response < 0.05:
            return None, False
        moved = np.array([dx, dy]) * (self.size[0] / grey.shape[1])
        self._flow = (index, moved)
        manoeuvre = flow_prev is not None and flow_prev[0] == index - 1 and float(np.hypot(*(moved - flow_prev[1]))) > self.cfg.manoeuvre
        if self._last_cam is None or self._last_cam[0] != index - 1 or self.centre is None:
            return None, manoeuvre
        centre = self.centre
        c = np.array([(self.size[0] - 1) / 2, (self.size[1] - 1) / 2])
        X = self._last_cam[1].backproject_to_pitch(c[None])
        if not np.all(np.isfinite(X)):
            return None, manoeuvre
        X3 = np.column_stack([X, np.zeros(1)])
        p0 = pred.project(X3)[0]
        miss = (c + moved) - p0  # where the frame's motion puts the point, less where the prediction does
        if not np.all(np.isfinite(miss)) or np.hypot(*miss) <= 3.0:
            return None, manoeuvre
        ptz = PTZ(*ptr_from_rotation(pred.R), f=pred.focal)
        # pan and tilt that move the point by ``miss`` (linearised at the prediction)
        J = np.empty((2, 2))
        e = 1e-4
        for k, (dp, dt) in enumerate(((e, 0.0), (0.0, e))):
            cam = camera_from_ptz(centre, PTZ(ptz.pan + dp, ptz.tilt + dt, ptz.roll, ptz.f), self.pp, dist=pred.dist)
            J[:, k] = (cam.project(X3)[0] - p0) / e
        try:
            dpt = np.linalg.solve(J, miss)
        except np.linalg.LinAlgError:
            return None, manoeuvre
        return camera_from_ptz(centre, PTZ(ptz.pan + dpt[0], ptz.tilt + dpt[1], ptz.roll, ptz.f), self.pp, dist=pred.dist), manoeuvre

    def _estimate(self, index, pts, status, cam, conf, centre, filtered: bool = True, **info) -> CameraEstimate:
        if self._image is not None and cam is not None:
            # never draw with a wrong camera: the frame's paint must back it (docs/evaluate.md)
            sup, spread = self._support(index, cam, self._image)
            info["support"] = sup
            info["spread"] = spread
            info["judged"] = cam
            # (a fresh initialisation also with its markings on painted lines,
            # not along bright steps: arstream.support.on_lines)
            fresh = info.get("source") in ("init", "paint")
            lines = on_lines(cam, self._image, self._bright[index], self.pitch) if fresh and sup is not None and backs(sup, spread, self.cfg.min_support) and index in self._bright else None
            if self._passes(index, sup, spread, info.get("source"), lines):
                self._unsupported = 0
            else:
                self.stats["unsupported"] += 1
                self._unsupported += 1
                if self._unsupported >= 3:  # a wrong camera the filter keeps: start afresh
                    self.reset(keep_centre=False, wrong=True)
                return _unsupported(index, pts, sup, spread)
        info["centre"] = np.array(centre, dtype=np.float64)
        if cam is not None:
            self._last_cam = (index, cam)
        if self.lag and self._kf is not None and filtered:
            kf = self._kf
            info["kf"] = (kf.x.copy(), kf.P.copy(), kf.F.copy(), kf.Q.copy(), getattr(self, "_kf_id", 0))
        return CameraEstimate(index, pts, status, cam, float(conf), info)

    def _paint_view(self, index: int, image: np.ndarray, det):
        """The frame's paint view; its white-paint mask is the line-support test's."""
        view = self.views.view(index, image, det, self.support_reach)
        self._keep_mask(index, view.bright)
        return view

    def _keep_mask(self, index: int, mask: np.ndarray) -> np.ndarray:
        """Keep frame ``index``'s line-support mask while the smoother holds the frame."""
        self._bright[index] = mask
        oldest = min(index - self.lag, self._window[0].frame if self._window else index)
        for k in [k for k in self._bright if k < oldest - 2]:
            del self._bright[k]
        return mask

    def _support(self, index: int, cam: Camera, image: np.ndarray | None = None) -> tuple[float | None, float]:
        """Line support of ``cam`` on frame ``index`` on white paint, and the
        share of its markings in view that are on paint (1 with fewer than 3 in
        view); the frame's mask is made from ``image`` once and kept while the
        smoother holds the frame."""
        hit = self._judged.get(id(cam))
        if hit is not None and hit[0] == index and hit[1] is cam:  # (a camera judged twice in a frame)
            return hit[2]
        mask = self._bright.get(index)
        if mask is None:
            if image is None:
                return None, 1.0
            mask = self._keep_mask(index, white_mask(image, reach=self.support_reach))
        out = backed_support(cam, mask, self.pitch, spacing=0.5)
        if len(self._judged) > 8:
            self._judged.clear()
        self._judged[id(cam)] = (index, cam, out)
        return out

    def _passes(self, index: int, sup: float | None, spread: float, source: str | None, lines: float | None = None) -> bool:
        """The test of a camera to output: line support at least ``min_support``
        with half its markings in view on paint (one long marking laid on one
        painted line does not make a camera right), and with ``lines`` (a
        fresh initialisation's :func:`arstream.support.on_lines`)
        :data:`arstream.support.ON_LINES` of its markings on paint on painted
        lines, not along bright steps. A tracked camera (not a fresh
        initialisation) is still shown within ``max_coast`` frames of a
        supported one at ``min_trusted``: blur in a fast pan hides the paint,
        not the camera."""
        if sup is None:
            return True
        if backs(sup, spread, self.cfg.min_support) and (lines is None or lines >= ON_LINES):
            self._supported_at = max(self._supported_at, index)
            return True
        return source not in ("init", "paint") and sup >= self.cfg.min_trusted and index - self._supported_at <= self.cfg.max_coast

    def _weak(self, est: CameraEstimate) -> bool:
        """Whether a later camera carried back may better ``est``
        (:meth:`_carry_back`): it has no camera (its picture kept), or one its
        paint backs below ``cfg.sure``."""
        if est.camera is None:
            return "image" in est.info
        sup = est.info.get("support")
        return sup is not None and sup < self.cfg.sure

    def _waits(self, est: CameraEstimate) -> bool:
        """Whether the held ``est`` waits for a camera to be carried back to it
        (:meth:`_carry_back`): one backed at ``cfg.sure`` has not been yet."""
        return self._paint and "image" in est.info and est.info.get("carried", 0.0) < self.cfg.sure and self._weak(est)

    def _carry_back(self, at: int) -> None:
        """Offline, on real frames: the camera of the held estimate ``at`` (a
        position in the window), when found afresh or backed by its paint at
        ``cfg.sure`` or more, is carried back over the frames just before it
        that are still held and were left without a camera or with a weaker
        one (:meth:`_weak`), back to the shot's first frame. Each is refined
        against its own paint from the later frame's camera moved on by the
        motion between the two frames after it (:class:`_CameraStep`: the pan
        goes on; else from the later camera as it is), about the tripod
        centre once frozen; the walk stops at the first frame whose paint does
        not back its refinement, at a frame backed at ``cfg.sure``, or at one
        walked over before from a camera backed as well (within
        ``cfg.carry_gain``: a later, better-backed camera walks again over
        the frames an earlier one carried its view to). A frame takes the
        refined camera when it had none or when its paint backs the refinement
        by ``cfg.carry_gain`` more than its own. Where a frame keeps its own
        camera, the walk's must agree with it (within ``cfg.carry_agree``
        px): one that does not ends the walk (a walk that went on past it
        made the output alternate between the walk's cameras and the frames'
        own: ``israel_league_wide`` mirrored after a move of the tripod
        centre, jitter 4.53 -> 2.15 px), and undoes what it put in since
        it last agreed when the frame's own camera is backed as well as the
        weakest of those (in a whip pan with a zoom, a walk that kept the
        focal length laid the long lines on their blurred paint better than
        the filter's camera and the centre circle 20 px inside its own; a
        walk that filled 15 frames at 0.97 is not undone by a sweep's camera
        at 0.56).

        Why: the paint initialiser runs every few frames while lost, and a
        camera found at frame k would otherwise leave the frames since the
        last try without one; and where a clip opens on a view its paint
        explains poorly (the centre circle in deep shadow, the markings beside
        another sport's lines), the filter starts from a camera the paint
        backs at 0.55-0.8 and takes a second or more to find the view, while
        the later, well-backed camera carried back lays each frame's markings
        on their paint (a synthetic opening of 37 frames: 20-35 px off -> 1.5
        px)."""
        if at < 0 or at >= len(self._window):
            return
        seed = self._window[at]
        fresh = seed.info.get("source") in ("paint", "init")
        if seed.status != "ok" or seed.camera is None or seed.info.get("seeded") or not (fresh or (seed.info.get("support") or 0.0) >= self.cfg.sure):
            return
        seed.info["seeded"] = True
        backing = seed.info.get("support") or 0.0
        after = self._window[at + 1] if at + 1 < len(self._window) else None
        nxt = after.camera if after is not None and after.frame == seed.frame + 1 else None
        cam, frame = seed.camera, seed.frame
        # (about the frozen centre, else the found camera's own: the main camera
        # does not leave its tripod between frames, and free poses of views the
        # paint backs poorly slide along their lines of sight)
        centre = self.centre if self.centre is not None else cam.center
        pending: list = []  # (position, estimate, mask) replaced since the walk last agreed with a frame's own camera
        for j in range(at - 1, -1, -1):
            prev = self._window[j]
            img = prev.info.get("image")
            if img is None or prev.frame != frame - 1 or frame in self._cuts or not self._weak(prev) or backing < prev.info.get("carried", -1.0) + self.cfg.carry_gain:
                break
            prev.info["carried"] = backing
            view = paint_view(img, None, reach=self.support_reach)
            # (from the later camera moved on by the motion, else from it as it
            # is: a fresh camera's successor differs from it by the filter's
            # correction as well as by the motion)
            for guess in [cam] if nxt is None else [_CameraStep.between(nxt, cam).apply(cam, 1.0), cam]:
                try:
                    r = refine_camera(guess, view.index, self.size, self.model, center=centre, radii=(10.0, 5.0, 3.0))
                except ValueError:
                    continue
                sup, spread = backed_support(r.camera, view.bright, self.pitch, spacing=0.5)
                if sup is not None and backs(sup, spread, self.cfg.min_support) and plausible(r.camera.center, r.camera.focal, self.size[0], self.pitch)[0]:
                    break
            else:
                break
            had = prev.info.get("support") if prev.camera is not None else None
            if had is None or sup >= had + self.cfg.carry_gain:
                pending.append((j, prev, self._bright.get(prev.frame), sup))
                self._keep_mask(prev.frame, view.bright)
                self._window[j] = CameraEstimate(prev.frame, prev.pts, "ok", r.camera, r.confidence, {"support": sup, "spread": spread, "judged": r.camera, "source": "backfill", "centre": np.array(centre, dtype=np.float64), "carried": backing, "image": img})
                self.stats[prev.status] -= 1
                self.stats["ok"] += 1
                self.stats["backfilled"] += 1
            elif _image_shift(prev.camera, r.camera, centre, self.size) <= self.cfg.carry_agree:
                pending.clear()  # (the frame's own camera agrees: what the walk replaced stands)
            else:
                # the frame's own camera lies elsewhere, and its paint backs
                # the walk's not clearly better (going on would leave this frame
                # on its own camera among the walk's): the walk ends, and when that camera is backed as well
                # as the weakest the walk put in since it last agreed, the walk
                # may have gone astray since (a whip pan's zoom that the motion
                # carried back did not follow): what it put in is undone
                if pending and had >= min(p[3] for p in pending):
                    for k, old, mask, _ in pending:
                        self._window[k] = old
                        if mask is not None:
                            self._bright[old.frame] = mask
                        self.stats["ok"] -= 1
                        self.stats[old.status] += 1
                        self.stats["backfilled"] -= 1
                break
            nxt, cam, frame = cam, r.camera, prev.frame

    def _final(self, est: CameraEstimate) -> CameraEstimate:
        """The line-support test again on the camera that is output (the
        smoother moved it): one that fails is "lost"."""
        for key in _HELD:
            est.info.pop(key, None)
        if est.camera is None or "support" not in est.info:
            return est
        if est.camera is est.info.get("judged"):  # (live: the camera judged when it was made)
            return est
        sup, spread = self._support(est.frame, est.camera)
        judged, was = est.info.get("judged"), est.info["support"]
        if judged is not None and sup is not None and was is not None and sup < was - self.cfg.smooth_slack:
            # the smoother moved the camera off the paint that the filter's own
            # estimate lay on (a change of pace the motion model lags): that one
            self.stats["unsmoothed"] += 1
            est = CameraEstimate(est.frame, est.pts, est.status, judged, est.confidence, est.info)
            sup, spread = was, est.info.get("spread", 1.0)
        if self._passes(est.frame, sup, spread, est.info.get("source")):
            est.info["support"] = sup
            return est
        self.stats["unsupported"] += 1
        self.stats[est.status] -= 1
        self.stats["lost"] += 1
        return _unsupported(est.frame, est.pts, sup, spread)

    def _lags(self, index: int, meas: Refinement, cam: Camera) -> bool:
        """Whether the filter's camera ``cam`` (its state after the update) is
        less supported by frame ``index``'s paint than the measurement
        ``meas`` by more than ``smooth_slack``."""
        if self._image is None:
            return False
        was, _ = self._support(index, meas.camera, self._image)
        now, _ = self._support(index, cam, self._image)
        return was is not None and now is not None and now < was - self.cfg.smooth_slack

    def _want_k1(self, focal: float) -> bool:
        """Whether a refinement at this focal length estimates k1: not once it was
        found to be 0, nor on real frames where k1 is not observable
        (:func:`arstream.solve.k1_observable`: a refinement there fits noise)."""
        return (self.k1 is None or self.k1 != 0.0) and (not self._paint or k1_observable(focal, self.size))

    def _paint_rival(self, index: int, r: Refinement, view, det) -> tuple[Refinement, float] | None:
        """The paint initialiser's camera and its line support where it should
        replace the camera ``r`` initialised from the detector's lines (the
        judgement :func:`arstream.initialise.register_frame` makes for a still):
        when the frame's paint does not back ``r``
        (:func:`arstream.initialise.paint_verdict`) or backs it with less than
        :data:`arstream.initialise.PAINT_CHECK`, the paint initialiser runs as
        for a still (:func:`arstream.initialise.still_paint_camera`), and its camera wins when the
        paint backs it and not ``r``, or backs it more by
        :func:`arstream.initialise.paint_score`. Else None.

        The ridge detector's lines on a real frame can fit a member of the
        centre circle's depth-zoom family (twice as far, twice the focal
        length) that lays the circle and the halfway line right and the rest
        on other lines: the artificial-turf clip pillarboxed (12.5 %) started
        on one 850 px off its reference and kept it.
        """
        sup, spread = self._support(index, r.camera, view.image)
        backed = paint_verdict(r.camera, sup, spread, view, self.size, self.pitch, self.cfg.min_support) is None
        if backed and sup >= PAINT_CHECK:
            return None
        self._paint_at = index
        rp, sp = still_paint_camera(view, self.size, principal_point=self.pp, pitch=self.pitch, detections=det, penalty_arcs=False, min_sides=None, more_splits=0)
        if rp is None or sp < self.cfg.paint_accept:
            return None
        sp2, spread_p = self._support(index, rp.camera, view.image)
        if paint_verdict(rp.camera, sp2, spread_p, view, self.size, self.pitch, self.cfg.min_support) is not None:
            return None
        if not backed or paint_score(rp.camera, sp2, view, self.size, self.model) > paint_score(r.camera, sup, view, self.size, self.model):
            self.stats["paint_rivals"] += 1
            return rp, sp
        return None

    def _tripod(self, recent: Camera | None = None) -> np.ndarray | None:
        """The centre a fresh camera is checked against (the same tripod?): the
        frozen one, else the one given up with a camera its paint stopped
        backing (:meth:`reset`'s ``wrong``), else the centre of ``recent``
        (the filter's prediction: a camera a moment ago, before any centre
        was frozen), else None."""
        if self.centre is not None:
            return self.centre
        if self._given_up is not None:
            return self._given_up
        return None if recent is None else recent.center

    def _another_camera(self, index: int, cam: Camera) -> bool:
        """Is a fresh camera far from the tripod centre, which the frozen centre
        does not fit, another camera (True: give the centre up for it)?

        After a shot cut, yes: the director cut to another camera. Within the
        shot the main camera stays on its tripod, and such a camera is far
        more often a wrong initialisation (a letterboxed artificial-turf clip:
        a camera 48 m along the touchline with 4 times the focal length, drawn
        on 45 frames) than a camera moved: it is believed when a second one
        agrees with it (centres within ``centre_break``) within
        ``other_within`` frames; till then it is no measurement."""
        prev, self._other = self._other, (index, cam.center)
        if self._cut_seen:
            return True
        if prev is not None and index - prev[0] <= self.cfg.other_within and np.linalg.norm(prev[1] - cam.center) <= self.cfg.centre_break:
            self.stats["other_cameras"] += 1
            return True
        self.stats["other_refused"] += 1
        return False

    def _learn(self, r: Refinement, lidx: LineIndex) -> None:
        """Update the tripod centre and the lens distortion from a confident
        measurement (``lidx``: its frame's line pixels)."""
        if self.centre is None and self._add_centre(r) and len(self._centres) >= self.cfg.centre_frames:
            self.centre = self._best_centre()
            self._given_up = None
            self._centre_view, self._axis_tries = (lidx, r.camera), 0
            self._cut_seen = False
            if self._paint and self._kf is not None:
                # real frames: keep the filter's rates (a pan goes on); its angles
                # were about each frame's own centre: widen them, not restart
                self._kf.P[0::2, 0::2] += np.diag([1e-4, 1e-4, 1e-4, 1e-3])
            else:
                self._kf = None  # restart the filter about the frozen centre
        if self.k1 != 0.0 and r.camera.dist and r.n_visible >= 250 and r.confidence >= 0.7:
            # k1 scales like 1/f for a zoom lens: keep k1 * f samples
            self._k1_samples.append(r.camera.dist[0] * r.camera.focal)
            if len(self._k1_samples) >= 5:
                med = float(np.median(self._k1_samples[-15:]))
                if self.k1 is None and abs(med / r.camera.focal) < 0.004:
                    self.k1 = 0.0  # no measurable distortion: stop estimating it
                else:
                    self.k1 = med / r.camera.focal
                    self._k1_f = r.camera.focal

    _k1_f: float | None = None

    def _complete(self, level: float) -> float:
        """The least confidence (share of the markings in view near a line pixel)
        of a measurement taken as complete: ``level``, or on real frames as
        complete as this clip's accepted measurements are (their running level
        less 0.1), when that is lower: a frame's paint puts 0.54 of the
        markings in view near a paint pixel on the shared Premier League
        frames, 0.7 on israel_league_wide."""
        return min(level, self._conf_ref - 0.1) if self._paint else level

    def _centre_sd(self, r: Refinement) -> float | None:
        """The largest standard deviation (m) of a free-pose measurement's
        centre, or None when it has none or it is not finite."""
        names = list(r.params)
        if "cx" not in names:
            return None
        sd = np.sqrt(np.maximum(np.diag(r.covariance)[[names.index(n) for n in ("cx", "cy", "cz")]], 0))
        return float(sd.max()) if np.all(np.isfinite(sd)) else None

    def _add_centre(self, r: Refinement) -> bool:
        """Keep a free-pose measurement's centre as a tripod-centre candidate, with
        its largest standard deviation, when it is complete and certain enough
        (``centre_sigma``); returns whether it was kept."""
        sd = self._centre_sd(r)
        if sd is None or r.confidence < self._complete(0.7) or sd >= self.cfg.centre_sigma:
            return False
        self._centres.append((sd, r.camera.center))
        return True

    def _best_centre(self) -> np.ndarray:
        """The tripod centre: the median of the more certain half (at least
        ``centre_frames``) of the free-pose centres so far."""
        best = sorted(self._centres, key=lambda e: e[0])[: max(self.cfg.centre_frames, len(self._centres) // 2)]
        return np.median(np.array([c for _, c in best]), axis=0)

    def _check_centre(self, index: int, meas: Refinement, lidx: LineIndex) -> Refinement:
        """Real frames: check the frozen tripod centre against a free-pose
        refinement of this frame's measurement, every ``centre_every`` frames.

        The centre is frozen from the clip's first confident views. A view of
        the centre circle from far away fixes it poorly along the line of sight
        (its focal length and distance trade), and a wrong centre makes every
        later frame bend its focal length and k1 to fit. Two ways move it:

        * a later view with a smaller uncertainty (a penalty area's lines at
          several depths) joins the candidates; when the median of the most
          certain ones moves by more than ``centre_move`` metres;
        * the first views, tracked one from the next, share one basin of that
          trade, and a free pose started from a measurement about a wrong
          centre stays in it. So the free pose is also started from the
          measurement moved along its line of sight (the camera at ``0.8``,
          ``0.9`` and ``1.1`` times its distance from the pitch point under the
          image centre, keeping its picture: :func:`arstream.solve.seated`),
          searched from 20 px in. When
          the best of them lays :attr:`TrackerConfig.centre_sure` of the
          markings in view near a line pixel, ``centre_gain`` more than the
          measurement, from a centre more than ``centre_move`` away, the
          frames checked before (up to ``centre_recall`` of them) are refined
          about that centre: when they are explained better on average and
          none clearly worse (``centre_gain`` / 2), the centre goes there and
          the candidates start again from it (a free pose of one frame is
          not trusted alone: through a long lens they scatter by metres).

        And once the view has turned from the one the centre was fixed in, the
        two views triangulate it (:meth:`_along_first_axis`), before the two
        ways above.

        Any way the tracker goes on about the new centre: the measurement
        refined about it, the filter's angles set to it (its rates kept, its
        angle variances widened). Returns the measurement to use."""
        self._centre_check_at = index
        want_k1 = self._want_k1(meas.camera.focal)
        try:
            # (several rounds: along the line of sight the fit is flat, and a round or
            # two from the frozen centre stop short of the view's own)
            rf = refine_camera(meas.camera, lidx, self.size, self.model, center=None, estimate_k1=want_k1, radii=(4.0, 2.5, 2.5, 2.5, 2.5), max_points=400)
        except ValueError:
            return meas
        recent = list(self._centre_views)
        self._centre_views.append((lidx, meas.camera, meas.confidence))
        rc = self._along_first_axis(meas, lidx, want_k1)
        if rc is not None:
            new = rc.camera.center
            self._centres = [(self.cfg.centre_sigma, new)]
            return self._move_centre(index, new, rc, meas.camera)
        # (a measurement within centre_gain of all markings near a line pixel: none can beat it)
        best = self._free_pose_along_sight(meas, lidx, rf, want_k1) if meas.confidence + self.cfg.centre_gain <= 1.0 else rf
        if best.confidence >= max(self.cfg.centre_sure, meas.confidence + self.cfg.centre_gain) and np.linalg.norm(best.camera.center - self.centre) > self.cfg.centre_move:
            new = best.camera.center
            if self._explains_better(new, recent):
                try:
                    rc = refine_camera(best.camera, lidx, self.size, self.model, center=new, estimate_k1=want_k1, radii=(4.0, 2.5), max_points=400)
                except ValueError:
                    rc = None
                if rc is not None and rc.confidence >= meas.confidence:
                    self._centres = [(self._centre_sd(best) or self.cfg.centre_sigma, new)]
                else:
                    rc = None
        if rc is None:
            if not self._add_centre(rf) or len(self._centres) < self.cfg.centre_frames:
                return meas
            new = self._best_centre()
            if np.linalg.norm(new - self.centre) <= self.cfg.centre_move:
                return meas
            try:
                rc = refine_camera(rf.camera, lidx, self.size, self.model, center=new, estimate_k1=want_k1, radii=(4.0, 2.5), max_points=400)
            except ValueError:
                return meas
            if rc.confidence < meas.confidence - 0.05:
                return meas
        self._centre_view, self._axis_tries = (lidx, meas.camera), 0  # (a view's own fix: along its axis again, should the view turn)
        return self._move_centre(index, new, rc, meas.camera)

    def _move_centre(self, index: int, new: np.ndarray, rc: Refinement, before: Camera) -> Refinement:
        """:meth:`_check_centre`'s move of the tripod centre to ``new``: the
        filter's angles set to ``rc`` (its camera about ``new``), its rates
        kept and its angle variances widened. Returns ``rc``.

        The frame's camera about the old centre (``before``) and about the new
        one differ by a step in the picture (the correction the move makes).
        Offline, the frames the smoother still holds take that step in equal
        parts (:class:`_CameraStep`, applied by :meth:`_smooth_pop`): the one ``n`` frames before this one by ``1 -
        n / (lag + 1)`` of it, so the picture goes over in ``lag + 1`` steps,
        not one."""
        if self.lag:
            step = _CameraStep.between(before, rc.camera)
            for e in self._window:
                n = index - e.frame
                if e.camera is not None and 0 < n <= self.lag:
                    e.info.setdefault("ramp", []).append((1.0 - n / (self.lag + 1), step))
        self.centre = new
        self.stats["centre_moves"] += 1
        kf = self._kf
        z = _ptz_vector(rc.camera, new)
        y = z - kf.x[0::2, 0]
        y[0] = _wrap(y[0])
        kf.x[0::2, 0] += y
        kf.P[0::2, 0::2] += np.diag([1e-4, 1e-4, 1e-4, 1e-3])
        self._kf_id = index  # (the smoother must not mix angles about two centres)
        return rc

    def _along_first_axis(self, meas: Refinement, lidx: LineIndex, want_k1: bool) -> Refinement | None:
        """The measurement refined about a centre that two views triangulate,
        or None: once the view has turned ``axis_turn`` degrees from the one
        the tripod centre was fixed in (``axis_tries`` times a centre at most).

        A view of the centre circle from far away fixes the centre only along
        its line of sight (the focal length and the distance trade), and the
        first views of a clip often show nothing else: on
        ``israel_league_wide`` softened (a 1.2 px blur) from frame 60 on, the
        centre was frozen 7 m too far out, and after the pan to the penalty
        area every frame was drawn 40-60 px off at a line support of about
        0.6. The centre lies near that view's axis; a view turned from it sees
        the axis across its own line of sight.

        * *The basin.* The measurement is refined about centres along the
          first view's axis (every ``axis_step`` metres up to ``axis_span``
          either way, then half a step either side of the best); the best
          must lay ``centre_gain / 2`` more of the markings in view near a
          line pixel than the same search about the centre itself (the
          measurement can have stopped short), from more than
          ``centre_move`` away.
        * *The point.* The grid's point can be a metre or two off (its 2 m
          steps, and the turned view alone is flat along its own line of
          sight), and a later free pose then no longer moves it. Both views
          are fitted jointly about one centre started there
          (:meth:`_two_views`, :func:`arstream.tripod.fit_tripod`), and the
          tracker goes there when that centre is more than ``centre_move``
          away and the two views together lay more of their markings near a
          line pixel about it than about the centre itself (the turned
          view's refinement against the measurement, plus the first view's
          refinements about the two centres). On the 720p crf 28 copy of the
          clip from frame 60 the grid's point was (21.6, -58.0, 8.9) m, the
          joint fit's (24.6, -61.4, 9.6), the full-size run's centre (24.8,
          -61.4, 9.7).
        * Else the grid's point, when it lays ``2 centre_gain`` more of the
          markings near a line pixel than the measurement. (The grid's point
          with ``centre_gain`` moved the full-size clip's centre twice, steps
          of 15-20 px in the picture. The joint centre moves it at frame 104,
          and a later check at 144, where before the checks moved it at 114,
          154 and 364: its reference frames 12 -> 13 of 13 within 5 px.)
        """
        if self._centre_view is None or self._axis_tries >= self.cfg.axis_tries:
            return None
        first_lidx, first = self._centre_view
        axis = first.R[2]
        if np.degrees(np.arccos(np.clip(float(axis @ meas.camera.R[2]), -1.0, 1.0))) < self.cfg.axis_turn:
            return None
        self._axis_tries += 1
        span, step = self.cfg.axis_span, self.cfg.axis_step

        def about(s: float) -> Refinement | None:
            C = self.centre + s * axis
            r = self._about(meas.camera, lidx, C)
            return r if r is not None and plausible(C, r.camera.focal, self.size[0], self.pitch)[0] else None

        fits = {float(s): about(float(s)) for s in np.arange(-span, span + step / 2, step)}
        base = fits.get(0.0)
        fits = {s: r for s, r in fits.items() if r is not None and s != 0.0}
        if not fits:
            return None
        best_s = max(fits, key=lambda s: fits[s].confidence)
        for s in (best_s - step / 2, best_s + step / 2):  # (half a step either side)
            r = about(s)
            if r is not None and r.confidence > fits[best_s].confidence:
                fits[s] = r
                best_s = s
        best = fits[best_s]
        if (base is not None and best.confidence < base.confidence + self.cfg.centre_gain / 2) or abs(best_s) <= self.cfg.centre_move:
            return None
        joint = self._two_views(first, first_lidx, best.camera, lidx, want_k1)
        moved = False
        if joint is not None and np.linalg.norm(joint.camera.center - self.centre) > self.cfg.centre_move:
            b1 = self._about(first, first_lidx, joint.camera.center)
            f0 = self._about(first, first_lidx, self.centre)
            if b1 is not None and f0 is not None and (joint.confidence - meas.confidence) + (b1.confidence - f0.confidence) > 0.0:
                best, moved = joint, True
        if not moved and best.confidence < meas.confidence + 2 * self.cfg.centre_gain:
            return None
        self._centre_view = None  # (fixed by two views)
        self.stats["axis_moves"] += 1
        return best

    def _about(self, cam: Camera, lidx: LineIndex, C: np.ndarray) -> Refinement | None:
        """``cam``'s frame (its line pixels ``lidx``) refined about the centre
        ``C`` (3,) from ``cam`` moved there keeping its picture
        (:func:`arstream.solve.seated`), searched from 20 px in; None where
        too few markings match."""
        try:
            return refine_camera(seated(cam, C, self.model, self.size), lidx, self.size, self.model, center=C, estimate_k1=self._want_k1(cam.focal), radii=(20.0, 10.0, 5.0, 3.0, 2.5), max_points=400)
        except ValueError:
            return None

    def _two_views(self, first: Camera, first_lidx: LineIndex, cam: Camera, lidx: LineIndex, want_k1: bool) -> Refinement | None:
        """The tripod centre fitted jointly to two views of it (the view it was
        fixed in, ``first``, and a turned one, ``cam``, both started about
        ``cam``'s centre keeping their pictures); returns ``cam``'s frame
        refined about it (None where the fit fails)."""
        C0 = cam.center
        try:
            fit = fit_tripod([seated(first, C0, self.model, self.size), cam], [first_lidx, lidx], [self.size, self.size], self.model, C0, self.pitch)
            r = refine_camera(fit.cameras[1], lidx, self.size, self.model, center=fit.centre, estimate_k1=want_k1, radii=(4.0, 2.5), max_points=400)
        except ValueError:
            return None
        return r if plausible(r.camera.center, r.camera.focal, self.size[0], self.pitch)[0] else None

    def _free_pose_along_sight(self, meas: Refinement, lidx: LineIndex, rf: Refinement, want_k1: bool) -> Refinement:
        """Of ``rf`` and the free poses of ``meas``'s camera moved along its line
        of sight (:func:`arstream.solve.refinements_along_sight`), the
        plausible one with the most markings near a line pixel."""
        best = rf
        for r in refinements_along_sight(meas.camera, lidx, self.size, self.model, estimate_k1=want_k1):
            if r.confidence > best.confidence and plausible(r.camera.center, r.camera.focal, self.size[0], self.pitch)[0]:
                best = r
        return best

    def _explains_better(self, centre: np.ndarray, recent: list) -> bool:
        """Whether the frames checked before (``recent``: (line index, measured
        camera, its confidence)), each refined about ``centre`` from its camera
        moved there keeping its picture, lay more of the markings near their
        line pixels on average, and none ``centre_gain`` / 2 fewer. False with
        fewer than two such frames."""
        gains = []
        for lj, cj, confj in recent:
            rj = self._about(cj, lj, centre)
            if rj is None:
                return False
            gains.append(rj.confidence - confj)
        return len(gains) >= 2 and float(np.mean(gains)) > 0.0 and min(gains) > -self.cfg.centre_gain / 2
