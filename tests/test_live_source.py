"""Live network sources that stall or drop (:class:`arstream.source.ReconnectingSource`
and ``arstream stream --reconnect/--timeout``), against an HTTP server on the
loopback address that each test scripts: serve the clip slowly, stop sending
without closing (a stall), close mid-stream (a drop), or answer 503 (down).

Time bounds: the pytest-timeout plugin is not used in this project, so every
read of a source and every in-process ``arstream`` command runs on a watchdog
thread (:func:`bounded`), and the Ctrl-C test runs the command in a
subprocess with timeouts on each wait; a hang fails the test within its bound
(at most 25 s) instead of blocking the suite.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import av
import pytest

from arstream.errors import InputError, SourceLost
from arstream.source import ReconnectingSource, VideoSource, open_live, reconnect_wait
from arstream.synth import generate

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RERUN = os.path.join(os.path.dirname(sys.executable), "rerun")
FRAMES = 40
CHUNK = 188 * 50  # bytes per write (50 MPEG-TS packets)


@pytest.fixture(scope="module")
def ts_clip(tmp_path_factory):
    """A 40-frame 25 fps 320 x 180 MPEG-TS clip (what a live HTTP source sends), its bytes and its decoded frames."""
    d = tmp_path_factory.mktemp("live")
    generate(d, preset="wide", seed=4, frames=FRAMES, size=(320, 180))
    ts = d / "clip.ts"
    with av.open(str(d / "clip.mp4")) as i, av.open(str(ts), "w") as o:
        v = i.streams.video[0]
        ov = o.add_stream_from_template(v)
        for p in i.demux(v):
            if p.dts is not None:
                p.stream = ov
                o.mux(p)
    with VideoSource(ts) as src:
        frames = list(src)
    assert len(frames) == FRAMES
    data = ts.read_bytes()
    return {"dir": d, "data": data, "frames": frames, "cuts": clean_cuts(data, ts)}


def clean_cuts(data: bytes, path) -> dict[int, int]:
    """{n: byte offset} where cutting the stream leaves exactly the first n frames
    complete: the offset is the TS packet that starts the video packet (PES) of
    decode-order packet n, and packets 0..n-1 are display frames 0..n-1 (no
    B-frame of the first n is still missing). A cut anywhere else leaves the last
    picture truncated, which the decoder conceals into a frame no test can predict."""
    pid = lambda i: ((data[i + 1] & 0x1F) << 8) | data[i + 2]
    with av.open(str(path)) as c:
        vpid = 256 + c.streams.video[0].index  # PyAV's (FFmpeg's) first elementary stream PID
        pts = [p.pts for p in c.demux(video=0) if p.size]
    starts = [i for i in range(0, len(data), 188) if data[i] == 0x47 and data[i + 1] & 0x40 and pid(i) == vpid]
    assert len(starts) == len(pts) == FRAMES
    order = sorted(pts)
    return {n: starts[n] for n in range(1, len(pts)) if sorted(pts[:n]) == order[:n]}


def cut_near(clip, share: float) -> tuple[int, int]:
    """(frames left, byte offset) of the clean cut nearest ``share`` of the clip."""
    n = min(clip["cuts"], key=lambda k: abs(k - share * FRAMES))
    return n, clip["cuts"][n]


class Server:
    """An HTTP server on 127.0.0.1 that answers each GET with the next step of ``plan``
    (the last step repeats):

    - ``("serve", None)``: the whole clip, paced, with its Content-Length
    - ``("cut", n)``: the first n bytes, paced, then close (Content-Length says more: a drop)
    - ``("stall", n)``: the first n bytes, paced, then nothing, connection open (until :meth:`close`)
    - ``("status", 503)``: that status and no body (the source is down)

    ``requests`` holds the monotonic time of every GET received.
    """

    def __init__(self, data: bytes, plan: list, pace: float = 0.01):
        self.data, self.plan, self.pace = data, list(plan), pace
        self.requests: list[float] = []
        self.release = threading.Event()
        server = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *a):
                pass

            def do_GET(self):
                server.requests.append(time.monotonic())
                kind, arg = server.plan.pop(0) if len(server.plan) > 1 else server.plan[0]
                if kind == "status":
                    self.send_response(arg)
                    self.send_header("Content-Length", "0")
                    self.end_headers()
                    return
                self.send_response(200)
                self.send_header("Content-Type", "video/mp2t")
                self.send_header("Content-Length", str(len(server.data)))
                self.end_headers()
                n = len(server.data) if arg is None else arg
                try:
                    for i in range(0, n, CHUNK):
                        self.wfile.write(server.data[i : min(i + CHUNK, n)])
                        self.wfile.flush()
                        if server.release.wait(server.pace):
                            return
                    if kind == "stall":
                        server.release.wait(60)
                except OSError:  # the client went away
                    pass

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.httpd.daemon_threads = True
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)
        self.thread.start()
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}/live.ts"

    def close(self) -> None:
        self.release.set()
        self.httpd.shutdown()
        self.httpd.server_close()

    def __enter__(self) -> "Server":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def bounded(fn, seconds: float):
    """``fn()`` on a watchdog thread: its result (or its exception), or a test
    failure when it has not returned after ``seconds`` (the thread, a daemon, is left behind)."""
    box: dict = {}

    def target():
        try:
            box["result"] = fn()
        except BaseException as exc:
            box["error"] = exc

    t = threading.Thread(target=target, daemon=True)
    t.start()
    t.join(seconds)
    if t.is_alive():
        pytest.fail(f"still running after {seconds} s: the source blocked")
    if "error" in box:
        raise box["error"]
    return box["result"]


def read_all(url: str, *, reconnect: float, timeout: float, log: list, bound: float = 20.0):
    """Every frame of a ReconnectingSource, the number of frames read before each
    report line, and the SourceLost it ended with (or None); within ``bound`` seconds."""

    def run():
        frames, lost = [], None
        with ReconnectingSource(url, reconnect=reconnect, timeout=timeout, report=lambda m: log.append((len(frames), time.monotonic(), m))) as src:
            try:
                for f in src:
                    frames.append(f)
            except SourceLost as exc:
                lost = (exc, time.monotonic())
            return frames, lost, src

    return bounded(run, bound)


def check_continuity(frames, clip_frames, n_first: int):
    """Frames 0..n_first-1 are the clip's first frames, as sent; the rest are the
    whole clip again (the second connection), one frame interval later each."""
    assert [f.index for f in frames] == list(range(len(frames)))
    assert len(frames) == n_first + len(clip_frames)
    for got, want in zip(frames, clip_frames[:n_first] + clip_frames):
        assert (got.yuv == want.yuv).all()
    ts = [f.ts for f in frames]
    tick = 3600  # one frame interval (1/25 s) in MPEG-TS's 90 kHz time base
    assert ts[:n_first] == [f.ts for f in clip_frames[:n_first]]  # the first connection keeps the source's clock
    assert all(b - a == tick for a, b in zip(ts, ts[1:]))  # then one frame interval each, across the reconnection too
    assert [f.pts for f in frames] == pytest.approx([t / 90000 for t in ts], abs=1e-9)


def test_backoff_doubles_up_to_the_cap():
    assert [reconnect_wait(n) for n in range(1, 8)] == [0.5, 1.0, 2.0, 4.0, 8.0, 8.0, 8.0]
    assert [reconnect_wait(n, (0.1, 0.3)) for n in range(1, 4)] == [0.1, 0.2, 0.3]


def test_a_clean_end_is_not_a_loss(ts_clip):
    log: list = []
    with Server(ts_clip["data"], [("serve", None)]) as srv:
        frames, lost, src = read_all(srv.url, reconnect=5, timeout=2, log=log)
    assert lost is None and log == [] and len(srv.requests) == 1
    assert [f.index for f in frames] == list(range(FRAMES)) and src.errors == []


def test_a_stalled_source_times_out_and_reconnects(ts_clip):
    """The server stops sending without closing; after 1 s without data the source
    reads the URL again (the server sees a second request) and the frames go on."""
    n_cut, cut = cut_near(ts_clip, 0.4)
    log: list = []
    with Server(ts_clip["data"], [("stall", cut), ("serve", None)]) as srv:
        t0 = time.monotonic()
        frames, lost, src = read_all(srv.url, reconnect=5, timeout=1, log=log)
        took = time.monotonic() - t0
    assert lost is None and len(srv.requests) == 2
    assert took < 1 + 0.5 + 4  # the stall is noticed after the 1 s timeout, attempt 1 is 0.5 s later
    assert srv.requests[1] - srv.requests[0] >= 1 + 0.5
    (n_lost, _, m_lost), (n_back, _, m_back) = log
    assert "lost the source" in m_lost and "no data for 1 s (timed out)" in m_lost and "attempt 1 in 0.5 s" in m_lost
    assert "reconnected" in m_back and "attempt 1" in m_back and f"frames go on from {n_back}" in m_back
    assert n_lost == n_back == n_cut
    check_continuity(frames, ts_clip["frames"], n_cut)
    assert src.reconnections == 1 and src.errors == []


def test_a_dropped_source_is_retried_with_backoff_until_it_comes_back(ts_clip):
    """The server closes mid-stream, is down (503) for the first attempt, back for the second."""
    n_cut, cut = cut_near(ts_clip, 0.5)
    log: list = []
    with Server(ts_clip["data"], [("cut", cut), ("status", 503), ("serve", None)]) as srv:
        frames, lost, src = read_all(srv.url, reconnect=10, timeout=2, log=log)
    assert lost is None and len(srv.requests) == 3
    gaps = [b - a for a, b in zip(srv.requests, srv.requests[1:])]
    assert gaps[0] >= 0.5 and gaps[1] >= 1.0  # waits 0.5 s then 1 s
    msgs = [m for _, _, m in log]
    assert len(msgs) == 3
    assert "lost the source" in msgs[0] and "Input/output error" in msgs[0] and "attempt 1 in 0.5 s" in msgs[0]
    assert "reconnection attempt 1" in msgs[1] and "5XX" in msgs[1] and "attempt 2 in 1.0 s" in msgs[1]
    assert "reconnected" in msgs[2] and "attempt 2" in msgs[2]
    assert log[-1][0] == n_cut
    check_continuity(frames, ts_clip["frames"], n_cut)


def test_gives_up_after_the_reconnection_window(ts_clip):
    """Down for good after the drop: attempts at 0.5, 1.5 and 2.0 s (the last one
    at the end of the 2 s window), then SourceLost after the frames that were read."""
    cut = len(ts_clip["data"]) // 2
    log: list = []
    with Server(ts_clip["data"], [("cut", cut), ("status", 503)]) as srv:
        frames, lost, src = read_all(srv.url, reconnect=2, timeout=2, log=log)
    assert lost is not None
    exc, t_lost = lost
    t_drop = log[0][1]
    assert 2.0 <= t_lost - t_drop < 2.0 + 2.0  # the window, plus at most one answer from the server
    assert len(srv.requests) == 1 + 3
    assert "gave up after 3 reconnection attempts" in str(exc) and srv.url in str(exc) and "5XX" in str(exc)
    assert "attempt 3 in 0.5 s" in log[-1][2]  # the last wait is cut to the window's end
    assert 0 < len(frames) < FRAMES and [f.index for f in frames] == list(range(len(frames)))
    assert exc.exit_code == 1


def test_no_reconnection_raises_at_the_first_loss(ts_clip):
    log: list = []
    with Server(ts_clip["data"], [("stall", len(ts_clip["data"]) // 2), ("serve", None)]) as srv:
        frames, lost, src = read_all(srv.url, reconnect=0, timeout=1, log=log)
    assert lost is not None and len(srv.requests) == 1 and log == []
    assert "no data for 1 s (timed out)" in str(lost[0]) and "reconnection is off" in str(lost[0])
    assert 0 < len(frames) < FRAMES


def test_a_source_that_never_answers_fails_to_open_within_the_timeout(ts_clip):
    with Server(ts_clip["data"], [("stall", 0)]) as srv:
        t0 = time.monotonic()
        with pytest.raises(InputError, match=r"cannot open .* no data for 1 s \(timed out\)"):
            bounded(lambda: ReconnectingSource(srv.url, timeout=1), 10)
        assert time.monotonic() - t0 < 5


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"reconnect": -1}, "reconnect must be 0 (off) or a number of seconds, got -1"),
        ({"reconnect": float("nan")}, "reconnect must be 0 (off) or a number of seconds, got nan"),
        ({"reconnect": "5"}, "reconnect must be 0 (off) or a number of seconds, got '5'"),
        ({"timeout": 0}, "timeout must be a number of seconds > 0, got 0"),
        ({"timeout": float("inf")}, "timeout must be a number of seconds > 0, got inf"),
    ],
)
def test_bad_reconnect_arguments(kwargs, message):
    with pytest.raises(ValueError) as e:
        ReconnectingSource("http://127.0.0.1:9/x.ts", **kwargs)
    assert str(e.value) == message


def test_a_reconnecting_source_needs_a_url(tmp_path):
    with pytest.raises(ValueError, match="a reconnecting source needs a URL"):
        ReconnectingSource(str(tmp_path / "clip.mp4"))


def _udp_bound(port: int) -> bool:
    """Whether a UDP socket is bound to ``port`` on this machine (Linux's /proc/net/udp)."""
    for table in ("/proc/net/udp", "/proc/net/udp6"):
        if os.path.exists(table):
            for line in open(table).read().splitlines()[1:]:
                if int(line.split()[1].rsplit(":", 1)[1], 16) == port:
                    return True
    return False


@pytest.mark.skipif(not os.path.exists("/proc/net/udp"), reason="needs /proc/net/udp to see when the receiver is listening")
def test_a_udp_source_that_stops_sending_times_out(ts_clip):
    """MPEG-TS over UDP (no connection to drop: a sender that goes quiet is a
    stall). Without reconnection the source ends with SourceLost after the timeout."""
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    data = ts_clip["data"]

    def send():
        deadline = time.monotonic() + 10
        while not _udp_bound(port) and time.monotonic() < deadline:
            time.sleep(0.01)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as out:
            for i in range(0, len(data), 7 * 188):
                out.sendto(data[i : i + 7 * 188], ("127.0.0.1", port))
                time.sleep(0.001)

    threading.Thread(target=send, daemon=True).start()
    log: list = []
    t0 = time.monotonic()
    frames, lost, src = read_all(f"udp://127.0.0.1:{port}", reconnect=0, timeout=2, log=log)
    assert lost is not None and "no data for 2 s (timed out)" in str(lost[0])
    assert lost[1] - t0 < 10
    assert len(frames) > FRAMES // 2 and [f.index for f in frames] == list(range(len(frames)))



def test_open_live_reconnects_urls_only(ts_clip):
    with open_live(ts_clip["dir"] / "clip.ts") as src:
        assert type(src) is VideoSource
    with Server(ts_clip["data"], [("serve", None)]) as srv, open_live(srv.url, reconnect=3, timeout=2) as src:
        assert type(src) is ReconnectingSource and (src.reconnect, src.timeout) == (3, 2)
        assert (src.width, src.height, src.fps, src.is_live, src.audio_stream) == (320, 180, 25, True, None)

# --------------------------------------------------------------------------- the command
def arstream_cmd(*args: str) -> list[str]:
    return [sys.executable, "-m", "arstream.cli", "stream", *args]


def outputs(tmp_path) -> list[str]:
    return ["--rerun", "save", str(tmp_path / "live.rrd"), "-o", str(tmp_path / "live.mp4"), "--cameras-out", str(tmp_path / "cameras.jsonl")]


def check_outputs(tmp_path, frames: int) -> None:
    """The three outputs are complete: cameras.jsonl parses with frames 0..frames-1 in
    order and increasing pts, the mp4 opens and holds that many frames, the .rrd verifies;
    no temporary file is left."""
    from arstream.sink import read_jsonl

    recs = read_jsonl(tmp_path / "cameras.jsonl")
    assert [r["frame"] for r in recs] == list(range(frames))
    pts = [r["pts"] for r in recs]
    assert all(b > a for a, b in zip(pts, pts[1:]))
    with av.open(str(tmp_path / "live.mp4")) as c:
        assert sum(1 for _ in c.decode(video=0)) == frames
    v = subprocess.run([RERUN, "rrd", "verify", str(tmp_path / "live.rrd")], capture_output=True, text=True, env=dict(os.environ, RERUN_ANALYTICS="0"), timeout=20)
    assert v.returncode == 0, v.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cameras.jsonl", "live.mp4", "live.rrd"]


def run_main(argv: list[str], capsys, bound: float = 25.0) -> tuple[int, str, str]:
    """``arstream`` in this process (no start-up cost) on a watchdog thread: (exit status, stdout, stderr)."""
    from arstream.cli import main

    capsys.readouterr()
    rc = bounded(lambda: main(argv), bound)
    out, err = capsys.readouterr()
    return rc, out, err


def test_stream_reconnects_after_a_stall_and_finalises_complete_outputs(ts_clip, tmp_path, capsys):
    n_cut, cut = cut_near(ts_clip, 0.4)
    with Server(ts_clip["data"], [("stall", cut), ("serve", None)]) as srv:
        rc, out, err = run_main(["stream", "--source", srv.url, "--timeout", "1", "--reconnect", "5", "--no-realtime", *outputs(tmp_path), "-q", "--json"], capsys)
    assert rc == 0, err
    assert len(srv.requests) == 2
    assert "lost the source" in err and "no data for 1 s (timed out)" in err and f"frames go on from {n_cut}" in err
    summary = json.loads(out)
    assert summary["frames"] == n_cut + FRAMES and summary["errors"] == []
    check_outputs(tmp_path, n_cut + FRAMES)


def test_stream_gives_up_after_reconnect_seconds_with_complete_outputs(ts_clip, tmp_path, capsys):
    n_cut, cut = cut_near(ts_clip, 0.5)
    with Server(ts_clip["data"], [("cut", cut), ("status", 503)]) as srv:
        rc, out, err = run_main(["stream", "--source", srv.url, "--timeout", "2", "--reconnect", "2", "--no-realtime", *outputs(tmp_path), "-q", "--json"], capsys)
    assert rc == 1
    assert len(srv.requests) == 1 + 3
    last = err.strip().splitlines()[-1]
    assert last.startswith("arstream: error: lost the source") and "gave up after 3 reconnection attempts" in last and "outputs finalised" in last
    assert json.loads(out)["frames"] == n_cut  # the summary still comes
    check_outputs(tmp_path, n_cut)


def test_ctrl_c_while_reconnecting_finalises_the_outputs(ts_clip, tmp_path):
    n_cut, cut = cut_near(ts_clip, 0.5)
    with Server(ts_clip["data"], [("cut", cut), ("status", 503)]) as srv:
        proc = subprocess.Popen(arstream_cmd("--source", srv.url, "--timeout", "2", "--reconnect", "20", "--no-realtime", *outputs(tmp_path), "-q"), stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True, cwd=ROOT)
        lines: list[str] = []
        reader = threading.Thread(target=lambda: lines.extend(proc.stderr), daemon=True)
        reader.start()
        try:
            deadline = time.monotonic() + 25  # start-up (imports, kernels, GL) then the drop and attempt 1
            while not any("reconnection attempt 1" in ln for ln in lines) and time.monotonic() < deadline and proc.poll() is None:
                time.sleep(0.05)
            assert any("reconnection attempt 1" in ln for ln in lines), "".join(lines)
            t_int = time.monotonic()
            proc.send_signal(signal.SIGINT)
            rc = proc.wait(timeout=10)
            took = time.monotonic() - t_int
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        reader.join(5)
    assert rc == 130, "".join(lines)
    assert took < 5  # the waits between attempts poll for a stop
    assert f"interrupted ({n_cut} frames" in "".join(lines)
    check_outputs(tmp_path, n_cut)


def test_stream_help_documents_the_options(capsys):
    from arstream.cli import main

    with pytest.raises(SystemExit):
        main(["stream", "--help"])
    h = " ".join(capsys.readouterr().out.split())
    assert "--reconnect SECONDS" in h and "--timeout SECONDS" in h
    assert "(default: 30)" in h and "(default: 10)" in h and "0 = no reconnection" in h


@pytest.mark.parametrize(
    "option, message",
    [
        (["--reconnect", "-1"], "argument --reconnect: must be 0 (no reconnection) or a number of seconds, got '-1'"),
        (["--reconnect", "soon"], "argument --reconnect: must be 0 (no reconnection) or a number of seconds, got 'soon'"),
        (["--timeout", "0"], "argument --timeout: must be a number of seconds > 0, got '0'"),
        (["--timeout", "inf"], "argument --timeout: must be a number of seconds > 0, got 'inf'"),
    ],
)
def test_stream_rejects_bad_reconnect_options(option, message, capsys):
    from arstream.cli import main

    with pytest.raises(SystemExit) as e:
        main(["stream", "--source", "http://127.0.0.1:9/x.ts", *option])
    assert e.value.code == 2
    assert message in capsys.readouterr().err
