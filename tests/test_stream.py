"""Live mode (``arstream stream``) and rerun logging: real PyAV, GL and rerun-sdk."""

from __future__ import annotations

import json
import os
import re
import socket
import subprocess
import sys

import pytest

import arstream
from arstream.cli import main
from arstream.errors import InputError
from arstream.live import DEFAULT_URL, RerunLogger, parse_rerun
from arstream.sink import read_jsonl
from arstream.synth import generate

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RERUN = os.path.join(os.path.dirname(sys.executable), "rerun")


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    d = tmp_path_factory.mktemp("stream")
    generate(d, preset="wide", seed=4, frames=10, size=(640, 360))
    return d


def entities(rrd: str) -> dict[str, set[str]]:
    """Entity path -> component columns, from ``rerun rrd print``."""
    out = subprocess.run([RERUN, "rrd", "print", rrd], capture_output=True, text=True, env=dict(os.environ, RERUN_ANALYTICS="0"))
    assert out.returncode == 0, out.stderr
    ents: dict[str, set[str]] = {}
    for path, cols in re.findall(r" - (/\S*) - data columns: \[([^\]]*)\]", out.stdout):
        ents.setdefault(path, set()).update(cols.split())
    return ents


def test_rerun_save_writes_a_valid_recording(clip, tmp_path, capsys):
    rrd = tmp_path / "live.rrd"
    rc = main(["stream", "--source", str(clip / "clip.mp4"), "--rerun", "save", str(rrd), "-o", str(tmp_path / "live.mp4"), "--cameras-out", str(tmp_path / "c.jsonl"), "-q", "--json"])
    assert rc == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["frames"] == 10 and summary["dropped"] == 0
    v = subprocess.run([RERUN, "rrd", "verify", str(rrd)], capture_output=True, text=True, env=dict(os.environ, RERUN_ANALYTICS="0"))
    assert v.returncode == 0, v.stderr
    ents = entities(str(rrd))
    assert "EncodedImage:blob" in ents["/input/frame"] and "EncodedImage:media_type" in ents["/input/frame"]
    assert "EncodedImage:blob" in ents["/output/frame"]
    assert "LineStrips2D:strips" in ents["/input/lines"] and "LineStrips2D:strips" in ents["/input/ellipse"]
    assert "LineStrips3D:strips" in ents["/world/pitch"]
    assert "/world/camera" in ents
    assert "Scalars:scalars" in ents["/camera/confidence"]
    assert {"/timing/decode", "/timing/detect", "/timing/track", "/timing/render"} <= set(ents)
    assert not any("Image:buffer" in c for cols in ents.values() for c in cols)  # frames are compressed, never raw
    assert len(read_jsonl(tmp_path / "c.jsonl")) == 10


def test_rerun_logs_the_camera_when_tracked(clip, tmp_path):
    rrd = tmp_path / "live.rrd"
    s = arstream.stream(clip / "clip.mp4", rerun=("save", rrd))
    assert s.tracked >= 8
    ents = entities(str(rrd))
    assert {"Pinhole:image_from_camera", "Transform3D:translation"} <= ents["/world/camera"]
    for name in ("focal", "pan", "tilt"):
        assert "Scalars:scalars" in ents[f"/camera/{name}"]
    assert "LineStrips2D:strips" in ents["/input/model"]


def test_unreachable_viewer_warns_and_keeps_going(clip, tmp_path, capsys):
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    url = f"rerun+http://127.0.0.1:{port}/proxy"
    rc = main(["stream", "--source", str(clip / "clip.mp4"), "--rerun", "connect", url, "-o", str(tmp_path / "o.mp4"), "--frames", "3", "-q"])
    err = capsys.readouterr().err
    assert rc == 0
    assert "warning: no rerun viewer at" in err and url in err
    assert (tmp_path / "o.mp4").exists()


def test_realtime_paces_and_reports_drops(clip, capsys):
    rc = main(["stream", "--source", str(clip / "clip.mp4"), "--rerun", "none", "--realtime", "--frames", "6", "-q", "--json"])
    assert rc == 0
    s = json.loads(capsys.readouterr().out)
    assert s["frames"] >= 1 and s["frames"] + s["dropped"] == 6
    assert s["seconds"] >= 5 / 25  # paced to the clip's clock (25 fps), never faster


def test_serve_binds_to_localhost_by_default():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    log = RerunLogger(parse_rerun("serve"), 320, 180, port=port)
    try:
        assert log.uri == f"rerun+http://127.0.0.1:{port}/proxy"
        listening = set()
        for table in ("/proc/net/tcp", "/proc/net/tcp6"):
            if os.path.exists(table):
                for line in open(table).read().splitlines()[1:]:
                    local, state = line.split()[1], line.split()[3]
                    addr, p = local.rsplit(":", 1)
                    if int(p, 16) == port and state == "0A":  # LISTEN
                        listening.add(addr)
        assert listening == {"0100007F"}, listening  # 127.0.0.1 only
    finally:
        log.close()


@pytest.mark.parametrize(
    "value, want",
    [
        (None, None),
        ("spawn", ("spawn", None)),
        ("serve", ("serve", None)),
        (["save", "a.rrd"], ("save", "a.rrd")),
        ("save:a.rrd", ("save", "a.rrd")),
        (["connect"], ("connect", DEFAULT_URL)),
        (["connect", "rerun+http://h:1/proxy"], ("connect", "rerun+http://h:1/proxy")),
    ],
)
def test_parse_rerun(value, want):
    assert parse_rerun(value) == want


@pytest.mark.parametrize("value, words", [(["save"], "needs a file"), (["view"], "unknown mode"), (["spawn", "x"], "takes no argument"), (["connect", "a", "b"], "at most one")])
def test_parse_rerun_errors(value, words):
    with pytest.raises(InputError, match=words):
        parse_rerun(value)


def test_stream_help_and_errors(capsys, tmp_path):
    with pytest.raises(SystemExit) as e:
        main(["stream", "--help"])
    assert e.value.code == 0
    h = capsys.readouterr().out
    for word in ("--source SRC", "--rerun", "--realtime", "--bind", "save FILE.rrd", "connect [URL]", "127.0.0.1"):
        assert word in h
    assert main(["stream", "--source", str(tmp_path / "none.mp4"), "--rerun", "none"]) == 2
    assert "input not found" in capsys.readouterr().err
    assert main(["stream", "--source", str(tmp_path / "none.mp4"), "--rerun", "save"]) == 2
    assert "needs a file name" in capsys.readouterr().err


def test_spawn_without_display_warns_and_keeps_going(clip, tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    rc = main(["stream", "--source", str(clip / "clip.mp4"), "--port", str(port), "--cameras-out", str(tmp_path / "c.jsonl"), "--frames", "2", "-q"])
    assert rc == 0
    assert "warning: no display to open a rerun viewer" in capsys.readouterr().err
    assert len(read_jsonl(tmp_path / "c.jsonl")) == 2


def test_network_source_is_paced_and_rebased(clip, tmp_path, capsys):
    """An MPEG-TS stream over HTTP: a URL source is real-time by default (paced, drops
    reported), and a recording of it starts at time 0."""
    import functools
    import threading
    from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer

    import av

    with av.open(str(clip / "clip.mp4")) as i, av.open(str(tmp_path / "clip.ts"), "w") as o:
        v = i.streams.video[0]
        ov = o.add_stream_from_template(v)
        for p in i.demux(v):
            if p.dts is not None:
                p.stream = ov
                o.mux(p)
    handler = functools.partial(SimpleHTTPRequestHandler, directory=str(tmp_path))
    handler.log_message = lambda *a, **k: None
    server = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        url = f"http://127.0.0.1:{server.server_address[1]}/clip.ts"
        rc = main(["stream", "--source", url, "--rerun", "none", "-o", str(tmp_path / "rec.mp4"), "-q", "--json"])
    finally:
        server.shutdown()
        server.server_close()
    assert rc == 0
    s = json.loads(capsys.readouterr().out)
    assert s["frames"] >= 1 and s["frames"] + s["dropped"] == 10 and s["seconds"] >= 9 / 25
    with av.open(str(tmp_path / "rec.mp4")) as c:
        pts = [f.pts for f in c.decode(video=0)]
    assert len(pts) == s["frames"] and pts[0] == 0


def test_a_file_inside_black_bars_is_streamed_on_its_picture(clip, tmp_path):
    # as process: the picture inside the bars analysed with the frame's
    # principal point, the cameras the frame's (a URL or device: whole).
    # Letterboxed (pillarboxed, this clip's view loses the halfway line and
    # most of the circle to the bars: no camera, in process too)
    from arstream.evaluate import score

    sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bench"))
    from real_bars import barred_copy

    barred = barred_copy(clip / "clip.mp4", tmp_path / "barred.mp4", "letter:0.125")
    s = arstream.stream(str(barred), cameras_out=tmp_path / "c.jsonl", handle_signals=False)
    x0, y0, x1, y1 = s.picture
    assert max(abs(x0), abs(640 - x1), abs(y0 - 45), abs(360 - y1 - 45)) <= 4
    assert "picture inside black bars" in s.line()
    sc = score(read_jsonl(clip / "truth.jsonl"), read_jsonl(tmp_path / "c.jsonl"), (640, 360))
    assert sc.coverage >= 0.9 and sc.median <= 0.5, (sc.coverage, sc.median, sc.p95)


def test_a_live_run_says_when_the_paint_backs_the_default_size_poorly(tmp_path):
    # a live source cannot be scanned at other sizes as process does: the
    # operator is told once, by process's rule (the median line support of the
    # judged frames below SCAN_BELOW), and the summary records it; a clip of a
    # 105 x 68 m pitch, and the same clip given its size, are not flagged
    from arstream.pitch_size import SCAN_BELOW

    said = {}
    for name, drawn_at, given in [("off", (110, 64), None), ("given", (110, 64), (110, 64)), ("default", None, None)]:
        d = tmp_path / name
        if not (tmp_path / str(drawn_at)).exists():
            generate(tmp_path / str(drawn_at), preset="wide", seed=4, frames=130, size=(640, 360), pitch=drawn_at)
        msgs = []
        s = arstream.stream(str(tmp_path / str(drawn_at) / "clip.mp4"), cameras_out=d.with_suffix(".jsonl"), handle_signals=False, warn=msgs.append, pitch=given, rerun=("save", d.with_suffix(".rrd")))
        said[name] = (msgs, s)
    msgs, s = said["off"]
    assert len(msgs) == 1 and "fit 105 x 68 m poorly" in msgs[0] and "--pitch" in msgs[0], msgs
    assert s.pitch["fits_poorly"] < SCAN_BELOW and s.pitch["source"] == "default"
    assert msgs[0] in s.pitch_text
    # (and in the operator's rerun viewer, as a warning in its text log)
    assert "TextLog:text" in entities(str(tmp_path / "off.rrd")).get("/log", set())
    assert "/log" not in entities(str(tmp_path / "default.rrd"))
    for name in ("given", "default"):
        msgs, s = said[name]
        assert msgs == [] and "fits_poorly" not in s.pitch and "poorly" not in (s.pitch_text or ""), (name, msgs, s.pitch)


def test_rerun_draws_the_pitch_at_the_size_given(tmp_path):
    # the viewer's pitch (world/pitch) and the model reprojected over the
    # input (input/model) are the size the cameras are solved at, not 105 x 68
    from geometry.pitch import PitchModel

    d = tmp_path / "clip"
    generate(d, preset="wide", seed=4, frames=5, size=(640, 360), pitch=(110, 64))
    for pitch in [(110, 64), None]:
        rrd = tmp_path / f"{pitch}.rrd"
        arstream.stream(str(d / "clip.mp4"), rerun=("save", rrd), pitch=pitch, handle_signals=False)
        out = subprocess.run([RERUN, "rrd", "print", "-vvv", str(rrd)], capture_output=True, text=True, env=dict(os.environ, RERUN_ANALYTICS="0"))
        assert out.returncode == 0, out.stderr
        chunk = out.stdout[out.stdout.index("entity_path: /world/pitch") :]
        first = [float(v) for v in re.search(r"\[\[(-?[\d.]+), (-?[\d.]+), (-?[\d.]+)\]", chunk).groups()]
        want = PitchModel(*(pitch or (105.0, 68.0))).polylines(0.5)[0][0]
        assert abs(first[0] - want[0]) < 1e-3 and abs(first[1] - want[1]) < 1e-3 and first[2] == 0.0, (pitch, first, want)
