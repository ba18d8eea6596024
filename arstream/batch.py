"""Batch processing of a clip archive, on one machine or a Ray cluster.

Mirrors ``arstream batch INPUTS... --out DIR [--engine local|ray]``::

    from arstream import batch
    summary = batch.run(["archive/2024/", "extra/*.mkv"], "out/", engine="local")
    print(summary.line(), summary.exit_code)

Every clip goes through :func:`arstream.process` in a worker process and
becomes ``DIR/<name>.mp4`` (augmented video) + ``DIR/<name>.cameras.jsonl``;
``DIR/summary.jsonl`` gets one record per clip of the batch (in input order).

Engines
-------
``local`` (default)
    A :class:`concurrent.futures.ProcessPoolExecutor`, one worker per core
    unless ``workers`` says otherwise. Workers come from the ``forkserver``
    context (``spawn`` where there is none), never a plain ``fork`` of the
    driver, whose threads and GL state would not survive it: a server
    process that has run nothing (no GL context, no pipeline threads)
    imports the pipeline's modules once, and each worker is forked from it. Each worker makes its own GL context, per
    clip. A worker that dies under a clip (crash, out of memory, killed)
    breaks the pool; a new pool takes over and the clips that were running
    are tried once more (a clip that kills its worker twice is ``failed``).
``ray``
    One Ray task per clip (``num_cpus=1``, retried once if its worker
    dies), on the cluster at ``address`` or, without one, on a local Ray
    started for the batch (stopped afterwards).
    Ray is an optional extra (``pip install "arstream[cluster]"``). On a
    cluster, every node must see the inputs and ``DIR`` at the same paths
    (a shared file system) and have arstream installed. If Ray is already
    initialised in this process (``ray.init(...)``), that instance is used
    and left running (``address`` is then not used).

Only plain data crosses process boundaries: a job is a dict of paths and
options, :func:`process_clip` (the top-level worker function) returns a
plain dict, the record.

Names
-----
A clip's name is its file name without the extension. Inputs whose names
collide (``a/clip.mp4`` and ``b/clip.mp4``) are prefixed with their folders
relative to the folder the colliding ones share, joined by ``__``
(``a__clip``, ``b__clip``); same folder and name but a different extension
adds it (``clip_mkv``); anything still taken gets ``-2``, ``-3``, ... in
input order. Names are stable across runs: an input that has a done record
in ``DIR`` keeps the name it had, and a name recorded for another input is
never given out, so adding clips to an archive or reusing an output folder
never overwrites a namesake's outputs.

Completeness and resume
-----------------------
A worker writes the pipeline's outputs in ``DIR/.arstream-batch/work/<name>/``
and, only when :func:`arstream.process` returned, renames both into ``DIR``
and then writes the clip's done record ``DIR/.arstream-batch/done/<name>.json``
(temporary name + rename, so it is whole or absent). A clip is *complete*
when its done record exists and matches: the same input (path, size,
modification time), the same options (scene file and its content, lag,
crf, preset, audio, B-frames kept, frames) and both outputs present with the recorded
sizes. Complete clips are skipped (``force=True`` redoes them); anything
else — no record, a leftover work folder, an output under its final name
without a record (a kill between the renames), an edited input — is redone.
Before a clip is (re)done its record is removed; if it fails, stale outputs
under its name are removed too, so what ``DIR`` holds always agrees with
``summary.jsonl``.

Records
-------
One JSON object per clip, in ``summary.jsonl`` and in :attr:`BatchSummary.clips`:
``name``, ``input`` (absolute path), ``status``, ``skipped``, ``frames``,
``tracked`` (frames with a camera), ``share_tracked``, ``mean_confidence``,
``fps`` (frames per second of the clip's pipeline), ``seconds`` (wall time
of the clip in its worker), ``cpu_seconds``, ``error`` (one line, or null),
``damage`` (what was wrong with a damaged input), ``output`` and ``cameras``
(file names in ``DIR``, null without outputs), ``host`` (where it ran).

Statuses (``record["status"]``): ``ok``; ``damaged`` (the input is damaged:
the frames that decoded were processed and written; a later run skips it,
as the result would be the same); ``failed`` (no outputs; ``error`` says
why); ``interrupted`` (was running when the batch was abandoned: its
partial outputs were discarded); ``cancelled`` (not started because the
batch was stopped). ``skipped: true`` marks a record taken from an earlier
run. The batch succeeds when every clip is ``ok``.

Interruption
------------
While :func:`run` schedules (main thread, ``handle_signals=True``), the
first SIGINT/SIGTERM stops scheduling: running clips finish and are kept,
the others are ``cancelled``. A second signal abandons the running clips:
their workers are killed and their partial outputs (never under a final
name) removed. Then ``summary.jsonl`` is written and :class:`BatchInterrupted`
(a ``KeyboardInterrupt``) raised with the :class:`BatchSummary`. Workers
ignore SIGINT (a terminal's Ctrl-C reaches the whole process group): the
driver alone decides. A batch killed outright (SIGKILL, power cut) leaves
only work folders and complete outputs without records, all redone by the
next run.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import dataclasses
import glob
import hashlib
import json
import os
import queue as queue_mod
import shutil
import signal
import socket
import threading
import time
from collections import defaultdict, deque
from dataclasses import dataclass, field
from typing import Callable, Iterable

from arstream.errors import ArstreamError, InputError
from arstream.workers import cores, init_worker, spawning, terminate, worker_context

__all__ = [
    "run",
    "collect",
    "assign_names",
    "process_clip",
    "is_complete",
    "RESULT_FIELDS",
    "Clip",
    "BatchSummary",
    "BatchProgress",
    "BatchInterrupted",
    "ENGINES",
    "VIDEO_EXTENSIONS",
    "STATE_DIR",
    "SUMMARY_NAME",
]

#: Engines :func:`run` knows.
ENGINES = ("local", "ray")

#: Extensions (lower case) taken from folders and glob patterns; a file named
#: explicitly is taken whatever its extension.
VIDEO_EXTENSIONS = frozenset(
    ".mp4 .m4v .mov .mkv .webm .avi .ts .mts .m2ts .mxf .mpg .mpeg .flv .wmv .3gp".split()
)

#: Hidden folder of ``DIR`` with the batch's bookkeeping (done records, work folders, lock).
STATE_DIR = ".arstream-batch"

#: The per-clip summary of a batch, in ``DIR``.
SUMMARY_NAME = "summary.jsonl"

_RECORD_VERSION = 1
_STATUSES = ("ok", "damaged", "failed", "interrupted", "cancelled")
_GLOB_CHARS = set("*?[")


# --------------------------------------------------------------------------- inputs and names
@dataclass(frozen=True)
class Clip:
    """One clip of a batch: its input (absolute path) and its output name in ``DIR``."""

    input: str
    name: str

    def video(self, out_dir) -> str:
        return os.path.join(os.fspath(out_dir), self.name + ".mp4")

    def cameras(self, out_dir) -> str:
        return os.path.join(os.fspath(out_dir), self.name + ".cameras.jsonl")


def _is_video(path: str) -> bool:
    return os.path.splitext(path)[1].lower() in VIDEO_EXTENSIONS


def _inside(path: str, folder: str | None) -> bool:
    if folder is None:
        return False
    try:
        return os.path.commonpath([path, folder]) == folder
    except ValueError:  # different drives
        return False


def collect(inputs: Iterable, *, exclude=None) -> list[str]:
    """The clips named by ``inputs``: files, folders and glob patterns.

    A file is taken as is. A folder is searched recursively for videos (by
    extension, :data:`VIDEO_EXTENSIONS`), skipping hidden files and folders.
    A pattern (``*``, ``?``, ``[``; ``**`` spans folders) takes the videos
    and folders it matches. Paths under ``exclude`` (the output folder) are
    left out of folders and patterns. The result is absolute paths, each
    file once (also when reached twice, e.g. through a link), in the order
    of ``inputs`` and sorted within each.

    Raises
    ------
    InputError : an input that names nothing (a missing file, a pattern
        matching nothing, a folder without videos), or no inputs at all
    """
    excl = os.path.realpath(os.fspath(exclude)) if exclude is not None else None
    out: list[str] = []
    seen: set[str] = set()

    def add(path: str) -> None:
        real = os.path.realpath(path)
        if real not in seen:
            seen.add(real)
            out.append(os.path.abspath(path))

    def scan(folder: str) -> list[str]:
        found = []
        for root, dirs, files in os.walk(folder, followlinks=True):
            dirs[:] = sorted(d for d in dirs if not d.startswith(".") and not _inside(os.path.realpath(os.path.join(root, d)), excl))
            if not _inside(os.path.realpath(root), excl):
                found.extend(os.path.join(root, f) for f in files if not f.startswith(".") and _is_video(f))
        return sorted(found)

    items = [os.fspath(i) for i in inputs]
    if not items:
        raise InputError("no inputs: give clips, folders or glob patterns")
    for item in items:
        if os.path.isfile(item):
            add(item)
        elif os.path.isdir(item):
            found = scan(item)
            if not found:
                raise InputError(f"no video files in folder {item} (extensions: {', '.join(sorted(VIDEO_EXTENSIONS))})")
            for f in found:
                add(f)
        elif _GLOB_CHARS & set(item):
            found = []
            for m in sorted(glob.glob(item, recursive=True)):
                if _inside(os.path.realpath(m), excl):
                    continue
                if os.path.isdir(m):
                    found.extend(scan(m))
                elif os.path.isfile(m) and _is_video(m) and not os.path.basename(m).startswith("."):
                    found.append(m)
            if not found:
                raise InputError(f"no clips match {item}")
            for f in found:
                add(f)
        elif os.path.exists(item):
            raise InputError(f"not a file or folder: {item}")
        else:
            raise InputError(f"input not found: {item}")
    return out


def _sanitize(stem: str) -> str:
    stem = stem.strip() or "clip"
    if stem.startswith("."):
        stem = "_" + stem.lstrip(".")  # hidden names are the batch's own temporaries
    return stem


def assign_names(paths: Iterable, *, known: dict | None = None) -> list[Clip]:
    """Output names for ``paths`` (see "Names" in the module docstring).

    Parameters
    ----------
    paths : iterable of str, the inputs (as :func:`collect` returns them)
    known : dict name -> input path, names already used in the output folder
        (by earlier runs): an input keeps the name it had, and no other input
        gets it

    Returns
    -------
    list of :class:`Clip`, in the order of ``paths``; names are unique
    (also ignoring case, for case-insensitive file systems).

    >>> [c.name for c in assign_names(["/m/a/clip.mp4", "/m/b/clip.mp4", "/m/x.mkv"])]
    ['a__clip', 'b__clip', 'x']
    """
    paths = [os.path.abspath(os.fspath(p)) for p in paths]
    groups: dict[str, list[str]] = defaultdict(list)
    for p in paths:
        groups[_sanitize(os.path.splitext(os.path.basename(p))[0]).lower()].append(p)
    first: dict[str, str] = {}
    for ps in groups.values():
        if len(ps) == 1:
            first[ps[0]] = _sanitize(os.path.splitext(os.path.basename(ps[0]))[0])
            continue
        common = os.path.commonpath([os.path.dirname(p) for p in ps])
        names = {}
        for p in ps:
            rel = os.path.relpath(os.path.splitext(p)[0], common)
            names[p] = _sanitize("__".join(part for part in rel.split(os.sep) if part))
        counts = defaultdict(int)
        for n in names.values():
            counts[n.lower()] += 1
        for p in ps:
            n = names[p]
            if counts[n.lower()] > 1:  # same folder and stem, another extension
                n = f"{n}_{os.path.splitext(p)[1].lstrip('.').lower() or 'noext'}"
            first[p] = n
    known = known or {}
    owner = {n.lower(): os.path.abspath(q) for n, q in known.items()}
    had = {os.path.abspath(q): n for n, q in sorted(known.items())}
    used: set[str] = set()
    names: dict[str, str] = {}
    for p in paths:  # names from earlier runs stay
        n = had.get(p)
        if n is not None and n.lower() not in used:
            names[p] = n
            used.add(n.lower())
    for p in paths:
        if p in names:
            continue
        base = first[p]
        n, k = base, 1
        while n.lower() in used or owner.get(n.lower(), p) != p:
            k += 1
            n = f"{base}-{k}"
        used.add(n.lower())
        names[p] = n
    return [Clip(p, names[p]) for p in paths]


# --------------------------------------------------------------------------- bookkeeping
def _state(out_dir: str, *parts: str) -> str:
    return os.path.join(out_dir, STATE_DIR, *parts)


def _done_path(out_dir: str, name: str) -> str:
    return _state(out_dir, "done", name + ".json")


def _work_dir(out_dir: str, name: str) -> str:
    return _state(out_dir, "work", name)


def _input_stat(path: str) -> dict:
    st = os.stat(path)
    return {"path": os.path.abspath(path), "size": st.st_size, "mtime_ns": st.st_mtime_ns}


def _read_done(out_dir: str, name: str) -> dict | None:
    try:
        with open(_done_path(out_dir, name), encoding="utf-8") as f:
            done = json.load(f)
    except (OSError, ValueError):
        return None
    if not isinstance(done, dict) or done.get("version") != _RECORD_VERSION or not isinstance(done.get("record"), dict):
        return None
    return done


def _known_names(out_dir: str) -> dict:
    """name -> input path of the done records in ``out_dir``."""
    known = {}
    with contextlib.suppress(OSError):
        for fname in os.listdir(_state(out_dir, "done")):
            if fname.endswith(".json") and not fname.startswith("."):
                done = _read_done(out_dir, fname[: -len(".json")])
                path = (done or {}).get("input", {}).get("path")
                if isinstance(path, str):
                    known[fname[: -len(".json")]] = path
    return known


def _write_json_atomic(path: str, obj) -> None:
    os.makedirs(os.path.dirname(path), exist_ok=True)
    d, base = os.path.split(path)
    tmp = os.path.join(d, f".{base}.{os.getpid()}.partial")
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(obj, f, indent=1)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def _remove(*paths: str) -> None:
    for p in paths:
        with contextlib.suppress(FileNotFoundError):
            os.remove(p)


def is_complete(out_dir, clip: Clip, params: dict) -> dict | None:
    """The done record of ``clip`` in ``out_dir`` if its outputs are complete for
    these ``params`` (see "Completeness and resume"), else None."""
    out_dir = os.fspath(out_dir)
    done = _read_done(out_dir, clip.name)
    if done is None:
        return None
    try:
        if done.get("input") != _input_stat(clip.input):
            return None
    except OSError:
        return None
    if done.get("params") != params:
        return None
    outputs = done.get("outputs") or {}
    expected = {os.path.basename(clip.video(out_dir)), os.path.basename(clip.cameras(out_dir))}
    if set(outputs) != expected:
        return None
    for fname, size in outputs.items():
        try:
            if os.path.getsize(os.path.join(out_dir, fname)) != size:
                return None
        except OSError:
            return None
    if done["record"].get("status") not in ("ok", "damaged"):
        return None
    return done["record"]


def _params(*, scene, lag, crf, preset, audio, keep_b_frames, max_frames) -> dict:
    """The options that shape a clip's outputs (a change redoes the clip)."""
    sha = None
    if scene is not None:
        with open(scene, "rb") as f:
            sha = hashlib.sha256(f.read()).hexdigest()
    return {
        "scene": scene,
        "scene_sha256": sha,
        "lag": int(lag),
        "crf": int(crf),
        "preset": str(preset),
        "audio": bool(audio),
        "keep_b_frames": bool(keep_b_frames),
        "max_frames": None if max_frames is None else int(max_frames),
    }


def _record(clip_name: str, input_path: str, status: str, **kw) -> dict:
    rec = {
        "name": clip_name,
        "input": input_path,
        "status": status,
        "skipped": False,
        "frames": 0,
        "tracked": 0,
        "share_tracked": 0.0,
        "mean_confidence": 0.0,
        "fps": 0.0,
        "seconds": 0.0,
        "cpu_seconds": 0.0,
        "error": None,
        "damage": [],
        "output": None,
        "cameras": None,
        "host": None,
    }
    rec.update(kw)
    return rec


#: Record fields that describe the result (the rest is timing and placement).
RESULT_FIELDS = ("name", "input", "status", "frames", "tracked", "share_tracked", "mean_confidence", "error", "damage", "output", "cameras")


# --------------------------------------------------------------------------- the worker
_PROGRESS_SINK = None  # set in local workers by _init_local_worker: a multiprocessing queue


def _init_local_worker(progress_queue, cv_threads: int) -> None:
    """Initializer of the local pool's workers: as any pool's
    (:func:`arstream.workers.init_worker`), and the progress queue kept."""
    init_worker(cv_threads)
    global _PROGRESS_SINK
    if progress_queue is not None:
        progress_queue.cancel_join_thread()  # progress is best effort: never wait for it at exit
    _PROGRESS_SINK = progress_queue


class _Reporter:
    """Per-frame progress of a clip, sent to the driver at most 4 times a second."""

    def __init__(self, name: str, send: Callable):
        self.name, self.send, self.last = name, send, 0.0

    def __call__(self, done: int, total: int | None) -> None:
        now = time.monotonic()
        if now - self.last >= 0.25:
            self.last = now
            with contextlib.suppress(Exception):  # progress is best effort
                self.send(self.name, int(done), int(total or 0))


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def process_clip(job: dict, progress_board=None) -> dict:
    """Process one clip of a batch; the engines' task (a top-level function, plain data in and out).

    Parameters
    ----------
    job : dict with ``input`` (path), ``name`` (output name), ``out_dir``,
        ``params`` (as recorded: scene, lag, crf, preset, audio, keep_b_frames, max_frames)
    progress_board : optional Ray actor handle with ``update.remote(name, done, total)``
        (local workers report through the queue their initializer was given)

    Returns
    -------
    dict, the clip's record (status ``ok``, ``damaged`` or ``failed``; never raises for a
    bad clip). Outputs appear under their final names only when the clip is done.
    """
    from arstream.pipeline import process

    name, inp, out_dir, params = job["name"], job["input"], job["out_dir"], job["params"]
    video = os.path.join(out_dir, name + ".mp4")
    cams = os.path.join(out_dir, name + ".cameras.jsonl")
    work = _work_dir(out_dir, name)
    host = socket.gethostname()
    t0 = time.perf_counter()

    def failed(msg: str) -> dict:
        _remove(video, cams)  # stale outputs of an earlier run must not outlive its record
        return _record(name, inp, "failed", error=msg, host=host, seconds=round(time.perf_counter() - t0, 3))

    reporter = None
    if progress_board is not None:
        reporter = _Reporter(name, lambda n, d, t: progress_board.update.remote(n, d, t))
    elif _PROGRESS_SINK is not None:
        reporter = _Reporter(name, lambda n, d, t: _PROGRESS_SINK.put_nowait((n, d, t)))

    try:
        _remove(_done_path(out_dir, name))  # outputs are about to be replaced
        shutil.rmtree(work, ignore_errors=True)
        os.makedirs(work)
        try:
            stat = _input_stat(inp)
        except OSError as exc:
            return failed(f"cannot read {inp}: {exc.strerror}")
        try:
            s = process(
                inp,
                os.path.join(work, name + ".mp4"),
                cameras_out=os.path.join(work, name + ".cameras.jsonl"),
                scene=params["scene"],
                lag=params["lag"],
                crf=params["crf"],
                preset=params["preset"],
                audio=params["audio"],
                keep_b_frames=params["keep_b_frames"],
                max_frames=params["max_frames"],
                progress=reporter,
                handle_signals=False,
                threads=int(job.get("threads", 0)),
            )
        except (ArstreamError, ValueError, OSError) as exc:
            return failed(_first_line(exc))
        except Exception as exc:  # a bug in a stage: the clip fails, the batch goes on
            return failed(f"internal error: {type(exc).__name__}: {_first_line(exc)}")
        if s.frames == 0:
            return failed("; ".join(s.errors) if s.errors else "no frames decoded")
        for fname, final in ((name + ".mp4", video), (name + ".cameras.jsonl", cams)):
            os.replace(os.path.join(work, fname), final)
        status = "damaged" if s.errors else "ok"
        rec = _record(
            name,
            inp,
            status,
            frames=s.frames,
            tracked=s.tracked,
            share_tracked=round(s.share_tracked, 4),
            mean_confidence=round(s.confidence, 4),
            fps=round(s.fps, 2),
            seconds=round(time.perf_counter() - t0, 3),
            cpu_seconds=round(s.cpu_seconds, 3),
            error=("input is damaged: " + "; ".join(s.errors)) if s.errors else None,
            damage=list(s.errors),
            output=os.path.basename(video),
            cameras=os.path.basename(cams),
            host=host,
        )
        done = {
            "version": _RECORD_VERSION,
            "record": rec,
            "input": stat,
            "params": params,
            "outputs": {os.path.basename(p): os.path.getsize(p) for p in (video, cams)},
        }
        _write_json_atomic(_done_path(out_dir, name), done)  # last: now the clip is complete
        return rec
    except OSError as exc:  # the output folder itself (full disk, permissions)
        return failed(f"cannot write outputs of {name}: {_first_line(exc)}")
    finally:
        shutil.rmtree(work, ignore_errors=True)


# --------------------------------------------------------------------------- results
@dataclass
class BatchProgress:
    """Where a batch stands; passed to ``run(progress=...)`` about 4 times a second.

    Attributes
    ----------
    clips_total : int, clips of the batch
    clips_done : int, clips finished (any status, skipped ones included)
    clips_skipped : int, clips complete from an earlier run
    frames : int, frames processed by this run (running clips included)
    running : dict name -> (frames done, frames total or 0), clips in progress
    seconds : float, since the batch started
    """

    clips_total: int = 0
    clips_done: int = 0
    clips_skipped: int = 0
    frames: int = 0
    running: dict = field(default_factory=dict)
    seconds: float = 0.0

    @property
    def fps(self) -> float:
        return self.frames / self.seconds if self.seconds > 0 else 0.0

    def copy(self) -> "BatchProgress":
        return dataclasses.replace(self, running=dict(self.running))

    @property
    def fraction(self) -> float:
        """Share of the batch done: finished clips plus the running clips' shares
        (skipped clips count as done)."""
        if not self.clips_total:
            return 1.0
        part = sum(min(d / t, 1.0) for d, t in self.running.values() if t)
        return min((self.clips_done + part) / self.clips_total, 1.0)


@dataclass
class BatchSummary:
    """What a batch did.

    Attributes
    ----------
    out_dir : str
    engine : "local" or "ray"
    workers : int, clips processed at once (0: no clip needed processing)
    clips : list of dict, one record per clip in input order (as ``summary.jsonl``)
    seconds : float, wall time of the batch
    interrupted : int or None, the signal that stopped it
    summary_path : str, ``DIR/summary.jsonl``
    """

    out_dir: str = ""
    engine: str = "local"
    workers: int = 0
    clips: list = field(default_factory=list)
    seconds: float = 0.0
    interrupted: int | None = None
    summary_path: str = ""

    def count(self, status: str) -> int:
        return sum(1 for r in self.clips if r["status"] == status)

    @property
    def skipped(self) -> int:
        return sum(1 for r in self.clips if r.get("skipped"))

    @property
    def frames(self) -> int:
        """Frames processed by this run (skipped clips not counted)."""
        return sum(r["frames"] for r in self.clips if not r.get("skipped"))

    @property
    def fps(self) -> float:
        return self.frames / self.seconds if self.seconds > 0 else 0.0

    @property
    def all_ok(self) -> bool:
        return bool(self.clips) and all(r["status"] == "ok" for r in self.clips)

    @property
    def exit_code(self) -> int:
        """0 every clip ok; 128 + signal when interrupted; 1 otherwise."""
        if self.interrupted is not None:
            return 128 + int(self.interrupted)
        return 0 if self.all_ok else 1

    def line(self) -> str:
        parts = [f"{self.count(s)} {s}" for s in _STATUSES if self.count(s)]
        s = f"{len(self.clips)} clips: " + ", ".join(parts)
        if self.skipped:
            s += f" ({self.skipped} skipped, complete from an earlier run)"
        if self.workers:
            s += f"; {self.frames} frames in {self.seconds:.1f} s ({self.fps:.1f} fps, {self.workers} {self.engine} worker{'' if self.workers == 1 else 's'})"
        else:  # every clip skipped or refused before it started: no engine ran
            s += f"; nothing processed ({self.seconds:.1f} s)"
        if self.summary_path:
            s += f" -> {self.summary_path}"
        return s

    def to_dict(self) -> dict:
        return {
            "out_dir": self.out_dir,
            "engine": self.engine,
            "workers": self.workers,
            "seconds": round(self.seconds, 3),
            "frames": self.frames,
            "fps": round(self.fps, 2),
            "interrupted": self.interrupted,
            "counts": {s: self.count(s) for s in _STATUSES} | {"skipped": self.skipped},
            "all_ok": self.all_ok,
            "summary": self.summary_path,
            "clips": list(self.clips),
        }


class BatchInterrupted(KeyboardInterrupt):
    """The batch was stopped by SIGINT/SIGTERM; ``summary`` says what finished
    (``summary.jsonl`` is written)."""

    def __init__(self, signum: int, summary: BatchSummary):
        super().__init__(f"batch interrupted by {signal.Signals(signum).name}")
        self.signum = signum
        self.summary = summary

    @property
    def exit_code(self) -> int:
        return 128 + int(self.signum)


# --------------------------------------------------------------------------- engines
#: Modules the local workers need, imported once by the fork server (not per worker).
_PRELOAD = ["arstream.batch", "arstream.pipeline", "arstream.source", "arstream.sink", "render", "av", "cv2", "numpy"]


class _Crash(Exception):
    """A worker died under a clip (segfault, out of memory, killed)."""


class _LocalEngine:
    """A spawn-context process pool; a dead worker breaks the pool, which is remade."""

    name = "local"

    def __init__(self, workers: int, want_progress: bool):
        self.workers = workers
        self.ctx = worker_context(_PRELOAD)
        self.want_progress = want_progress
        self.queue = None
        self.pool = None
        self.owner: dict = {}  # future -> the pool that runs it
        self._start()

    def _start(self) -> None:
        if self.want_progress:  # a fresh queue: a dead worker may have held the old one's lock
            self.queue = self.ctx.Queue()
        cv_threads = max(1, cores() // self.workers)
        self.pool = cf.ProcessPoolExecutor(self.workers, mp_context=self.ctx, initializer=_init_local_worker, initargs=(self.queue, cv_threads))

    def capacity(self) -> int:
        return self.workers

    def submit(self, job: dict):
        with spawning(self.ctx):  # submit() may start the workers
            fut = self.pool.submit(process_clip, job)
        self.owner[fut] = self.pool
        return fut

    def wait(self, handles: list, timeout: float) -> list[tuple]:
        done, _ = cf.wait(handles, timeout=timeout, return_when=cf.FIRST_COMPLETED)
        out = []
        broken = False
        for fut in done:
            pool = self.owner.pop(fut, None)
            try:
                out.append((fut, fut.result()))
            except cf.process.BrokenProcessPool as exc:
                broken = broken or pool is self.pool
                out.append((fut, _Crash(f"worker process died ({_first_line(exc)})")))
            except BaseException as exc:  # e.g. a result that failed to unpickle
                out.append((fut, _Crash(f"{type(exc).__name__}: {_first_line(exc)}")))
        if broken:  # every clip of this pool fails with it (the caller resubmits them): a new pool
            self.pool.shutdown(wait=False, cancel_futures=True)
            self._start()
        return out

    def poll_progress(self) -> dict:
        got = {}
        if self.queue is None:
            return got
        while True:
            try:
                name, d, t = self.queue.get_nowait()
            except (queue_mod.Empty, OSError, ValueError, EOFError):
                return got
            got[name] = (d, t)

    def abandon(self, handles: list) -> None:
        terminate(self.pool)

    def close(self) -> None:
        self.pool.shutdown(wait=True)
        if self.queue is not None:
            self.queue.close()
            self.queue.join_thread()


class _ProgressBoard:
    """Latest per-clip progress, held by a small Ray actor (``num_cpus=0``)."""

    def __init__(self):
        self.state = {}

    def update(self, name: str, done: int, total: int) -> None:
        self.state[name] = (done, total)

    def read(self) -> dict:
        state, self.state = self.state, {}
        return state


def _import_ray():
    try:
        import ray
    except ImportError:
        raise ArstreamError('the ray engine needs Ray: pip install "arstream[cluster]"') from None
    return ray


def _check_reachable(address: str, timeout: float = 5.0) -> None:
    """A clear error now for ``host:port`` (or ``ray://host:port``) where nothing listens
    (Ray itself would retry for minutes). Other forms (``auto``) are left to Ray."""
    hostport = address.split("://", 1)[1] if "://" in address else address
    host, sep, port = hostport.rpartition(":")
    if not sep or not port.isdigit() or not host:
        return
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=timeout).close()
    except OSError as exc:
        raise ArstreamError(f"no Ray cluster at {address}: cannot connect to {host}:{port} ({_first_line(exc)})") from None


class _RayEngine:
    """One Ray task per clip (``num_cpus=1``, retried once if its worker dies)."""

    name = "ray"

    def __init__(self, workers: int | None, address: str | None, want_progress: bool):
        ray = self.ray = _import_ray()
        self.started = False
        if not ray.is_initialized():
            kw = dict(log_to_driver=False, logging_level="error", configure_logging=True)
            try:
                if address:
                    _check_reachable(address)
                    ray.init(address=address, **kw)
                else:
                    ray.init(num_cpus=workers, include_dashboard=False, **kw)
            except (ConnectionError, RuntimeError, ValueError) as exc:
                where = f"the Ray cluster at {address}" if address else "a local Ray instance"
                raise ArstreamError(f"cannot start or join {where}: {_first_line(exc)}") from None
            self.started = True
        cpus = int(ray.cluster_resources().get("CPU", 1))
        self.workers = int(workers) if workers else max(cpus, 1)
        self.task = ray.remote(num_cpus=1, max_retries=1)(process_clip)
        self.board = ray.remote(num_cpus=0)(_ProgressBoard).remote() if want_progress else None

    def capacity(self) -> int:
        return self.workers

    def submit(self, job: dict):
        return self.task.remote(job, self.board)

    def wait(self, handles: list, timeout: float) -> list[tuple]:
        ray = self.ray
        ready, _ = ray.wait(handles, num_returns=1, timeout=timeout)
        if ready:  # take everything else that is ready too
            ready, _ = ray.wait(handles, num_returns=len(handles), timeout=0)
        out = []
        for ref in ready:
            try:
                out.append((ref, ray.get(ref)))
            except Exception as exc:  # WorkerCrashedError, RayTaskError, ...
                out.append((ref, _Crash(f"ray task failed: {type(exc).__name__}: {_first_line(exc)}")))
        return out

    def poll_progress(self) -> dict:
        if self.board is None:
            return {}
        try:
            return self.ray.get(self.board.read.remote(), timeout=2.0)
        except Exception:
            return {}

    def abandon(self, handles: list) -> None:
        for ref in handles:
            with contextlib.suppress(Exception):
                self.ray.cancel(ref, force=True)
        for ref in handles:  # wait until the workers are gone before the driver cleans up
            with contextlib.suppress(Exception):
                self.ray.wait([ref], timeout=10.0)

    def close(self) -> None:
        if self.board is not None:
            with contextlib.suppress(Exception):
                self.ray.kill(self.board)
        if self.started:
            self.ray.shutdown()


# --------------------------------------------------------------------------- the driver
class _Signals:
    """SIGINT/SIGTERM while scheduling: the first stops scheduling, the second abandons.

    Python runs a handler once for however many times its signal arrived while
    the main thread was busy in C code, and a loaded machine may not schedule
    that thread between two quick Ctrl-Cs. So the deliveries are counted from
    the wakeup fd too (``signal.set_wakeup_fd``: the C-level handler writes the
    signal's number there once per delivery)."""

    def __init__(self):
        self.first: int | None = None
        self.count = 0
        self._wakeup: socket.socket | None = None

    def _deliveries(self) -> int:
        """SIGINTs and SIGTERMs written to the wakeup fd since the last look."""
        n = 0
        while self._wakeup is not None:
            try:
                data = self._wakeup.recv(256)
            except (BlockingIOError, InterruptedError):
                break
            if not data:
                break
            n += sum(1 for b in data if b in (signal.SIGINT, signal.SIGTERM))
        return n

    def handler(self, signum, _frame) -> None:
        self.count += max(1, self._deliveries())
        if self.first is None:
            self.first = signum

    @contextlib.contextmanager
    def installed(self, enabled: bool):
        if not enabled or threading.current_thread() is not threading.main_thread():
            yield
            return
        old = {}
        r, w = socket.socketpair()
        r.setblocking(False)
        w.setblocking(False)
        old_fd = None
        try:
            old_fd = signal.set_wakeup_fd(w.fileno(), warn_on_full_buffer=False)
            self._wakeup = r
            for s in (signal.SIGINT, signal.SIGTERM):
                old[s] = signal.signal(s, self.handler)
            yield
        finally:
            for s, h in old.items():
                signal.signal(s, h)
            if old_fd is not None:
                signal.set_wakeup_fd(old_fd)
            self._wakeup = None
            r.close()
            w.close()


@contextlib.contextmanager
def _locked(out_dir: str):
    """One batch at a time per output folder (advisory lock, where the OS has one)."""
    os.makedirs(_state(out_dir), exist_ok=True)
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        yield
        return
    f = open(_state(out_dir, "lock"), "a+")
    try:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise InputError(f"another batch is writing to {out_dir}") from None
        except OSError:  # a file system without locks: go on unguarded
            pass
        yield
    finally:
        f.close()


def _write_summary(path: str, records: list[dict]) -> None:
    from arstream.sink import JsonlWriter

    with JsonlWriter(path) as w:
        for rec in records:
            w.write(rec)


def run(
    inputs,
    out_dir,
    *,
    scene=None,
    engine: str = "local",
    address: str | None = None,
    workers: int | None = None,
    force: bool = False,
    lag: int | None = None,
    crf: int = 20,
    preset: str = "veryfast",
    audio: bool = True,
    keep_b_frames: bool = True,
    max_frames: int | None = None,
    progress: Callable[[BatchProgress], None] | None = None,
    on_clip: Callable[[dict], None] | None = None,
    handle_signals: bool = True,
) -> BatchSummary:
    """Process a batch of clips; mirrors ``arstream batch INPUTS... --out DIR``.

    Parameters
    ----------
    inputs : path, or iterable of files, folders and glob patterns (see :func:`collect`)
    out_dir : output folder (made if missing): ``<name>.mp4``,
        ``<name>.cameras.jsonl`` per clip, ``summary.jsonl``
    scene : path of a scene file (.toml/.json), or None for the demo scene
    engine : "local" (process pool) or "ray"
    address : Ray cluster to join (``ray`` engine; default: start a local Ray)
    workers : clips at once (default: the cores, or the Ray cluster's CPUs)
    force : redo clips that are already complete
    lag, crf, preset, audio, keep_b_frames, max_frames : as :func:`arstream.process`
    progress : callable(:class:`BatchProgress`), about 4 times a second
    on_clip : callable(record), as each clip finishes (skipped clips first)
    handle_signals : stop gracefully on SIGINT/SIGTERM (main thread only)

    Returns
    -------
    BatchSummary (``summary.exit_code`` is 0 when every clip is ok).

    Raises
    ------
    InputError : no clips, bad options, an unreadable scene, an output folder
        in use by another batch
    ArstreamError : the engine cannot start (e.g. Ray is not installed)
    BatchInterrupted : stopped by a signal, after ``summary.jsonl`` was written
    """
    from arstream.pipeline import DEFAULT_LAG

    t_start = time.perf_counter()
    if engine not in ENGINES:
        raise InputError(f"engine must be one of {', '.join(ENGINES)}, got {engine!r}")
    if address is not None and engine != "ray":
        raise InputError("an address is for the ray engine (engine='ray')")
    if workers is not None and int(workers) < 1:
        raise InputError(f"workers must be 1 or more, got {workers}")
    lag = DEFAULT_LAG if lag is None else int(lag)
    if lag < 0:
        raise InputError(f"lag must be 0 or more, got {lag}")
    if max_frames is not None and int(max_frames) < 1:
        raise InputError(f"max_frames must be 1 or more, got {max_frames}")
    if scene is not None:
        if not isinstance(scene, (str, os.PathLike)):
            raise InputError("scene must be the path of a scene file (workers load it themselves)")
        scene = os.path.abspath(os.fspath(scene))
        from render.scene import load_scene

        load_scene(scene)  # a bad scene is one error now, not one per clip (ValueError names it)
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    out_dir = os.path.abspath(os.fspath(out_dir))
    if os.path.exists(out_dir) and not os.path.isdir(out_dir):
        raise InputError(f"output folder {out_dir} is a file")
    paths = collect(inputs, exclude=out_dir)
    params = _params(scene=scene, lag=lag, crf=crf, preset=preset, audio=audio, keep_b_frames=keep_b_frames, max_frames=max_frames)
    try:
        os.makedirs(out_dir, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create output folder {out_dir}: {exc.strerror}") from None

    with _locked(out_dir):
        shutil.rmtree(_state(out_dir, "work"), ignore_errors=True)  # leftovers of a killed batch

        clips = assign_names(paths, known=_known_names(out_dir))
        summary = BatchSummary(out_dir=out_dir, engine=engine, summary_path=os.path.join(out_dir, SUMMARY_NAME))
        records: dict[str, dict] = {}
        todo: deque = deque()
        for clip in clips:
            rec = None if force else is_complete(out_dir, clip, params)
            if rec is not None:
                records[clip.name] = dict(rec, skipped=True)
                if on_clip is not None:
                    on_clip(dict(records[clip.name]))
            elif os.path.realpath(clip.video(out_dir)) == os.path.realpath(clip.input) or os.path.realpath(clip.cameras(out_dir)) == os.path.realpath(clip.input):
                records[clip.name] = _record(clip.name, clip.input, "failed", error=f"its output {clip.video(out_dir)} would overwrite the input")
                if on_clip is not None:
                    on_clip(dict(records[clip.name]))
            else:
                todo.append({"input": clip.input, "name": clip.name, "out_dir": out_dir, "params": params, "attempt": 0})

        state = BatchProgress(clips_total=len(clips), clips_done=len(records), clips_skipped=len(records))
        signals = _Signals()

        def finish() -> BatchSummary:
            for clip in clips:  # not started: cancelled
                records.setdefault(clip.name, _record(clip.name, clip.input, "cancelled"))
            summary.clips = [records[c.name] for c in clips]
            summary.seconds = time.perf_counter() - t_start
            summary.interrupted = signals.first
            _write_summary(summary.summary_path, summary.clips)
            with contextlib.suppress(OSError):
                os.rmdir(_state(out_dir, "work"))
            return summary

        if not todo:
            summary.workers = 0
            s = finish()
            if progress is not None:
                progress(state.copy())
            return s

        if engine == "local":
            n = min(int(workers) if workers else cores(), len(todo))
            eng = _LocalEngine(n, want_progress=progress is not None)
            # as many clips at once as cores: each one single-threaded (no thread
            # overhead, no oversubscription); fewer: each uses its share of the cores
            threads = 1 if n >= cores() else 0
        else:
            eng = _RayEngine(workers, address, want_progress=progress is not None)
            threads = 1  # a task holds one CPU of the cluster (num_cpus=1)
        for job in todo:
            job["threads"] = threads
        summary.workers = min(eng.capacity(), len(todo))
        running: dict = {}  # handle -> job
        frames_done = 0
        abandoned = False
        last_report = 0.0
        try:
            with signals.installed(handle_signals):
                while todo or running:
                    while todo and len(running) < eng.capacity() and signals.first is None:
                        job = todo.popleft()
                        running[eng.submit(job)] = job
                        state.running[job["name"]] = (0, 0)
                    if not running:
                        break
                    for handle, res in eng.wait(list(running), 0.2):
                        job = running.pop(handle)
                        state.running.pop(job["name"], None)
                        if isinstance(res, _Crash):
                            if job["attempt"] == 0 and signals.first is None:
                                todo.appendleft(dict(job, attempt=1))  # maybe a neighbour's crash: once more
                                continue
                            shutil.rmtree(_work_dir(out_dir, job["name"]), ignore_errors=True)
                            res = _record(job["name"], job["input"], "failed", error=str(res))
                        elif res["status"] in ("ok", "damaged") and not all(os.path.exists(os.path.join(out_dir, res[k])) for k in ("output", "cameras")):
                            res = dict(res, status="failed", error=f"the outputs written on {res['host']} are not in {out_dir} here: the output folder must be on a file system every node shares")
                        records[job["name"]] = res
                        frames_done += res.get("frames", 0)
                        state.clips_done += 1
                        if on_clip is not None:
                            on_clip(dict(res))
                    if signals.count >= 2 and running:
                        abandoned = True
                        break
                    now = time.monotonic()
                    if progress is not None and now - last_report >= 0.25:
                        last_report = now
                        for name, dt in eng.poll_progress().items():
                            if name in state.running:
                                state.running[name] = dt
                        state.frames = frames_done + sum(d for d, _ in state.running.values())
                        state.seconds = time.perf_counter() - t_start
                        progress(state.copy())
        except BaseException:
            abandoned = True  # e.g. KeyboardInterrupt with handle_signals=False
            raise
        finally:
            if abandoned and running:
                eng.abandon(list(running))
                for job in running.values():
                    shutil.rmtree(_work_dir(out_dir, job["name"]), ignore_errors=True)
                    records[job["name"]] = _record(job["name"], job["input"], "interrupted", error="stopped before it finished; partial outputs discarded")
                running.clear()
            try:
                eng.close()
            finally:
                finish()
        if progress is not None:
            state.frames, state.running, state.seconds = frames_done, {}, summary.seconds
            progress(state.copy())
        if summary.interrupted is not None:
            raise BatchInterrupted(summary.interrupted, summary)
        return summary
