#!/usr/bin/env python3
"""Times Mitsuba 3 (variant scalar_rgb) on a scene `raycast mitsuba` wrote:

    python ci/mitsuba_bench.py [--frames N] [--threads T] [--png OUT.png] SCENE.xml

Loads the scene once, renders one untimed frame, then times N frames of
mi.render (each with its own seed) and prints their median, with the
camera rays' hits (an `aov` render of depth, untimed) and so the rays a
pixel: 1 camera ray + emitter_samples shadow rays a hit (the `direct`
integrator tests one light's visibility for each emitter sample; a light
behind the surface is still tested). --frames 0 times nothing: it loads,
renders once and writes --png if given, as one whole command (`ci/benchmarks.sh
mitsuba` times it so). --png writes the last frame's linear values as
8-bit (no sRGB curve), as raycast writes its pictures. A benchmark
dependency only: `pip install mitsuba` in a virtual environment.
"""
import argparse
import statistics
import sys
import time

parser = argparse.ArgumentParser()
parser.add_argument("--frames", type=int, default=5)
parser.add_argument("--threads", type=int, default=0, help="render threads (0: Mitsuba's default, every core)")
parser.add_argument("--png")
parser.add_argument("scene")
args = parser.parse_args()

start = time.perf_counter()
import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402

mi.set_variant("scalar_rgb")
if args.threads > 0:
    dr.set_thread_count(args.threads)
scene = mi.load_file(args.scene)
loaded = time.perf_counter() - start
image = mi.render(scene, seed=0)
first = time.perf_counter() - start - loaded
print(f"mitsuba: loaded {args.scene} in {loaded:.3f} s (import and parse), first frame {first:.3f} s, "
      f"{dr.thread_count()} threads, Mitsuba {mi.__version__}")
if args.frames > 0:
    times = []
    for i in range(args.frames):
        t = time.perf_counter()
        image = mi.render(scene, seed=i + 1)
        times.append(time.perf_counter() - t)
    film = scene.sensors()[0].film()
    width, height = film.size()
    depth = mi.render(scene, integrator=mi.load_dict({"type": "aov", "aovs": "d:depth"}), seed=0)
    values = depth.array
    channels = len(values) // (width * height)
    hits = sum(1 for k in range(0, len(values), channels) if values[k] > 0)
    # The direct integrator's emitter_samples, as the file gives it.
    samples = 1
    text = open(args.scene, encoding="utf-8").read()
    marker = '<integer name="emitter_samples" value="'
    if marker in text:
        samples = int(text.split(marker, 1)[1].split('"', 1)[0])
    spp = scene.sensors()[0].sampler().sample_count()
    pixels = width * height
    print(f"mitsuba: frame median {statistics.median(times):.4f} s (min {min(times):.4f}, max {max(times):.4f}; "
          f"{args.frames} frames after 1 untimed) at {width}x{height}, {spp} spp")
    print(f"mitsuba: hits {hits} of {pixels} pixels; rays per pixel {spp * (1 + samples * hits / pixels):.3f} "
          f"(1 camera ray + {samples} emitter samples a hit)")
if args.png:
    mi.Bitmap(image).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, False).write(args.png)
sys.stdout.flush()
