"""The offline pipeline and ``arstream process``: real PyAV, real GL, real stages.

Clips are synthetic (arstream.synth), small and short; one has an AAC audio
track muxed beside the video. Robustness: missing / non-video / truncated
inputs, a clip without a pitch, a 1-frame clip, odd sizes, SIGINT/SIGTERM
mid-run, no GL context.
"""

from __future__ import annotations

import gc
import importlib.metadata
import json
import os
import signal
import subprocess
import sys
import time
from fractions import Fraction

import av
import cv2
import numpy as np
import pytest

import arstream
from arstream.cli import entry, main
from arstream.pipeline import Summary
from arstream.pipeline.stages import Analysis
from render.compositor import composite_i420
from render.keying import GrassKeyI420
from arstream.sink import VideoSink, atomic_path, read_jsonl
from arstream.source import VideoSource, i420_planes
from arstream.synth import generate

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RECORD_KEYS = {"frame", "pts", "status", "K", "R", "t", "dist", "H", "confidence"}


# --------------------------------------------------------------------------- helpers
def add_audio(src: str, dst: str, *, codec: str = "aac", rate: int = 48000) -> int:
    """Remux ``src``'s video (packets copied) beside a 440 Hz sine in ``codec``; returns audio packets."""
    inp = av.open(src)
    vin = inp.streams.video[0]
    duration = float(vin.duration * vin.time_base) if vin.duration else vin.frames / float(vin.average_rate)
    out = av.open(dst, "w")
    vout = out.add_stream_from_template(vin)
    aout = out.add_stream(codec, rate=rate, layout="mono")
    for pkt in inp.demux(vin):
        if pkt.dts is None:
            continue
        pkt.stream = vout
        out.mux(pkt)
    n = 0
    t = 0
    samples = int(duration * rate)
    while t < samples:
        k = min(1024, samples - t)
        s = (0.3 * np.sin(2 * np.pi * 440 * (t + np.arange(k)) / rate)).astype(np.float32)
        fr = av.AudioFrame.from_ndarray(s[None, :], format="fltp", layout="mono")
        fr.sample_rate = rate
        fr.pts = t
        fr.time_base = Fraction(1, rate)
        for p in aout.encode(fr):
            out.mux(p)
            n += 1
        t += k
    for p in aout.encode(None):
        out.mux(p)
        n += 1
    out.close()
    inp.close()
    return n


def remux(src: str, dst: str, *, repeat: int = 1, faststart: bool = False) -> None:
    """Copy ``src``'s video packets to ``dst`` (``repeat`` times back to back; ``faststart``
    puts the index first, so a truncated copy still opens)."""
    inp = av.open(src)
    vin = inp.streams.video[0]
    pkts = [p for p in inp.demux(vin) if p.dts is not None]
    step = pkts[-1].pts + (pkts[1].pts - pkts[0].pts) if len(pkts) > 1 else 512
    out = av.open(dst, "w", options={"movflags": "faststart"} if faststart else {})
    vout = out.add_stream_from_template(vin)
    for r in range(repeat):
        for p in pkts:
            q = av.Packet(bytes(p))
            q.pts, q.dts = p.pts + r * step, p.dts + r * step
            q.is_keyframe = p.is_keyframe
            q.time_base = p.time_base
            q.stream = vout
            out.mux(q)
    out.close()
    inp.close()


def video_facts(path: str) -> dict:
    with av.open(path) as c:
        v = c.streams.video[0]
        pts = [f.pts for f in c.decode(v)]
    with av.open(path) as c:
        audio = [bytes(p) for p in c.demux(c.streams.audio[0]) if p.dts is not None] if c.streams.audio else []
        v = c.streams.video[0]
        return {
            "frames": len(pts),
            "pts": pts,
            "time_base": v.time_base,
            "rate": v.average_rate,
            "duration": float(v.duration * v.time_base) if v.duration else None,
            "size": (v.codec_context.width, v.codec_context.height),
            "audio": audio,
            "audio_codec": c.streams.audio[0].codec_context.name if c.streams.audio else None,
        }


def cli(*args: str) -> int:
    return main(list(args))


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    """640x360, 25 frames, wide preset, with an AAC track."""
    d = tmp_path_factory.mktemp("clip")
    generate(d, preset="wide", seed=3, frames=25, size=(640, 360))
    add_audio(str(d / "clip.mp4"), str(d / "clip_audio.mp4"))
    return d


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """320x180, 12 frames, no audio."""
    d = tmp_path_factory.mktemp("small")
    generate(d, preset="wide", seed=5, frames=12, size=(320, 180))
    return d


# --------------------------------------------------------------------------- end to end
@pytest.fixture(scope="module")
def processed(clip, tmp_path_factory):
    """``arstream process`` on the clip with audio (the real stages)."""
    out = tmp_path_factory.mktemp("out")
    import contextlib
    import io

    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        rc = cli("process", str(clip / "clip_audio.mp4"), "-o", str(out / "ar.mp4"), "--cameras-out", str(out / "cameras.jsonl"))
    return out, (rc, stdout.getvalue(), stderr.getvalue())


def test_process_keeps_frames_timing_and_audio(clip, processed):
    out, (rc, stdout, stderr) = processed
    assert rc == 0, stderr
    assert "frames in" in stdout and "tracked" in stdout and "fps" in stdout
    a, b = video_facts(str(clip / "clip_audio.mp4")), video_facts(str(out / "ar.mp4"))
    assert b["frames"] == a["frames"] == 25
    assert b["time_base"] == a["time_base"] and b["rate"] == a["rate"]
    assert [p * b["time_base"] for p in b["pts"]] == [p * a["time_base"] for p in a["pts"]]
    assert b["duration"] == pytest.approx(a["duration"], abs=1e-6)
    assert b["size"] == a["size"]
    types_in, types_out = picture_types(clip / "clip_audio.mp4"), picture_types(out / "ar.mp4")
    assert types_in.count("B") > 5 and all(t == "B" for s, t in zip(types_in, types_out) if s == "B")  # the input's B-frames kept
    assert b["audio_codec"] == "aac" and len(b["audio"]) == len(a["audio"]) > 0
    assert b["audio"] == a["audio"]  # copied through unchanged
    recs = read_jsonl(out / "cameras.jsonl")
    assert [r["frame"] for r in recs] == list(range(25))
    assert all(set(r) >= RECORD_KEYS for r in recs)
    assert not any(name.startswith(".") for name in os.listdir(out))  # no partial files left


def test_process_accuracy_within_solver_targets(clip, processed, capsys):
    """Synth clip -> arstream process (real detector, tracker, renderer) -> arstream eval."""
    out, (rc, _, stderr) = processed
    assert rc == 0, stderr
    assert cli("eval", "--truth", str(clip / "truth.jsonl"), "--pred", str(out / "cameras.jsonl"), "--json") == 0
    s = json.loads(capsys.readouterr().out)
    assert s["coverage"] >= 0.95 and s["false_estimates"] == 0
    assert s["median"] <= 1.0 and s["p95"] <= 3.0
    assert s["acc"]["@5"] >= 0.95
    # graphics were drawn: the output differs from the input where the demo scene lies
    with VideoSource(clip / "clip.mp4") as a, VideoSource(out / "ar.mp4") as b:
        diffs = [np.abs(fa.image.astype(int) - fb.image.astype(int)).max() for fa, fb in zip(a, b)]
    assert max(diffs) > 60


def test_analysis_resolution_maps_cameras_exactly():
    """A camera solved on the scaled frame, mapped back, projects where the scaled
    projection lands once mapped back (pixel centres at integer coordinates)."""
    from geometry.camera import PTZ, camera_from_ptz
    from geometry.conics import Ellipse

    for W, H, aw in ((1280, 720, 640), (1920, 1080, 960), (1366, 768, 500)):
        an = Analysis(W, H, aw)
        assert an.w % 2 == 0 and an.h % 2 == 0 and abs(an.w / an.h - W / H) < 0.02
        small = camera_from_ptz(np.array([0.0, -60.0, 18.0]), PTZ(0.1, 0.25, 0.01, 1.2 * an.w), ((an.w - 1) / 2, (an.h - 1) / 2), dist=(-0.05,))
        full = an.camera(small)
        X = np.random.default_rng(0).uniform((-40, -30, 0), (40, 30, 3), (50, 3))
        assert np.allclose(full.project(X), an.points(small.project(X)), atol=1e-9)
        assert np.allclose(full.K[:2, 2], ((W - 1) / 2, (H - 1) / 2), atol=1e-9)  # centre maps to centre
        e = an.ellipse(Ellipse((100.0, 80.0), (40.0, 20.0), 0.3))
        pts = an.points(Ellipse((100.0, 80.0), (40.0, 20.0), 0.3).points(16))
        assert np.allclose(np.einsum("ni,ij,nj->n", np.c_[pts, np.ones(16)], e.conic, np.c_[pts, np.ones(16)]), 0, atol=1e-9)
    assert Analysis(640, 360, 960).full and Analysis(640, 360, None).full
    # a low-resolution frame at its own size (MIN_REDUCTION), not one of 1.5 times
    assert Analysis(854, 480, 640).full and Analysis(848, 478, 640).full
    assert (Analysis(960, 540, 640).w, Analysis(1280, 720, 640).w) == (640, 640)
    assert Analysis(720, 576, 640, pixel_aspect=16 / 15).w == 640  # (other pixels: resampled)
    # reduced by at most 2 (MAX_REDUCTION): the line-support test's 2 px a whole analysis px
    assert [Analysis(w, h, 640).w for w, h in ((1920, 1080), (1440, 810), (3840, 2160))] == [960, 720, 1920]
    assert Analysis(1920, 1080, 0).full and Analysis(1920, 1080, None).full


@pytest.mark.parametrize(
    "size, aspect, reach",
    [
        ((1280, 720), 1.0, 1),  # 2 px of the frame: 1 analysis px
        ((1920, 1080), 1.0, 1),  # analysed at 960 x 540 (MAX_REDUCTION): 1
        ((3840, 2160), 1.0, 1),  # at 1920 x 1080
        ((854, 480), 1.0, 2),  # analysed at its own size (MIN_REDUCTION)
        ((1000, 562), 1.0, 1),  # 1.28 analysis px
        ((720, 576), 64 / 45, 2),  # an anamorphic SD frame: 1.78
        ((512, 512), 16 / 9, 2),  # the Premier League frames: 2.5
        ((640, 360), 1.0, 2),  # full resolution
    ],
)
def test_the_trackers_line_support_reach_is_the_frames_2_px(size, aspect, reach):
    from arstream.pipeline.stages import TrackStage

    an = Analysis(*size, 640, pixel_aspect=aspect)
    assert TrackStage(*size, analysis=an).tracker.support_reach == reach


def test_process_at_analysis_resolution(tmp_path):
    """The committed 720p sample solved on 640x360 frames: cameras mapped back to 720p."""
    truth = read_jsonl(os.path.join(ROOT, "samples", "wide", "truth.jsonl"))[:12]
    s = arstream.process(os.path.join(ROOT, "samples", "wide", "clip.mp4"), None, cameras_out=tmp_path / "c.jsonl", analysis_width=640, max_frames=12)
    assert s.frames == 12 and s.tracked == 12
    from arstream.evaluate import score

    sc = score(truth, read_jsonl(tmp_path / "c.jsonl"), (1280, 720))
    assert sc.coverage == 1.0 and sc.median <= 1.0 and sc.p95 <= 2.0


def test_library_api_mirrors_cli(small, tmp_path):
    s = arstream.process(small / "clip.mp4", tmp_path / "o.mp4", cameras_out=tmp_path / "c.jsonl", lag=3)
    assert isinstance(s, Summary)
    assert s.frames == 12 and s.interrupted is None and s.errors == []
    assert 0.0 <= s.share_tracked <= 1.0 and 0.0 <= s.confidence <= 1.0
    assert {"decode", "detect", "track", "render", "encode"} <= set(s.stage_ms)
    assert s.to_dict()["frames"] == 12 and "fps" in s.line()
    assert video_facts(str(tmp_path / "o.mp4"))["frames"] == 12
    assert len(read_jsonl(tmp_path / "c.jsonl")) == 12


def test_cameras_only_needs_no_video_output(small, tmp_path):
    assert cli("process", str(small / "clip.mp4"), "--cameras-out", str(tmp_path / "c.jsonl"), "-q") == 0
    assert len(read_jsonl(tmp_path / "c.jsonl")) == 12
    assert os.listdir(tmp_path) == ["c.jsonl"]


# --------------------------------------------------------------------------- robustness
@pytest.mark.parametrize(
    "make, code, words",
    [
        (lambda d: d / "nope.mp4", 2, "not found"),
        (lambda d: (d / "notes.mp4").write_text("these are not the frames you are looking for\n" * 50) and d / "notes.mp4", 2, "cannot open"),
        (lambda d: d, 2, "folder"),
        (lambda d: (d / "empty.mp4").write_bytes(b"") or d / "empty.mp4", 2, "cannot open"),
    ],
    ids=["missing", "text-file", "folder", "empty-file"],
)
def test_bad_inputs_are_one_line_errors(tmp_path, capsys, make, code, words):
    path = make(tmp_path)
    assert cli("process", str(path), "-o", str(tmp_path / "o.mp4"), "-q") == code
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("arstream: error:") and words in err[0], err
    assert not (tmp_path / "o.mp4").exists() and not os.path.exists(atomic_path(str(tmp_path / "o.mp4")))


def test_usage_errors(small, tmp_path, capsys):
    assert cli("process", str(small / "clip.mp4")) == 2  # nothing to write
    assert "nothing to write" in capsys.readouterr().err
    assert cli("process", str(small / "clip.mp4"), "-o", str(small / "clip.mp4")) == 2
    assert "overwrite the input" in capsys.readouterr().err
    assert cli("process", str(small / "clip.mp4"), "-o", str(tmp_path / "o.mp4"), "--scene", str(tmp_path / "none.toml")) == 2
    assert "scene file not found" in capsys.readouterr().err
    assert not (tmp_path / "o.mp4").exists()


def test_truncated_mp4_without_index_is_rejected(small, tmp_path, capsys):
    data = (small / "clip.mp4").read_bytes()
    (tmp_path / "cut.mp4").write_bytes(data[: len(data) // 2])  # the moov atom is at the end: gone
    assert cli("process", str(tmp_path / "cut.mp4"), "-o", str(tmp_path / "o.mp4"), "-q") == 2
    assert "cannot open" in capsys.readouterr().err


def test_truncated_mp4_processes_what_decodes(clip, tmp_path, capsys):
    remux(str(clip / "clip.mp4"), str(tmp_path / "fs.mp4"), faststart=True)
    data = (tmp_path / "fs.mp4").read_bytes()
    (tmp_path / "cut.mp4").write_bytes(data[: int(len(data) * 0.6)])
    rc = cli("process", str(tmp_path / "cut.mp4"), "-o", str(tmp_path / "o.mp4"), "--cameras-out", str(tmp_path / "c.jsonl"), "-q")
    err = capsys.readouterr().err
    assert rc == 1
    assert "missing" in err and "damaged" in err
    n = video_facts(str(tmp_path / "o.mp4"))["frames"]
    assert 0 < n < 25
    assert len(read_jsonl(tmp_path / "c.jsonl")) == n


@pytest.mark.long
def test_corrupt_packets_are_skipped_and_reported(clip, tmp_path, capsys):
    data = bytearray((clip / "clip.mp4").read_bytes())
    rng = np.random.default_rng(0)
    for start in (len(data) // 3, len(data) // 2):
        data[start : start + 3000] = rng.integers(0, 256, 3000, dtype=np.uint8).tobytes()
    (tmp_path / "bad.mp4").write_bytes(bytes(data))
    rc = cli("process", str(tmp_path / "bad.mp4"), "-o", str(tmp_path / "o.mp4"), "--cameras-out", str(tmp_path / "c.jsonl"), "-q")
    err = capsys.readouterr().err
    assert rc == 1 and "skipped an undecodable packet" in err and "damaged" in err
    n = video_facts(str(tmp_path / "o.mp4"))["frames"]
    assert 0 < n < 25 and len(read_jsonl(tmp_path / "c.jsonl")) == n


def test_clip_without_pitch_is_all_lost_and_still_written(tmp_path):
    rng = np.random.default_rng(0)
    with VideoSink(tmp_path / "crowd.mp4", 320, 180, 25) as sink:
        for i in range(8):
            img = rng.integers(0, 255, (18, 32, 3), dtype=np.uint8)
            sink.write(cv2.resize(img, (320, 180), interpolation=cv2.INTER_NEAREST))
    s = arstream.process(tmp_path / "crowd.mp4", tmp_path / "o.mp4", cameras_out=tmp_path / "c.jsonl")
    recs = read_jsonl(tmp_path / "c.jsonl")
    assert s.frames == 8 and s.tracked == 0
    assert [r["status"] for r in recs] == ["lost"] * 8 and all(r["K"] is None for r in recs)
    assert video_facts(str(tmp_path / "o.mp4"))["frames"] == 8


def test_one_frame_clip(tmp_path):
    generate(tmp_path, preset="wide", seed=1, frames=1, size=(320, 180))
    s = arstream.process(tmp_path / "clip.mp4", tmp_path / "o.mp4", cameras_out=tmp_path / "c.jsonl")
    assert s.frames == 1
    assert video_facts(str(tmp_path / "o.mp4"))["frames"] == 1
    assert len(read_jsonl(tmp_path / "c.jsonl")) == 1


def write_odd_clip(path, frames, size) -> None:
    """An FFV1/Matroska clip of an odd size (H.264 4:2:0 cannot hold one), cropped from a synth render."""
    from arstream.synth import SynthClip

    w, h = size
    clip = SynthClip("wide", 2, frames, (w + 1, h + 1), 25.0)
    with av.open(str(path), "w") as out:
        st = out.add_stream("ffv1", rate=25)
        st.width, st.height, st.pix_fmt = w, h, "yuv444p"
        for i in range(frames):
            vf = av.VideoFrame.from_ndarray(np.ascontiguousarray(clip.render(i)[:h, :w]), format="bgr24")
            vf.pts = None
            for p in st.encode(vf):
                out.mux(p)
        for p in st.encode(None):
            out.mux(p)


@pytest.mark.parametrize("size", [(1366, 768), (720, 576), (321, 181)], ids=["1366x768", "720x576", "odd-321x181"])
def test_odd_sizes(tmp_path, size):
    if size[0] % 2:
        write_odd_clip(tmp_path / "clip.mkv", 3, size)
        src = tmp_path / "clip.mkv"
    else:
        generate(tmp_path, preset="wide", seed=2, frames=3, size=size)
        src = tmp_path / "clip.mp4"
    s = arstream.process(src, tmp_path / "o.mp4", cameras_out=tmp_path / "c.jsonl")
    assert s.frames == 3 and (s.width, s.height) == size
    f = video_facts(str(tmp_path / "o.mp4"))
    assert f["frames"] == 3
    assert f["size"] == (size[0] + size[0] % 2, size[1] + size[1] % 2)  # x264 4:2:0 pads odd sizes by one pixel


@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)], ids=["SIGINT", "SIGTERM"])
def test_signal_mid_run_finalises_outputs(clip, tmp_path, sig, code):
    long = tmp_path / "long.mp4"
    remux(str(clip / "clip.mp4"), str(long), repeat=40)  # 1000 frames
    out, cams = tmp_path / "o.mp4", tmp_path / "c.jsonl"
    p = subprocess.Popen([sys.executable, "-m", "arstream.cli", "process", str(long), "-o", str(out), "--cameras-out", str(cams)], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    partial = atomic_path(str(cams))
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and p.poll() is None:
        if os.path.exists(partial) and open(partial).read().count("\n") >= 12:
            break
        time.sleep(0.02)
    assert p.poll() is None, "finished before the signal"
    p.send_signal(sig)
    stdout, stderr = p.communicate(timeout=60)
    assert p.returncode == code, stderr
    assert "interrupted" in stderr and "Traceback" not in stderr
    recs = [json.loads(line) for line in cams.read_text().splitlines()]  # every line complete
    n = len(recs)
    assert 12 <= n < 1000 and [r["frame"] for r in recs] == list(range(n))
    f = video_facts(str(out))  # playable: trailer written
    assert f["frames"] == n
    assert not os.path.exists(partial) and not os.path.exists(atomic_path(str(out)))


def test_no_gl_context_names_the_fix(small, tmp_path, capsys, monkeypatch):
    # the real context factory, pointed at an EGL library that is not there
    monkeypatch.setenv("GLCONTEXT_LINUX_LIBEGL", str(tmp_path / "missing" / "libEGL.so.1"))
    args = ["process", str(small / "clip.mp4"), "-o", str(tmp_path / "o.mp4"), "-q"]
    assert cli(*args) == 1
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "OpenGL" in lines[0] and "apt-get install" in lines[0], lines
    assert not (tmp_path / "o.mp4").exists() and not os.path.exists(atomic_path(str(tmp_path / "o.mp4")))
    assert cli("--verbose", *args) == 1
    assert "Traceback" in capsys.readouterr().err
    # cameras only: no GL needed
    assert cli("process", str(small / "clip.mp4"), "--cameras-out", str(tmp_path / "c.jsonl"), "-q") == 0


# --------------------------------------------------------------------------- help
def test_help_reads_like_a_unix_tool(capsys):
    with pytest.raises(SystemExit) as e:
        cli("--help")
    assert e.value.code == 0
    top = capsys.readouterr().out
    assert "process" in top and "stream" in top
    with pytest.raises(SystemExit):
        cli("process", "--help")
    h = capsys.readouterr().out
    for word in ("usage: arstream process", "IN", "-o OUT.mp4", "--scene", "--cameras-out", "examples:", "exit status:"):
        assert word in h


def test_the_command_is_main_then_a_quick_shutdown(tmp_path):
    """The installed command (``arstream.cli:entry``) returns :func:`main`'s exit code,
    then moves what is loaded to the collector's permanent generation, so that the
    interpreter's shutdown does not walk it (about 0.5 s of every run)."""
    assert [e.value for e in importlib.metadata.entry_points(group="console_scripts", name="arstream")] == ["arstream.cli:entry"]
    gc.unfreeze()
    try:
        assert gc.get_freeze_count() == 0
        missing = str(tmp_path / "missing.jsonl")
        assert entry(["eval", "--truth", missing, "--pred", missing]) == 2
        assert gc.get_freeze_count() > 0
    finally:
        gc.unfreeze()


# --------------------------------------------------------------------------- building blocks
def test_source_yuv_fast_path_matches_bgr(small):
    with VideoSource(small / "clip.mp4") as src:
        frames = list(src)
        assert src.errors == []
    with av.open(str(small / "clip.mp4")) as c:
        ref = [f.to_ndarray(format="bgr24") for f in c.decode(video=0)]
    assert len(frames) == len(ref) == 12
    f = frames[4]
    assert f.yuv is not None and f.ts is not None and f.pts == pytest.approx(4 / 25)
    assert f.image.shape == (180, 320, 3)
    assert np.abs(f.image.astype(int) - ref[4]).mean() < 2.0  # BT.601 both ways, rounding apart
    assert np.array_equal(f.gray, i420_planes(f.yuv, 320, 180)[0])


def picture_types(path) -> str:
    """The picture type of each frame of a video, in order ("I", "P", "B", "?" for others)."""
    with av.open(str(path)) as c:
        return "".join({1: "I", 2: "P", 3: "B"}.get(int(f.pict_type), "?") for f in c.decode(video=0))


def test_source_reports_picture_types(small):
    with VideoSource(small / "clip.mp4") as src:
        got = "".join(f.picture_type or "?" for f in src)
    assert got == picture_types(small / "clip.mp4")
    assert got[0] == "I" and "P" in got and "B" in got  # x264 veryfast: B-frames between P-frames


def _types_given(monkeypatch) -> list[str]:
    """A list that receives the picture type of every frame a :class:`VideoSink`
    hands to libx264 ("NONE": x264 chooses), in order.

    What the sink and the pipeline control, compared instead of x264's bytes:
    libx264's AVX-512 code (on CPUs that have it) reads memory it has not
    written, so two encodes of the same frames with the same settings may differ
    in a few pixels (bench/README.md, "Reproducible encodes")."""
    given: list[str] = []
    orig = VideoSink._encode

    def spy(self, vf, *args):
        orig(self, vf, *args)
        given.append(av.video.frame.PictureType(vf.pict_type).name)

    monkeypatch.setattr(VideoSink, "_encode", spy)
    return given


def _decoded(path) -> list[np.ndarray]:
    with av.open(str(path)) as c:
        return [f.to_ndarray() for f in c.decode(video=0)]


def test_sink_follows_the_input_b_frames_only(tmp_path, monkeypatch):
    """A "B" asks x264 for a B-frame (it makes the last frame a P itself: nothing
    follows it to predict from); "I" and "P" are left to x264, so an all-intra
    input does not make an all-intra output; keep_b_frames=False ignores them all."""
    rng = np.random.default_rng(0)
    frames = [rng.integers(0, 256, (64, 64, 3), np.uint8) for _ in range(12)]  # unrelated frames: x264 alone picks few B-frames
    given = _types_given(monkeypatch)

    def encode(name, hints, **kw):
        given.clear()
        with VideoSink(tmp_path / name, 64, 64, 25, **kw) as sink:
            for f, h in zip(frames, hints):
                sink.write(f, picture_type=h)
        return picture_types(tmp_path / name), list(given)

    free, free_given = encode("free.mp4", [None] * 12)
    hints = "IBPBPBPBBBPB"
    kept, kept_given = encode("kept.mp4", hints)
    assert free_given == ["NONE"] * 12
    assert kept_given == ["B" if h == "B" else "NONE" for h in hints]
    assert kept == hints[:-1] + "P"
    assert free.count("B") < kept.count("B")  # the hints changed something
    assert encode("ignored.mp4", hints, keep_b_frames=False)[1] == ["NONE"] * 12
    intra, intra_given = encode("intra.mp4", "I" * 12)
    assert intra_given == ["NONE"] * 12 and intra.count("I") < 12
    assert encode("p_only.mp4", "I" + "P" * 11)[1] == ["NONE"] * 12


def _i420_reference(bgr: np.ndarray) -> np.ndarray:
    """BT.601 limited-range I420 with 2 x 2 chroma averaging (OpenCV's own takes one sample)."""
    b, g, r = (bgr[..., i].astype(np.float64) for i in range(3))
    y = 16 + (24.966 * b + 128.553 * g + 65.481 * r) / 255
    u = 128 + (112.0 * b - 74.203 * g - 37.797 * r) / 255
    v = 128 + (-18.214 * b - 93.786 * g + 112.0 * r) / 255
    H, W = y.shape
    avg = lambda p: p.reshape(H // 2, 2, W // 2, 2).mean(axis=(1, 3))  # noqa: E731
    return np.concatenate([y.ravel(), avg(u).ravel(), avg(v).ravel()])


def test_composite_i420_matches_bgr_over():
    from render.compositor import composite_over

    rng = np.random.default_rng(1)
    W, H = 64, 48
    bgr = cv2.GaussianBlur(rng.integers(0, 256, (H, W, 3), dtype=np.uint8), (7, 7), 3)
    yuv = cv2.cvtColor(bgr, cv2.COLOR_BGR2YUV_I420)
    before = yuv.copy()
    a = np.zeros((H, W), np.float32)
    a[8:40, 16:48] = 1.0
    a = cv2.GaussianBlur(a, (9, 9), 2)
    ov = np.zeros((H, W, 4), np.uint8)
    ov[..., :3] = np.round(np.array([40, 200, 250], np.float32) * a[..., None])
    ov[..., 3] = np.round(255 * a)
    composite_i420(yuv, W, H, ov, [(16, 0, 48, 48), (0, 0, 16, 48), (48, 0, 64, 48)])
    # reference: "over" in BGR at full resolution, then to I420 with averaged chroma; where
    # the frame is untouched (alpha 0) the input's own chroma is the reference
    frame = cv2.cvtColor(before, cv2.COLOR_YUV2BGR_I420)
    want = _i420_reference(composite_over(frame, ov)) - _i420_reference(frame) + before.ravel()
    err = np.abs(yuv.ravel().astype(np.float64) - want)
    assert np.percentile(err, 99) <= 1.5 and err.max() <= 3, (np.percentile(err, 99), err.max())
    yuv2 = before.copy()
    composite_i420(yuv2, W, H, ov, [])
    assert np.array_equal(yuv2, before)


@pytest.mark.parametrize("grow", [0, 3, 4])
def test_key_i420_is_refine_matte_on_the_i420_planes(grow):
    # the compiled key of an I420 frame (render.keying.GrassKeyI420) against
    # render.keying.refine_matte on the BGR conversion of the same rectangles:
    # pixel for pixel, on a frame of the sample clip (grass, lines, players,
    # stands) and on random colours (every hue, saturation and value)
    from arstream.source import VideoSource
    from render.keying import refine_matte

    with VideoSource(os.path.join(ROOT, "samples", "wide", "clip.mp4")) as src:
        frame = next(iter(src))
    W, H = frame.width, frame.height
    rng = np.random.default_rng(grow)
    noise = cv2.cvtColor(rng.integers(0, 256, (H, W, 3), dtype=np.uint8), cv2.COLOR_BGR2YUV_I420)
    pitch = np.zeros((90, 160), np.uint8)
    pitch[20:, 5:150] = 255  # a coarse mask (nearest samples)
    keep = np.zeros((360, 640), np.uint8)
    keep[rng.integers(0, 360, 400), rng.integers(0, 640, 400)] = 255
    keep[100, 50:600] = 255
    rects = [(0, 0, 1280, 720), (100, 37, 333, 301), (1200, 600, 1280, 720), (640, 0, 641, 720), (5, 5, 5, 9)]
    key_i420 = GrassKeyI420()  # (its colour table carries over from the clip's frame to the noise)
    for yuv in (frame.yuv, noise):
        bgr = cv2.cvtColor(yuv, cv2.COLOR_YUV2BGR_I420)
        want = np.full((H, W), 7, np.uint8)
        refine_matte(want, rects, lambda r: bgr[r[1] : r[3], r[0] : r[2]], pitch, keep=keep, keep_grow=grow)
        got = np.full((H, W), 7, np.uint8)
        key_i420(got, yuv, W, H, rects, pitch, keep=keep, keep_grow=grow)
        assert np.array_equal(got, want), np.count_nonzero(got != want)
        assert 0.1 < np.mean(got == 255) < 0.9
        # rectangles reaching past the frame are clipped to it
        assert np.array_equal(key_i420(np.zeros((H, W), np.uint8), yuv, W, H, [(1200, 600, 1300, 800), (-8, -8, 100, 50)], pitch, keep=keep, keep_grow=grow),
                              key_i420(np.zeros((H, W), np.uint8), yuv, W, H, [(1200, 600, 1280, 720), (0, 0, 100, 50)], pitch, keep=keep, keep_grow=grow))
    assert np.array_equal(key_i420(np.zeros((H, W), np.uint8), noise, W, H, [], pitch), np.zeros((H, W), np.uint8))


@pytest.mark.parametrize("key", [False, "green"])
def test_render_clip_draws_known_cameras(small, tmp_path, key):
    """The decode -> composite -> encode loop with cameras from a file (``arstream render``)."""
    truth = read_jsonl(small / "truth.jsonl")
    cams = tmp_path / "cams.jsonl"
    # frame 3 lost: copied through unchanged
    cams.write_text("".join(json.dumps(dict(r, K=None, R=None, t=None, status="lost") if r["frame"] == 3 else r) + "\n" for r in truth))
    s = arstream.render_clip(small / "clip.mp4", cams, tmp_path / "o.mp4", key=key)
    assert s.frames == 12 and s.tracked == 11
    with VideoSource(small / "clip.mp4") as a, VideoSource(tmp_path / "o.mp4") as b:
        changed = [int((np.abs(fa.image.astype(int) - fb.image.astype(int)).max(axis=2) > 60).sum()) for fa, fb in zip(a, b)]
    assert len(changed) == 12
    assert max(changed) > 200  # the demo logo / offside line were drawn
    assert changed[3] < 20  # the lost frame: only re-encoding noise


@pytest.mark.parametrize("command", ["process", "render"])
def test_no_keep_b_frames_leaves_the_types_to_x264(small, tmp_path, command, monkeypatch):
    """``--no-keep-b-frames`` is the library's ``keep_b_frames=False``: no frame is
    given a type, and the same pictures are encoded (lossless encodes decode to
    them exactly); by default the input's B-frames stay B-frames."""
    src = small / "clip.mp4"
    args = [command, str(src), "-q"] + (["--cameras", str(small / "truth.jsonl")] if command == "render" else [])
    given = _types_given(monkeypatch)
    types_in = picture_types(src)
    assert "B" in types_in

    def library(out):
        if command == "process":
            return arstream.process(src, out, crf=0, keep_b_frames=False).frames
        return arstream.render_clip(src, small / "truth.jsonl", out, crf=0, keep_b_frames=False).frames

    runs = {}
    for name, run in (
        ("free", lambda out: cli(*args, "--crf", "0", "-o", str(out), "--no-keep-b-frames") == 0),
        ("lib", lambda out: library(out) == len(types_in)),
        ("kept", lambda out: cli(*args, "-o", str(out)) == 0),
    ):
        given.clear()
        assert run(tmp_path / f"{name}.mp4")
        runs[name] = list(given), _decoded(tmp_path / f"{name}.mp4")
    assert runs["free"][0] == runs["lib"][0] == ["NONE"] * len(types_in)
    assert len(runs["free"][1]) == len(types_in) and all(np.array_equal(a, b) for a, b in zip(runs["free"][1], runs["lib"][1]))
    assert runs["kept"][0] == ["B" if t == "B" else "NONE" for t in types_in]
    assert all(t == "B" for s, t in zip(types_in, picture_types(tmp_path / "kept.mp4")) if s == "B")


@pytest.mark.parametrize("name, words", [("o.xyz", "Could not determine output format"), ("noext", "give the file an extension")])
def test_bad_output_paths_are_one_line_errors(small, tmp_path, capsys, name, words):
    assert cli("process", str(small / "clip.mp4"), "-o", str(tmp_path / name), "-q") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0], err
    assert os.listdir(tmp_path) == []


def test_overlapped_stage_gives_identical_output(small, tmp_path):
    """The matte of frame i+1 computed on a worker thread while frame i renders: same bytes."""
    outs = []
    for overlap in (False, True):
        out = tmp_path / f"o{int(overlap)}.mp4"
        s = arstream.render_clip(small / "clip.mp4", small / "truth.jsonl", out, key="green", overlap=overlap, crf=0)  # lossless: see _types_given
        assert s.frames == 12 and s.stage_ms["key"] > 0
        outs.append(_decoded(out))
    assert len(outs[0]) == len(outs[1]) == 12
    assert all(np.array_equal(a, b) for a, b in zip(*outs))


def test_single_threaded_process_gives_identical_output(small, tmp_path):
    """``threads=1`` (a batch worker per core: no detection overlap, one decoder
    thread) writes the same video and cameras as the default."""
    outs = []
    for threads in (0, 1):
        out, cams = tmp_path / f"t{threads}.mp4", tmp_path / f"t{threads}.jsonl"
        s = arstream.process(small / "clip.mp4", out, cameras_out=cams, threads=threads, handle_signals=False, crf=0)  # lossless: see _types_given
        assert s.frames == 12 and s.tracked >= 9  # (the halfway line shows as a straight line from frame 2 or 3 at this size)
        outs.append((_decoded(out), cams.read_bytes()))
    assert outs[0][1] == outs[1][1]
    assert len(outs[0][0]) == len(outs[1][0]) == 12 and all(np.array_equal(a, b) for a, b in zip(outs[0][0], outs[1][0]))
    with pytest.raises(ValueError, match=r"threads must be 0 \(auto\) or positive, got -1"):
        arstream.process(small / "clip.mp4", tmp_path / "x.mp4", threads=-1)


def test_a_bug_in_a_stage_is_one_line_and_the_outputs_are_finalised(small, tmp_path, capsys, monkeypatch):
    import arstream.track

    orig = arstream.track.Tracker.process

    def broken(self, index, *a, **k):
        if index == 8:
            raise AttributeError("'NoneType' object has no attribute 'fun'")
        return orig(self, index, *a, **k)

    monkeypatch.setattr(arstream.track.Tracker, "process", broken)
    out, cams = tmp_path / "o.mp4", tmp_path / "c.jsonl"
    assert cli("process", str(small / "clip.mp4"), "-o", str(out), "--cameras-out", str(cams), "--lag", "2", "-q") == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["arstream: internal error: AttributeError: 'NoneType' object has no attribute 'fun' (--verbose shows the traceback)"]
    with av.open(str(out)) as c:  # what was done is a complete, playable file
        n = sum(1 for _ in c.decode(video=0))
    assert n == len(read_jsonl(cams)) == 6  # frames 0-5: the smoother held 6 and 7
    assert not os.path.exists(atomic_path(str(out)))



@pytest.mark.parametrize("pool_threads", [1, None])
def test_library_pools_during_a_run_and_restored_after(small, pool_threads):
    """The pipeline runs OpenCV and the BLAS behind numpy / scipy on one thread
    each (its own threads use the cores) and gives them their settings back
    afterwards, also when a stage fails; ``pool_threads=None`` leaves them alone."""
    from threadpoolctl import threadpool_info, threadpool_limits

    from arstream.pipeline.runner import Pipeline
    from arstream.pipeline.stage import Stage

    def blas():
        return sorted({p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"})

    seen = []

    class Probe(Stage):
        name = "probe"

        def process(self, item):
            seen.append((cv2.getNumThreads(), blas()))
            if item.index == 3:
                raise RuntimeError("stage failed")
            return [item]

    before = cv2.getNumThreads()
    cv2.setNumThreads(2)
    try:
        with threadpool_limits(2, user_api="blas"):
            assert blas() == [2]
            with VideoSource(small / "clip.mp4") as src:
                with pytest.raises(RuntimeError, match="stage failed"):
                    Pipeline(src, [Probe()], pool_threads=pool_threads).run(handle_signals=False)
            assert seen == [(1, [1]) if pool_threads == 1 else (2, [2])] * 4
            assert cv2.getNumThreads() == 2 and blas() == [2]
    finally:
        cv2.setNumThreads(before)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="per-thread niceness is Linux's")
def test_overlapped_worker_yields_to_the_encoder(small):
    """The overlapped stage's worker runs WORKER_NICE nicer than the thread that
    made it (the encoder's threads go first); the caller's thread is untouched."""
    import threading

    from arstream.pipeline.api import WORKER_NICE, _overlapped
    from arstream.pipeline.stage import Item, Stage, ThreadedStage

    def niceness():
        return os.getpriority(os.PRIO_PROCESS, threading.get_native_id())

    class Probe(Stage):
        name = "probe"
        seen: list = []

        def process(self, item):
            self.seen.append(niceness())
            return [item]

    mine = niceness()
    with VideoSource(small / "clip.mp4") as src:
        frames = [f for _, f in zip(range(3), src)]
    for stage, want in ((_overlapped(Probe(), True), min(19, mine + WORKER_NICE)), (ThreadedStage(Probe()), mine)):
        Probe.seen = []
        out = [it for f in frames for it in stage.process(Item(f))] + stage.flush()
        stage.close()
        assert [it.index for it in out] == [0, 1, 2] and Probe.seen == [want] * 3
    assert WORKER_NICE > 0 and niceness() == mine


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="per-thread niceness is Linux's")
@pytest.mark.parametrize("nice", [0, 3])
def test_decode_thread_niceness(small, nice):
    """``Pipeline(decode_nice=n)``: the decode thread runs n nicer than the caller
    (process and render_clip pass WORKER_NICE; live streams 0)."""
    import threading

    from arstream.pipeline.runner import Pipeline

    def niceness():
        return os.getpriority(os.PRIO_PROCESS, threading.get_native_id())

    seen = []
    mine = niceness()
    with VideoSource(small / "clip.mp4") as src:
        frames = src.frames

        def watched(*a, **k):
            seen.append(niceness())
            yield from frames(*a, **k)

        src.frames = watched
        s = Pipeline(src, [], decode_nice=nice).run(handle_signals=False)
    assert s.frames == 12 and seen == [min(19, mine + nice)] and niceness() == mine


def test_prepare_runs_on_the_decode_thread_and_fills_the_items(small):
    """``Pipeline(prepare=fn)``: ``fn`` sees every frame on the decode thread and
    its fields land on the frame's item; :meth:`Analysis.prepare` gives the
    analysis frame that :meth:`Analysis.image` makes (pixel for pixel) and the
    thumbnail from the scaled luma, which the tracker takes in place of one made
    from the analysis frame."""
    import threading

    from arstream.imaging import grey_thumbnail
    from arstream.pipeline.runner import Pipeline
    from arstream.pipeline.stage import Item, Stage

    an = Analysis(320, 180, 160)
    threads, seen = [], []

    def prepare(frame):
        threads.append(threading.current_thread().name)
        return an.prepare(frame)

    class Probe(Stage):
        name = "probe"

        def process(self, item):
            again = Item(item.frame)  # (nothing prepared: made here, as before)
            seen.append((item.index, item.analysis.shape, np.array_equal(item.analysis, an.image(again)), np.abs(item.thumbnail - grey_thumbnail(item.analysis)).max()))
            assert an.image(item) is item.analysis and np.array_equal(again.thumbnail, item.thumbnail)
            return [item]

    with VideoSource(small / "clip.mp4") as src:
        s = Pipeline(src, [Probe()], prepare=prepare).run(handle_signals=False)
    assert s.frames == 12 and threads == ["arstream-decode"] * 12
    assert [x[:3] for x in seen] == [(i, (90, 160, 3), True) for i in range(12)]
    assert max(x[3] for x in seen) < 4.0  # the same frame, within rounding (test_imaging)
    # full resolution and BGR frames: no thumbnail (the tracker makes its own)
    assert Analysis(320, 180, None).prepare(None) == {}
    with VideoSource(small / "clip.mp4", threads=False) as src:
        f = next(iter(src))
    f.image  # (a BGR copy made: the BGR path)
    assert set(an.prepare(f)) == {"analysis"}


@pytest.mark.parametrize(
    "size, aw, area, crop, aspect",
    [
        ((1280, 720), 640, (160, 0, 1120, 720), (80, 0, 560, 360), 1.0),  # pillarbox, scaled by 2
        ((1280, 720), 640, (0, 90, 1280, 630), (0, 46, 640, 314), 1.0),  # letterbox
        ((1280, 720), 640, (0, 0, 1280, 601), (0, 0, 640, 300), 1.0),  # a bar at the bottom only
        ((854, 480), 640, (107, 0, 747, 480), (108, 0, 746, 480), 1.0),  # at the frame's own size
        ((720, 576), 640, (90, 0, 630, 576), (80, 0, 560, 360), 64 / 45),  # anamorphic SD, pillarboxed
        ((1280, 720), 640, (0, 0, 1280, 720), (0, 0, 640, 360), 1.0),  # no bars: no crop
    ],
)
def test_analysis_of_a_picture_inside_black_bars_maps_cameras_exactly(size, aw, area, crop, aspect):
    """The analysis frame is the picture, its corners inward on even pixels;
    a camera solved on it with the frame's centre as principal point maps back
    exactly, and a mask of it goes back into the whole frame over the bars."""
    from geometry.camera import PTZ, camera_from_ptz

    W, H = size
    an = Analysis(W, H, aw, area=area, pixel_aspect=aspect)
    assert an.crop == crop and (an.w, an.h) == (crop[2] - crop[0], crop[3] - crop[1])
    assert an.cropped == (crop != (0, 0) + an.scaled) and (an.picture is None) == (not an.cropped)
    if an.cropped:
        x0, y0, x1, y1 = an.picture
        assert area[0] <= x0 and area[1] <= y0 and x1 <= area[2] and y1 <= area[3]  # inside the picture
    # the solver's principal point is the frame's centre
    assert np.allclose(an.S @ [*an.principal_point, 1.0], [(W - 1) / 2, (H - 1) / 2, 1.0], atol=1e-9)
    small = camera_from_ptz(np.array([0.0, -60.0, 18.0]), PTZ(0.1, 0.25, 0.01, 1.2 * an.w), an.principal_point, dist=(-0.05,))
    full = an.camera(small)
    X = np.random.default_rng(0).uniform((-40, -30, 0), (40, 30, 3), (50, 3))
    assert np.allclose(full.project(X), an.points(small.project(X)), atol=1e-9)
    assert np.allclose(full.K[:2, 2], ((W - 1) / 2, (H - 1) / 2), atol=1e-9)
    # the analysis frame is the scaled frame's box, made from BGR or from the I420 planes alike
    rng = np.random.default_rng(1)
    img = cv2.GaussianBlur(rng.integers(0, 256, (H, W, 3), dtype=np.uint8), (0, 0), 3)
    yuv = cv2.cvtColor(img, cv2.COLOR_BGR2YUV_I420)
    from arstream.imaging import scale_to
    from arstream.source import Frame

    want = scale_to(img, an.scaled)[crop[1] : crop[3], crop[0] : crop[2]] if an.scaling else img[crop[1] : crop[3], crop[0] : crop[2]]
    got = an.prepare(Frame(0, 0.0, img.copy()))
    if an.full:
        assert got == {}
    else:
        assert np.array_equal(got["analysis"], want)
        g = an.prepare(Frame(0, 0.0, yuv=yuv, width=W, height=H))["analysis"]
        assert g.shape == want.shape and np.mean(np.abs(g.astype(int) - want.astype(int))) < 3.0
    # a mask of the analysis frame at a quarter of its size goes back where it came from
    m = np.full((an.h // 4, an.w // 4), 255, np.uint8)
    e = an.embed(m)
    if not an.cropped:
        assert e is m
    else:
        assert np.allclose(e.shape, (an.scaled[1] / 4, an.scaled[0] / 4), atol=1.0)  # the whole frame
        ys, xs = np.nonzero(e)
        assert (xs.max() + 1 - xs.min(), ys.max() + 1 - ys.min()) == (an.w // 4, an.h // 4)  # all of it, to the nearest mask pixel:
        assert np.allclose((xs.min(), ys.min()), (crop[0] / 4, crop[1] / 4), atol=0.5)


@pytest.mark.parametrize("area", [(0, 0, 1281, 720), (-1, 0, 100, 100), (200, 0, 100, 720)])
def test_analysis_refuses_a_picture_outside_the_frame(area):
    with pytest.raises(ValueError, match=r"picture area must lie in the 1280 x 720 frame"):
        Analysis(1280, 720, 640, area=area)


@pytest.mark.parametrize("variant, left, top", [("pillar:0.125", 80, 0), ("letter:0.125", 0, 45)])
def test_a_clip_inside_black_bars_is_tracked_on_its_picture(clip, tmp_path, variant, left, top):
    """Pillarbox and letterbox bars (12.5 % a side) over a synthetic clip: the
    run analyses the picture inside them (the summary says which) with the
    frame's principal point, and the cameras are the frame's. With the bars
    in the analysed picture their edges pass for markings (without the crop:
    median 0.67 and 1.18 px, against 0.13 and 0.14)."""
    from arstream.evaluate import score

    sys.path.insert(0, os.path.join(ROOT, "bench"))
    from real_bars import barred_copy  # (bench/real_bars.py's copies of the real clips)

    barred = barred_copy(clip / "clip.mp4", tmp_path / "barred.mp4", variant)
    s = arstream.process(barred, tmp_path / "o.mp4", cameras_out=tmp_path / "c.jsonl")
    x0, y0, x1, y1 = s.picture
    assert max(abs(x0 - left), abs(640 - x1 - left), abs(y0 - top), abs(360 - y1 - top)) <= 4
    assert "picture inside black bars" in s.line()
    sc = score(read_jsonl(clip / "truth.jsonl"), read_jsonl(tmp_path / "c.jsonl"), (640, 360))
    assert sc.coverage >= 0.9 and sc.median <= 0.5 and sc.p95 <= 1.0, (sc.coverage, sc.median, sc.p95)
    # the graphics are keyed to the picture: drawn in it, nothing over the bars
    # (beyond the two encodings' noise)
    with VideoSource(barred) as a, VideoSource(tmp_path / "o.mp4") as b:
        drawn = 0
        for fa, fb in zip(a, b):
            d = np.abs(fa.image.astype(int) - fb.image.astype(int)).max(axis=2)
            inside = d[top : 360 - top, left : 640 - left]
            assert d.max() == inside.max() or d.max() <= 24
            drawn = max(drawn, int(inside.max()))
        assert drawn > 60


def test_the_demo_offside_line_ends_at_the_touchlines_of_the_pitch_given(tmp_path):
    # process --pitch 100x64 with the demo scene: the offside line (x = 21.5 m)
    # spans 64 m, not 105 x 68's 68 m. Its drawn pixels, carried back to the
    # pitch plane by the camera they were drawn with, lie within the touchlines
    # (32 m + its anti-aliased edge), and so do arstream render's with those
    # cameras; a scene that states 68 m draws 2 m past them
    generate(tmp_path, preset="wide", seed=4, frames=3, size=(640, 360), pitch=(100, 64))
    stated = tmp_path / "stated.toml"
    stated.write_text('[pitch]\nlength = 105.0\nwidth = 68.0\n[[objects]]\ntype = "offside_line"\nx = 21.5\nwidth = 0.2\ncolor = "#ffd21f"\n')

    def frames(path):
        with av.open(str(path)) as c:
            return [f.to_ndarray(format="bgr24") for f in c.decode(video=0)]

    beyond = {}
    for name, scene in [("demo", None), ("stated", stated), ("rendered", None)]:
        out, cams = tmp_path / f"{name}.mp4", tmp_path / f"{name}.jsonl"
        if name == "rendered":  # (arstream render with the demo run's cameras: their records say the size)
            cams = tmp_path / "demo.jsonl"
            arstream.render_clip(str(tmp_path / "clip.mp4"), str(cams), str(out), handle_signals=False)
        else:
            arstream.process(str(tmp_path / "clip.mp4"), str(out), cameras_out=str(cams), pitch=(100, 64), scene=scene, handle_signals=False)
        line = far = 0
        for before, after, rec in zip(frames(tmp_path / "clip.mp4"), frames(out), read_jsonl(cams)):
            assert rec["H"] is not None
            v, u = np.nonzero(np.abs(after.astype(int) - before.astype(int)).sum(axis=2) > 60)
            P = np.linalg.inv(np.asarray(rec["H"], float)) @ np.vstack([u, v, np.ones_like(u)])
            X, Y = P[0] / P[2], P[1] / P[2]
            on = np.abs(X - 21.5) < 1.0  # (the line's pixels, not the logo's)
            line += int(on.sum())
            far += int((np.abs(Y[on]) > 32.6).sum())
        assert line > 1000, (name, line)
        beyond[name] = far / line
    assert beyond["demo"] <= 0.01 and beyond["rendered"] <= 0.01 and beyond["stated"] >= 0.04, beyond


def test_a_clip_longer_than_the_scan_decides_its_size_on_its_opening(tmp_path, monkeypatch):
    # a clip longer than the scan's window (made 50 frames here) whose size is
    # not 105 x 68: the runs that decide the size track the window and write
    # nothing; the clip is tracked in full twice (the default's run, then the
    # size decided), not once more per decision. The outputs are the last
    # run's, whole, and as right as the truth allows
    from arstream.evaluate import score
    from arstream.pipeline import api
    from geometry.pitch import PitchModel

    generate(tmp_path, preset="wide", seed=4, frames=100, size=(640, 360), pitch=(110, 64))
    runs = []
    once = api._process_once

    def counted(input, output, cameras_out, **kw):
        runs.append((kw["max_frames"], output is not None or cameras_out is not None))
        return once(input, output, cameras_out, **kw)

    monkeypatch.setattr(api, "_process_once", counted)
    monkeypatch.setattr(api, "DECISION_FRAMES", 50)
    s = arstream.process(str(tmp_path / "clip.mp4"), str(tmp_path / "o.mp4"), cameras_out=str(tmp_path / "c.jsonl"), handle_signals=False)
    assert runs[0] == (None, True) and runs[-1] == (None, True) and len(runs) >= 3, runs
    assert all(r == (50, False) for r in runs[1:-1]), runs
    assert s.frames == 100 and len(read_jsonl(tmp_path / "c.jsonl")) == 100
    assert abs(s.pitch["length"] - 110) <= 1.0 and abs(s.pitch["width"] - 64) <= 1.0 and s.pitch["source"] == "estimated", s.pitch_text
    got = score(read_jsonl(tmp_path / "truth.jsonl"), read_jsonl(tmp_path / "c.jsonl"), (640, 360), pitch=PitchModel(110, 64), pred_pitch=PitchModel(s.pitch["length"], s.pitch["width"]))
    assert got.coverage == 1.0 and got.median <= 1.0, (got.coverage, got.median)
    with av.open(str(tmp_path / "o.mp4")) as c:
        assert sum(1 for _ in c.decode(video=0)) == 100


def test_stopped_while_deciding_a_long_clip_s_size_the_first_run_s_outputs_stand(tmp_path, monkeypatch):
    # Ctrl-C during the decision runs (which write nothing): the Interrupted
    # carries the first run's summary, whose outputs are whole
    from arstream.pipeline import api
    from arstream.pipeline.summary import Interrupted

    generate(tmp_path, preset="wide", seed=4, frames=60, size=(640, 360), pitch=(110, 64))

    def stopped(input, output, cameras_out, first, an, run):
        assert output is None and cameras_out is None and run["max_frames"] == 30
        raise Interrupted(signal.SIGINT, Summary(frames=30, seconds=first.seconds + 1.0))

    monkeypatch.setattr(api, "_rescan", stopped)
    monkeypatch.setattr(api, "DECISION_FRAMES", 30)
    import arstream.pitch_size

    monkeypatch.setattr(arstream.pitch_size, "needs_scan", lambda *a, **k: True)  # (asked whatever the first run's paint)
    with pytest.raises(Interrupted) as exc:
        arstream.process(str(tmp_path / "clip.mp4"), str(tmp_path / "o.mp4"), cameras_out=str(tmp_path / "c.jsonl"), handle_signals=False)
    s = exc.value.summary
    assert s.frames == 60 and s.interrupted == signal.SIGINT and s.output == str(tmp_path / "o.mp4")
    assert len(read_jsonl(tmp_path / "c.jsonl")) == 60
    with av.open(str(tmp_path / "o.mp4")) as c:
        assert sum(1 for _ in c.decode(video=0)) == 60


def test_cameras_jsonl_says_the_size_each_camera_was_made_at(tmp_path):
    # each record with a camera carries the pitch's size it was solved at, so
    # that eval --video judges a run at a size it found (or was given) on that
    # size's markings without --pitch; a lost record carries none
    from arstream.evaluate_video import evaluate_video
    from geometry.pitch import PitchModel

    generate(tmp_path, preset="wide", seed=4, frames=12, size=(640, 360), pitch=(110, 64))
    for given, want in [((110, 64), (110.0, 64.0)), (None, (105.0, 68.0))]:
        cams = tmp_path / f"{given}.jsonl"
        arstream.process(str(tmp_path / "clip.mp4"), cameras_out=str(cams), pitch=given, handle_signals=False)
        recs = read_jsonl(cams)
        assert all(r["pitch"] == {"length": want[0], "width": want[1]} for r in recs if r["K"] is not None), recs[0]
        assert all("pitch" not in r for r in recs if r["K"] is None)
    recs = read_jsonl(tmp_path / "(110, 64).jsonl")
    own = evaluate_video(str(tmp_path / "clip.mp4"), recs)
    told = evaluate_video(str(tmp_path / "clip.mp4"), recs, pitch=PitchModel(110, 64))
    wrong = evaluate_video(str(tmp_path / "clip.mp4"), recs, pitch=PitchModel(105, 68))
    assert own.support_median == told.support_median and own.support_median >= 0.95
    assert wrong.support_median < own.support_median - 0.05, (wrong.support_median, own.support_median)
    # eval --truth as well: the 105 x 68 run's cameras on the 110 x 64 m clip are
    # judged where they draw their own pitch's markings, not as if made at 110 x 64
    from arstream.evaluate import score

    truth, recs = read_jsonl(tmp_path / "truth.jsonl"), read_jsonl(tmp_path / "None.jsonl")
    own = score(truth, recs, (640, 360), pitch=PitchModel(110, 64))
    told = score(truth, recs, (640, 360), pitch=PitchModel(110, 64), pred_pitch=PitchModel(105, 68))
    same = score(truth, recs, (640, 360), pitch=PitchModel(110, 64), pred_pitch=PitchModel(110, 64))
    assert own.median == told.median and abs(own.median - same.median) > 0.5, (own.median, told.median, same.median)
