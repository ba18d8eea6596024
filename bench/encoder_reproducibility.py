"""Benchmark: are libx264's encodes of the same pictures the same bytes, and what
does its AVX-512 code buy?

    .venv/bin/python bench/encoder_reproducibility.py [--repeats 3] [--sizes 320x180,1366x768,1920x1080]

Clips: the committed 720p sample and short synthetic clips (``arstream.synth``,
preset wide, 25 frames) at ``--sizes``. Each clip is decoded once per run (not
timed) and its pictures encoded with the pipeline's settings (libx264, crf 20, preset veryfast, FFmpeg's thread count,
every frame's type left to x264), each run in a fresh process, with x264's CPU
capabilities as it detects them ("auto") and without AVX-512 (the same list,
as x264 reports it, less "AVX512"; only on a CPU that has it). Each setting
runs under glibc's ``MALLOC_PERTURB_`` unset and set to two values (freshly
allocated memory then holds a fixed byte instead of what was there before):
an encoder that reads memory it has not written gives different bytes.
Reported per setting and clip: the distinct encodes (MD5 of the video
packets) over those runs; on the 720p sample also the encode's frames/s and
CPU ms per frame (medians over ``--repeats`` alternating runs without the
perturbation).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from arstream.sink import x264_capabilities, x264_reproducible_params  # noqa: E402
PERTURB = (None, "85", "170")


def child(clip: str, asm: str) -> None:
    """Encode ``clip``'s pictures with ``asm`` (x264's ``asm`` parameter, or "auto");
    prints JSON {md5, frames, fps, cpu_ms}."""
    import av

    with av.open(clip) as inp:
        vin = inp.streams.video[0]
        vin.thread_type = "AUTO"
        frames = list(inp.decode(vin))
        rate, tb = vin.average_rate, vin.time_base
    for f in frames:
        f.pict_type = av.video.frame.PictureType.NONE
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "out.mp4")
        out = av.open(path, "w")
        vo = out.add_stream("libx264", rate=rate)
        vo.width, vo.height, vo.pix_fmt = frames[0].width, frames[0].height, "yuv420p"
        vo.time_base = vo.codec_context.time_base = tb
        vo.options = {"crf": "20", "preset": "veryfast", **({} if asm == "auto" else {"x264-params": f"asm={asm}"})}
        t0, c0 = time.perf_counter(), time.process_time()
        for f in frames:
            for p in vo.encode(f):
                out.mux(p)
        for p in vo.encode(None):
            out.mux(p)
        out.close()
        seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
        with av.open(path) as c:
            md5 = hashlib.md5(b"".join(bytes(p) for p in c.demux(video=0) if p.size)).hexdigest()
    print(json.dumps({"md5": md5, "frames": len(frames), "fps": len(frames) / seconds, "cpu_ms": 1e3 * cpu / len(frames)}))


def run(clip: str, asm: str, perturb: str | None) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "MALLOC_PERTURB_"}
    if perturb is not None:
        env["MALLOC_PERTURB_"] = perturb
    r = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", asm, "--clip", clip], env=env, cwd=ROOT, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"encoding with asm={asm} failed: {r.stderr.strip()[-2000:]}")
    return json.loads(r.stdout)


def synthetic(size: tuple[int, int], work: str) -> str:
    from arstream.synth import generate

    d = os.path.join(work, f"clip_{size[0]}x{size[1]}")
    generate(d, preset="wide", seed=1, frames=25, size=size)
    return os.path.join(d, "clip.mp4")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--clip", default=os.path.join(ROOT, "samples", "wide", "clip.mp4"), help=argparse.SUPPRESS)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--sizes", default="320x180,1366x768,1920x1080")
    ap.add_argument("--child", metavar="ASM", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args.clip, args.child)
        return
    caps = x264_capabilities()
    if not caps:
        raise SystemExit("libx264 did not report its CPU capabilities")
    settings = {"auto": "auto"}
    params = x264_reproducible_params()
    if params:
        settings["without AVX-512"] = params.removeprefix("asm=")
    else:
        print("this CPU has no AVX-512 (x264 reports: " + " ".join(caps) + "): one setting only", file=sys.stderr)
    sample = os.path.join(ROOT, "samples", "wide", "clip.mp4")
    with tempfile.TemporaryDirectory() as work:
        clips = {"1280x720 (sample)": sample}
        for size in args.sizes.split(",") if args.sizes else []:
            w, h = (int(v) for v in size.split("x"))
            clips[f"{w}x{h}"] = synthetic((w, h), work)
        md5 = {(c, n): set() for c in clips for n in settings}
        speed = {n: {"fps": [], "cpu_ms": []} for n in settings}
        for rep in range(args.repeats):
            for name, asm in settings.items():
                for clip, path in clips.items():
                    if rep > 0 and path != sample:
                        continue
                    for perturb in PERTURB if rep == 0 else (None,):
                        r = run(path, asm, perturb)
                        md5[clip, name].add(r["md5"])
                        if path == sample and perturb is None:
                            speed[name]["fps"].append(r["fps"])
                            speed[name]["cpu_ms"].append(r["cpu_ms"])
    print(f"x264's CPU capabilities here: {' '.join(caps)}")
    print(f"runs per clip and setting: MALLOC_PERTURB_ unset, {PERTURB[1]} and {PERTURB[2]} (the sample: {args.repeats - 1} more unset, timed)\n")
    print("| clip | " + " | ".join(f"distinct encodes, x264 {n}" for n in settings) + " |")
    print("|---|" + "---|" * len(settings))
    for clip in clips:
        print(f"| {clip} | " + " | ".join(str(len(md5[clip, n])) for n in settings) + " |")
    print("\n| x264 CPU capabilities | 720p encode fps | 720p encode CPU ms/frame |")
    print("|---|---|---|")
    for name, sp in speed.items():
        print(f"| {name} | {statistics.median(sp['fps']):.1f} | {statistics.median(sp['cpu_ms']):.2f} |")


if __name__ == "__main__":
    main()
