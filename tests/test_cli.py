"""The command line's shared behaviour (issue 31, the newcomer's friction list):
option checks that name the option, ``--verbose`` anywhere, outputs that
cannot be written, a reader that closes stdout early, warnings for empty
inputs, and the batch summary when nothing ran.

Each check is made before any work: no video is decoded here, so these tests
are fast and need no GL context.
"""

from __future__ import annotations

import argparse
import io
import os
import subprocess
import sys
from pathlib import Path

import pytest

import arstream
from arstream.batch import BatchSummary
from arstream.cli import build_parser, main
from arstream.errors import InputError
from arstream.sink import JsonlWriter, VideoSink, atomic_path

ROOT = Path(__file__).resolve().parents[1]


def cli(capsys, *args) -> tuple[int, str]:
    """Exit code and stderr of ``arstream ARGS``."""
    code = main([str(a) for a in args])
    return code, capsys.readouterr().err


# --------------------------------------------------------------------------- --frames and the batch's options
FRAMES_CASES = [
    ("process", ["process", "IN.mp4", "-o", "OUT.mp4"]),
    ("stream", ["stream", "--source", "IN.mp4", "--rerun", "none"]),
    ("batch", ["batch", "IN.mp4", "--out", "OUTDIR"]),
    ("synth", ["synth", "--out", "OUTDIR"]),
]


@pytest.mark.parametrize("frames", ["0", "-5"])
@pytest.mark.parametrize("command, args", FRAMES_CASES, ids=[c[0] for c in FRAMES_CASES])
def test_frames_below_one_is_refused_naming_the_option(tmp_path, capsys, command, args, frames):
    args = [str(tmp_path / a) if a.isupper() or "." in a else a for a in args]
    code, err = cli(capsys, *args, "--frames", frames)
    assert code == 2
    assert err.strip() == f"arstream: error: --frames must be 1 or more, got {frames}"
    assert not any(tmp_path.iterdir())  # refused before anything was made


@pytest.mark.parametrize(
    "option, value, message",
    [
        ("--workers", "0", "--workers must be 1 or more, got 0"),
        ("--lag", "-1", "--lag must be 0 or more, got -1"),
    ],
)
def test_batch_names_its_options(tmp_path, capsys, option, value, message):
    code, err = cli(capsys, "batch", tmp_path / "in.mp4", "--out", tmp_path / "out", option, value)
    assert (code, err.strip()) == (2, f"arstream: error: {message}")


# --------------------------------------------------------------------------- --verbose
@pytest.mark.parametrize(
    "args, verbose",
    [
        (["process", "in.mp4", "-o", "o.mp4"], False),
        (["--verbose", "process", "in.mp4", "-o", "o.mp4"], True),
        (["process", "in.mp4", "-o", "o.mp4", "--verbose"], True),
        (["process", "-v", "in.mp4", "-o", "o.mp4"], True),
        (["calib", "fmatrix", "a.txt", "b.txt", "--verbose"], True),
        (["calib", "--verbose", "fmatrix", "a.txt", "b.txt"], True),
        (["calib", "fmatrix", "a.txt", "b.txt"], False),
    ],
)
def test_verbose_before_or_after_the_command(args, verbose):
    assert build_parser().parse_args(args).verbose is verbose


def test_verbose_after_the_command_shows_the_traceback(tmp_path, capsys):
    args = ["process", tmp_path / "in.mp4", "-o", tmp_path / "o.mp4", "--frames", "0"]
    code, err = cli(capsys, *args)
    assert code == 2 and "Traceback" not in err
    code, err = cli(capsys, *args, "--verbose")
    assert code == 2 and "Traceback" in err and err.strip().endswith("arstream: error: --frames must be 1 or more, got 0")


# --------------------------------------------------------------------------- outputs
@pytest.mark.parametrize("command", ["process", "stream"])
def test_one_file_for_video_and_cameras_is_refused(tmp_path, capsys, command):
    src = ["process", tmp_path / "in.mp4"] if command == "process" else ["stream", "--source", tmp_path / "in.mp4", "--rerun", "none"]
    out = tmp_path / "out.mp4"
    same = tmp_path / "sub" / ".." / "out.mp4"  # the same file, spelt differently
    code, err = cli(capsys, *src, "-o", out, "--cameras-out", same)
    assert code == 2
    assert err.strip() == f"arstream: error: -o and --cameras-out are the same file ({out}): give the cameras a file of their own, e.g. cameras.jsonl"
    assert not any(tmp_path.iterdir())


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux's /proc, where files cannot be made")
@pytest.mark.parametrize(
    "make, path",
    [
        (lambda p: VideoSink(p, 64, 64, 25), "/proc/x.mp4"),
        (lambda p: JsonlWriter(p), "/proc/x.jsonl"),
    ],
    ids=["video", "jsonl"],
)
def test_an_output_that_cannot_be_made_is_named(make, path):
    with pytest.raises(InputError) as e:
        make(path)
    assert str(e.value) == f"cannot write {path}: No such file or directory"


def test_a_refused_video_leaves_no_temporary_file(tmp_path):
    with pytest.raises(InputError, match="give the file an extension"):
        VideoSink(tmp_path / "noext", 64, 64, 25)
    assert not os.path.exists(atomic_path(str(tmp_path / "noext"))) and not any(tmp_path.iterdir())


EXAMPLES = ROOT / "docs" / "examples" / "calib"


@pytest.mark.parametrize(
    "args, code",
    [
        (["calib", "fmatrix", EXAMPLES / "view-1.txt", EXAMPLES / "view-2.txt", "--per-point", "--pretty"], 1),
        (["calib", "fmatrix", EXAMPLES / "view-1.txt", EXAMPLES / "view-2.txt"], 1),
        (["--help"], 0),  # argparse's own printing swallows the error: quiet too
    ],
    ids=["large output", "one line", "help"],
)
def test_a_closed_stdout_ends_quietly(args, code):
    """``arstream ... | head``: the reader has gone before the command writes.
    stdout is a pipe whose read end is closed first, so the first write fails
    with EPIPE every time (Python ignores SIGPIPE): no message, exit code 1
    (before: "Exception ignored ... BrokenPipeError" or "arstream: error:
    [Errno 32] Broken pipe")."""
    r, w = os.pipe()
    os.close(r)
    try:
        proc = subprocess.run(
            [sys.executable, "-c", "import sys; from arstream.cli import entry; sys.exit(entry())", *map(str, args)],
            stdout=w, stderr=subprocess.PIPE, cwd=ROOT, timeout=120,
        )
    finally:
        os.close(w)
    assert (proc.stderr.decode(), proc.returncode) == ("", code)


# --------------------------------------------------------------------------- empty inputs
@pytest.mark.parametrize("text", ["", "# nothing yet\n", "[render]\nsamples = 4\n"], ids=["empty", "comment", "settings"])
def test_a_scene_without_objects_is_a_warning(tmp_path, capsys, text):
    scene = tmp_path / "scene.toml"
    scene.write_text(text)
    code, err = cli(capsys, "batch", tmp_path / "missing.mp4", "--out", tmp_path / "out", "--scene", scene)
    lines = err.strip().splitlines()
    assert lines[0] == f"arstream: warning: the scene {scene} has no objects: nothing will be drawn (see docs/render.md for the format)"
    assert code == 2 and lines[1].startswith("arstream: error:")  # then the missing input, as before


def test_a_scene_with_objects_is_no_warning(capsys):
    from arstream.commands._clip import load_scene

    assert load_scene(ROOT / "render" / "scenes" / "demo.toml").objects
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("text", ["", "\n\n  \n"], ids=["empty", "blank lines"])
def test_an_empty_cameras_file_is_a_warning(tmp_path, capsys, text):
    cams = tmp_path / "cameras.jsonl"
    cams.write_text(text)
    code, err = cli(capsys, "render", tmp_path / "missing.mp4", "--cameras", cams, "-o", tmp_path / "o.mp4")
    lines = err.strip().splitlines()
    assert lines[0] == f"arstream: warning: the cameras file {cams} is empty: no frame has a camera, so the output is the input without graphics"
    assert code == 2 and "missing.mp4" in lines[1]


def test_a_cameras_file_with_records_is_no_warning(tmp_path, capsys):
    from arstream.commands.render import has_records

    cams = tmp_path / "cameras.jsonl"
    cams.write_text('\n{"frame": 0, "status": "lost", "K": null}\n')
    assert has_records(str(cams)) and not has_records(os.devnull)


# --------------------------------------------------------------------------- the batch's summary line
def test_a_batch_with_nothing_to_do_reports_no_workers():
    rec = {"name": "a", "status": "ok", "skipped": True, "frames": 12}
    line = BatchSummary(out_dir="out", workers=0, clips=[rec], seconds=0.3).line()
    assert line == "1 clips: 1 ok (1 skipped, complete from an earlier run); nothing processed (0.3 s)"
    ran = BatchSummary(out_dir="out", workers=2, clips=[dict(rec, skipped=False)], seconds=2.0).line()
    assert ran.endswith("; 12 frames in 2.0 s (6.0 fps, 2 local workers)")


# --------------------------------------------------------------------------- the library's boundaries
@pytest.mark.parametrize(
    "call, message",
    [
        (lambda d: arstream.process(d / "in.mp4", d / "o.mp4", max_frames=-5), "max_frames must be 1 or more, got -5"),
        (lambda d: arstream.process(d / "in.mp4", cameras_out=d / "c.jsonl", max_frames=0), "max_frames must be 1 or more, got 0"),
        (lambda d: arstream.stream(d / "in.mp4", max_frames=0), "max_frames must be 1 or more, got 0"),
        (lambda d: arstream.process(d / "in.mp4", d / "o.mp4", cameras_out=d / "x" / ".." / "o.mp4"), "output and cameras_out are the same file ({d}/o.mp4): give the cameras a file of their own"),
        (lambda d: arstream.stream(d / "in.mp4", cameras_out=d / "in.mp4"), "output {d}/in.mp4 would overwrite the input"),
        (lambda d: arstream.render_clip(d / "in.mp4", d / "c.jsonl", d / "in.mp4"), "output {d}/in.mp4 would overwrite the input"),
    ],
    ids=["process -5", "process 0", "stream 0", "same file", "stream cameras over input", "render over input"],
)
def test_the_library_refuses_before_any_work(tmp_path, call, message):
    with pytest.raises(InputError) as e:
        call(tmp_path)
    assert str(e.value) == message.format(d=tmp_path)
    assert not any(tmp_path.iterdir())


# --------------------------------------------------------------------------- the progress bar and the summary line
class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_the_final_bar_shows_the_summary_lines_fps(monkeypatch, capsys):
    """The run took 2.0 s for 10 frames after 3 s of set-up (a fake clock): the bar
    counts from its first update, and its final draw shows the summary's own
    10 / 2.0 = 5.0 fps, the number the summary line prints."""
    from arstream import progress
    from arstream.commands._clip import run_clip
    from arstream.pipeline import Summary

    clock = [100.0]
    monkeypatch.setattr(progress.time, "perf_counter", lambda: clock[0])
    term = _Terminal()
    monkeypatch.setattr(sys, "stderr", term)

    def call(update):
        clock[0] += 3.0  # opening, GL context, kernels
        for i in range(1, 11):
            clock[0] += 0.19
            update(i, 10)
        return Summary(frames=10, seconds=2.0, tracked=10, confidence=0.9)

    args = argparse.Namespace(quiet=False, json=False)
    assert run_clip(call, args, label="process", verb="processed", finalised="", missing=lambda s: "") == 0
    draws = term.getvalue().split("\r")
    assert draws[-1] == "process [##############################] 10/10    5.0 fps ETA   0.0s\n"
    assert "(5.0 fps)" in capsys.readouterr().out
    assert "  5.3 fps" in draws[-2]  # the live rate: 9 frames in 1.71 s, set-up excluded (it was 0.6 fps with it)


def test_render_does_not_say_tracked():
    from arstream.pipeline import Summary

    drawn = Summary(frames=4, tracked=3, seconds=1.0, confidence=1.0, cameras_in="c.jsonl", output="o.mp4")
    assert drawn.line() == "4 frames in 1.0 s (4.0 fps), a camera from c.jsonl on 75.0% of them -> o.mp4"
    assert drawn.to_dict()["cameras_in"] == "c.jsonl"
    tracked = Summary(frames=4, tracked=3, seconds=1.0, confidence=0.5)
    assert tracked.line() == "4 frames in 1.0 s (4.0 fps), tracked 75.0%, mean confidence 0.50"


# --------------------------------------------------------------------------- a clip with no camera at all
def test_a_clip_with_no_camera_says_so_and_where_to_look(tmp_path, capsys):
    # a grayscale clip: every frame lost, the outputs written as always; the
    # summary is followed by a warning that points at register, which says why
    import numpy as np

    clip = tmp_path / "grey.mp4"
    with VideoSink(clip, 320, 180, 25) as sink:
        for _ in range(6):
            sink.write(np.full((180, 320, 3), 100, np.uint8))
    code, err = cli(capsys, "process", clip, "--cameras-out", tmp_path / "c.jsonl", "--pitch", "105x68")
    assert code == 0
    assert err.strip() == f"arstream: warning: no frame got a camera, so nothing was drawn: the frames show no pitch whose markings give one (`arstream register {clip} --frame N` says why for frame N)"
    assert main(["register", str(clip), "--frame", "3"]) == 1
    assert capsys.readouterr().out == "lost: no pitch: the picture has no colour (the grass is found by its green)\n"
