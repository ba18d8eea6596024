"""Live logging to rerun: frames, detections, the solved camera, and timings.

One recording per run, one blueprint::

    +---------------------------+---------------------------+
    | input + detections (2-D)  | pitch + camera (3-D)      |
    +---------------------------+---------------------------+
    | output (2-D)              | camera: f, pan, tilt,     |
    |                           | confidence / timings (ms) |
    +---------------------------+---------------------------+

Entities (timelines ``frame`` (sequence) and ``time`` (the frame's pts)):

- ``input/frame``     the decoded frame, JPEG (``rr.EncodedImage``; never raw pixels)
- ``input/lines``     detected line segments (``rr.LineStrips2D``)
- ``input/ellipse``   detected centre-circle ellipse(s) (``rr.LineStrips2D``)
- ``input/model``     the pitch model reprojected with the solved camera
- ``output/frame``    the composited output, JPEG
- ``world/pitch``     the pitch markings in the pitch frame, at the size solved with (static, ``rr.LineStrips3D``)
- ``world/camera``    the camera in the pitch frame: ``rr.Transform3D``
  (camera -> pitch: rotation R^T, translation the camera centre) and
  ``rr.Pinhole`` (K, image size, OpenCV axes RDF); cleared on lost frames
- ``camera/focal``, ``camera/pan``, ``camera/tilt`` (degrees), ``camera/confidence``
- ``timing/<stage>``  milliseconds per frame of each pipeline stage
- ``log``             what the run tells the operator (``rr.TextLog``, e.g. the
  pitch's size in doubt: :meth:`RerunLogger.note`)

Sinks: ``spawn`` a viewer, ``save`` an .rrd, ``connect`` to a viewer's gRPC
URL, or ``serve`` gRPC (bound to 127.0.0.1 unless told otherwise). A viewer
that cannot be reached is a warning, not an error: processing goes on
without rerun.
"""

from __future__ import annotations

import math
import os
import shutil
import socket
import sys
import time
import urllib.parse
import uuid

import cv2
import numpy as np

from arstream.errors import ArstreamError, InputError

__all__ = ["RerunLogger", "parse_rerun", "blueprint", "DEFAULT_URL", "MODES"]

DEFAULT_URL = "rerun+http://127.0.0.1:9876/proxy"
MODES = ("spawn", "save", "connect", "serve")

_LINE_COLOR = (255, 64, 64)
_ELLIPSE_COLOR = (64, 160, 255)
_MODEL_COLOR = (255, 220, 0)


def parse_rerun(value):
    """Normalise a ``--rerun`` value: None, "spawn", "serve", ("save", path), ("connect", url).

    Accepts a string (``"spawn"``, ``"serve"``, ``"save:out.rrd"``) or a
    sequence ``(mode, arg)``. Returns None or a tuple ``(mode, arg_or_None)``.
    """
    if value is None:
        return None
    if isinstance(value, str):
        parts = value.split(":", 1) if value.startswith(("save:", "connect:")) else [value]
    else:
        parts = list(value)
    if not parts:
        return None
    mode, args = parts[0], parts[1:]
    if mode not in MODES:
        raise InputError(f"--rerun: unknown mode {mode!r} (one of: spawn, save FILE.rrd, connect [URL], serve)")
    if mode == "save":
        if len(args) != 1 or not args[0]:
            raise InputError("--rerun save needs a file name: --rerun save out.rrd")
        return ("save", os.fspath(args[0]))
    if mode == "connect":
        if len(args) > 1:
            raise InputError("--rerun connect takes at most one URL")
        return ("connect", args[0] if args else DEFAULT_URL)
    if args:
        raise InputError(f"--rerun {mode} takes no argument (got {' '.join(map(str, args))})")
    return (mode, None)


def blueprint():
    """The viewer layout (see the module docstring)."""
    import rerun.blueprint as rrb

    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(
                rrb.Spatial2DView(origin="input", name="input + detections"),
                rrb.Spatial2DView(origin="output", name="output"),
            ),
            rrb.Vertical(
                rrb.Spatial3DView(origin="world", name="pitch + camera"),
                rrb.Horizontal(
                    rrb.TimeSeriesView(origin="camera", name="camera"),
                    rrb.TimeSeriesView(origin="timing", name="stage timings (ms)"),
                ),
            ),
            column_shares=[3, 2],
        ),
        collapse_panels=True,
    )


def _reachable(url: str, timeout: float = 1.0) -> str | None:
    """None if a TCP connection to the URL's host and port opens, else the reason."""
    u = urllib.parse.urlparse(url)
    host = u.hostname or "127.0.0.1"
    port = u.port or (443 if u.scheme.endswith("https") else 9876)
    try:
        with socket.create_connection((host, port), timeout=timeout):
            return None
    except OSError as exc:
        return exc.strerror or str(exc) or type(exc).__name__


def _first_line(exc: BaseException) -> str:
    return (str(exc).strip() or type(exc).__name__).splitlines()[0].rstrip(".")


def _viewer_on_path() -> None:
    """Let ``spawn`` find the ``rerun`` viewer installed beside this Python (a virtualenv
    that is used without being activated)."""
    if shutil.which("rerun") is None:
        here = os.path.dirname(sys.executable)
        if os.path.exists(os.path.join(here, "rerun")):
            os.environ["PATH"] = here + os.pathsep + os.environ.get("PATH", "")


class _InputStage:
    name = "rerun"

    def __init__(self, logger: "RerunLogger"):
        self.logger = logger

    def process(self, item):
        self.logger.log_input(item)
        return [item]

    def flush(self):
        return []

    def close(self) -> None:
        pass


class _OutputStage(_InputStage):
    name = "rerun-out"

    def process(self, item):
        self.logger.log_output(item)
        return [item]

    def close(self) -> None:
        self.logger.close()


class RerunLogger:
    """Log the pipeline's frames to rerun (see the module docstring).

    Parameters
    ----------
    mode : tuple from :func:`parse_rerun`
    width, height : int, frame size
    bind, port : gRPC server address for ``serve`` (``spawn`` uses ``port`` too)
    jpeg_quality : int, 1..100
    warn : callable(str), non-fatal problems
    name : str, shown as the recording's name
    analysis : arstream.pipeline.stages.Analysis, optional: detections are at its size
        and are drawn mapped to frame pixels
    pitch : the PitchModel the cameras are solved at, or a callable returning
        it (the tracker's, which ``--pitch auto`` changes during a run);
        ``world/pitch`` and ``input/model`` are drawn at it (default 105 x 68 m)

    Two pipeline stages: ``input_stage`` (before rendering: input frame,
    detections, camera, scalars) and ``output_stage`` (after: the composite;
    its ``close`` flushes and closes the recording).
    """

    def __init__(self, mode, width: int, height: int, *, bind: str = "127.0.0.1", port: int = 9876, jpeg_quality: int = 75, warn=None, name: str = "arstream", analysis=None, pitch=None):
        import rerun as rr

        self.rr = rr
        self.analysis = analysis
        self._pitch = pitch
        self._pitch_size = None
        self.mode = mode
        self.width, self.height = width, height
        self.jpeg = [int(cv2.IMWRITE_JPEG_QUALITY), int(min(max(jpeg_quality, 1), 100))]
        self.warn = warn or (lambda msg: None)
        self.enabled = True
        self.uri = None
        self.rec = rr.RecordingStream("arstream", recording_id=uuid.uuid4())
        if hasattr(self.rec, "send_recording_name"):
            self.rec.send_recording_name(name)
        bp = blueprint()
        kind, arg = mode
        if kind == "save":
            d = os.path.dirname(os.path.abspath(arg))
            try:
                os.makedirs(d, exist_ok=True)
            except OSError as exc:
                raise InputError(f"cannot create folder {d} for {arg}: {exc.strerror}") from None
            try:
                self.rec.save(arg, default_blueprint=bp)
            except Exception as exc:
                raise InputError(f"cannot write rerun recording {arg}: {_first_line(exc)}") from None
            self.uri = arg
        elif kind == "connect":
            why = _reachable(arg)
            if why is not None:
                self._disable(f"no rerun viewer at {arg} ({why}); going on without rerun (start a viewer with `rerun`, or use --rerun save FILE.rrd)")
            else:
                self.rec.connect_grpc(arg, default_blueprint=bp)
                self.uri = arg
        elif kind == "spawn":
            url = f"rerun+http://127.0.0.1:{port}/proxy"
            if _reachable(url, timeout=0.3) is None:  # a viewer is already there: use it
                self.rec.connect_grpc(url, default_blueprint=bp)
                self.uri = url
            elif sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
                self._disable("no display to open a rerun viewer on (DISPLAY and WAYLAND_DISPLAY are unset); going on without rerun (use --rerun save FILE.rrd or --rerun serve)")
            else:
                _viewer_on_path()
                try:
                    self.rec.spawn(port=port, connect=False)
                except Exception as exc:
                    self._disable(f"could not start a rerun viewer ({_first_line(exc)}); going on without rerun (install the viewer with: pip install rerun-sdk)")
                else:
                    deadline = time.monotonic() + 2.0  # spawn itself waited for the port already
                    why = _reachable(url)
                    while why is not None and time.monotonic() < deadline:
                        time.sleep(0.2)
                        why = _reachable(url)
                    if why is not None:
                        self._disable(f"the rerun viewer did not start listening on port {port} ({why}); going on without rerun")
                    else:
                        self.rec.connect_grpc(url, default_blueprint=bp)
                        self.uri = url
        elif kind == "serve":
            try:
                self.rec.set_sinks(rr.GrpcServerSink(bind_ip=bind, port=port), default_blueprint=bp)
            except Exception as exc:
                raise ArstreamError(f"cannot serve rerun on {bind}:{port}: {_first_line(exc)}") from None
            self.uri = f"rerun+http://{bind}:{port}/proxy"
            self.warn(f"serving rerun on {self.uri} (open it with: rerun {self.uri})")
        else:  # pragma: no cover - parse_rerun rejects it
            raise InputError(f"unknown rerun mode {kind!r}")
        self.input_stage = _InputStage(self)
        self.output_stage = _OutputStage(self)
        self._closed = False
        if self.enabled:
            self._log_static()

    def _disable(self, msg: str) -> None:
        self.warn(msg)
        self.enabled = False

    # ------------------------------------------------------------------ static
    def _log_static(self) -> None:
        rr, rec = self.rr, self.rec
        rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self._sync_pitch()
        names = {"camera/focal": "focal length (px)", "camera/pan": "pan (deg)", "camera/tilt": "tilt (deg)", "camera/confidence": "confidence"}
        for path, label in names.items():
            rec.log(path, rr.SeriesLines(names=[label]), static=True)

    def pitch(self):
        """The PitchModel the cameras are solved at now: ``pitch`` as given
        (a PitchModel, or a callable returning the tracker's, which an
        estimate may change during the run), 105 x 68 m by default."""
        from geometry.pitch import PitchModel

        p = self._pitch() if callable(self._pitch) else self._pitch
        return p if p is not None else PitchModel()

    def _sync_pitch(self) -> None:
        """Log ``world/pitch`` (and keep the polylines ``input/model`` projects)
        at :meth:`pitch`, when it is not the size logged last."""
        p = self.pitch()
        if (p.length, p.width) == self._pitch_size:
            return
        self._pitch_size = (p.length, p.width)
        self._pitch_pts = [np.column_stack([q, np.zeros(len(q))]) for q in p.polylines(0.5)]
        self.rec.log("world/pitch", self.rr.LineStrips3D(self._pitch_pts, colors=[(230, 230, 230)], radii=[0.12]), static=True)

    def _time(self, item) -> None:
        self.rec.set_time("frame", sequence=int(item.index))
        self.rec.set_time("time", duration=float(item.pts))

    def _jpeg(self, bgr: np.ndarray) -> bytes:
        ok, buf = cv2.imencode(".jpg", bgr, self.jpeg)
        if not ok:  # pragma: no cover - OpenCV always encodes uint8 BGR
            raise ArstreamError("JPEG encoding failed")
        return buf.tobytes()

    # ------------------------------------------------------------------ per frame
    def log_input(self, item) -> None:
        if not self.enabled:
            return
        rr, rec = self.rr, self.rec
        self._time(item)
        self._sync_pitch()
        rec.log("input/frame", rr.EncodedImage(contents=self._jpeg(item.frame.image), media_type="image/jpeg"))
        det = item.detections
        an = self.analysis
        lines = [np.asarray(getattr(l, "endpoints", ()), float).reshape(-1, 2) for l in (getattr(det, "lines", None) or [])]
        lines = [an.points(l) if an is not None else l for l in lines if len(l) >= 2]
        rec.log("input/lines", rr.LineStrips2D(lines, colors=[_LINE_COLOR], radii=[1.5]))
        strips = []
        for e in getattr(det, "ellipses", None) or []:
            ell = getattr(e, "ellipse", None)
            if ell is not None and an is not None:
                ell = an.ellipse(ell)
            if ell is not None and hasattr(ell, "points"):
                p = ell.points(96)
                strips.append(np.vstack([p, p[:1]]))
        rec.log("input/ellipse", rr.LineStrips2D(strips, colors=[_ELLIPSE_COLOR], radii=[1.5]))
        est = item.estimate
        cam = est.camera if est is not None else None
        if cam is None:
            rec.log("input/model", rr.Clear(recursive=False))
            rec.log("world/camera", rr.Clear(recursive=True))
        else:
            rec.log("input/model", rr.LineStrips2D(self._project_model(cam), colors=[_MODEL_COLOR], radii=[1.0]))
            C = cam.center
            rec.log("world/camera", rr.Transform3D(translation=C, mat3x3=cam.R.T))
            rec.log("world/camera", rr.Pinhole(image_from_camera=cam.K, resolution=[self.width, self.height], camera_xyz=rr.ViewCoordinates.RDF, image_plane_distance=8.0))
            from geometry.camera import ptz_from_camera

            try:
                _, ptz = ptz_from_camera(cam)
                rec.log("camera/pan", rr.Scalars(math.degrees(ptz.pan)))
                rec.log("camera/tilt", rr.Scalars(math.degrees(ptz.tilt)))
            except (ValueError, np.linalg.LinAlgError):
                pass
            rec.log("camera/focal", rr.Scalars(float(cam.focal)))
        rec.log("camera/confidence", rr.Scalars(float(est.confidence) if est is not None else 0.0))

    def _project_model(self, cam) -> list[np.ndarray]:
        out = []
        W, H = self.width, self.height
        for X in self._pitch_pts:
            front = cam.in_front(X)
            if not front.any():
                continue
            uv = cam.project(X)
            ok = front & np.all(np.isfinite(uv), axis=1) & (np.abs(uv[:, 0] - W / 2) < 2 * W) & (np.abs(uv[:, 1] - H / 2) < 2 * H)
            # split the polyline where points are dropped
            idx = np.flatnonzero(ok)
            if len(idx) < 2:
                continue
            breaks = np.flatnonzero(np.diff(idx) > 1) + 1
            for run in np.split(idx, breaks):
                if len(run) >= 2:
                    out.append(uv[run])
        return out

    def note(self, text: str, level: str = "WARN") -> None:
        """Log ``text`` for the operator at ``log`` (``rr.TextLog`` at ``level``,
        on the timeline of the last frame logged)."""
        if not self.enabled:
            return
        self.rec.log("log", self.rr.TextLog(text, level=level))

    def log_output(self, item) -> None:
        if not self.enabled:
            return
        rr, rec = self.rr, self.rec
        self._time(item)
        rec.log("output/frame", rr.EncodedImage(contents=self._jpeg(item.output_bgr()), media_type="image/jpeg"))
        for name, ms in item.timings.items():
            rec.log(f"timing/{name}", rr.Scalars(float(ms)))

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        if self.enabled:
            try:
                self.rec.flush()
            except Exception:
                pass
            try:
                self.rec.disconnect()
            except Exception as exc:
                self.warn(f"closing the rerun recording failed: {exc}")
