"""Benchmark: ``arstream process`` against a plain decode + encode of the same clip.

    .venv/bin/python bench/pipeline_speed.py [--sizes 1280x720,1920x1080] [--frames 250]
                                             [--repeats 3] [--write]

For each size, a synthetic broadcast clip (``arstream.synth``, preset wide,
H.264 crf 23; the committed ``samples/wide/clip.mp4`` at 720p) is run,
alternately, through

* **plain**: PyAV threaded decode -> libx264 encode with the pipeline's
  settings (crf 20, preset veryfast, yuv420p, auto threads), decoded frames
  handed to the encoder as they are (no colour conversion), timestamps kept,
  every frame's type left to x264 (the issue's baseline);
* **plain, B-frames kept**: the same, with the input's B-frames coded as
  B-frames, as ``arstream process`` does by default (reported for reference);
* **process**: ``arstream process IN -o OUT`` (decode, detect, track with a
  10-frame smoother, render the demo scene, composite, encode),

each in a fresh subprocess, ``--repeats`` times. Reported per size: frames/s
of the run itself (the pipeline's own clock, without interpreter start-up,
imports and GL set-up) and wall time of the whole command; the ratio of the
medians (process / plain, same run); CPU seconds per frame (user + system,
all threads: the work done, less sensitive to other users of this shared
machine than wall time); peak resident memory (``ru_maxrss`` of the child);
and the pipeline's mean milliseconds per frame per stage. Memory flatness:
peak memory of ``process`` on the clip and on the clip repeated ``--long``
times (default 2).

``--write`` replaces the figures (tables and targets) of the section
"## Pipeline (arstream process)" of bench/README.md; the hand-written text
after the section's ``KEEP`` marker and the other sections are left alone.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

SECTION = "## Pipeline (arstream process)"

# bench/README.md: what follows this line in the section is hand-written
# (comparisons, analysis) and --write keeps it
KEEP = "<!-- hand-written below: bench/pipeline_speed.py --write keeps it -->"


# --------------------------------------------------------------------------- child: plain decode+encode
def plain(src: str, dst: str, keep_b_frames: bool = False) -> None:
    """Decode + encode with the pipeline's codec settings; prints JSON {frames, seconds}.
    ``keep_b_frames``: the input's B-frames stay B-frames, as ``arstream process``
    does by default (``arstream.sink.VideoSink``); otherwise x264 chooses every type."""
    import av

    t0 = time.perf_counter()
    c0 = time.process_time()
    inp = av.open(src)
    vin = inp.streams.video[0]
    vin.thread_type = "AUTO"
    ain = inp.streams.audio[0] if inp.streams.audio else None
    out = av.open(dst, "w")
    vout = out.add_stream("libx264", rate=vin.average_rate)
    vout.width, vout.height, vout.pix_fmt = vin.codec_context.width, vin.codec_context.height, "yuv420p"
    vout.time_base = vin.time_base
    vout.codec_context.time_base = vin.time_base
    vout.options = {"crf": "20", "preset": "veryfast"}
    vout.codec_context.thread_count = 0
    aout = out.add_stream_from_template(ain) if ain is not None else None
    n = 0
    for pkt in inp.demux(*[s for s in (vin, ain) if s is not None]):
        if pkt.stream is ain:
            if pkt.dts is not None:
                pkt.stream = aout
                out.mux(pkt)
            continue
        for f in pkt.decode():
            # a decoded frame carries its type, which libx264 would take as an order
            if not (keep_b_frames and f.pict_type == av.video.frame.PictureType.B):
                f.pict_type = av.video.frame.PictureType.NONE
            for p in vout.encode(f):
                out.mux(p)
            n += 1
    for p in vout.encode(None):
        out.mux(p)
    out.close()
    inp.close()
    print(json.dumps({"frames": n, "seconds": time.perf_counter() - t0, "cpu_seconds": time.process_time() - c0}))


# --------------------------------------------------------------------------- parent
def measured(args: list[str]) -> dict:
    """Run a command in a fresh process; its stdout JSON plus wall time, CPU seconds
    (user + system, all threads) and peak RSS in MiB (from wait4: this child only)."""
    with tempfile.TemporaryFile() as errf:
        t0 = time.perf_counter()
        p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=errf, cwd=ROOT)
        out = p.stdout.read()
        _, status, ru = os.wait4(p.pid, 0)
        wall = time.perf_counter() - t0
        p.returncode = os.waitstatus_to_exitcode(status)
        if p.returncode != 0:
            errf.seek(0)
            raise SystemExit(f"{' '.join(args)} failed ({p.returncode}): {errf.read().decode(errors='replace').strip()[-2000:]}")
    res = json.loads(out)
    res.update(wall=wall, cpu=ru.ru_utime + ru.ru_stime, rss=ru.ru_maxrss / 1024.0)
    return res


def clip_for(size: tuple[int, int], frames: int, work: str) -> str:
    sample = os.path.join(ROOT, "samples", "wide", "clip.mp4")
    if size == (1280, 720) and frames == 250 and os.path.exists(sample):
        return sample
    from arstream.synth import generate

    d = os.path.join(work, f"clip_{size[0]}x{size[1]}_{frames}")
    if not os.path.exists(os.path.join(d, "clip.mp4")):
        print(f"generating a {size[0]}x{size[1]} clip of {frames} frames ...", file=sys.stderr)
        generate(d, preset="wide", seed=1, frames=frames, size=size)
    return os.path.join(d, "clip.mp4")


def repeat_clip(src: str, dst: str, times: int) -> None:
    """``src``'s video packets ``times`` times back to back (a longer clip, no re-encode)."""
    import av

    inp = av.open(src)
    vin = inp.streams.video[0]
    pkts = [p for p in inp.demux(vin) if p.dts is not None]
    step = pkts[-1].pts + (pkts[1].pts - pkts[0].pts)
    out = av.open(dst, "w")
    vout = out.add_stream_from_template(vin)
    for r in range(times):
        for p in pkts:
            q = av.Packet(bytes(p))
            q.pts, q.dts, q.is_keyframe, q.time_base, q.stream = p.pts + r * step, p.dts + r * step, p.is_keyframe, p.time_base, vout
            out.mux(q)
    out.close()
    inp.close()


def bench_size(size, frames, repeats, work, long_times: int = 2) -> dict:
    py = sys.executable
    src = clip_for(size, frames, work)
    out = os.path.join(work, "out.mp4")
    plain_cmd = [py, os.path.abspath(__file__), "--plain", src, os.path.join(work, "plain.mp4")]
    plain_b_cmd = [py, os.path.abspath(__file__), "--plain-keep-b", src, os.path.join(work, "plain.mp4")]
    proc_cmd = [py, "-m", "arstream.cli", "process", src, "-o", out, "-q", "--json"]
    truth = os.path.join(os.path.dirname(src), "truth.jsonl")
    # the same loop with the cameras known (no detection, no solving): the pipeline's own cost
    render_cmd = [py, "-m", "arstream.cli", "render", src, "--cameras", truth, "--key", "none", "-o", out, "-q", "--json"]
    runs = {"plain": [], "plain_b": [], "process": [], "render": []}
    for _ in range(repeats):
        runs["plain"].append(measured(plain_cmd))
        runs["plain_b"].append(measured(plain_b_cmd))
        runs["process"].append(measured(proc_cmd))
        runs["render"].append(measured(render_cmd))
    n = runs["process"][0]["frames"]

    def med(kind, key):
        return statistics.median(r[key] for r in runs[kind])

    rss_process = max(r["rss"] for r in runs["process"])
    res = {
        "size": f"{size[0]}x{size[1]}",
        "frames": n,
        "plain_fps": n / med("plain", "seconds"),
        "process_fps": n / med("process", "seconds"),
        "plain_wall": med("plain", "wall"),
        "process_wall": med("process", "wall"),
        "ratio_run": med("process", "seconds") / med("plain", "seconds"),
        "ratio_wall": med("process", "wall") / med("plain", "wall"),
        "plain_b_fps": n / med("plain_b", "seconds"),
        "ratio_run_b": med("process", "seconds") / med("plain_b", "seconds"),
        "plain_b_run_cpu_ms": 1e3 * med("plain_b", "cpu_seconds") / n,
        "plain_cpu_ms": 1e3 * med("plain", "cpu") / n,
        "process_cpu_ms": 1e3 * med("process", "cpu") / n,
        "plain_run_cpu_ms": 1e3 * med("plain", "cpu_seconds") / n,
        "process_run_cpu_ms": 1e3 * med("process", "cpu_seconds") / n,
        "render_fps": n / med("render", "seconds"),
        "render_ratio": med("render", "seconds") / med("plain", "seconds"),
        "render_run_cpu_ms": 1e3 * med("render", "cpu_seconds") / n,
        "stage_ms": {k: statistics.median(r["stage_ms"].get(k, 0.0) for r in runs["process"]) for k in runs["process"][0]["stage_ms"]},
        "tracked": runs["process"][0]["share_tracked"],
        "missing": runs["process"][0]["missing"],
    }
    # memory: the clip, and the clip ``long_times`` over (flat means no whole-clip buffering)
    res["rss_plain"] = max(r["rss"] for r in runs["plain"])
    res["rss_process"] = rss_process
    res["long_times"] = long_times
    if long_times > 1:
        long = os.path.join(work, f"long_{size[0]}x{size[1]}.mp4")
        repeat_clip(src, long, long_times)
        res["rss_process_long"] = measured([py, "-m", "arstream.cli", "process", long, "-o", out, "-q", "--json"])["rss"]
    else:
        res["rss_process_long"] = float("nan")
    return res


def table(results: list[dict]) -> str:
    lines = [
        "| clip | plain decode+encode | arstream process | ratio (run / whole command) | CPU ms/frame plain / process (run; whole command) | peak RSS plain / process / process on the clip repeated |",
        "|---|---|---|---|---|---|",
    ]
    for r in results:
        lines.append(
            f"| {r['size']}, {r['frames']} frames | {r['plain_fps']:.1f} fps ({r['plain_wall']:.1f} s) | {r['process_fps']:.1f} fps ({r['process_wall']:.1f} s) "
            f"| {r['ratio_run']:.2f}x / {r['ratio_wall']:.2f}x | {r['plain_run_cpu_ms']:.1f} / {r['process_run_cpu_ms']:.1f} ({r['plain_cpu_ms']:.1f} / {r['process_cpu_ms']:.1f}) "
            f"| {r['rss_plain']:.0f} / {r['rss_process']:.0f} / {r['rss_process_long']:.0f} MiB ({r['long_times']}x) |"
        )
    lines += [
        "",
        "For reference, plain decode+encode with the input's B-frames kept as B-frames (as `arstream process` does by",
        "default; the target's plain run lets x264 choose every frame's type):",
        "",
        "| clip | plain, B-frames kept | ratio process / it (run) | CPU ms/frame (run) |",
        "|---|---|---|---|",
    ]
    for r in results:
        lines.append(f"| {r['size']} | {r['plain_b_fps']:.1f} fps | {r['ratio_run_b']:.2f}x | {r['plain_b_run_cpu_ms']:.1f} |")
    lines += [
        "",
        "The same decode -> render -> composite -> encode loop with the cameras known (`arstream render --cameras truth.jsonl --key none`,",
        "demo scene; no detection, no solving): what the pipeline itself costs over a plain decode+encode.",
        "",
        "| clip | plain decode+encode | render with known cameras | ratio (run) | CPU ms/frame plain / render (run) |",
        "|---|---|---|---|---|",
    ]
    for r in results:
        lines.append(
            f"| {r['size']} | {r['plain_fps']:.1f} fps | {r['render_fps']:.1f} fps | {r['render_ratio']:.2f}x | {r['plain_run_cpu_ms']:.1f} / {r['render_run_cpu_ms']:.1f} |"
        )
    lines += [
        "",
        "Mean wall milliseconds per frame in each stage of `arstream process` (decode, detect and encode run on their own",
        "threads, detect one frame ahead of track + render on the main thread; under load, wall times include waiting for a core):",
        "",
    ]
    stages = list(dict.fromkeys(k for r in results for k in r["stage_ms"]))
    lines.append("| clip | " + " | ".join(stages) + " |")
    lines.append("|---|" + "---|" * len(stages))
    for r in results:
        lines.append(f"| {r['size']} | " + " | ".join(f"{r['stage_ms'].get(k, 0.0):.2f}" for k in stages) + " |")
    return "\n".join(lines)


def verdicts(results: list[dict]) -> str:
    """The issue's targets, met or not, from the figures."""
    out = []
    for r in results:
        w, h = (int(v) for v in r["size"].split("x"))
        if h == 720:
            out.append(f"- 720p: {r['process_fps']:.1f} fps, target >= 60: {'met' if r['process_fps'] >= 60 else 'NOT met'}")
            out.append(f"- 720p: {r['ratio_run']:.3f}x the wall time of plain decode+encode (whole command {r['ratio_wall']:.2f}x), target <= 1.5x: {'met' if r['ratio_run'] <= 1.5 else 'NOT met'}")
            cpu_fps = 2000.0 / r["process_run_cpu_ms"] if r["process_run_cpu_ms"] > 0 else 0.0
            out.append(f"- 720p: {r['process_run_cpu_ms']:.1f} CPU ms per frame, i.e. at most {cpu_fps:.0f} fps on two idle cores")
            out.append(f"- 720p without detection and solving (cameras known): {r['render_fps']:.1f} fps, {r['render_ratio']:.2f}x plain decode+encode")
        if h == 1080:
            out.append(f"- 1080p: {r['process_fps']:.1f} fps, target >= 25: {'met' if r['process_fps'] >= 25 else 'NOT met'}; {r['process_run_cpu_ms']:.1f} CPU ms per frame (at most {2000.0 / max(r['process_run_cpu_ms'], 1e-9):.0f} fps on two idle cores)")
            out.append(f"- 1080p without detection and solving (cameras known): {r['render_fps']:.1f} fps, {r['render_ratio']:.2f}x plain decode+encode")
        long = r["rss_process_long"] if r["rss_process_long"] == r["rss_process_long"] else 0.0
        peak = max(r["rss_process"], long)
        if h >= 1080:
            out.append(f"- 1080p peak memory {peak:.0f} MiB ({r['frames']} frames: {r['rss_process']:.0f} MiB; {r['long_times']}x as long: {r['rss_process_long']:.0f} MiB), target <= 1 GB: {'met' if peak <= 1024 else 'NOT met'}")
    return "\n".join(out)


def write_section(text: str) -> None:
    """Replace the generated part of the section (tables, targets) with ``text``;
    the hand-written part after the :data:`KEEP` line stays."""
    path = os.path.join(ROOT, "bench", "README.md")
    old = open(path, encoding="utf-8").read() if os.path.exists(path) else "# Benchmarks\n"
    block = f"{SECTION}\n\n{text.strip()}\n\n{KEEP}\n"
    if SECTION in old:
        start = old.index(SECTION)
        m = re.search(r"^## ", old[start + len(SECTION) :], flags=re.M)
        end = start + len(SECTION) + m.start() if m else len(old)
        section = old[start:end]
        kept = section[section.index(KEEP) + len(KEEP) :].strip("\n") if KEEP in section else ""
        new = old[:start] + block + (f"\n{kept}\n" if kept else "") + ("\n" + old[end:] if m else "")
    else:
        new = old.rstrip("\n") + "\n\n" + block
    with open(path, "w", encoding="utf-8") as f:
        f.write(new)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--plain", nargs=2, metavar=("IN", "OUT"), help=argparse.SUPPRESS)
    ap.add_argument("--plain-keep-b", nargs=2, metavar=("IN", "OUT"), help=argparse.SUPPRESS)
    ap.add_argument("--sizes", default="1280x720,1920x1080")
    ap.add_argument("--frames", type=int, default=250)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--long", type=int, default=2, metavar="K", help="memory check on the clip repeated K times (default: 2; 1 skips it)")
    ap.add_argument("--work", default=os.path.join(tempfile.gettempdir(), "arstream-bench-pipeline"))
    ap.add_argument("--write", action="store_true", help="write the figures into bench/README.md")
    args = ap.parse_args()
    if args.plain or args.plain_keep_b:
        plain(*(args.plain or args.plain_keep_b), keep_b_frames=bool(args.plain_keep_b))
        return
    os.makedirs(args.work, exist_ok=True)
    sizes = [tuple(int(v) for v in s.split("x")) for s in args.sizes.split(",")]
    results = []
    for size in sizes:
        r = bench_size(size, args.frames, args.repeats, args.work, args.long)
        print(json.dumps(r, indent=2), file=sys.stderr)
        results.append(r)
    load = os.getloadavg()
    info = f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, load average {load[0]:.1f} at the end"
    text = table(results) + "\n\nTargets (issue 7):\n\n" + verdicts(results)
    missing = sorted({m for r in results for m in r["missing"]})
    note = f"\n\nStages missing from this build (frames passed through): {', '.join(missing)}." if missing else ""
    print(text + note)
    if args.write:
        write_section(
            f"`.venv/bin/python bench/pipeline_speed.py --frames {args.frames} --repeats {args.repeats} --long {args.long} --write` "
            f"({time.strftime('%Y-%m-%d')}; {info}). Medians of {args.repeats} alternating runs per command, "
            f"each in a fresh process; \"run\" is the pipeline's own clock (decode of the first frame to the "
            f"trailer), \"whole command\" adds interpreter start-up, imports and GL set-up.\n\n{text}{note}\n"
        )


if __name__ == "__main__":
    main()
