"""``arstream batch``: a clip archive on a real process pool and a real local Ray.

Short synthetic clips (arstream.synth, 320x180), one of them corrupt; real
PyAV, real GL, real worker processes. Interruption is tested with real
signals to a real ``arstream batch`` process, a worker crash by killing a
real worker. Ray tests skip where Ray is not installed.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time

import av
import numpy as np
import pytest

from arstream import batch
from arstream.batch import RESULT_FIELDS, STATE_DIR, assign_names, collect
from arstream.cli import main
from arstream.errors import ArstreamError, InputError
from arstream.sink import read_jsonl
from arstream.synth import generate

# one worker of a parallel run (pytest-xdist) takes the whole module: its
# fixtures (the archive, the Ray session) are made once, and two Ray clusters
# are not started side by side
pytestmark = [pytest.mark.xdist_group("batch"), pytest.mark.long]

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FRAMES = 12
# ``local_out``'s batch, and those that resume it or are compared with it, encode
# losslessly (x264 at crf 0), so that their pictures are compared, not x264's choices: its AVX-512
# code (on CPUs that have it) reads memory it has not written, and two lossy
# encodes of the same pictures may differ in a few pixels (bench/README.md,
# "Reproducible encodes"). The cameras are compared byte for byte as they are.
LOSSLESS = {"crf": 0}
SUMMARY_KEYS = {"name", "input", "status", "skipped", "frames", "tracked", "share_tracked", "fps", "seconds", "error", "output", "cameras"}


# --------------------------------------------------------------------------- helpers
def frame_hashes(path) -> list[str]:
    with av.open(str(path)) as c:
        return [hashlib.md5(f.to_ndarray(format="yuv420p").tobytes()).hexdigest() for f in c.decode(video=0)]


def repeat_clip(src, dst, times: int, *, faststart: bool = False) -> None:
    """``src``'s video packets ``times`` times back to back (a longer clip, no re-encode);
    ``faststart`` puts the index first, so a truncated copy still opens."""
    with av.open(str(src)) as inp, av.open(str(dst), "w", options={"movflags": "faststart"} if faststart else {}) as out:
        vin = inp.streams.video[0]
        vout = out.add_stream_from_template(vin)
        pkts = [p for p in inp.demux(vin) if p.dts is not None]
        step = pkts[-1].pts - pkts[0].pts + (pkts[1].pts - pkts[0].pts)
        for k in range(times):
            for p in pkts:
                q = av.Packet(bytes(p))
                q.pts, q.dts = p.pts + k * step, p.dts + k * step
                q.is_keyframe = p.is_keyframe
                q.time_base = p.time_base
                q.stream = vout
                out.mux(q)


def outputs(d) -> set[str]:
    """Files in ``d`` (not the bookkeeping folder)."""
    return {f for f in os.listdir(d) if f != STATE_DIR}


def by_name(summary_or_records) -> dict:
    recs = summary_or_records.clips if hasattr(summary_or_records, "clips") else summary_or_records
    return {r["name"]: r for r in recs}


def result(rec: dict) -> dict:
    return {k: rec[k] for k in RESULT_FIELDS}


def wait_for(cond, what: str, timeout: float = 90.0) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.02)


def partial_lines(out, name) -> int:
    p = os.path.join(out, STATE_DIR, "work", name, f".{name}.cameras.partial.jsonl")
    try:
        with open(p) as f:
            return f.read().count("\n")
    except OSError:
        return 0


def done(out, name) -> bool:
    return os.path.exists(os.path.join(out, STATE_DIR, "done", name + ".json"))


# --------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def archive(tmp_path_factory):
    """archive/a/clip.mp4, archive/b/clip.mp4 (same file name: a name collision) and
    archive/corrupt.mp4 (the first half of a clip: no index, cannot be opened)."""
    root = tmp_path_factory.mktemp("archive")
    generate(root / "a", preset="wide", seed=1, frames=FRAMES, size=(320, 180))
    generate(root / "b", preset="zoom", seed=2, frames=FRAMES, size=(320, 180))
    data = (root / "a" / "clip.mp4").read_bytes()
    (root / "corrupt.mp4").write_bytes(data[: len(data) // 2])
    return root


@pytest.fixture(scope="module")
def local_out(archive, tmp_path_factory):
    out = tmp_path_factory.mktemp("local") / "out"
    s = batch.run([archive], out, engine="local", workers=2, handle_signals=False, **LOSSLESS)
    return out, s


@pytest.fixture(scope="module")
def long_clip(archive, tmp_path_factory):
    """Archive clip a repeated into a clip that takes about 5 seconds at this build's
    steady speed (at least 2 and at most 400 times): one that is still running when we
    look. The speed is the marginal time per frame between a 12-frame run and a
    120-frame run, both after a warm-up run: a clip's own ``fps`` counts the worker's
    start (GL context, the first frames' compiled kernels), which at 320x180 is most of
    a 12-frame clip's time, and a clip sized by it is over in a second. Returns
    (path, frames)."""
    d = tmp_path_factory.mktemp("long")
    src = archive / "a" / "clip.mp4"
    repeat_clip(src, d / "probe.mp4", 10)
    runs = {}
    for name, clip in (("warm", src), ("short", src), ("probe", d / "probe.mp4")):
        s = batch.run([clip], tmp_path_factory.mktemp(name) / "out", engine="local", workers=1, handle_signals=False)
        (rec,) = s.clips
        assert rec["status"] == "ok", rec
        runs[name] = rec["seconds"]
    per_frame = max(runs["probe"] - runs["short"], 1e-3) / (9 * FRAMES)
    times = int(min(max(round(5.0 / (per_frame * FRAMES)), 2), 400))
    repeat_clip(src, d / "long.mp4", times)
    return d / "long.mp4", times * FRAMES


@pytest.fixture(scope="module")
def ray_session():
    ray = pytest.importorskip("ray")
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, logging_level="error")
    yield ray
    ray.shutdown()


# --------------------------------------------------------------------------- local engine
def test_local_batch_writes_outputs_and_summary(archive, local_out):
    out, s = local_out
    recs = by_name(s)
    assert list(recs) == ["a__clip", "b__clip", "corrupt"]  # input order; same stems get their folders
    assert recs["a__clip"]["status"] == recs["b__clip"]["status"] == "ok"
    assert recs["corrupt"]["status"] == "failed" and "cannot open" in recs["corrupt"]["error"]
    assert s.exit_code == 1 and not s.all_ok and s.interrupted is None
    assert s.workers == 2 and s.frames == 2 * FRAMES
    assert outputs(out) == {"a__clip.mp4", "a__clip.cameras.jsonl", "b__clip.mp4", "b__clip.cameras.jsonl", "summary.jsonl"}
    for name in ("a__clip", "b__clip"):
        r = recs[name]
        assert r["frames"] == FRAMES and r["error"] is None and r["output"] == name + ".mp4"
        assert 0.0 <= r["share_tracked"] <= 1.0 and r["fps"] > 0
        assert len(frame_hashes(out / (name + ".mp4"))) == FRAMES
        assert [c["frame"] for c in read_jsonl(out / (name + ".cameras.jsonl"))] == list(range(FRAMES))
    lines = read_jsonl(out / "summary.jsonl")
    assert lines == s.clips and all(SUMMARY_KEYS <= set(r) for r in lines)
    assert sorted(os.listdir(out / STATE_DIR / "done")) == ["a__clip.json", "b__clip.json"]
    assert not (out / STATE_DIR / "work").exists()


def test_cli_rerun_skips_complete_clips(archive, local_out, tmp_path, capsys):
    out = tmp_path / "out"
    shutil.copytree(local_out[0], out)
    mtimes = {f: os.stat(out / f).st_mtime_ns for f in outputs(out) if f.endswith(".mp4")}
    assert main(["batch", str(archive), "--out", str(out), "--crf", "0", "--json", "-q"]) == 1  # the corrupt clip still fails
    res = json.loads(capsys.readouterr().out)
    recs = by_name(res["clips"])
    assert recs["a__clip"]["skipped"] and recs["b__clip"]["skipped"] and not recs["corrupt"]["skipped"]
    assert recs["corrupt"]["status"] == "failed" and res["counts"]["skipped"] == 2 and res["frames"] == 0
    assert {f: os.stat(out / f).st_mtime_ns for f in mtimes} == mtimes  # not redone
    # --force redoes them, with the same results
    assert main(["batch", str(archive / "a" / "clip.mp4"), str(archive / "b" / "clip.mp4"), "--out", str(out), "--crf", "0", "--force", "-q"]) == 0
    out_lines = capsys.readouterr().out
    assert "2 clips: 2 ok" in out_lines
    new = by_name(read_jsonl(out / "summary.jsonl"))
    assert not any(r["skipped"] for r in new.values())
    first = by_name(local_out[1])
    assert [result(new[n]) for n in ("a__clip", "b__clip")] == [result(first[n]) for n in ("a__clip", "b__clip")]


def test_resume_after_an_interrupted_batch(archive, local_out, tmp_path):
    """What a batch killed outright leaves: b__clip's video renamed into place but not its
    cameras nor its done record; a work folder with partial files. Only b__clip is redone."""
    out = tmp_path / "out"
    shutil.copytree(local_out[0], out)
    os.remove(out / STATE_DIR / "done" / "b__clip.json")
    os.remove(out / "b__clip.cameras.jsonl")
    (out / "b__clip.mp4").write_bytes(b"half a video")  # under its final name, but not done
    work = out / STATE_DIR / "work" / "b__clip"
    work.mkdir(parents=True)
    (work / ".b__clip.partial.mp4").write_bytes(b"\0" * 1000)
    a_mtime = os.stat(out / "a__clip.mp4").st_mtime_ns
    seen = []
    s = batch.run([archive / "a", archive / "b"], out, workers=2, handle_signals=False, progress=seen.append, **LOSSLESS)
    recs = by_name(s)
    last = seen[-1]  # the whole batch's progress
    assert (last.clips_total, last.clips_done, last.clips_skipped, last.frames, last.running) == (2, 2, 1, FRAMES, {})
    assert last.fraction == 1.0 and all(0.0 <= p.fraction <= 1.0 for p in seen)
    assert recs["a__clip"]["skipped"] and not recs["b__clip"]["skipped"]
    assert recs["b__clip"]["status"] == "ok" and s.exit_code == 0
    assert os.stat(out / "a__clip.mp4").st_mtime_ns == a_mtime
    assert frame_hashes(out / "b__clip.mp4") == frame_hashes(local_out[0] / "b__clip.mp4")
    assert (out / "b__clip.cameras.jsonl").read_bytes() == (local_out[0] / "b__clip.cameras.jsonl").read_bytes()
    assert not (out / STATE_DIR / "work").exists()


def test_changed_input_or_options_redo_the_clip(archive, local_out, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(local_out[0], out)
    src = tmp_path / "src"
    shutil.copytree(archive / "a", src / "a")
    shutil.copytree(archive / "b", src / "b")
    # same names, other inputs: the recorded names are not reused for them
    s = batch.run([src], out, workers=2, max_frames=2, handle_signals=False)
    assert [r["name"] for r in s.clips] == ["a__clip-2", "b__clip-2"]
    assert all(r["frames"] == 2 for r in s.clips)
    assert len(frame_hashes(out / "a__clip.mp4")) == FRAMES  # the namesake's outputs are untouched
    # options changed (max_frames): redone; input touched: redone
    s = batch.run([src], out, workers=2, max_frames=3, handle_signals=False)
    assert [r["frames"] for r in s.clips] == [3, 3] and not any(r["skipped"] for r in s.clips)
    os.utime(src / "b" / "clip.mp4", ns=(1, 1))
    s = batch.run([src], out, workers=2, max_frames=3, handle_signals=False)
    assert [r["skipped"] for r in s.clips] == [True, False]
    # an encoder option (the input's B-frames left to x264): redone
    s = batch.run([src], out, workers=2, max_frames=3, keep_b_frames=False, handle_signals=False)
    assert [r["skipped"] for r in s.clips] == [False, False]


def test_damaged_input_is_kept_reported_and_not_redone(archive, tmp_path):
    repeat_clip(archive / "b" / "clip.mp4", tmp_path / "fs.mp4", 1, faststart=True)
    data = (tmp_path / "fs.mp4").read_bytes()
    (tmp_path / "cut.mp4").write_bytes(data[: int(len(data) * 0.6)])  # opens, ends early
    out = tmp_path / "out"
    s = batch.run([tmp_path / "cut.mp4"], out, workers=1, handle_signals=False)
    (r,) = s.clips
    assert r["status"] == "damaged" and r["damage"] and "damaged" in r["error"]
    assert 0 < r["frames"] < FRAMES and s.exit_code == 1
    assert len(read_jsonl(out / "cut.cameras.jsonl")) == r["frames"] == len(frame_hashes(out / "cut.mp4"))
    s = batch.run([tmp_path / "cut.mp4"], out, handle_signals=False)  # the same result again: kept
    assert s.clips[0]["skipped"] and s.clips[0]["status"] == "damaged" and s.exit_code == 1


def test_a_worker_killed_mid_clip_is_retried(archive, long_clip, tmp_path):
    long_clip, long_frames = long_clip
    out = tmp_path / "out"
    box = {}
    t = threading.Thread(target=lambda: box.update(s=batch.run([long_clip, archive / "b"], out, workers=1, handle_signals=False)))
    t.start()
    try:
        wait_for(lambda: partial_lines(out, "long") >= 2, "the long clip to start")
        workers = writers_of(out / STATE_DIR / "work" / "long")
        assert len(workers) == 1 and workers[0] != os.getpid()
        os.kill(workers[0], signal.SIGKILL)
    finally:
        t.join(120)
    recs = by_name(box["s"])
    assert recs["long"]["status"] == "ok" and recs["long"]["frames"] == long_frames  # retried in a new worker
    assert recs["clip"]["status"] == "ok"
    assert not (out / STATE_DIR / "work").exists()


def writers_of(folder) -> list[int]:
    """Processes with a file in ``folder`` open (the worker processing that clip)."""
    folder = str(folder) + os.sep
    pids = set()
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            for fd in os.listdir(f"/proc/{d}/fd"):
                if os.readlink(f"/proc/{d}/fd/{fd}").startswith(folder):
                    pids.add(int(d))
        except OSError:
            continue
    return sorted(pids)



def test_two_quick_signals_count_twice_while_the_main_thread_is_busy():
    # Python runs a signal's handler once for however many times the signal
    # arrived while the main thread was busy in C code (a loaded machine may not
    # schedule it between two quick Ctrl-Cs); the batch still counts both
    sig = batch._Signals()
    big = np.random.default_rng(0).random(3 * 10**7)  # (a heapsort of 0.4-1 s)
    sent = []

    def send():
        time.sleep(0.05)
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.05)
        os.kill(os.getpid(), signal.SIGINT)
        sent.append(time.perf_counter())

    with sig.installed(True):
        t = threading.Thread(target=send)
        t0 = time.perf_counter()
        t.start()
        np.sort(big, kind="heapsort")  # one C call, no handler runs inside it
        t1 = time.perf_counter()
        t.join()
        for _ in range(3):  # the handlers run between bytecodes
            time.sleep(0.01)
    assert t0 < sent[0] < t1  # (both signals arrived inside the sort)
    assert sig.first == signal.SIGINT and sig.count == 2

@pytest.mark.parametrize("signals", [1, 2], ids=["ctrl-c-finishes-running", "second-ctrl-c-abandons"])
def test_ctrl_c_stops_the_batch(archive, long_clip, tmp_path, signals):
    long_clip, long_frames = long_clip
    out = tmp_path / "out"
    shutil.copy(archive / "a" / "clip.mp4", tmp_path / "first.mp4")
    shutil.copy(archive / "b" / "clip.mp4", tmp_path / "last.mp4")
    inputs = [str(tmp_path / "first.mp4"), str(long_clip), str(tmp_path / "last.mp4")]
    p = subprocess.Popen([sys.executable, "-m", "arstream.cli", "batch", *inputs, "--out", str(out), "--workers", "1"], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_for(lambda: (done(out, "first") and partial_lines(out, "long") >= 2) or p.poll() is not None, "the long clip to start")
        assert p.poll() is None, p.communicate()
        for _ in range(signals):
            p.send_signal(signal.SIGINT)
            time.sleep(0.05)
        stdout, stderr = p.communicate(timeout=120)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 130, stderr
    assert "interrupted" in stderr and "Traceback" not in stderr
    recs = by_name(read_jsonl(out / "summary.jsonl"))
    assert recs["first"]["status"] == "ok" and recs["last"]["status"] == "cancelled"
    if signals == 1:  # the running clip finished
        assert recs["long"]["status"] == "ok" and recs["long"]["frames"] == long_frames
        assert outputs(out) == {"first.mp4", "first.cameras.jsonl", "long.mp4", "long.cameras.jsonl", "summary.jsonl"}
    else:  # abandoned: nothing of it under a final name
        assert recs["long"]["status"] == "interrupted"
        assert outputs(out) == {"first.mp4", "first.cameras.jsonl", "summary.jsonl"}
    assert not (out / STATE_DIR / "work").exists()
    if signals == 2:  # the next run does what is left
        s = batch.run(inputs, out, workers=2, handle_signals=False)
        assert [r["skipped"] for r in s.clips] == [True, False, False]
        assert s.all_ok and s.exit_code == 0


# --------------------------------------------------------------------------- ray engine
def test_ray_batch_matches_local(archive, local_out, ray_session, tmp_path):
    out = tmp_path / "out"
    s = batch.run([archive], out, engine="ray", handle_signals=False, **LOSSLESS)
    assert ray_session.is_initialized()  # a Ray the caller started is left running
    assert s.engine == "ray" and s.workers == 2
    assert [result(r) for r in s.clips] == [result(r) for r in local_out[1].clips]
    assert outputs(out) == outputs(local_out[0])
    for name in ("a__clip", "b__clip"):
        assert (out / f"{name}.cameras.jsonl").read_bytes() == (local_out[0] / f"{name}.cameras.jsonl").read_bytes()
        assert frame_hashes(out / f"{name}.mp4") == frame_hashes(local_out[0] / f"{name}.mp4")
    # resumable the same way
    s = batch.run([archive], out, engine="ray", handle_signals=False, **LOSSLESS)
    assert [r["skipped"] for r in s.clips] == [True, True, False]


def test_ray_cli_joins_an_existing_cluster(archive, local_out, ray_session, tmp_path):
    address = ray_session.get_runtime_context().gcs_address
    out = tmp_path / "out"
    r = subprocess.run(
        [sys.executable, "-m", "arstream.cli", "batch", str(archive / "a"), str(archive / "b"), "--out", str(out), "--engine", "ray", "--address", address, "-q", "--json"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=180,
    )
    assert r.returncode == 0, r.stderr
    res = json.loads(r.stdout)
    assert res["engine"] == "ray" and res["all_ok"]
    local = by_name(local_out[1])
    assert [result(c) for c in res["clips"]] == [result(local[n]) for n in ("a__clip", "b__clip")]


def test_ray_unreachable_address_is_a_clear_error(archive, tmp_path):
    pytest.importorskip("ray")
    r = subprocess.run(
        [sys.executable, "-m", "arstream.cli", "batch", str(archive / "a"), "--out", str(tmp_path / "out"), "--engine", "ray", "--address", "127.0.0.1:1"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 1
    assert r.stderr.strip().splitlines()[-1].startswith("arstream: error: no Ray cluster at 127.0.0.1:1")


def test_ray_missing_names_the_extra(archive, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # as if not installed
    with pytest.raises(ArstreamError, match=r'pip install "arstream\[cluster\]"'):
        batch.run([archive / "a"], tmp_path / "out", engine="ray", handle_signals=False)


# --------------------------------------------------------------------------- inputs, names, usage
def test_collect_files_folders_and_patterns(tmp_path):
    for rel in ("m/a/x.mp4", "m/a/y.MKV", "m/b/x.mp4", "m/notes.txt", "m/.hidden/z.mp4", "m/.w.mp4", "m/out/o.mp4", "solo.bin"):
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_bytes(b"")
    m = str(tmp_path / "m")
    assert collect([m], exclude=tmp_path / "m" / "out") == [f"{m}/a/x.mp4", f"{m}/a/y.MKV", f"{m}/b/x.mp4"]
    assert collect([f"{m}/**/x.mp4", f"{m}/a/x.mp4"]) == [f"{m}/a/x.mp4", f"{m}/b/x.mp4"]  # each once
    assert collect([str(tmp_path / "solo.bin")]) == [str(tmp_path / "solo.bin")]  # named explicitly: taken
    for bad, words in (([str(tmp_path / "nope.mp4")], "not found"), ([f"{m}/*.avi"], "no clips match"), ([f"{m}/out"], "no video files"), ([], "no inputs")):
        with pytest.raises(InputError, match=words):
            collect(bad, exclude=tmp_path / "m" / "out")  # the output folder is never an input


def test_names_are_unique_and_stable():
    names = lambda paths, **kw: [c.name for c in assign_names(paths, **kw)]  # noqa: E731
    assert names(["/m/a/clip.mp4", "/m/b/clip.mp4", "/m/x.mkv"]) == ["a__clip", "b__clip", "x"]
    assert names(["/x/2023/final/clip.mp4", "/x/2024/final/clip.mp4"]) == ["2023__final__clip", "2024__final__clip"]
    assert names(["/m/a/clip.mp4", "/m/a/clip.mkv", "/m/a__clip.mp4"]) == ["clip_mp4", "clip_mkv", "a__clip"]
    assert names(["/m/A.mp4", "/n/a.mp4"]) == ["m__A", "n__a"]  # case-insensitive file systems
    assert names(["/m/.x.mp4"]) == ["_x"]  # never a hidden name
    # earlier runs: a recorded input keeps its name, and nobody else gets it
    assert names(["/m/a/clip.mp4", "/m/b/clip.mp4"], known={"clip": "/m/b/clip.mp4"}) == ["a__clip", "clip"]
    assert names(["/n/clip.mp4"], known={"clip": "/m/b/clip.mp4"}) == ["clip-2"]


@pytest.mark.parametrize(
    "args, code, words",
    [
        (["nope.mp4"], 2, "input not found"),
        (["{a}", "--engine", "spark"], 2, "invalid choice"),
        (["{a}", "--address", "auto"], 2, "ray engine"),
        (["{a}", "--workers", "0"], 2, "workers must be"),
        (["{a}", "--scene", "none.toml"], 2, "scene file not found"),
    ],
    ids=["missing-input", "bad-engine", "address-without-ray", "no-workers", "missing-scene"],
)
def test_usage_errors_are_one_line(archive, tmp_path, capsys, args, code, words):
    args = [a.replace("{a}", str(archive / "a")) for a in args]
    if "invalid choice" in words:
        with pytest.raises(SystemExit) as e:
            main(["batch", *args, "--out", str(tmp_path / "out")])
        assert e.value.code == code and words in capsys.readouterr().err
        return
    assert main(["batch", *args, "--out", str(tmp_path / "out")]) == code
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("arstream: error:") and words in err[0], err
    assert not (tmp_path / "out").exists() or outputs(tmp_path / "out") == set()


def test_help(capsys):
    with pytest.raises(SystemExit):
        main(["batch", "--help"])
    text = capsys.readouterr().out
    for words in ("--out DIR", "--engine {local,ray}", "--address ADDR", "--workers N", "--force", "summary.jsonl", 'arstream[cluster]', "exit status"):
        assert words in text, words
