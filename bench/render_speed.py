"""Benchmark: render + readback + composite per frame, 4-object scene, 720p and 1080p.

    .venv/bin/python bench/render_speed.py [--frames 200] [--sizes 1280x720,1920x1080]

The scene: the demo logo on the grass, an offside line, a 9.15 m distance
ring with its label, and a standing billboard. The camera pans slowly across
the frames (so the drawn region changes as in a real clip) over a synthetic
broadcast frame with a grass matte (keying on). Each timed frame is
``Renderer.render`` (footprint, MSAA draw, resolve, one readback) plus
``Compositor.composite`` in place; copying a fresh frame is not timed.
Prints the median, 10th and 90th percentiles of wall time in milliseconds,
the median CPU time of the process (all threads, llvmpipe's included: the
work done, less sensitive to other load on a shared machine than wall time),
and the share of the frame inside the compositing rectangles.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from render import Billboard, DistanceRing, Logo, OffsideLine, Renderer, Scene  # noqa: E402
from render.context import create_context, describe_context  # noqa: E402
from render.scene import DEMO_SCENE  # noqa: E402
from render.synthetic import main_camera, pitch_frame  # noqa: E402


def bench_scene() -> Scene:
    """The 4-object benchmark scene."""
    logo = DEMO_SCENE.parent / "demo_logo.png"
    return Scene(
        objects=[
            Logo(image=str(logo), center=(-20.0, -14.0), size=(16.0, 5.0), opacity=0.9),
            OffsideLine(x=21.5, width=0.2),
            DistanceRing(center=(-2.0, 8.0), radius=9.15, width=0.25),
            Billboard(position=(6.0, -20.0), width=8.0, height=1.0, color="#d02020"),
        ]
    )


def run(width: int, height: int, frames: int, ctx) -> dict:
    scene = bench_scene()
    base = main_camera(width, height)
    frame0, matte = pitch_frame(base, width, height)
    pans = np.deg2rad(2.0) * np.sin(np.linspace(0.0, 2 * np.pi, frames))
    cams = [main_camera(width, height, pan_deg=float(np.rad2deg(p))) for p in pans]
    times, cpu, areas = [], [], []
    with Renderer(width, height, scene, ctx=ctx) as r:
        frame = frame0.copy()
        for cam in cams[:10]:  # warm up: shader variants, first uploads
            r.draw(frame, cam, matte)
        for cam in cams:
            np.copyto(frame, frame0)
            c0, t0 = time.process_time(), time.perf_counter()
            ov = r.render(cam, matte)
            r.compositor.composite(frame, ov)
            times.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
            areas.append(sum((x1 - x0) * (y1 - y0) for x0, y0, x1, y1 in ov.rects))
        samples = r.samples
    t = np.array(times) * 1e3
    return {
        "size": f"{width}x{height}",
        "median": float(np.median(t)),
        "p10": float(np.percentile(t, 10)),
        "p90": float(np.percentile(t, 90)),
        "area": float(np.mean(areas)) / (width * height),
        "cpu": float(np.median(cpu)) * 1e3,
        "samples": samples,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=200)
    ap.add_argument("--sizes", default="1280x720,1920x1080")
    args = ap.parse_args(argv)
    ctx = create_context()
    print(f"GL: {describe_context(ctx)}")
    print(f"CPU: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}")
    print(f"{'size':>10} {'MSAA':>4} {'median ms':>10} {'p10':>7} {'p90':>7} {'CPU ms':>7} {'composited':>10}")
    for size in args.sizes.split(","):
        w, h = (int(v) for v in size.lower().split("x"))
        res = run(w, h, args.frames, ctx)
        print(f"{res['size']:>10} {res['samples']:>4} {res['median']:>10.2f} {res['p10']:>7.2f} {res['p90']:>7.2f} {res['cpu']:>7.2f} {100 * res['area']:>9.1f}%")
    ctx.release()
    return 0


if __name__ == "__main__":
    sys.exit(main())
